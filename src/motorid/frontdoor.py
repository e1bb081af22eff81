"""The Python front door: captures → model → controller → closed loop → report in five calls.

>>> import motorid as mi                                             # doctest: +SKIP
>>> exp = mi.read_experiment(position="D/ALL0000", velocity="D/ALL0001", current="D/ALL0002")
>>> fit = mi.identify(exp)
>>> print(fit.summary())
>>> des = mi.design(fit.model, damping=0.7, wn=5.0)
>>> sim = mi.simulate(fit.model, des, duration_s=3.0); sim.plot()
>>> mi.write_report("report.html", fit, design=des)

Each function is a thin layer over the library (:func:`motorid.io.read_capture`,
:func:`motorid.identification.pipeline.identify_experiment`, :func:`motorid.control.design.design_controller`,
:func:`motorid.simulation.closed_loop.simulate_closed_loop`, :func:`motorid.report.assemble.make_report`):
it checks the keyword options, naming the Python parameter in the one-line
:class:`~motorid.errors.MotorIdError` it raises, and returns a frozen result.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace
from importlib.metadata import PackageNotFoundError, version
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Literal, cast

from motorid.frozen import frozen_getstate, frozen_setstate
from motorid.capture import Capture
from motorid.identification.result import ParameterEstimate
from motorid.errors import MotorIdError, OptionError
from motorid.numfmt import complex_text, sig
from motorid.options import speaks_as_called

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from motorid.analysis.advice import Advice
    from motorid.analysis.validation import ValidationResult
    from motorid.conditioning.segment import StepSegment
    from motorid.control.design import Design
    from motorid.control.pid import PidDesign
    from motorid.identification.hammerstein import MultiLevelResult
    from motorid.identification.method_options import MethodOptions
    from motorid.identification.pipeline import Identification
    from motorid.identification.sanity import SanityReport
    from motorid.model import MotorModel
    from motorid.model.units import ChannelScale
    from motorid.simulation.closed_loop import ReferenceSignal, SimulationResult, SimulationSettings

__all__ = [
    "Experiment",
    "IdentificationResult",
    "ParameterEstimate",
    "Provenance",
    "advise",
    "design",
    "design_pid",
    "identify",
    "identify_levels",
    "read_experiment",
    "simulate",
    "validate",
    "write_report",
]

#: The roles a capture can be given as, in the order the command line lists them.
ROLES: tuple[str, ...] = ("position", "velocity", "current")

CapturePath = str | PathLike[str] | Sequence[str | PathLike[str]]


# --------------------------------------------------------------------------------- experiment


@dataclass(frozen=True, slots=True)
class Experiment:
    """The captures of one step experiment, by role, as read from the files.

    Attributes
    ----------
    captures : Mapping[str, Capture]
        ``position``, ``velocity`` and/or ``current`` (read-only mapping).
    step_volts : float or None
        Step level for captures without an input channel (CH1 gives it otherwise) [V].
    t0_s : float or None
        Step instant on the files' time axis (default: CH1's edge, or the response's onset) [s].
    sources : Mapping[str, tuple of str]
        The file(s) or folder each role was read from.
    sha256 : Mapping[str, str]
        SHA-256 (hex) of every input file, keyed by path (a folder gives each of its files).
    units : Mapping[str, str]
        Each channel's unit as the user declared it (``{"velocity": "rpm"}``); the files'
        own labels otherwise.
    scales : Mapping[str, ChannelScale]
        Sensor constants (volts per physical unit) the user gave.
    steps : tuple of StepSegment
        The input steps of a velocity log that holds several (a staircase, a pulse), in time
        order; empty for an ordinary step capture.
    segment : int or None
        Which of ``steps`` the velocity capture was cut to (1-based); None when it is the
        whole log (an ordinary capture, or a staircase for :func:`identify_levels`).
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    captures: Mapping[str, Capture]
    step_volts: float | None = None
    t0_s: float | None = None
    sources: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    sha256: Mapping[str, str] = field(default_factory=dict)
    units: Mapping[str, str] = field(default_factory=dict)
    scales: Mapping[str, ChannelScale] = field(default_factory=dict)
    steps: tuple[StepSegment, ...] = ()
    segment: int | None = None

    def __post_init__(self) -> None:
        for name in ("captures", "sources", "sha256", "units", "scales"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))
        object.__setattr__(self, "steps", tuple(self.steps))

    def step_captures(self) -> tuple[Capture, ...]:
        """Each input step of a several-steps velocity log as a capture of its own.

        What :func:`identify_levels` takes: ``identify_levels(exp.step_captures())`` is
        ``motorid identify --velocity LOG`` on a staircase.

        Returns
        -------
        tuple of Capture
            One per entry of :attr:`steps` (empty for an ordinary step capture).

        Raises
        ------
        OptionError
            The experiment holds one segment only (``segment`` was given).
        """
        from motorid.conditioning.segment import cut_segment

        if self.segment is not None:
            raise OptionError(f"this experiment is segment {self.segment} of its log: read the log again without "
                              "--segment to cut every step")
        return tuple(cut_segment(self.captures["velocity"], s) for s in self.steps)

    def several_steps(self) -> bool:
        """Whether the velocity capture is a whole log with several input steps (no segment picked).

        Returns
        -------
        bool
        """
        return len(self.steps) >= 2 and self.segment is None


def _paths(spec: CapturePath, role: str = "capture") -> list[Path]:
    """A capture argument's files: one path, or a sequence of paths (a CH1/CH2 pair); else refused."""
    if isinstance(spec, (str, PathLike)):
        return [Path(spec)]
    if isinstance(spec, Sequence) and spec and all(isinstance(p, (str, PathLike)) for p in spec):
        return [Path(p) for p in spec]
    raise OptionError(f"--{role}: give a capture file, an ALLnnnn folder or a [CH1, CH2] pair of files, "
                      f"not {spec!r}")


def _file_digests(paths: Sequence[Path]) -> dict[str, str]:
    """SHA-256 of each file (each regular file of a folder), for the provenance record."""
    files: list[Path] = []
    for p in paths:
        files.extend(sorted(f for f in p.iterdir() if f.is_file()) if p.is_dir() else [p])
    digests = {}
    for f in files:
        h = hashlib.sha256()
        with open(f, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        digests[str(f)] = h.hexdigest()
    return digests


@speaks_as_called("identify_levels")
def identify_levels(
    velocity: Sequence[CapturePath | Capture],
    *,
    step_volts: Sequence[float] | None = None,
    columns: Mapping[str, str] | str | None = None,
) -> MultiLevelResult:
    """Identify dead-zone, gain, rails and shared dynamics from steps at several levels.

    ``motorid identify --velocity A --velocity B ...`` in Python: a Hammerstein
    model ``y = K·G(s)·f(u)``.

    Parameters
    ----------
    velocity : sequence of str, Path (or CH1/CH2 pairs) or Capture
        One velocity capture per step experiment (repeats of a level are separate captures);
        a :class:`Capture` is taken as it is (e.g. one step of a staircase log).
    step_volts : sequence of float, optional
        The level of each capture without an input channel: one per capture, or one for all.
    columns : Mapping or str, optional
        Plain-CSV column map.

    Returns
    -------
    MultiLevelResult
        ``.model`` (with ``static_nonlinearity``), ``.static`` (the law with intervals and
        every level's status), ``.dynamics`` and ``.dynamics_note``.

    Raises
    ------
    OptionError
        Fewer than two moving levels, or mismatched ``step_volts``.
    """
    from motorid.identification.hammerstein import identify_levels as _identify_levels
    from motorid.io import read_capture
    from motorid.options import real_numbers

    levels: list[float | None] | None = None
    step_volts = real_numbers(step_volts, "--step-volts")
    if step_volts is not None:
        if len(step_volts) == 1:
            levels = [float(step_volts[0])] * len(velocity)
        elif len(step_volts) == len(velocity):
            levels = [float(v) for v in step_volts]
        else:
            raise OptionError(f"--step-volts gives {len(step_volts)} levels for {len(velocity)} captures; give one "
                              "per capture, in the order of the --velocity/--experiment options")
    caps = []
    for spec in velocity:
        if isinstance(spec, Capture):
            caps.append(spec)
            continue
        paths = [str(p) for p in _paths(spec, "velocity")]
        caps.append(read_capture(paths[0] if len(paths) == 1 else paths, columns=columns,
                                 role="velocity"))
    return _identify_levels(caps, step_volts=levels)


def _mapping(value: Any, flag: str) -> list[tuple[Any, Any]]:
    """The items of an option given as a mapping (None: none); anything else is refused, naming ``flag``."""
    if value is None:
        return []
    if not isinstance(value, Mapping):
        raise OptionError(f"{flag}: give CHANNEL=VALUE text or a mapping, not {value!r}")
    return list(value.items())


@speaks_as_called("read_experiment")
def read_experiment(
    *,
    position: CapturePath | None = None,
    velocity: CapturePath | None = None,
    current: CapturePath | None = None,
    step_volts: float | None = None,
    t0: float | None = None,
    columns: Mapping[str, str] | str | None = None,
    force_role: bool = False,
    time_unit: Literal["s", "ms", "us"] | None = None,
    units: Mapping[str, str] | str | None = None,
    scale: Mapping[str, str | ChannelScale] | str | None = None,
    segment: int | None = None,
    counted_velocity: bool = False,
) -> Experiment:
    """Read the captures of one step experiment, one per role.

    Parameters
    ----------
    position, velocity, current : path or [CH1, CH2] pair, optional
        A capture file (Tektronix CSV, ``.xlsx``, plain CSV), a scope ``ALLnnnn`` folder, or
        a sequence of Tektronix channel files (CH1 = input, CH2 = output).  ``velocity`` or
        ``position`` is required.
    step_volts : float, optional
        Step level [V] for captures without an input channel.
    t0 : float, optional
        Step instant [s] on the files' time axis.
    columns : Mapping[str, str] or str, optional
        Column map of plain tables, e.g. ``{"time": "t", "input": "u", "velocity": "rpm"}`` or the
        command line's ``"time=t,input=u,velocity=rpm"``; a table with no header row names its
        columns by position (``"time=1,input=2,velocity=3"``).
    force_role : bool
        Keep a role even when the capture confidently looks like another one.
    time_unit : {"s", "ms", "us"}, optional
        Unit of a plain table's time column (default: from its name, or whole milliseconds).
    units : Mapping[str, str] or str, optional
        Each channel's unit, e.g. ``{"velocity": "rpm"}`` or the command line's
        ``"velocity=rpm,current=A"`` (default: from the files).
    scale : Mapping[str, str or ChannelScale] or str, optional
        Sensor constants, e.g. ``{"velocity": "0.1504V/(rad/s)", "current": "0.47ohm"}`` or the
        command line's ``"velocity=0.1504V/(rad/s);current=0.47ohm"``.
    segment : int, optional
        A velocity log with several input steps (a staircase, a pulse): cut it to step N
        (1-based) for :func:`identify`.  Without it such a log stays whole, its steps listed in
        :attr:`Experiment.steps`, for :func:`identify_levels` (``exp.step_captures()``); a pulse
        (one level that moves the motor) is cut to its first step.
    counted_velocity : bool
        The velocity is counted over each sample interval (encoder edges since the last sample,
        as Arduino sketches print rpm): each value is the mean speed over the interval before
        it, and the output-error fit models it so (:attr:`Capture.sample_window_s`).  A log whose
        speed times its own jittered stamped intervals is whole counts is read so by the reader
        (:attr:`Capture.count_over_stamps`).

    Returns
    -------
    Experiment
        The captures by role, the step options, the files' SHA-256 and the input steps found.

    Raises
    ------
    OptionError
        No velocity or position capture; a bad ``step_volts``/``t0``; a capture that looks
        like another role (the same check as the command line's ``--force-role``).
    CaptureFormatError, CaptureDataError
        A missing or unreadable file (the message names it).
    """
    from motorid.conditioning.role import role_conflict
    from motorid.io import read_capture
    from motorid.io._table import parse_column_map

    from motorid.model.units import channel_unit, parse_scales, parse_units, units_of

    named = {"position": position, "velocity": velocity, "current": current}
    given = {role: spec for role, spec in named.items() if spec is not None}
    if "velocity" not in given and "position" not in given:
        raise OptionError("give at least --velocity or --position (a capture file or ALLnnnn folder)")
    if not isinstance(counted_velocity, bool):
        # (the command line's switch is always a bool: only a Python or web caller gets here)
        raise OptionError(f"counted_velocity must be True or False, got {counted_velocity!r}")
    if counted_velocity and "velocity" not in given:
        raise OptionError("--counted-velocity describes a velocity capture: give it with --velocity")
    if step_volts is not None and not (isinstance(step_volts, (int, float)) and math.isfinite(step_volts)
                                       and step_volts != 0):
        raise OptionError(f"--step-volts {step_volts!r}: give a finite, non-zero number of volts "
                          "(a negative value is a step down)")
    if t0 is not None and not (isinstance(t0, (int, float)) and math.isfinite(t0)):
        raise OptionError(f"--t0 {t0!r}: give a finite time in seconds")
    # the command line's text is taken as well as a mapping (one parser for every front end)
    declared = parse_units([units] if isinstance(units, str) else (f"{k}={v}" for k, v in _mapping(units, "--units")))
    if isinstance(scale, str):
        scales: dict[str, ChannelScale] = parse_scales([scale])
    else:
        given_scales = _mapping(scale, "--scale")
        scales = {k: v for k, v in given_scales if not isinstance(v, str)}
        scales.update(parse_scales(f"{k}={v}" for k, v in given_scales if isinstance(v, str)))
    columns = parse_column_map(columns)
    if time_unit is not None:
        columns = {**(columns or {}), "time_unit": time_unit}
    captures: dict[str, Capture] = {}
    sources: dict[str, tuple[str, ...]] = {}
    digests: dict[str, str] = {}
    for role, spec in given.items():
        paths = _paths(spec, role)
        arg = str(paths[0]) if len(paths) == 1 else [str(p) for p in paths]
        cap = read_capture(arg, columns=columns, role=role)
        if not force_role:
            looks = role_conflict(cap, role)
            if looks is not None:
                raise OptionError(f"given as --{role} but looks like a {looks.role} capture ({looks.reason}); "
                                  f"give it as --{looks.role}, or --force-role to keep --{role}",
                                  file=str(paths[0]))
        if role == "velocity" and counted_velocity:
            cap = cap.counted()
        captures[role] = cap
        sources[role] = tuple(str(p) for p in paths)
        digests.update(_file_digests(paths))
    data_units = units_of(captures, declared)
    for channel, sc in scales.items():
        if channel_unit(data_units, channel) != "V":
            raise OptionError(f"--scale {channel}: the {channel} data are already in {data_units[channel]}, not volts "
                              f"(a sensor constant turns volts into {sc.unit}); leave --scale {channel} out, or "
                              f"declare --units {channel}=V if the column is volts")
    steps, picked = _log_steps(captures, segment)
    if picked is not None:
        captures["velocity"] = picked[1]
    return Experiment(captures, None if step_volts is None else float(step_volts),
                      None if t0 is None else float(t0), sources, digests, declared, scales,
                      steps=steps, segment=None if picked is None else picked[0])


def _log_steps(captures: Mapping[str, Capture], segment: int | None
               ) -> tuple[tuple[StepSegment, ...], tuple[int, Capture] | None]:
    """The input steps of the velocity log (several, or none), and the segment to cut it to.

    ``segment`` picks one; a pulse (one level that moves the motor: a static characteristic
    needs two) is cut to its first step, with a note on the capture; a staircase stays whole.
    """
    from motorid.conditioning.segment import cut_segment, find_steps

    if segment is not None and (isinstance(segment, bool) or not isinstance(segment, int)):
        raise OptionError(f"--segment {segment!r}: give a whole number ≥ 1")
    cap = captures.get("velocity")
    steps = find_steps(cap) if cap is not None else ()
    if segment is not None and not (1 <= segment <= max(1, len(steps))):
        found = "; ".join(s.describe() for s in steps) or "one step"
        raise OptionError(f"--segment {segment}: the velocity log has {max(1, len(steps))} step(s) ({found})")
    if cap is None or len(steps) < 2:
        return (), None
    if segment is not None:
        return steps, (segment, cut_segment(cap, steps[segment - 1]))
    span = max(abs(s.to_v) for s in steps)
    moving = sorted({round(s.to_v, 6) for s in steps if abs(s.to_v) > 0.05 * span})
    if len(moving) < 2:
        first = cut_segment(cap, steps[0])
        note = (f"one level moves the motor ({', '.join(f'{v:g} {steps[0].unit}' for v in moving)}): identified "
                "from segment 1 (--segment N for another)")
        return steps, (1, replace(first, warnings=(*first.warnings, note)))
    return steps, None


#: A record length must hold at least this many samples of the captures.
MIN_RECORD_SAMPLES = 20


def check_record_length(captures: Mapping[str, Capture], record_length_s: float | None) -> None:
    """Refuse a record length that keeps fewer than :data:`MIN_RECORD_SAMPLES` samples of a capture.

    Parameters
    ----------
    captures : Mapping[str, Capture]
        The captures as read (not yet conditioned).
    record_length_s : float or None
        Seconds kept after the step (None: all).

    Raises
    ------
    OptionError
        Naming the capture, its sample interval and the shortest length that would do.
    """
    if record_length_s is None:
        return
    for cap in captures.values():
        dt = float(cap.time_s[-1] - cap.time_s[0]) / max(cap.n_samples - 1, 1)
        if record_length_s < MIN_RECORD_SAMPLES * dt:
            raise OptionError(f"--record-length {record_length_s:g} s holds fewer than {MIN_RECORD_SAMPLES} samples "
                              f"(Δt {dt:.3g} s): give at least {MIN_RECORD_SAMPLES * dt:.3g} s", file=cap.source)


def several_steps_message(experiment: Experiment) -> str:
    """Why :func:`identify` does not take a whole staircase log, and what to do instead.

    Parameters
    ----------
    experiment : Experiment
        One with :meth:`Experiment.several_steps`.

    Returns
    -------
    str
        The steps found, and the two ways on (one segment, or all of them together).
    """
    cap = experiment.captures["velocity"]
    found = "; ".join(s.describe() for s in experiment.steps)
    return (f"{cap.source}: {len(experiment.steps)} input steps found ({found}): one model is identified from one "
            "step — pick one with --segment N (segment = N in a batch's experiment.toml), or fit all of them "
            "together (dead-zone, gain, rails and shared dynamics): the command line's identify does so with the "
            "log alone, Python with identify_levels(experiment.step_captures())")


# ------------------------------------------------------------------------------ identification


@dataclass(frozen=True, slots=True)
class Provenance:
    """How a result was obtained.

    Attributes
    ----------
    version : str
        motorid's version.
    inputs_sha256 : Mapping[str, str]
        SHA-256 of every input file, keyed by path.
    settings : Mapping[str, Any]
        The identification settings (``IdentifySettings`` as a dict) with ``step_volts`` and ``t0_s``.
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    version: str
    inputs_sha256: Mapping[str, str]
    settings: Mapping[str, Any]

    def __post_init__(self) -> None:
        object.__setattr__(self, "inputs_sha256", MappingProxyType(dict(self.inputs_sha256)))
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))


@dataclass(frozen=True, slots=True)
class IdentificationResult:
    """An identified motor model with everything about how it was obtained.

    Attributes
    ----------
    model : MotorModel
        The model (python-control objects inside: ``model.velocity_tf``, ``model.state_space``).
    params : Mapping[str, ParameterEstimate]
        ``dc_gain`` [V/V], ``time_constant`` [s], ``delay`` [s] (when fitted), ``pole_1``…,
        ``zero_1``… [1/s] (read-only).
    stages : tuple of Mapping
        What each stage of ``method="auto"`` found.
    fit : Mapping[str, float]
        Goodness of fit (``velocity_nrmse`` as a fraction, ``*_fit_percent``).
    warnings : tuple of str
        Everything the method was unsure about, the sanity gate's failures first.
    sanity : SanityReport
        The sanity gate's checks.
    reason : str
        Why this model was chosen.
    provenance : Provenance
        Version, input files' SHA-256 and settings.
    experiment : Experiment
        The captures it was identified from.
    identification : Identification
        The pipeline's own result (conditioned data, every candidate model).
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    model: MotorModel
    params: Mapping[str, ParameterEstimate]
    provenance: Provenance
    experiment: Experiment
    identification: Identification

    # each of these is held once, by the model or by the pipeline's result, and read from there
    @property
    def stages(self) -> tuple[Mapping[str, Any], ...]:
        """What each stage of ``method="auto"`` found (the model's ``stages``)."""
        return tuple(self.model.stages)

    @property
    def fit(self) -> Mapping[str, float]:
        """Goodness of fit (the model's ``fit``)."""
        return self.model.fit

    @property
    def warnings(self) -> tuple[str, ...]:
        """Everything the method was unsure about, the sanity gate's failures first (the model's)."""
        return self.model.warnings

    @property
    def sanity(self) -> SanityReport:
        """The sanity gate's checks (the pipeline's)."""
        return self.identification.sanity

    @property
    def reason(self) -> str:
        """Why this model was chosen (the pipeline's)."""
        return self.identification.reason

    def __repr__(self) -> str:
        """One line: method, structure, the headline numbers with their intervals, the checks."""
        return f"<IdentificationResult {self._headline()}>"

    def _headline(self) -> str:
        m = self.model
        parts = [f"{m.method}, {len(m.poles())} pole(s)"]
        for key, label in (("dc_gain", "dc gain"), ("time_constant", "τ"), ("delay", "dead time")):
            p = self.params.get(key)
            if p is None:
                continue
            text = f"{label} {sig(complex(p.value).real)} {p.unit}".rstrip()
            if p.ci95 is not None:
                text += f" [{sig(p.ci95[0])}, {sig(p.ci95[1])}]"
            parts.append(text)
        checks = len(self.sanity.checks)
        parts.append(f"{checks - len(self.sanity.failures)}/{checks} checks passed")
        if self.warnings:
            parts.append(f"{len(self.warnings)} warning(s)")
        return "; ".join(parts)

    def _repr_html_(self) -> str:
        """A notebook's view: the headline, the parameters with their intervals, the warnings."""
        from html import escape

        rows = []
        for name, p in self.params.items():
            ci = "" if p.ci95 is None else f"[{sig(p.ci95[0])}, {sig(p.ci95[1])}]"
            err = "" if not math.isfinite(p.stderr) else sig(p.stderr)
            value = complex_text(p.value) if isinstance(p.value, complex) else sig(float(p.value))
            rows.append(f"<tr><td>{escape(name)}</td><td>{escape(value)}</td><td>{escape(err)}</td>"
                        f"<td>{escape(ci)}</td><td>{escape(p.unit)}</td></tr>")
        warn = "".join(f"<li>{escape(w)}</li>" for w in self.warnings)
        return (f"<p><b>IdentificationResult</b>: {escape(self._headline())}</p>"
                "<table><tr><th>parameter</th><th>value</th><th>std</th><th>95 % interval</th><th>unit</th></tr>"
                + "".join(rows) + "</table>" + (f"<p>warnings:</p><ul>{warn}</ul>" if warn else ""))

    def plot(self) -> Figure:
        """Measured vs model step responses with their residuals, one pair of axes per channel.

        Returns
        -------
        matplotlib.figure.Figure
            The report's fit figure (data's units on the axes); ``fig.savefig(path)`` saves it.
        """
        from motorid.report.figures import step_fit_figure

        return step_fit_figure(self.model, self.identification.conditioned)

    def summary(self, *, advice: bool = True) -> str:
        """The text ``motorid identify`` prints for the same captures and options.

        Parameters
        ----------
        advice : bool
            End with the ``advice:`` line (:meth:`advice_line`) when there is one.

        Returns
        -------
        str
            Model, transfer functions, poles, intervals, stages, fit, checks and warnings
            (lines not wrapped), then the ``choice:`` line and the ``advice:`` line.
        """
        from motorid.report.summary import model_summary

        lines = [*model_summary(self.model, "identified model"), f"choice: {self.reason}"]
        line = self.advice_line() if advice else None
        return "\n".join(lines if line is None else [*lines, f"advice: {line}"])

    def advice_line(self) -> str | None:
        """How to record the next capture, in one line (:func:`advise`'s ``summary_line``).

        Returns
        -------
        str or None
            The line; ``None`` for captures without an oscilloscope header (volts/div, time/div)
            or a model not from the output-error fit, which the advice cannot plan for.
        """
        from motorid.errors import MotorIdError

        caps = list(self.experiment.captures.values())
        if self.model.method != "oe" or not all(c.scope.horizontal_scale_s and c.output_info.vertical_scale
                                                for c in caps):
            return None
        try:
            return advise(self).summary_line()
        except MotorIdError:
            return None

    def to_dict(self) -> dict[str, Any]:
        """The model JSON as a dict (:meth:`to_json` is the older name of the same).

        Returns
        -------
        dict
            ``self.model.to_dict()``.
        """
        return self.model.to_dict()

    def to_json(self) -> dict[str, Any]:
        """The model JSON (docs/formats.md "Model JSON"), the dict ``motorid identify --json`` writes.

        Returns
        -------
        dict
            :meth:`MotorModel.to_json` of :attr:`model`.
        """
        return self.model.to_json()


def _roots_by_size(values: Any) -> list[float | complex]:
    # as the uncertainty block lists them: slowest first
    out = sorted((complex(v) for v in values), key=lambda v: (-v.real, -v.imag))
    return [v.real if v.imag == 0 else v for v in out]


def _params(model: MotorModel) -> dict[str, ParameterEstimate]:
    """The model's headline quantities: its ``uncertainty`` intervals where the method gives them."""
    u = model.uncertainty
    fo = model.first_order()
    params: dict[str, ParameterEstimate] = {}
    for key, value in (("dc_gain", fo.dc_gain), ("time_constant", fo.time_constant_s), ("t63_s", model.t63_s()),
                       ("residence_time_s", model.residence_time_s())):
        item = None if u is None else u.headline(key)
        params[key] = ParameterEstimate(float(value)) if item is None else item
    if u is not None and u.delay is not None:
        params["delay"] = u.delay
    elif model.delay_s > 0:
        params["delay"] = ParameterEstimate(model.delay_s)
    for name, roots in (("pole", model.poles()), ("zero", model.zeros())):
        items = () if u is None else (u.poles if name == "pole" else u.zeros)
        if items:
            for i, item in enumerate(items):
                # a real root is a float, as the model's own roots below
                root_value = item.value.real if item.value.imag == 0 else item.value
                params[f"{name}_{i + 1}"] = replace(item, value=root_value)
        else:
            for i, root in enumerate(_roots_by_size(roots)):
                params[f"{name}_{i + 1}"] = ParameterEstimate(root)
    # each carries its unit: the gain the data's (rpm/V on a log in rpm), times s, poles 1/s
    return {k: replace(p, unit=model.dc_gain_unit if k == "dc_gain" else "1/s" if k.startswith(("pole_", "zero_"))
                       else "s") for k, p in params.items()}


def _package_version() -> str:
    try:
        return version("motorid")
    except PackageNotFoundError:  # a source tree that is not installed
        from motorid import __version__

        return __version__


@speaks_as_called("identify")
def identify(
    experiment: Experiment,
    *,
    method: Literal["auto", "pinv", "markov", "classic", "oe", "srivc", "paper-auto"] = "auto",
    order: Literal["auto", 1, 2, 3] = "auto",
    sample_interval: float | Literal["auto"] = "auto",
    delay: bool | None = None,
    markov_basis: Literal["laguerre", "taylor"] = "laguerre",
    markov_params: int | None = None,
    markov_window_s: float | None = None,
    ratio: int | None = None,
    record_length_s: float | None = None,
    reduction: str = "subsample",
    derivative: str = "five_point",
    structure: str = "free",
    sync: str = "interp",
    method_options: MethodOptions | None = None,
    progress: Callable[[int, int, str], None] | None = None,
) -> IdentificationResult:
    """Identify the motor model of an experiment (``motorid identify`` in Python).

    Parameters
    ----------
    experiment : Experiment
        From :func:`read_experiment`.
    method : str
        ``auto`` (the paper's methods → output-error refinement → order selection →
        uncertainty), ``pinv``, ``markov``, ``classic``, ``oe``, ``srivc`` or ``paper-auto``.
    order : "auto" or int
        1–3: for ``pinv`` the number of states, for the others the poles of the velocity TF.
    sample_interval : float or "auto"
        Sample interval after reduction [s] (``auto``: chosen from the measured response; the
        paper's: 0.1).
    delay : bool or None
        ``oe``/``auto``: fit a dead time (``True``), none (``False``), or let BIC decide (``None``).
    markov_basis : str
        ``laguerre`` (generalised Markov parameters on a Laguerre basis) or ``taylor`` (the
        paper's procedure).
    markov_params : int, optional
        Markov parameters / Laguerre terms (default: chosen by fit).
    markov_window_s : float, optional
        Markov window Tε [s] (default: chosen by fit).
    ratio : int, optional
        Sample reduction ratio (overrides ``sample_interval``).
    record_length_s : float, optional
        Seconds kept after the step (default: all).
    reduction : str
        ``subsample`` (paper), ``block_mean`` or ``fir``.
    derivative : str
        ``euler``, ``central``, ``five_point`` (paper) or ``savgol`` (pinv).
    structure : str
        pinv: ``free`` or ``known``.
    sync : str
        ``interp`` or ``index`` (the paper's).
    method_options : MethodOptions, optional
        The estimators' own settings, Python only: ``MethodOptions(laguerre=LaguerreSettings(pole=40.0),
        srivc=SrivcSettings(max_iter=60), output_error=OutputErrorOptions(max_nfev=400))``
        (:class:`~motorid.identification.method_options.MethodOptions`).  ``markov_params`` and
        ``order`` set the Laguerre terms and order; asking for other values there is an error.
    progress : callable, optional
        ``progress(done, total, label)`` before each stage (the command line draws its bar
        with it); not an option of the model: it changes nothing in the result.

    Returns
    -------
    IdentificationResult
        The model, its parameters with intervals, stages, fit, warnings, sanity checks and
        provenance.

    Raises
    ------
    OptionError
        An unknown or out-of-range option (the message names the parameter).
    IdentificationError, ConditioningError, StepNotFoundError
        Data that cannot give a model (the message names the file and what would fix it).
    """
    from motorid.conditioning.pipeline import ConditioningSettings
    from motorid.identification.method_options import MethodOptions
    from motorid.identification.pipeline import IdentifySettings, identify_experiment

    if not isinstance(experiment, Experiment):
        raise OptionError(f"identify needs the Experiment of read_experiment(...), got {type(experiment).__name__}")
    if experiment.several_steps():
        raise OptionError(several_steps_message(experiment))
    # the settings validate every option themselves, naming the parameter (one check, not two)
    settings = IdentifySettings(
        method=method,
        order=order,
        conditioning=ConditioningSettings(
            sample_interval_s=None if ratio is not None else sample_interval,
            ratio=ratio, reduction=reduction, record_length_s=record_length_s, sync=sync,
        ),
        derivative=derivative,
        structure=structure,
        markov_params=markov_params,
        markov_window_s=markov_window_s,
        delay=delay,
        markov_basis=markov_basis,
        method_options=MethodOptions() if method_options is None else method_options,
    )
    check_record_length(experiment.captures, record_length_s)
    ident = identify_experiment(experiment.captures, settings, step_volts=experiment.step_volts,
                                t0_s=experiment.t0_s, progress=progress, units=experiment.units)
    if experiment.scales:  # the maths stays in the data's units (the identification carries them); the constants travel
        ident = replace(ident, model=ident.model.replace(scales=dict(experiment.scales)))
    model = ident.model
    provenance = Provenance(
        version=_package_version(),
        inputs_sha256=experiment.sha256,
        settings={**asdict(settings), "step_volts": experiment.step_volts, "t0_s": experiment.t0_s},
    )
    return IdentificationResult(
        model=model,
        params=MappingProxyType(_params(model)),
        provenance=provenance,
        experiment=experiment,
        identification=ident,
    )


@speaks_as_called("advise")
def advise(fit: IdentificationResult, *, threshold: float = 0.2) -> Advice:
    """How to record the next capture of the experiment (``motorid advise`` in Python).

    Parameters
    ----------
    fit : IdentificationResult
        From :func:`identify` (``method="auto"`` or ``"oe"``) on oscilloscope captures.
    threshold : float
        Narrowing of the DC gain's or the time constant's 95 % interval a change must bring to be
        worth it (0.2: 20 %).

    Returns
    -------
    Advice
        The current predicted widths, the suggestions one setting at a time and the combined
        one; ``.to_dict()`` is the advice JSON, ``.summary_line()`` one line.

    Raises
    ------
    OptionError
        A capture without the scope's header, a model of a paper method, a bad threshold.
    """
    from motorid.analysis.advice import AdviceSettings
    from motorid.analysis.advice import advise as _advise

    if not isinstance(fit, IdentificationResult):
        raise OptionError(f"advise needs the IdentificationResult of identify(...), got {type(fit).__name__}")
    settings = AdviceSettings(threshold=threshold)
    return _advise(fit.identification, fit.experiment.captures, settings)


# ---------------------------------------------------------------------------- design, simulate


def _model_of(model: Any, param: str = "model") -> MotorModel:
    from motorid.model import MotorModel

    if isinstance(model, IdentificationResult):
        return model.model
    if isinstance(model, MotorModel):
        return model
    if isinstance(model, (str, PathLike)):
        from motorid.model.serialize import load_model

        return load_model(Path(model))
    raise OptionError(f"{param}= must be a MotorModel, an IdentificationResult or a model JSON file, "
                      f"got {type(model).__name__}")


def _design_of(design: Any) -> Design | PidDesign:
    from motorid.control.design import Design
    from motorid.control.pid import PidDesign

    if isinstance(design, (Design, PidDesign)):
        return design
    if isinstance(design, (str, PathLike)):
        from motorid.control.design_io import load_controller

        return load_controller(Path(design))
    raise OptionError("design= must be the Design of mi.design(...), a PidDesign or a design JSON file, "
                      f"got {type(design).__name__}")


@contextmanager
def _blamed_on(source: Any) -> Iterator[None]:
    """Name ``source``'s file in an :class:`OptionError` raised inside, when it was given as a file.

    The model or design a file holds is what a refusal of the work on it is about (a design
    for other states than the model's); objects given in Python name no file.
    """
    try:
        yield
    except OptionError as exc:
        if isinstance(source, (str, PathLike)):
            raise exc.with_file(str(source)) from None
        raise


def _names(param: str, values: Any) -> tuple[str, ...]:
    if isinstance(values, str):
        values = [v.strip() for v in values.split(",") if v.strip()]
    if not isinstance(values, Sequence) or not all(isinstance(v, str) for v in values):
        raise OptionError(f"{param}={values!r}: give channel names, e.g. ['position', 'velocity']")
    return tuple(values)


def _poles(param: str, values: Any) -> tuple[complex, ...] | None:
    if values is None:
        return None
    if isinstance(values, str):  # "-3+2j,-3-2j", as the command line and the web form give them
        from motorid.control.feedback import parse_poles

        return tuple(complex(v) for v in parse_poles(values, "--" + param.replace("_", "-")))
    try:
        return tuple(complex(v) for v in (values if isinstance(values, Sequence) else list(values)))
    except (TypeError, ValueError):
        raise OptionError(f"{param}={values!r}: give a sequence of numbers (complex for a pair)") from None


@speaks_as_called("design")
def design(
    model: MotorModel | IdentificationResult | str | PathLike[str],
    *,
    poles: Sequence[complex] | str | None = None,
    damping: float | None = None,
    wn: float | None = None,
    k2: float | None = None,
    settling_time: float | None = None,
    overshoot: float | None = None,
    integral: bool = False,
    ki: float | None = None,
    integral_pole: complex | None = None,
    observer_poles: Sequence[complex] | str | None = None,
    output: str | None = None,
    robust_samples: int = 2000,
    sensors: Sequence[str] | str | None = None,
    robust_fraction: float | None = None,
) -> Design:
    """Design state feedback, integral action and an observer (``motorid design`` in Python).

    Give exactly one way of placing the poles: ``poles``; ``damping`` with ``wn`` or ``k2``;
    or ``settling_time`` with ``overshoot``.

    Parameters
    ----------
    model : MotorModel, IdentificationResult or path
        The plant (a path: a model JSON file, named in errors about it).
    poles : sequence of complex or str, optional
        Closed-loop poles (``n``, or ``n + 1`` with integral action); a string is read as the
        command line reads it (``"-3+2j,-3-2j"``).
    damping : float, optional
        ζ, with ``wn`` [rad/s] or ``k2`` (the lab report's design, eqs. 32–36).
    wn, k2 : float, optional
        Natural frequency [rad/s]; velocity gain.
    settling_time, overshoot : float, optional
        2 % settling time [s] and percent overshoot [%].
    integral : bool
        Add ``ż = y − r`` and ``u = −K x − ki z``.
    ki : float, optional
        Given integral gain (Routh-checked).
    integral_pole : complex, optional
        The extra pole placed with the state poles.
    observer_poles : sequence of complex or str, optional
        Luenberger observer poles (a string as for ``poles``).
    output : str, optional
        Measured channel ``y`` (default: position if the model has it, else velocity).
    robust_samples : int
        Plausible motors, drawn from the model's uncertainty, the design is checked on
        (``design.robust``); 0: no check.
    sensors : sequence of str or str, optional
        What the rig measures (``position``, ``velocity``, ``current``, or one comma-separated
        string; default: the model's channels); the other states are estimated by a
        reduced-order observer.
    robust_fraction : float, optional
        Tighten the design's own settling time and overshoot until this fraction of the
        plausible motors meets ``settling_time``/``overshoot`` (e.g. 0.95).

    Returns
    -------
    Design
        Gains ``K``, ``kr`` or ``ki``, observer ``L``, closed-loop poles, warnings
        (``design.to_json()`` is docs/formats.md "Design JSON").

    Raises
    ------
    OptionError, ControlDesignError
        Conflicting or missing specifications, bad poles, an uncontrollable model.
    """
    from motorid.control.design import DesignSettings, design_controller

    settings = DesignSettings(
        poles=_poles("poles", poles), damping=damping, k2=k2, wn=wn, settling_time_s=settling_time,
        overshoot_pct=overshoot, integral=integral, ki=ki, integral_pole=integral_pole,
        observer_poles=_poles("observer_poles", observer_poles), output=output, robust_samples=robust_samples,
        sensors=None if sensors is None else _names("sensors", sensors), robust_fraction=robust_fraction,
    )
    plant = _model_of(model)
    with _blamed_on(model):
        return design_controller(plant, settings)


@speaks_as_called("design_pid")
def design_pid(
    model: MotorModel | IdentificationResult | str | PathLike[str],
    *,
    loop: str = "velocity",
    rule: str = "simc",
    integral: bool = False,
    tau_c: float | None = None,
    derivative_filter: float = 10.0,
    damping: float | None = None,
    wn: float | None = None,
) -> PidDesign:
    """Design a PID on the model (``motorid design --pid`` in Python).

    Parameters
    ----------
    model : MotorModel, IdentificationResult or path
        The plant (first to third order, with or without a dead time; a path: a model JSON file).
    loop : str
        ``velocity`` (a PI) or ``position`` (a PD; a PID with ``integral``).
    rule : str
        ``simc`` (Skogestad 2003) or ``placement`` (closed-loop poles from ``damping``, ``wn``).
    integral : bool
        Integral action on the position loop.
    tau_c : float, optional
        SIMC's closed-loop time constant [s] (default ``max(θ, 0.25 τ)``).
    derivative_filter : float
        ``N`` of the derivative filter ``Td / N``.
    damping, wn : float, optional
        ζ and ωn [rad/s] of the placed poles (``rule="placement"``).

    Returns
    -------
    PidDesign
        Gains in the data's units, margins, closed-loop poles, warnings; ``.tf()`` and
        ``.system()`` are python-control objects, ``.to_json()`` the Design JSON.

    Raises
    ------
    OptionError, ControlDesignError
        Bad settings, a loop the model has no channel for, a model the rules cannot tune.
    """
    from motorid.control.pid import PidSettings, design_pid as _design_pid

    settings = PidSettings(loop=loop, rule=rule, tau_c_s=tau_c, derivative_filter=derivative_filter,
                           integral=True if integral else None, damping=damping, wn=wn)
    plant = _model_of(model)
    with _blamed_on(model):
        return _design_pid(plant, settings)


@speaks_as_called("simulate")
def simulate(
    model: MotorModel | IdentificationResult | str | PathLike[str],
    design: Design | PidDesign | str | PathLike[str],
    *,
    duration_s: float = 5.0,
    reference: str | ReferenceSignal = "step",
    level_v: float | None = None,
    saturation: float | None = None,
    disturbance: float | None = None,
    disturbance_start_s: float = 0.0,
    plant: Literal["linear", "trainer"] = "linear",
    dt_s: float | None = None,
    x0: Sequence[float] | None = None,
    z0: float = 0.0,
    xhat0: Sequence[float] | None = None,
    trainer_preset: str = "lab-report",
    anti_windup: bool | None = None,
    compensate_dead_zone: bool = False,
) -> SimulationResult:
    """Run a design in closed loop on the model or the virtual trainer (``motorid simulate``).

    Parameters
    ----------
    model : MotorModel, IdentificationResult or path
        The plant (``plant="linear"``) and the observer's model (a path: a model JSON file).
    design : Design, PidDesign or path
        From :func:`design` or :func:`design_pid`, or a design JSON file (read after the
        options are checked, and named in errors about it).
    duration_s : float
        Record length [s].
    reference : str or ReferenceSignal
        ``step``, ``sine``, ``triangle``, ``square`` (with ``level_v``), or a
        :class:`motorid.simulation.ReferenceSignal` for every detail.
    level_v : float, optional
        Step level (or the mean of a periodic reference) in the output's unit when
        ``reference`` is a name.  Default: 5 on a model of scope volts (the lab report's 5 V),
        else what the identification's own step reached (the result's ``reference_level``
        says which, :func:`motorid.simulation.reference.default_reference_level`).
    saturation : float, optional
        Actuator rails ± in the input's unit (V; pwm or % for a logged duty cycle); default: none.
    disturbance : float, optional
        Load as an input-equivalent voltage opposing positive motion [V].
    disturbance_start_s : float
        When the load is applied [s].
    plant : str
        ``linear`` (the model) or ``trainer`` (the nonlinear virtual trainer).
    dt_s : float, optional
        Control interval [s] (default 1 ms on the model, 2 ms on the trainer).
    x0, xhat0 : sequence of float, optional
        Initial plant state and observer estimate (default zero).
    z0 : float
        Initial integrator state.
    trainer_preset : str
        Trainer preset for ``plant="trainer"``.
    anti_windup : bool, optional
        Hold the integrator while the command is beyond a rail and its error would push it
        further (conditional integration). Default: on when ``saturation`` is given and the
        design integrates.
    compensate_dead_zone : bool
        Add the model's dead-zone ``u0·sign(u)`` to the command (inverse dead-zone
        feed-forward; a model identified from several step levels).

    Returns
    -------
    SimulationResult
        Time series and metrics; ``.plot()`` returns a matplotlib Figure.

    Raises
    ------
    OptionError
        Bad settings, or a design for other states than the model's.
    """
    from motorid.simulation.closed_loop import simulate_closed_loop

    settings = _simulation_settings(
        duration_s=duration_s, reference=reference, level_v=level_v, saturation=saturation, disturbance=disturbance,
        disturbance_start_s=disturbance_start_s, plant=plant, dt_s=dt_s, x0=x0, z0=z0, xhat0=xhat0,
        trainer_preset=trainer_preset, anti_windup=anti_windup, compensate_dead_zone=compensate_dead_zone)
    # the options are checked above, before any file is read
    motor, controller = _model_of(model), _design_of(design)
    with _blamed_on(design):
        if plant == "trainer":
            from motorid.trainer.closed_loop import simulate_on_trainer

            return simulate_on_trainer(motor, controller, settings)
        return simulate_closed_loop(motor, controller, settings)


def _simulation_settings(
    *,
    duration_s: float,
    reference: str | ReferenceSignal,
    level_v: float | None,
    saturation: float | None,
    disturbance: float | None,
    disturbance_start_s: float,
    plant: str,
    dt_s: float | None,
    x0: Sequence[float] | None,
    z0: float,
    xhat0: Sequence[float] | None,
    trainer_preset: str,
    anti_windup: bool | None,
    compensate_dead_zone: bool = False,
) -> SimulationSettings:
    """:func:`simulate`'s keyword options as the simulator's settings (the report takes the same)."""
    from motorid.simulation.closed_loop import ReferenceSignal, SimulationSettings

    from motorid.options import real_number, real_numbers

    duration_s = cast(float, real_number(duration_s, "--duration"))
    level_v = real_number(level_v, "--level", optional=True)
    saturation = real_number(saturation, "--saturation", optional=True)
    disturbance = real_number(disturbance, "--disturbance", optional=True)
    disturbance_start_s = cast(float, real_number(disturbance_start_s, "--disturbance-start"))
    dt_s = real_number(dt_s, "--dt", optional=True)
    z0 = cast(float, real_number(z0, "--z0"))
    x0, xhat0 = real_numbers(x0, "--x0"), real_numbers(xhat0, "--xhat0")
    if plant == "trainer":
        from motorid.trainer import preset

        try:
            preset(trainer_preset)  # an unknown preset is refused before any file is read
        except OptionError as exc:
            raise OptionError(f"--preset: {exc.message}") from None
    ref = reference if isinstance(reference, ReferenceSignal) else ReferenceSignal(kind=reference, level_v=level_v)
    return SimulationSettings(
        duration_s=duration_s,
        dt_s=dt_s if dt_s is not None else (2e-3 if plant == "trainer" else 1e-3),
        reference=ref,
        saturation_v=saturation,
        disturbance_v=0.0 if disturbance is None else disturbance,
        disturbance_start_s=disturbance_start_s,
        x0=None if x0 is None else tuple(float(v) for v in x0),
        z0=z0,
        xhat0=None if xhat0 is None else tuple(float(v) for v in xhat0),
        plant=plant,
        trainer_preset=trainer_preset,
        anti_windup=anti_windup,
        dead_zone_compensation=compensate_dead_zone,
    )


# ------------------------------------------------------------------------------------ validate


@speaks_as_called("validate")
def validate(
    model: MotorModel | IdentificationResult | str | PathLike[str],
    captures: Sequence[CapturePath | Capture] | CapturePath | Capture,
    *,
    channel: str = "velocity",
    step_volts: float | None = None,
    t0: float | None = None,
    warmup_s: float = 0.0,
    columns: Mapping[str, str] | str | None = None,
    counted_velocity: bool = False,
) -> tuple[ValidationResult, ...]:
    """Drive the model with recorded inputs and score it on each capture (``motorid validate``).

    The initial state and an output offset are estimated by least squares over the whole
    record (reported); a position channel is unwrapped; the model's fitted dead time is applied.

    Parameters
    ----------
    model : MotorModel, IdentificationResult or path
        The model (a path: a model JSON file, read after the options are checked).
    captures : path, Capture, or a sequence of them
        Captures with the input on CH1 (any input, not only steps), or step responses without
        an input channel (give ``step_volts``).
    channel : str
        The model output the captures measured: ``velocity``, ``position`` or ``current``.
    step_volts : float, optional
        Step level for captures without an input channel [V].
    t0 : float, optional
        The step instant on the files' time axis [s] (default: CH1's edge, or the response's onset).
    warmup_s : float
        Seconds at the start simulated but not scored (default 0: the initial state is estimated).
    columns : Mapping or str, optional
        Plain-CSV column map.
    counted_velocity : bool
        The captures' velocity counts encoder edges over each sample interval: the model's means
        over each interval are scored (:attr:`Capture.sample_window_s`; a capture that carries
        its window already keeps it).

    Returns
    -------
    tuple of ValidationResult
        One per capture, in order: NRMSE, fit %, the estimated offset and initial state, the
        series (``.to_dict()`` is the ``motorid validate --json`` entry).

    Raises
    ------
    OptionError, CaptureFormatError
        Bad options, a channel the model has not, an unreadable capture (named).
    """
    from motorid.analysis.validation import check_channel, check_options, validate_capture
    from motorid.io import read_capture

    from motorid.options import real_number

    warmup_s = cast(float, real_number(warmup_s, "--warmup"))
    step_volts = real_number(step_volts, "--step-volts", optional=True)
    if not isinstance(captures, (str, PathLike, Capture, Sequence)) or (isinstance(captures, Sequence)
                                                                          and not captures):
        raise OptionError(f"give the validation capture(s): a file, an ALLnnnn folder, a Capture or a sequence of "
                          f"them, not {captures!r}")
    check_options(channel, warmup_s)  # before any file is read
    if not isinstance(counted_velocity, bool):
        raise OptionError(f"counted_velocity must be True or False, got {counted_velocity!r}")
    if counted_velocity and channel != "velocity":
        raise OptionError(f"--counted-velocity describes a counted velocity: it does not go with --channel {channel}")
    if step_volts is not None and not (step_volts != 0 and abs(step_volts) < float("inf")):
        raise OptionError(f"--step-volts must be a non-zero number of volts, got {step_volts:g}")
    motor = _model_of(model)
    with _blamed_on(model):  # the model file, not the first capture, is at fault
        check_channel(motor, channel)
    items = [captures] if isinstance(captures, (str, PathLike, Capture)) else list(captures)
    results = []
    for item in items:
        if isinstance(item, Capture):
            cap = item
        else:
            paths = [str(p) for p in _paths(item)]
            cap = read_capture(paths[0] if len(paths) == 1 else paths, columns=columns)
        if counted_velocity:
            cap = cap.counted()
        try:
            res = validate_capture(motor, cap, channel=channel, step_volts=step_volts, t0_s=t0, warmup_s=warmup_s)
        except MotorIdError as exc:
            raise exc.with_file(cap.source) from None
        results.append(_with_channel_hint(res, motor, cap, channel, step_volts=step_volts, t0_s=t0,
                                          warmup_s=warmup_s))
    return tuple(results)


#: A validation NRMSE above this asks whether the capture was of another model output.
POOR_VALIDATION_NRMSE = 0.2


def _with_channel_hint(res: ValidationResult, motor: MotorModel, cap: Capture, channel: str,
                       **options: Any) -> ValidationResult:
    """``res``, with a warning when the capture fits far better as another output of the model.

    A capture of the velocity validated as ``--channel position`` (or the other way round) gives
    a large NRMSE that reads as a bad model; the model's other outputs are tried and one that
    fits at least four times better, and within 10 %, is named.
    """
    from motorid.analysis.validation import check_channel, validate_capture

    if not res.nrmse > POOR_VALIDATION_NRMSE:
        return res
    better = []
    for other in ("position", "velocity", "current"):
        if other == channel:
            continue
        try:
            check_channel(motor, other)
            alt = validate_capture(motor, cap, channel=other, **options)
        except MotorIdError:
            continue
        if alt.nrmse < min(0.25 * res.nrmse, 0.1):
            better.append((alt.nrmse, other))
    if not better:
        return res
    nrmse, other = min(better)
    hint = (f"NRMSE {sig(100 * res.nrmse)} % as the {channel}, {sig(100 * nrmse)} % as the model's {other}: was "
            f"this capture of the {other}? (--channel {other})")
    return replace(res, warnings=(*res.warnings, hint))


# -------------------------------------------------------------------------------------- report


def _validation_captures(validation: Sequence[Any] | Mapping[str, Any]) -> dict[str, Capture]:
    from motorid.io import read_capture

    if isinstance(validation, Mapping):  # named by the caller ({"sine": ...})
        return {str(k): v if isinstance(v, Capture) else read_capture(str(v)) for k, v in validation.items()}
    if isinstance(validation, (str, PathLike, Capture)):
        validation = [validation]
    caps = [v if isinstance(v, Capture) else read_capture(str(v)) for v in validation]
    # keyed by file name; two captures of the same name in different folders keep their paths
    short = [Path(c.source).name for c in caps]
    return {(k if short.count(k) == 1 else c.source): c for k, c in zip(short, caps, strict=False)}


def write_report(
    path: str | PathLike[str],
    fit: IdentificationResult,
    *,
    design: Design | PidDesign | Mapping[str, Any] | None = None,
    validation: Sequence[str | PathLike[str] | Capture] | Mapping[str, str | PathLike[str] | Capture] = (),
    overwrite: bool = True,
    simulation: Mapping[str, Any] | None = None,
    truth: Mapping[str, Any] | None = None,
    title: str = "motorid report",
) -> Path:
    """Write the self-contained HTML report of an identification (``motorid report``).

    Parameters
    ----------
    path : path
        The HTML file; its folder must exist.  Written atomically: a failure leaves no file.
    fit : IdentificationResult
        From :func:`identify`.
    design : Design, PidDesign or Mapping, optional
        A design (or its JSON dict) to show with its closed-loop step response.
    validation : sequence or mapping of paths or Captures
        Captures of other inputs (sine, triangle, square…) to validate the model on, named by
        their files, or by the mapping's keys (``{"sine": "ALL0003"}``).
    overwrite : bool
        Replace an existing file (``False``: refuse, as the command line without ``--force``).
    simulation : Mapping, optional
        :func:`simulate`'s options for the design's closed loop (``duration_s``, ``level_v``,
        ``saturation``…): the report then shows the run the caller saw (default: the report's
        5 s step of 5 V with ±10 V rails).
    truth : Mapping, optional
        The virtual trainer's truth document (``truth.json`` of ``motorid demo``, schema
        ``motorid.trainer-truth/1``): the report compares the model with it.
    title : str
        The page's title.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OptionError, OutputExistsError, OutputWriteError
        A path that cannot be written (missing folder, a folder, an existing file with
        ``overwrite=False``, a full disk).
    """
    from motorid.control.design import Design
    from motorid.control.pid import PidDesign
    from motorid.io import atomic_outputs, check_writable
    from motorid.report.assemble import make_report

    if not isinstance(fit, IdentificationResult):
        raise OptionError(f"write_report needs the result of mi.identify(...), got {type(fit).__name__}")
    out = Path(path)
    check_writable({"path": out}, force=overwrite, create_parents=False)
    kinds: tuple[tuple[str, Any, type | tuple[type, ...], str], ...] = (
        ("design", design, (Design, PidDesign, Mapping), "Design, PidDesign or Mapping"),
        ("simulation", simulation, Mapping, "Mapping"), ("truth", truth, Mapping, "Mapping"),
        ("validation", validation, (Sequence, Mapping, PathLike, Capture),
         "path, a sequence of paths or Captures, or a Mapping of them"))
    for name, given, ok, what in kinds:
        if (given is not None and not isinstance(given, ok)) or (name == "validation" and given is None):
            raise OptionError(f"write_report: {name}={given!r} is not a {what}")
    doc = design.to_json() if isinstance(design, (Design, PidDesign)) else (None if design is None else dict(design))
    run = None
    if simulation is not None:
        from motorid.options import SIMULATE, defaults

        unknown = sorted(set(simulation) - set(defaults(SIMULATE)))
        if unknown:
            raise OptionError(f"simulation={{{unknown[0]!r}: …}}: not an option of simulate; use "
                              f"{', '.join(defaults(SIMULATE))}")
        run = _simulation_settings(**{**defaults(SIMULATE), **simulation})
    page = make_report(fit.identification, fit.experiment.captures, validation=_validation_captures(validation),
                       design=doc, simulation=run, truth=truth, title=title)
    with atomic_outputs() as outs:
        outs.write_text(out, page)
    return out
