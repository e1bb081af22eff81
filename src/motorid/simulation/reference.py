"""The closed loop's reference ``r(t)``, its level when none is given, and the rails a page starts from.

The lab report steps its position loop to 5 V of the potentiometer (its Figs. 4–9), and that is
the level on a model of a scope's volts.  On data in another unit a 5 is no set-point (5 rpm for
a motor that turns 2 500 rpm): the default there is what the identification's own step reached,
a level the rig is known to reach with the command it was given — the speed it settled at, or
for a position loop the distance that speed covers in one time constant.  The level is rounded
to two significant digits (a set-point a student would type) and the result says where it came
from (:class:`ReferenceLevel`), so that every output can print it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from motorid.errors import OptionError
from motorid.model.units import channel_unit

if TYPE_CHECKING:
    from motorid.model import MotorModel

__all__ = [
    "REFERENCE_KINDS",
    "REPORT_AMPLITUDE_RATIO",
    "REPORT_LEVEL_V",
    "ReferenceLevel",
    "ReferenceSignal",
    "default_rails",
    "default_reference_level",
    "reference_values",
    "with_level",
]

#: Reference waveforms: a step (report §2.2.1), a sinusoid (§2.2.3) and the trainer's test signals.
REFERENCE_KINDS: tuple[str, ...] = ("step", "sine", "triangle", "square")
#: The lab report's reference step, in volts of the output's sensor (its Figs. 4–9).
REPORT_LEVEL_V = 5.0
#: The paper's actuator rails, ±10 V (its Fig. 12), on a command in volts.
PAPER_RAILS_V = 10.0
#: Default rails on a command not in volts, in identification steps (:func:`default_rails`).
RAILS_PER_STEP = 1.5
#: A wave's default amplitude over its mean: the lab report's 5 + 2 sin ωt (§2.2.3).
REPORT_AMPLITUDE_RATIO = 0.4
#: Significant digits of a default level taken from the model.
LEVEL_DIGITS = 2


@dataclass(frozen=True, slots=True)
class ReferenceSignal:
    """The reference ``r(t)`` in the output's unit.

    Attributes
    ----------
    kind : str
        ``step``: ``initial_v`` before ``start_s``, ``level_v`` after; ``sine``/``triangle``/
        ``square``: ``level_v + amplitude_v·wave(2π f t)`` (report: ``5 + 2 sin ωt``).
    level_v : float or None
        The step's level or the wave's mean; None: the model's default
        (:func:`default_reference_level`), chosen when the loop is simulated.
    amplitude_v : float or None
        The wave's amplitude; None: :data:`REPORT_AMPLITUDE_RATIO` × the level (the report's
        ``5 + 2 sin ωt``), chosen with it.
    initial_v, frequency_hz, start_s : float
    """

    kind: str = "step"
    level_v: float | None = None
    initial_v: float = 0.0
    amplitude_v: float | None = None
    frequency_hz: float = 0.25
    start_s: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in REFERENCE_KINDS:
            raise OptionError(f"--reference {self.kind!r}: use one of {', '.join(REFERENCE_KINDS)}")
        for name in ("level_v", "initial_v", "amplitude_v", "frequency_hz", "start_s"):
            value = getattr(self, name)
            if value is not None and not math.isfinite(float(value)):
                raise OptionError(f"reference {name} must be finite")
        if self.kind != "step" and not self.frequency_hz > 0:
            raise OptionError(f"--frequency must be > 0 Hz, got {self.frequency_hz!r}")


@dataclass(frozen=True, slots=True)
class ReferenceLevel:
    """The reference's level as a simulation used it, and where it came from.

    Attributes
    ----------
    value : float
        The level, in :attr:`unit`.
    unit : str
        The output's unit (the model's data unit, ``V`` for a scope's volts).
    source : str
        ``given``, or in words why this default (e.g. "the speed the identification's 12 V
        step reached").
    amplitude : float or None
        A wave's amplitude about the level, in :attr:`unit` (None for a step).
    """

    value: float
    unit: str
    source: str
    amplitude: float | None = None

    @property
    def given(self) -> bool:
        """Whether the caller gave the level (not a default)."""
        return self.source == "given"

    def text(self) -> str:
        """One line for a printout: the level, its unit and, for a default, why.

        Returns
        -------
        str
            E.g. ``reference level 2500 rpm (the speed the identification's 12 V step reached;
            --level sets it)``.
        """
        head = f"reference level {self.value:.6g} {self.unit}"
        if self.amplitude is not None:
            head += f", a wave of amplitude {self.amplitude:.6g} {self.unit} about it"
        return head if self.given else f"{head} ({self.source}; --level sets it)"

    def to_dict(self) -> dict[str, object]:
        """The simulation JSON's ``reference_level`` entry.

        Returns
        -------
        dict
            ``value``, ``unit``, ``source`` and, for a wave, ``amplitude``.
        """
        return {"value": self.value, "unit": self.unit, "source": self.source,
                **({} if self.amplitude is None else {"amplitude": self.amplitude})}


def _rounded(x: float) -> float:
    return float(f"{x:.{LEVEL_DIGITS}g}")


def default_reference_level(model: MotorModel, output: str) -> ReferenceLevel:
    """The reference level a simulation of ``model`` uses when none is given.

    Parameters
    ----------
    model : MotorModel
        The identified model (its units, DC gain, time constant and identification step).
    output : str
        The controlled output (``position``, ``velocity``…).

    Returns
    -------
    ReferenceLevel
        5 on a model in volts (the lab report's); otherwise, rounded to two significant
        digits, the speed the identification's step reached (``|K·u|``) for a velocity loop,
        the distance that speed covers in one time constant (``|K·u|·τ``, dead time included)
        for a position loop, and 5 with the reason when the model does not say its step.
    """
    unit = channel_unit(model.units, output)
    if unit == "V":
        return ReferenceLevel(REPORT_LEVEL_V, unit, "the lab report's 5 V step")
    step = model.step_volts
    input_unit = channel_unit(model.units, "input")
    fo = model.first_order()
    speed = abs(fo.dc_gain * step) if step else math.nan
    if output == "velocity" and math.isfinite(speed) and speed > 0:
        return ReferenceLevel(_rounded(speed), unit,
                              f"about the speed the identification's {step:.4g} {input_unit} step reached")
    span = speed * (fo.time_constant_s + model.delay_s)
    if output == "position" and math.isfinite(span) and span > 0:
        return ReferenceLevel(_rounded(span), unit,
                              f"about the distance the identification's {step:.4g} {input_unit} step's speed "
                              f"covers in one time constant, {fo.time_constant_s + model.delay_s:.3g} s")
    return ReferenceLevel(REPORT_LEVEL_V, unit, f"5 {unit}: the model does not say what its identification step "
                                                 f"reached in {output}")


def default_rails(model: MotorModel) -> float:
    """The actuator rails (±, in the input's unit) a page or a report starts from.

    Parameters
    ----------
    model : MotorModel
        The identified model (its input unit and identification step).

    Returns
    -------
    float
        :data:`PAPER_RAILS_V` when the command is in volts (or the model does not say its step);
        otherwise :data:`RAILS_PER_STEP` × the identification step's level, to two digits (153 pwm
        → 230): the default reference needs that step's command when settled, and the rails leave
        it room to accelerate, where 10 would be a few counts of duty.
    """
    if channel_unit(model.units, "input") == "V" or not model.step_volts:
        return PAPER_RAILS_V
    return _rounded(RAILS_PER_STEP * abs(float(model.step_volts)))


def with_level(model: MotorModel, output: str, ref: ReferenceSignal) -> tuple[ReferenceSignal, ReferenceLevel]:
    """``ref`` with its level filled in (:func:`default_reference_level` when it has none), and its amplitude.

    Parameters
    ----------
    model : MotorModel
        The model simulated.
    output : str
        The controlled output.
    ref : ReferenceSignal
        The reference asked for.

    Returns
    -------
    tuple of ReferenceSignal and ReferenceLevel
        The reference with a level and an amplitude (:data:`REPORT_AMPLITUDE_RATIO` × the level
        when it has none), and the level with its source.
    """
    if ref.level_v is not None:
        level = ReferenceLevel(float(ref.level_v), channel_unit(model.units, output), "given")
    else:
        level = default_reference_level(model, output)
    amplitude = ref.amplitude_v if ref.amplitude_v is not None else REPORT_AMPLITUDE_RATIO * level.value
    if ref.kind != "step":
        level = replace(level, amplitude=float(amplitude))
    return replace(ref, level_v=level.value, amplitude_v=amplitude), level


def reference_values(ref: ReferenceSignal, time_s: np.ndarray) -> np.ndarray:
    """``r(t)`` at the sample times.

    Parameters
    ----------
    ref : ReferenceSignal
        The reference signal, with its level (:func:`with_level`).
    time_s : ndarray
        Sample times in s.

    Returns
    -------
    ndarray
        The reference in the output's unit.

    Raises
    ------
    OptionError
        A reference without a level.
    """
    if ref.level_v is None or ref.amplitude_v is None:
        raise OptionError("the reference has no level or amplitude: give them, or fill in the model's defaults "
                          "(with_level)")
    t = np.asarray(time_s, dtype=float)
    if ref.kind == "step":
        return np.where(t >= ref.start_s, ref.level_v, ref.initial_v)
    from motorid.simulation.signals import test_signal

    wave = test_signal(t - ref.start_s, ref.kind, amplitude_v=ref.amplitude_v, frequency_hz=ref.frequency_hz)
    return ref.level_v + np.where(t >= ref.start_s, wave, 0.0)
