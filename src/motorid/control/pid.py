"""PID design on a :class:`~motorid.model.MotorModel`: a velocity PI, a position PD or PID.

The controller reads one measured channel ``y`` (the velocity for the velocity loop, the
position for the position loop) and the reference ``r``, and commands the amplifier:

``u = kp (r − y) + ki ∫(r − y) dt − kd · s/(tf s + 1) · y``

in parallel (ideal) form, the derivative acting on the measurement, not on the error (a step of
the reference gives no derivative kick), filtered by a first-order lag ``tf = Td / N``
(``Td = kd / kp``).  Gains are in the data's units: a velocity in rpm gives ``kp`` in V per rpm,
``ki`` in V per (rpm·s) and ``kd`` in V·s per rpm.

Two tuning rules:

- ``simc``: Skogestad's SIMC rules on a first-order-plus-dead-time approximation of the velocity
  channel (velocity PI) or an integrating-plus-lag-plus-dead-time approximation of the position
  channel (position PD, or PID with integral action).  Higher-order models are reduced by
  Skogestad's half rule first; the closed-loop time constant is ``τc = max(θ, 0.25 τ)`` unless
  given (θ the effective dead time, τ the dominant lag): SIMC's "tight control" ``τc = θ``
  where the dead time dominates, and a loop four times faster than the motor where it does not
  (a motor's dead time is often zero, where ``τc = θ`` asks for infinite gain).  When that
  default leaves the full model's loop unstable or with a sensitivity peak Ms above 2 (a lightly
  damped pair, a zero the approximation handles coarsely), τc is doubled until Ms ≤ 2, and the
  warnings say so.
- ``placement``: the closed-loop poles of the same low-order approximation (without its dead
  time) placed at ``ζ``/``ωn`` (the PID's third pole, with integral action on the position, at
  ``−ωn``).

Margins, closed-loop poles and the step response are those of the full model with its dead time
(a Padé approximant, as :mod:`.margins` does), not of the approximation.

References
----------
Skogestad, S. (2003). Simple analytic rules for model reduction and PID controller tuning.
Journal of Process Control 13, 291–309: §3 (the half rule, numerator time constants),
§4 (SIMC PI/PID for first- and second-order plus dead time, integrating processes).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from motorid.control.controller import COMMAND, REFERENCE
from motorid.control.design import SCHEMA, output_row
from motorid.control.feedback import ControlDesignError
from motorid.control.margins import LoopMargins, closed_loop_bandwidth, dead_time_pade, open_loop_margins
from motorid.errors import OptionError
from motorid.model import MotorModel
from motorid.model.units import channel_unit

if TYPE_CHECKING:
    import control

__all__ = [
    "DERIVATIVE_FILTER_N",
    "MAX_DETUNE",
    "MS_TARGET",
    "PID_LOOPS",
    "PID_RULES",
    "STATE_FEEDBACK_OPTIONS",
    "TAU_C_FRACTION",
    "PidDesign",
    "PidSettings",
    "ReducedModel",
    "design_pid",
    "pid_loop_frequency_response",
    "reduce_half_rule",
    "refuse_state_feedback_options",
]

#: The loops a PID closes: the velocity (PI) or the position (PD, or PID with integral action).
PID_LOOPS: tuple[str, ...] = ("velocity", "position")
#: The tuning rules.
PID_RULES: tuple[str, ...] = ("simc", "placement")
#: Default SIMC closed-loop time constant as a fraction of the approximation's lag: ``τc = max(θ, 0.25 τ)``.
TAU_C_FRACTION = 0.25
#: Default derivative filter ``N`` (``tf = Td / N``); 5–20 is the usual range.
DERIVATIVE_FILTER_N = 10.0
#: Largest sensitivity peak SIMC's default τc is allowed to leave (Skogestad 2003 aims at 1.6–2).
MS_TARGET = 2.0
#: How many times the default τc may be doubled to reach :data:`MS_TARGET`.
MAX_DETUNE = 12
#: The command, as the model's python-control systems name their input (the plant's input here).
_COMMAND = "u [V]"


#: The options of state feedback by pole placement that a PID design refuses (by their flags).
STATE_FEEDBACK_OPTIONS: tuple[str, ...] = ("--poles", "--k2", "--settling-time", "--overshoot", "--integral", "--ki",
                                           "--integral-pole", "--observer-poles", "--output", "--sensors")


def refuse_state_feedback_options(given: Mapping[str, bool]) -> None:
    """Refuse, in one line naming both, a state-feedback option given with ``--pid``.

    Parameters
    ----------
    given : Mapping of str to bool
        Whether each flag of :data:`STATE_FEEDBACK_OPTIONS` was given.

    Raises
    ------
    OptionError
        For the first one given.
    """
    clash = next((flag for flag in STATE_FEEDBACK_OPTIONS if given.get(flag)), None)
    if clash is not None:
        raise OptionError(f"--pid and {clash} do not go together: {clash} is for state feedback by pole placement "
                          "(the PID's loop is chosen with --pid-loop, its poles with --pid-rule placement "
                          "--damping Z --wn W)")


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


@dataclass(frozen=True, slots=True)
class PidSettings:
    """How a PID is tuned.

    Attributes
    ----------
    loop : str
        ``velocity`` (a PI on the velocity channel) or ``position`` (a PD on the position
        channel; a PID with ``integral``).
    rule : str
        ``simc`` (Skogestad 2003) or ``placement`` (closed-loop poles from ``damping``/``wn``).
    tau_c_s : float, optional
        SIMC's closed-loop time constant τc (s); default ``max(θ, tau_c_fraction · τ)``.
    tau_c_fraction : float
        The fraction of the approximation's lag τ in the default τc.
    derivative_filter : float
        ``N`` of the derivative filter ``tf = Td / N``.
    integral : bool, optional
        Integral action on the position loop (a PID; default: a PD, as the motor integrates).
        The velocity loop always has it (a PI).
    damping, wn : float, optional
        ζ and ωn (rad/s) of the placed poles (``rule='placement'``; both needed there).
    kp, ki, kd : float, optional
        Gains given instead of the rule's (each on its own); the margins and poles are those
        of the gains used.
    """

    loop: str = "velocity"
    rule: str = "simc"
    tau_c_s: float | None = None
    tau_c_fraction: float = TAU_C_FRACTION
    derivative_filter: float = DERIVATIVE_FILTER_N
    integral: bool | None = None
    damping: float | None = None
    wn: float | None = None
    kp: float | None = None
    ki: float | None = None
    kd: float | None = None

    def __post_init__(self) -> None:
        if self.loop not in PID_LOOPS:
            raise OptionError(f"--pid-loop {self.loop!r}: use velocity or position")
        if self.rule not in PID_RULES:
            raise OptionError(f"--pid-rule {self.rule!r}: use simc or placement")
        for name, option in (("tau_c_s", "--tau-c"), ("damping", "--damping"), ("wn", "--wn")):
            v = getattr(self, name)
            if v is not None and not (_finite(v) and v > 0):
                raise OptionError(f"{option} must be a finite number > 0, got {v!r}")
        if not (_finite(self.tau_c_fraction) and self.tau_c_fraction > 0):
            raise OptionError(f"tau_c_fraction must be a finite number > 0, got {self.tau_c_fraction!r}")
        if not (_finite(self.derivative_filter) and self.derivative_filter > 0):
            raise OptionError(f"--derivative-filter must be a finite number > 0, got {self.derivative_filter!r}")
        for name in ("kp", "ki", "kd"):
            v = getattr(self, name)
            if v is not None and not _finite(v):
                raise OptionError(f"{name} must be a finite number, got {v!r}")
        if self.integral is False and self.loop == "velocity":
            raise OptionError("the velocity loop is a PI (integral action is what removes its steady-state error)")
        if self.rule == "placement":
            if self.damping is None or self.wn is None:
                raise OptionError("--pid-rule placement needs --damping and --wn (the placed poles)")
            if self.tau_c_s is not None:
                raise OptionError("--tau-c is SIMC's; --pid-rule placement takes --damping and --wn")
        elif self.damping is not None or self.wn is not None:
            raise OptionError("--damping and --wn place the PID's poles: add --pid-rule placement")

    @property
    def with_integral(self) -> bool:
        """Whether the controller integrates (always on the velocity loop)."""
        return self.loop == "velocity" or bool(self.integral)


@dataclass(frozen=True, slots=True)
class ReducedModel:
    """The low-order approximation a rule tunes on.

    ``gain · e^{−θs} / (τ s + 1)`` (the velocity channel) or ``gain · e^{−θs} / (s (τ s + 1))``
    (the position channel, ``integrating``).

    Attributes
    ----------
    gain : float
        ``k`` (output unit per V) or, integrating, ``k'`` (output unit per (V·s)).
    tau_s : float
        The lag τ (s); 0 when none is left.
    theta_s : float
        The effective dead time θ (s): the model's own plus what the half rule moved into it.
    integrating : bool
        The position channel's integrator is kept.
    order : int
        The order of the channel's transfer function it approximates.
    notes : tuple of str
        How it was obtained (the half rule's steps), for the printout and the warnings.
    """

    gain: float
    tau_s: float
    theta_s: float
    integrating: bool
    order: int
    notes: tuple[str, ...] = ()

    def text(self, unit: str = "V", input_unit: str = "V") -> str:
        """The approximation as a formula with its numbers.

        Parameters
        ----------
        unit : str
            The output's unit (``rpm``; ``V`` for scope volts).
        input_unit : str
            The command's unit (``V``; ``pwm`` for a PWM register, ``%`` for a duty cycle).

        Returns
        -------
        str
            E.g. ``2 rpm/V · e^(−0.1·s) / (0.5·s + 1)``.
        """
        from motorid.numfmt import sig

        per = f"{unit}/({input_unit}·s)" if self.integrating else f"{unit}/{input_unit}"
        lag = f"({sig(self.tau_s)}·s + 1)" if self.tau_s > 0 else "1"
        den = f"s·{lag}" if self.integrating else lag
        dead = f" · e^(−{sig(self.theta_s)}·s)" if self.theta_s > 0 else ""
        return f"{sig(self.gain)} {per}{dead} / {den}"

    def to_json(self) -> dict[str, Any]:
        """The Design JSON's ``pid.approximation`` object.

        Returns
        -------
        dict
            ``gain``, ``tau_s``, ``theta_s``, ``integrating``, ``order``, ``notes``.
        """
        return {"gain": self.gain, "tau_s": self.tau_s, "theta_s": self.theta_s, "integrating": self.integrating,
                "order": self.order, "notes": list(self.notes)}


def _lags(roots: np.ndarray, what: str) -> tuple[list[float], list[str]]:
    """Time constants ``1/|p|`` of stable poles (or of zeros); a complex pair gives two (a note says so)."""
    taus: list[float] = []
    notes: list[str] = []
    for p in roots:
        if p.imag < 0 and abs(p.imag) > 1e-9 * abs(p):
            continue  # its conjugate speaks for the pair
        if abs(p.imag) > 1e-9 * abs(p):
            wn = abs(p)
            taus += [1.0 / wn, 1.0 / wn]
            notes.append(f"the complex {what} pair at ωn = {wn:.4g} rad/s (ζ = {-p.real / wn:.3g}) is taken as "
                         f"two lags of 1/ωn = {1.0 / wn:.4g} s")
        else:
            taus.append(1.0 / abs(p.real))
    return taus, notes


def reduce_half_rule(num: np.ndarray, den: np.ndarray, delay_s: float, *, integrating: bool,
                     channel: str = "velocity") -> ReducedModel:
    """Skogestad's half rule: a transfer function as gain, one lag and an effective dead time.

    The largest neglected lag is split half to the kept lag, half to the dead time; smaller
    lags go to the dead time whole; a right-half-plane zero's time constant goes to the dead
    time; a left-half-plane zero is taken out with the pole closest to it (rules T1–T3).

    Parameters
    ----------
    num, den : ndarray
        The channel's transfer function, highest power first.
    delay_s : float
        The model's own dead time (s).
    integrating : bool
        Keep one pole at ``s = 0`` (the position channel); the rest must be stable.
    channel : str
        The channel's name, for messages.

    Returns
    -------
    ReducedModel

    Raises
    ------
    ControlDesignError
        For an unstable channel, a velocity channel with an integrator, a position channel
        without one, or a channel without a lag.

    References
    ----------
    Skogestad 2003, §3.1 (half rule), §3.2 (numerator time constants, rules T1–T3).
    """
    num = np.trim_zeros(np.asarray(num, float), "f")
    den = np.trim_zeros(np.asarray(den, float), "f")
    order = den.size - 1
    scale = float(np.max(np.abs(den)))
    if integrating:
        if abs(den[-1]) > 1e-12 * scale:
            raise ControlDesignError(f"the {channel} channel does not integrate the command; the position loop "
                                     "needs a position output that integrates the velocity")
        den = den[:-1]
    poles = np.roots(den) if den.size > 1 else np.zeros(0, complex)
    if np.any(np.abs(poles) < 1e-12 * max(1.0, scale)) or np.any(poles.real >= 0):
        which = "another integrator" if integrating else "an integrator or an unstable pole"
        raise ControlDesignError(f"the {channel} transfer function has {which} (poles "
                                 f"{', '.join(f'{p:.4g}' for p in poles)}); the PID rules need a stable "
                                 "(or, for the position, singly integrating) motor")
    if num.size == 0 or num[-1] == 0:
        raise ControlDesignError(f"the {channel} transfer function has a zero at s = 0 (no steady-state gain)")
    gain = float(num[-1] / den[-1])
    taus, notes = _lags(poles, "pole")
    theta = float(delay_s)
    zeros = np.roots(num) if num.size > 1 else np.zeros(0, complex)
    pairs: list[tuple[float, float]] = []
    for z in sorted(zeros, key=lambda z: -1.0 / abs(z)):
        t0 = 1.0 / abs(z)
        if z.real > 0:  # inverse response: its time constant is dead time
            theta += t0
            notes.append(f"the right-half-plane zero at {z.real:.4g} adds {t0:.4g} s to the dead time")
            continue
        if not taus:
            continue
        j = int(np.argmin([abs(math.log(t0 / t)) for t in taus]))
        pairs.append((t0, taus.pop(j)))
    # a provisional dead time for the zero rules: the half rule on the lags left
    ordered = sorted(taus, reverse=True)
    theta_pre = theta + (ordered[1] / 2 + sum(ordered[2:]) if len(ordered) > 1 else 0.0)
    for t0, tau0 in pairs:
        if t0 >= tau0:  # rules T1, T1a, T1b
            factor = t0 / tau0 if tau0 >= theta_pre else (t0 / theta_pre if t0 >= theta_pre else 1.0)
            gain *= factor
            notes.append(f"the zero with time constant {t0:.4g} s and the lag {tau0:.4g} s are taken as a gain "
                         f"{factor:.4g}")
        else:  # rules T2/T3: zero and lag become one shorter lag
            tilde = min(tau0, 5 * theta_pre) if theta_pre > 0 else tau0
            if tilde < t0:
                tilde = tau0
            gain *= tilde / tau0
            taus.append(tilde - t0)
            notes.append(f"the zero with time constant {t0:.4g} s and the lag {tau0:.4g} s are taken as one lag "
                         f"of {tilde - t0:.4g} s")
    ordered = sorted(taus, reverse=True)
    tau = 0.0
    if ordered:
        half = ordered[1] / 2 if len(ordered) > 1 else 0.0
        tau = ordered[0] + half
        theta += half + sum(ordered[2:])
    if len(ordered) > 1 or pairs or notes:
        shape = "k·e^(−θs)/(s(τs + 1))" if integrating else "k·e^(−θs)/(τs + 1)"
        notes.insert(0, f"the order-{order} {channel} transfer function is reduced to {shape} by Skogestad's "
                        "half rule (the PID is tuned on it; margins, poles and the step response are the full "
                        "model's)")
    if not integrating and tau <= 0:
        raise ControlDesignError(f"the {channel} transfer function leaves no lag to tune a PI on")
    return ReducedModel(gain, tau, theta, integrating, order, tuple(notes))


def channel_system(model: MotorModel, channel: str) -> tuple[control.StateSpace, np.ndarray, np.ndarray]:
    """The command → ``channel`` transfer function as ``(minimal state space, num, den)``.

    From the transfer function (states the channel cannot see, such as the position
    integrator seen from the velocity, are left out: they would be closed-loop poles at 0).
    """
    import control

    if channel not in model.outputs:
        raise OptionError(f"--pid-loop {channel}: the model has no {channel} output (its outputs are "
                          f"{list(model.outputs)}); identify with --{channel} or use the other loop")
    output_row(model, channel)  # refuses a direct feed-through
    coeffs = model.tf_coefficients("position") if channel == "position" else model.tf_coefficients("velocity")
    num, den = (np.asarray(v, float) for v in coeffs)
    plant = control.ss(control.tf(num, den), inputs=[_COMMAND], outputs=[model.signal_name(channel)])
    return plant, num, den


@dataclass(frozen=True, slots=True)
class PidDesign:
    """A PID designed on a model (the Design JSON's ``pid`` object; docs/formats.md).

    Attributes
    ----------
    kp, ki, kd : float
        Parallel-form gains, in the data's units (:attr:`units`).
    tf_s : float
        Time constant of the derivative filter (s); 0 without a derivative.
    loop : str
        ``velocity`` or ``position``.
    rule : str
        ``simc`` or ``placement``.
    output : str
        The measured channel ``y``.
    output_unit : str
        The unit of ``y`` and ``r`` (``rpm``; ``V`` for scope volts).
    units : Mapping[str, str]
        Each gain's unit (``kp``: ``V per rpm``, ``ki``: ``V per (rpm·s)``, ``kd``:
        ``V·s per rpm``, ``tf_s``: ``s``).
    tau_c_s : float or None
        SIMC's closed-loop time constant (None for placement).
    derivative_filter : float
        ``N`` of ``tf = Td / N``.
    approximation : ReducedModel
        What the rule tuned on.
    margins : LoopMargins or None
        Margins of the loop ``C(s)·G(s)·e^{−θs}`` on the full model, broken at the motor's input.
    closed_loop_poles : ndarray
        Poles of the closed loop on the full model, its dead time by a Padé approximant.
    warnings : tuple of str
    dead_time_s : float
        The model's dead time the design was made with.
    """

    kp: float
    ki: float
    kd: float
    tf_s: float
    loop: str
    rule: str
    output: str
    output_unit: str
    units: Mapping[str, str]
    tau_c_s: float | None
    derivative_filter: float
    approximation: ReducedModel
    margins: LoopMargins | None
    closed_loop_poles: np.ndarray
    warnings: tuple[str, ...] = ()
    dead_time_s: float = 0.0
    model_units: Mapping[str, str] = field(default_factory=dict)

    @property
    def kind(self) -> str:
        """``PI``, ``PD``, ``PID``, ``P`` or ``I`` from the non-zero gains."""
        name = "".join(c for c, g in (("P", self.kp), ("I", self.ki), ("D", self.kd)) if g != 0)
        return name or "none"

    @property
    def measured_signal(self) -> str:
        """The name of ``y`` on the python-control systems (``velocity [rpm]``)."""
        return f"{self.output} [{self.output_unit}]"

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int | None]:
        """``(A, B, C, D, i_z)`` of the controller, inputs ``[r, y]``, output ``u``.

        States: the integral ``z`` of ``r − y`` (when ``ki ≠ 0``; index ``i_z``) and the
        filtered measurement ``w`` (``ẇ = (y − w)/tf``, when ``kd ≠ 0``):
        ``u = kp (r − y) + ki z − (kd/tf) (y − w)``.

        Returns
        -------
        (ndarray, ndarray, ndarray, ndarray, int or None)
            The state-space matrices and the integrator's state index (None without one).
        """
        a_rows: list[list[float]] = []
        b_rows: list[list[float]] = []
        c_row: list[float] = []
        i_z = None
        if self.ki != 0:
            i_z = 0
            a_rows.append([0.0])
            b_rows.append([1.0, -1.0])
            c_row.append(self.ki)
        d_y = -self.kp
        if self.kd != 0:
            n = len(a_rows)
            for row in a_rows:
                row.append(0.0)
            a_rows.append([0.0] * n + [-1.0 / self.tf_s])
            b_rows.append([0.0, 1.0 / self.tf_s])
            c_row.append(self.kd / self.tf_s)
            d_y -= self.kd / self.tf_s
        n = len(a_rows)
        return (np.array(a_rows, float).reshape(n, n), np.array(b_rows, float).reshape(n, 2),
                np.array(c_row, float).reshape(1, n), np.array([[self.kp, d_y]]), i_z)

    def system(self) -> control.StateSpace:
        """The controller as a python-control state space: inputs ``r`` and ``y``, output ``u``.

        The derivative acts on the measurement ``y`` only (filtered by ``1/(tf s + 1)``), the
        proportional and integral terms on the error ``r − y``.  The signals are named as
        :func:`motorid.control.controller_system` names a state-feedback controller's, so
        :mod:`motorid.control.emit` discretises and emits either.

        Returns
        -------
        control.StateSpace
            Inputs ``["r", "<channel>"]`` (``r`` and ``y`` in the channel's unit,
            :attr:`output_unit`), output ``["u"]`` (V), states ``z`` (the integral of the
            error) and ``w`` (the filtered measurement) as present.
        """
        import control

        a, b, c, d, i_z = self.matrices()
        states = (["z"] if i_z is not None else []) + (["w"] if self.kd != 0 else [])
        return control.ss(a, b, c, d, inputs=[REFERENCE, self.output], outputs=[COMMAND], states=states)

    def tf(self) -> control.TransferFunction:
        """The PID as a python-control transfer function from the error: ``kp + ki/s + kd s/(tf s + 1)``.

        This is the controller the loop sees (from ``−y`` to ``u``, what the margins are
        computed on); :meth:`system` applies its derivative to the measurement only.

        Returns
        -------
        control.TransferFunction
            Input ``e``, output ``u``.
        """
        import control

        s = control.tf("s")
        c = control.tf([self.kp], [1.0])
        if self.ki != 0:
            c = c + self.ki / s
        if self.kd != 0:
            c = c + self.kd * s / (self.tf_s * s + 1)
        return control.tf(c.num[0][0], c.den[0][0], inputs=["e"], outputs=[COMMAND])

    def gains(self) -> list[tuple[str, float, str]]:
        """``(name, value, unit)`` of ``kp``, ``ki``, ``kd`` and ``tf_s``.

        Returns
        -------
        list of (str, float, str)
        """
        return [(k, float(getattr(self, k)), self.units[k]) for k in ("kp", "ki", "kd", "tf_s")]

    def pid_json(self) -> dict[str, Any]:
        """The Design JSON's ``pid`` object.

        Returns
        -------
        dict
            ``kp``, ``ki``, ``kd``, ``tf_s``, ``loop``, ``rule``, ``units``, ``output``,
            ``output_unit``, ``kind``, ``derivative_on``, ``tau_c_s``, ``derivative_filter``,
            ``dead_time_s``, ``approximation``.
        """
        return {"kp": self.kp, "ki": self.ki, "kd": self.kd, "tf_s": self.tf_s, "loop": self.loop,
                "rule": self.rule, "units": dict(self.units), "output": self.output, "output_unit": self.output_unit,
                "kind": self.kind, "derivative_on": "measurement", "tau_c_s": self.tau_c_s,
                "derivative_filter": self.derivative_filter, "dead_time_s": self.dead_time_s,
                "approximation": self.approximation.to_json()}

    def to_json(self) -> dict[str, Any]:
        """The whole Design JSON (``motorid.design/1``) of this PID, as :meth:`Design.to_json` gives a design's.

        No state feedback: ``states`` and ``K`` are empty, ``kr``, ``ki`` (the state-feedback
        integrator's), ``L`` and ``observer_poles`` null; the controller is the ``pid`` object
        (:meth:`pid_json`).

        Returns
        -------
        dict
            JSON-able.
        """
        from motorid.control.design import _pairs

        doc: dict[str, Any] = {
            "schema": SCHEMA, "states": [], "output": self.output, "K": [], "kr": None, "ki": None, "L": None,
            "closed_loop_poles": _pairs(self.closed_loop_poles), "observer_poles": None, "routh": [],
            "warnings": list(self.warnings), "pid": self.pid_json(),
        }
        if self.model_units:
            doc["units"] = dict(self.model_units)
        if self.margins is not None:
            doc["margins"] = self.margins.to_json()
        return doc

    def to_dict(self) -> dict[str, Any]:
        """The Design JSON as a dict (the same as :meth:`to_json`).

        Returns
        -------
        dict
            JSON-able.
        """
        return self.to_json()

    def to_json_text(self) -> str:
        """:meth:`to_json` as indented text.

        Returns
        -------
        str
        """
        return json.dumps(self.to_json(), indent=2)

    @classmethod
    def from_json(cls, data: Any, *, file: str | None = None) -> PidDesign:
        """Rebuild from a Design JSON with a ``pid`` object (:meth:`to_json`).

        Parameters
        ----------
        data : dict
            The Design JSON.
        file : str, optional
            Named in errors.

        Returns
        -------
        PidDesign

        Raises
        ------
        OptionError
            A malformed ``pid`` object (one line naming the key).
        """
        try:
            return cls._from_json(data)
        except OptionError as exc:
            raise (exc.with_file(file) if file else exc) from None
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
            raise OptionError(f"not a motorid PID design: bad or missing entry ({exc!s})", file=file) from None

    @classmethod
    def _from_json(cls, data: Any) -> PidDesign:
        if not isinstance(data, dict) or data.get("schema") != SCHEMA or not isinstance(data.get("pid"), dict):
            raise OptionError(f"not a motorid PID design: a {SCHEMA} object with a 'pid' object expected")
        p = data["pid"]

        def number(key: str) -> float:
            v = p.get(key)
            if not _finite(v):
                raise OptionError(f"not a motorid PID design: pid.{key} must be a finite number")
            return float(v)

        kp, ki, kd, tf_s = number("kp"), number("ki"), number("kd"), number("tf_s")
        if tf_s < 0:
            raise OptionError("not a motorid PID design: pid.tf_s must be ≥ 0")
        if kd != 0 and not tf_s > 0:
            raise OptionError("not a motorid PID design: pid.tf_s must be > 0 with a derivative (kd ≠ 0)")
        loop = p.get("loop")
        if loop not in PID_LOOPS:
            raise OptionError(f"not a motorid PID design: pid.loop must be one of {list(PID_LOOPS)}")
        output = p.get("output", loop)
        if output not in ("velocity", "position"):
            raise OptionError("not a motorid PID design: pid.output must be velocity or position")
        units = p.get("units") or {}
        if not isinstance(units, dict) or not all(isinstance(v, str) for v in units.values()):
            raise OptionError("not a motorid PID design: pid.units must map gains to unit strings")
        unit = p.get("output_unit") or "V"
        full = _gain_units(str(unit)) | {k: v for k, v in units.items() if k in ("kp", "ki", "kd", "tf_s")}
        appr = p.get("approximation") or {}
        approximation = ReducedModel(float(appr.get("gain", math.nan)), float(appr.get("tau_s", 0.0)),
                                     float(appr.get("theta_s", 0.0)), bool(appr.get("integrating", loop == "position")),
                                     int(appr.get("order", 0)), tuple(str(n) for n in appr.get("notes", [])))
        margins = LoopMargins.from_json(data["margins"]) if isinstance(data.get("margins"), dict) else None
        poles = np.array([complex(re, im) for re, im in (data.get("closed_loop_poles") or [])], dtype=complex)
        tau_c = p.get("tau_c_s")
        raw_units = data.get("units")
        model_units = {str(k): str(v) for k, v in raw_units.items()} if isinstance(raw_units, dict) else {}
        return cls(kp, ki, kd, tf_s, loop, str(p.get("rule", "simc")), output, str(unit), full,
                   float(tau_c) if _finite(tau_c) else None, float(p.get("derivative_filter", DERIVATIVE_FILTER_N)),
                   approximation, margins, poles, tuple(str(w) for w in data.get("warnings", [])),
                   float(p.get("dead_time_s", 0.0) or 0.0), model_units)


def _gain_units(unit: str, input_unit: str = "V") -> dict[str, str]:
    """Each gain's unit for a measured channel in ``unit`` and a command in ``input_unit``."""
    return {"kp": f"{input_unit} per {unit}", "ki": f"{input_unit} per ({unit}·s)",
            "kd": f"{input_unit}·s per {unit}", "tf_s": "s"}


def _simc(red: ReducedModel, s: PidSettings) -> tuple[float, float, float, float, list[str]]:
    """SIMC gains ``(kp, ki, kd, τc)`` in parallel form (Skogestad 2003, eqs. for PI and integrating processes)."""
    tau_c = s.tau_c_s if s.tau_c_s is not None else max(red.theta_s, s.tau_c_fraction * red.tau_s)
    notes = []
    if s.tau_c_s is None:
        notes.append(f"SIMC's τc = max(θ, {s.tau_c_fraction:g}·τ) = {tau_c:.4g} s")
    if not tau_c + red.theta_s > 0:
        raise ControlDesignError("SIMC needs τc + θ > 0: the approximation has neither a lag nor a dead time; "
                                 "give --tau-c")
    if not red.integrating:
        # first-order plus dead time: Kc = τ1 / (k (τc + θ)), τI = min(τ1, 4 (τc + θ))
        kc = red.tau_s / (red.gain * (tau_c + red.theta_s))
        tau_i = min(red.tau_s, 4 * (tau_c + red.theta_s))
        return kc, kc / tau_i, 0.0, tau_c, notes
    # integrating with a lag: Kc = 1 / (k' (τc + θ)), τI = 4 (τc + θ), τD = τ2 (series form)
    kc = 1.0 / (red.gain * (tau_c + red.theta_s))
    tau_d = red.tau_s
    if not s.with_integral:
        return kc, 0.0, kc * tau_d, tau_c, notes
    tau_i = 4 * (tau_c + red.theta_s)
    # series Kc (τI s + 1)(τD s + 1)/(τI s) in parallel form
    return kc * (1 + tau_d / tau_i), kc / tau_i, kc * tau_d, tau_c, notes


def _placement(red: ReducedModel, s: PidSettings) -> tuple[float, float, float, list[str]]:
    """Gains placing the approximation's closed-loop poles (its dead time left out) at ζ/ωn."""
    z, w = float(s.damping or 0.0), float(s.wn or 0.0)
    k, tau = red.gain, red.tau_s
    notes = []
    if red.theta_s > 0:
        notes.append(f"pole placement leaves out the approximation's {red.theta_s:.4g} s dead time: the margins and "
                     "the step response include it")
    if not red.integrating:
        # τ s² + (1 + k kp) s + k ki = τ (s² + 2ζωn s + ωn²)
        return (2 * z * w * tau - 1) / k, w * w * tau / k, 0.0, notes
    if tau <= 0:  # k'/s: s + k' kp (PD) or s² + k' kp s + k' ki (PID)
        if s.with_integral:
            return 2 * z * w / k, w * w / k, 0.0, notes
        notes.append("the position channel has no lag left: one pole placed, at −ωn")
        return w / k, 0.0, 0.0, notes
    if not s.with_integral:
        # τ s² + (1 + k' kd) s + k' kp = τ (s² + 2ζωn s + ωn²)  (derivative filter neglected)
        return w * w * tau / k, 0.0, (2 * z * w * tau - 1) / k, notes
    # τ s³ + (1 + k' kd) s² + k' kp s + k' ki = τ (s² + 2ζωn s + ωn²)(s + ωn)
    notes.append("the third pole is placed at −ωn")
    return tau * (w * w + 2 * z * w * w) / k, tau * w ** 3 / k, (tau * (2 * z * w + w) - 1) / k, notes


def design_pid(model: MotorModel, settings: PidSettings) -> PidDesign:
    """Tune a PID for ``model`` (velocity PI, position PD or PID).

    Parameters
    ----------
    model : MotorModel
        Any model ``identify`` writes (first to third order, with or without a dead time).
    settings : PidSettings

    Returns
    -------
    PidDesign
        Gains, margins and closed-loop poles on the full model with its dead time.

    Raises
    ------
    OptionError
        The loop's channel is not an output of the model.
    ControlDesignError
        A model the rules cannot tune (unstable, no lag left, no steady-state gain).

    References
    ----------
    Skogestad 2003, §3 (half rule), §4 (SIMC).
    """
    s = settings
    channel = s.loop
    plant, num, den = channel_system(model, channel)
    red = reduce_half_rule(num, den, model.delay_s, integrating=channel == "position", channel=channel)
    unit = channel_unit(model.units, channel)

    def tuned(tau_c_s: float | None) -> tuple[PidDesign, list[str]]:
        notes: list[str] = []
        tau_c: float | None = None
        if s.rule == "simc":
            kp, ki, kd, tau_c, notes = _simc(red, replace(s, tau_c_s=tau_c_s) if tau_c_s is not None else s)
        else:
            kp, ki, kd, notes = _placement(red, s)
        for name, given in (("kp", s.kp), ("ki", s.ki), ("kd", s.kd)):
            if given is not None:
                rule_value = {"kp": kp, "ki": ki, "kd": kd}[name]
                notes.append(f"{name} = {given:.4g} given (the rule's: {rule_value:.4g})")
                kp, ki, kd = (given if name == "kp" else kp, given if name == "ki" else ki,
                              given if name == "kd" else kd)
        for name, v in (("kp", kp), ("ki", ki), ("kd", kd)):
            if v < 0:
                notes.append(f"{name} = {v:.4g} is negative: the poles asked for are slower than the motor's own; "
                             "ask for a larger --wn")
        td = kd / kp if kp != 0 else kd
        tf_s = abs(td) / s.derivative_filter if kd != 0 else 0.0
        pid = PidDesign(float(kp), float(ki), float(kd), float(tf_s), channel, s.rule, channel, unit,
                        _gain_units(unit, model.input_unit), tau_c, float(s.derivative_filter), red,
                        None, np.zeros(0, complex), (),
                        float(model.delay_s), dict(model.units))
        return _with_loop(pid, plant), notes

    pid, notes = tuned(None)
    # SIMC's own τc on an approximation too coarse for the model (a lightly damped pair, a large
    # zero) can leave a fragile loop: slow it down (τc doubled) until Ms ≤ 2, Skogestad's upper
    # robustness target, and say so; a τc, a gain or poles the user gave are kept as given
    if s.rule == "simc" and s.tau_c_s is None and s.kp is None and s.ki is None and s.kd is None:
        first = pid.tau_c_s
        for _ in range(MAX_DETUNE):
            if _robust(pid):
                break
            pid, notes = tuned(2 * float(pid.tau_c_s or 0.0))
        if pid.tau_c_s != first:
            notes.append(f"τc raised from {first:.4g} s to {pid.tau_c_s:.4g} s (doubled until Ms ≤ {MS_TARGET:g}): "
                         "SIMC's τc left the full model's loop fragile")
    warnings = [*red.notes, *notes]
    poles, margins = pid.closed_loop_poles, pid.margins
    if np.any(poles.real >= 0):
        worst = poles[np.argmax(poles.real)]
        warnings.append(f"UNSTABLE: the closed loop on the full model{' with its dead time' if model.delay_s else ''} "
                        f"has a pole at {worst:.4g}; ask for a slower loop (a larger --tau-c or a smaller --wn)")
    elif margins is not None and math.isfinite(margins.ms) and margins.ms > MS_TARGET:
        warnings.append(f"the sensitivity peak Ms = {margins.ms:.3g} is above {MS_TARGET:g}: little robustness; ask "
                        "for a slower loop (a larger --tau-c or a smaller --wn)")
    return replace(pid, warnings=tuple(warnings))


def _robust(pid: PidDesign) -> bool:
    """Stable, with a sensitivity peak within :data:`MS_TARGET`."""
    m = pid.margins
    return bool(np.all(pid.closed_loop_poles.real < 0)) and m is not None and math.isfinite(m.ms) \
        and m.ms <= MS_TARGET


def _with_loop(pid: PidDesign, plant: control.StateSpace) -> PidDesign:
    """``pid`` with the closed-loop poles and margins of its loop on ``plant`` and the model's dead time."""
    import control

    ctrl = control.ss(pid.tf())
    fastest = max(float(np.max(np.abs(np.linalg.eigvals(np.asarray(plant.A, float))), initial=0.0)),
                  1.0 / pid.tf_s if pid.tf_s > 0 else 0.0, 1.0)
    pade = dead_time_pade(pid.dead_time_s, fastest)
    delayed = plant if pade is None else plant * pade
    closed = control.feedback(delayed, ctrl)
    poles = np.asarray(closed.poles(), complex)
    c_r = control.tf([pid.kp], [1.0]) + (control.tf([pid.ki], [1.0, 0.0]) if pid.ki != 0 else 0)
    bandwidth = closed_loop_bandwidth(control.tf(closed) * c_r)
    margins = open_loop_margins(ctrl * plant, pid.dead_time_s, bandwidth)
    return replace(pid, margins=margins, closed_loop_poles=poles)


def pid_loop_frequency_response(model: MotorModel, pid: PidDesign, points: int = 800) -> tuple[np.ndarray, np.ndarray]:
    """``L(jω) = C(jω) G(jω) e^{−jωθ}`` of the PID's loop, the model's dead time exact.

    The counterpart of :func:`motorid.control.margins.loop_frequency_response` for a PID.

    Parameters
    ----------
    model : MotorModel
        The model the PID was designed for.
    pid : PidDesign
    points : int
        Frequencies, log-spaced over five decades around the loop's fastest pole.

    Returns
    -------
    (ndarray, ndarray)
        ``ω`` (rad/s) and the complex ``L(jω)``.
    """
    import control

    from motorid.control.margins import _response

    plant, _num, _den = channel_system(model, pid.loop)
    loop = control.ss(pid.tf()) * plant
    fastest = max(float(np.max(np.abs(np.linalg.eigvals(np.asarray(loop.A, float))), initial=0.0)), 1.0)
    omega = np.logspace(np.log10(fastest) - 4, np.log10(fastest) + 1, points)
    return omega, _response(loop, omega) * np.exp(-1j * omega * float(model.delay_s))
