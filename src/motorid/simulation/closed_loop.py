"""Closed-loop simulation of a :class:`~motorid.control.Design` on a model or the virtual trainer.

The loop is sampled: at each instant the controller reads the measured states (or the
observer's estimate), computes ``u = −K x − ki z + kr r``, clips it to the actuator rails and
holds it for one interval.  The linear plant is advanced with its exact ZOH discretisation
(``expm`` of the augmented matrix, once); the trainer's nonlinear plant
is passed in (:class:`ClosedLoopPlant`; :mod:`motorid.trainer.closed_loop`) and advanced one
interval at a time.  ``ż = y − r`` (report eq. 40) is integrated exactly for a held ``y − r``.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from motorid._threads import single_blas_thread
from motorid.control.controller import integrator_holds
from motorid.control.design import Design, design_model, output_row
from motorid.control.pid import PidDesign
from motorid.errors import OptionError
from motorid.model import MotorModel
from motorid.model.units import channel_unit
from motorid.simulation.reference import (
    REFERENCE_KINDS,
    ReferenceLevel,
    ReferenceSignal,
    reference_values,
    with_level,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "REFERENCE_KINDS",
    "ReferenceSignal",
    "ResponseMetrics",
    "SampledDamping",
    "SimulationResult",
    "SimulationSettings",
    "least_damping",
    "plot_simulation",
    "reference_values",
    "response_metrics",
    "simulate_closed_loop",
    "simulation_figure",
    "step_check",
]


@dataclass(frozen=True, slots=True)
class SimulationSettings:
    """Everything about a closed-loop run except the model and the design.

    Attributes
    ----------
    duration_s, dt_s : float
        Record length and control interval.
    reference : ReferenceSignal
    saturation_v : float or None
        Actuator rails ± in the input's unit (None: none).
    disturbance_v : float
        Load as an input-equivalent voltage opposing positive motion (the magnetic brake,
        report §2.2.2), applied from ``disturbance_start_s``.  On the trainer it becomes the
        brake torque ``disturbance_v · gain · k_motor / Ra`` (the stall torque of that voltage).
    disturbance_start_s : float
    x0 : tuple of float or None
        Initial plant state (model states; on the trainer only ``position`` and ``velocity``
        are used).  Default: zero.
    z0 : float
        Initial integrator state (report Fig. 8: ``z(0) = −2``).
    xhat0 : tuple of float or None
        Initial observer estimate (default: zero).
    plant : str
        ``linear`` (the model) or ``trainer``.
    trainer_preset : str
        Trainer preset for ``plant='trainer'`` (its noise-free ``quiet()`` variant is used).
    dead_zone_compensation : bool
        Add the model's dead-zone to the controller's command (inverse dead-zone
        feed-forward, :meth:`StaticNonlinearity.compensate`); needs a model with a static
        nonlinearity.
    anti_windup : bool or None
        Integral action against the rails by conditional integration: the integrator holds
        while the command is beyond a rail and its error would push it further. ``None``
        (default): on when there are rails (``saturation_v``) and the design integrates.
    """

    duration_s: float = 5.0
    dt_s: float = 1e-3
    reference: ReferenceSignal = field(default_factory=ReferenceSignal)
    saturation_v: float | None = None
    disturbance_v: float = 0.0
    disturbance_start_s: float = 0.0
    x0: tuple[float, ...] | None = None
    z0: float = 0.0
    xhat0: tuple[float, ...] | None = None
    plant: str = "linear"
    trainer_preset: str = "lab-report"
    dead_zone_compensation: bool = False
    anti_windup: bool | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise OptionError(f"--duration must be > 0 s, got {self.duration_s!r}")
        if not (math.isfinite(self.dt_s) and 0 < self.dt_s <= self.duration_s / 10):
            raise OptionError(f"--dt must be > 0 and at most a tenth of the duration, got {self.dt_s!r}")
        if self.duration_s / self.dt_s > 2_000_000:
            raise OptionError("--duration/--dt asks for more than 2 million steps; raise --dt")
        if self.saturation_v is not None and not (math.isfinite(self.saturation_v) and self.saturation_v > 0):
            raise OptionError(f"--saturation must be > 0 V, got {self.saturation_v!r}")
        for name, flag in (("disturbance_v", "--disturbance"), ("disturbance_start_s", "--disturbance-start"),
                           ("z0", "--z0")):
            if not math.isfinite(float(getattr(self, name))):
                raise OptionError(f"{flag} must be finite, got {getattr(self, name)!r}")
        if self.disturbance_v != 0 and self.disturbance_start_s >= self.duration_s:
            raise OptionError(f"--disturbance-start {self.disturbance_start_s:g} s is at or after the end of the run "
                              f"(--duration {self.duration_s:g} s): the load would never act; raise --duration or "
                              "lower --disturbance-start")
        if self.plant not in ("linear", "trainer"):
            raise OptionError(f"--plant {self.plant!r}: use linear or trainer")


@dataclass(frozen=True, slots=True)
class ResponseMetrics:
    """Step-response metrics (NaN where undefined, e.g. for a sinusoidal reference).

    Attributes
    ----------
    rise_time_s : float
        10 % → 90 % of the step (first samples at or beyond each level).
    settling_time_s : float
        Time after the step of the first sample after the last one at or outside the ±2 % band
        of the step around the final reference (``control.step_info``'s definition).
    overshoot_pct : float
        Peak beyond the final reference, % of the step.
    steady_state_error_v : float
        Final reference − mean output over the last 5 % of the record.
    tracking_rms_v : float
        RMS of ``r − y`` over the second half of the record.
    peak_control_v : float
        Largest ``|u|`` applied.
    """

    rise_time_s: float
    settling_time_s: float
    overshoot_pct: float
    steady_state_error_v: float
    tracking_rms_v: float
    peak_control_v: float


def least_damping(poles_s: np.ndarray) -> float:
    """The smallest damping ratio ``−Re(p)/|p|`` of continuous-time poles (1 for none; a pole at 0 counts 0).

    Parameters
    ----------
    poles_s : ndarray
        Poles in the s-plane (an infinitely fast one, ``−inf``, counts 1).

    Returns
    -------
    float
        Below 0 for an unstable pole.
    """
    p = np.asarray(poles_s, dtype=complex).ravel()
    p = p[np.isfinite(p)]
    if p.size == 0:
        return 1.0
    mag = np.abs(p)
    return float(np.min(np.where(mag > 0, -p.real / np.where(mag > 0, mag, 1.0), 0.0)))


@dataclass(frozen=True, slots=True)
class SampledDamping:
    """The sampled loop's least damping against the continuous design's.

    The design places continuous poles; the simulation (and the emitted code) runs the
    controller every ``dt`` with its command held.  The sampled loop's eigenvalues ``z``
    mapped back by ``s = ln(z)/dt`` show what sampling did to the damping, which the
    printout says instead of assuming (a zero-order-hold observer keeps its poles exactly;
    the held command lags the state feedback by about half an interval).

    Attributes
    ----------
    sampled, design : float
        Least damping ratio of the sampled loop's poles mapped back, and of the continuous
        design's poles (controller, integrator and observer).
    dt_s : float
        The control interval.
    without_dead_time : bool
        The model has a dead time, which neither set of poles includes (the design ignores it).
    """

    sampled: float
    design: float
    dt_s: float
    without_dead_time: bool = False

    #: Dampings within this of each other are the same to the printout's two digits.
    SAME = 0.005

    @classmethod
    def of(cls, z_poles: np.ndarray, design_poles: np.ndarray, dt_s: float, lag: int = 0) -> SampledDamping:
        """From the sampled loop's eigenvalues and the continuous design's poles.

        Parameters
        ----------
        z_poles : ndarray
            Eigenvalues of the sampled loop (a ``z`` of 0, deadbeat, maps to an infinitely fast pole).
        design_poles : ndarray
            The continuous design's poles.
        dt_s : float
            Control interval.
        lag : int
            Whole intervals of the model's dead time (left out of both).

        Returns
        -------
        SampledDamping
        """
        z = np.asarray(z_poles, dtype=complex).ravel()
        with np.errstate(divide="ignore", invalid="ignore"):
            s_poles = np.where(np.abs(z) > 0, np.log(np.where(np.abs(z) > 0, z, 1.0)) / dt_s, -np.inf)
        return cls(least_damping(s_poles), least_damping(np.asarray(design_poles)), float(dt_s), lag > 0)

    def text(self) -> str:
        """The printout's sentence about the sampled controller.

        Returns
        -------
        str
        """
        head = (f"the controller runs every {self.dt_s:.3g} s (--dt), its command held between samples: sampled, "
                "the loop's poles mapped back (ln z / dt)")
        aside = " (the dead time aside)" if self.without_dead_time else ""
        if not (math.isfinite(self.sampled) and math.isfinite(self.design)):
            return f"{head} cannot be compared with the design's{aside}"
        if abs(self.sampled - self.design) <= self.SAME:
            return f"{head} keep the continuous design's least damping, ζ {self.design:.2g}{aside}"
        how = "less" if self.sampled < self.design else "more"
        hint = "; a smaller --dt brings it closer" if self.sampled < self.design else ""
        return (f"{head} are {how} damped than the continuous design's: least ζ {self.sampled:.2g} against "
                f"{self.design:.2g}{aside}{hint}")

    def to_dict(self) -> dict[str, object]:
        """The simulation JSON's ``sampled_damping`` entry.

        Returns
        -------
        dict
            ``sampled``, ``design`` (least damping ratios; null when not finite), ``dt_s`` and
            ``without_dead_time``.
        """
        clean = lambda v: float(v) if math.isfinite(v) else None  # noqa: E731
        return {"sampled": clean(self.sampled), "design": clean(self.design), "dt_s": self.dt_s,
                "without_dead_time": self.without_dead_time}


@dataclass(frozen=True, slots=True)
class SimulationResult:
    """Time series of a closed-loop run.

    Attributes
    ----------
    time_s, reference_v, output_v, control_v, control_raw_v : ndarray
        ``control_v`` is what the actuator applied (after saturation), ``control_raw_v`` what
        the controller asked for.
    states : ndarray, shape (N, n)
        Plant states (measured ones on the trainer).
    estimates : ndarray or None
        Observer estimates.
    integrator : ndarray or None
        ``z``.
    state_names : tuple of str
    output : str
    metrics : ResponseMetrics
    warnings : tuple of str
    units : Mapping[str, str]
        The model's channel units: the output, the reference and the errors are in
        :attr:`output_unit`; ``u`` is in volts.
    anti_windup : bool
        The integrator was held against the rails (conditional integration).
    """

    time_s: np.ndarray
    reference_v: np.ndarray
    output_v: np.ndarray
    control_v: np.ndarray
    control_raw_v: np.ndarray
    states: np.ndarray
    estimates: np.ndarray | None
    integrator: np.ndarray | None
    state_names: tuple[str, ...]
    output: str
    metrics: ResponseMetrics
    warnings: tuple[str, ...] = ()
    units: Mapping[str, str] = field(default_factory=dict)
    anti_windup: bool = False
    #: The reference's level and where it came from (given, or the model's default).
    reference_level: ReferenceLevel | None = None
    #: The sampled loop's damping against the continuous design's (None: not computed).
    sampled_damping: SampledDamping | None = None

    @property
    def output_unit(self) -> str:
        """The unit of the output, the reference and the errors (the model's, e.g. ``rpm``; else ``V``)."""
        return channel_unit(self.units, self.output)

    @property
    def input_unit(self) -> str:
        """The unit of the command ``u`` (the model's input: ``V``, or ``pwm``/``%`` for a logged PWM command)."""
        return channel_unit(self.units, "input")

    def columns(self) -> dict[str, np.ndarray]:
        """Named columns (``time``, ``reference``, ``output``, ``u``, ``u_raw``, states, ``*_hat``, ``z``).

        Returns
        -------
        dict of str to ndarray
            The columns, all of the same length.
        """
        cols = {"time": self.time_s, "reference": self.reference_v, "output": self.output_v,
                "u": self.control_v, "u_raw": self.control_raw_v}
        for i, name in enumerate(self.state_names):
            cols[name] = self.states[:, i]
        if self.estimates is not None:
            for i, name in enumerate(self.state_names):
                cols[f"{name}_hat"] = self.estimates[:, i]
        if self.integrator is not None:
            cols["z"] = self.integrator
        return cols

    def to_dataframe(self) -> Any:
        """The time series of :meth:`columns` as a pandas DataFrame (pandas is optional).

        Returns
        -------
        pandas.DataFrame
            Indexed by time (s); the units in ``attrs["units"]`` (reference, output and the
            output's state in the model's unit, ``u`` in V).
        """
        from motorid.frames import to_dataframe

        cols = self.columns()
        units = {name: channel_unit(self.units, name) for name in cols}
        units.update({"reference": self.output_unit, "output": self.output_unit, "u": self.input_unit,
                      "u_raw": self.input_unit, "z": ""})
        return to_dataframe(cols, units)

    def to_csv_text(self) -> str:
        """The time series as CSV with a header row.

        Returns
        -------
        str
            The CSV text.
        """
        cols = self.columns()
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(list(cols))
        for row in zip(*cols.values(), strict=False):
            w.writerow([f"{v:.9g}" for v in row])
        return buf.getvalue()

    def to_dict(self) -> dict[str, Any]:
        """The simulation JSON as a dict (:meth:`to_json` is the older name of the same).

        Returns
        -------
        dict
            JSON-able (schema ``motorid.simulation/1``).
        """
        return self.to_json()

    def to_json(self) -> dict[str, Any]:
        """Metrics, warnings and the time series as a JSON dict (NaN written as null).

        Returns
        -------
        dict
            JSON-able (schema ``motorid.simulation/1``).
        """
        clean = lambda v: None if not math.isfinite(v) else float(v)  # noqa: E731
        m = self.metrics
        return {
            "schema": "motorid.simulation/1",
            "output": self.output,
            "output_unit": self.output_unit,
            "metrics": {k: clean(getattr(m, k)) for k in m.__slots__},
            "warnings": list(self.warnings),
            "anti_windup": self.anti_windup,
            **({} if self.reference_level is None else {"reference_level": self.reference_level.to_dict()}),
            **({} if self.sampled_damping is None else {"sampled_damping": self.sampled_damping.to_dict()}),
            "series": {k: [clean(x) for x in v] for k, v in self.columns().items()},
        }

    def to_json_text(self) -> str:
        """The :meth:`to_json` dict as indented JSON text.

        Returns
        -------
        str
            The JSON text.
        """
        return json.dumps(self.to_json(), indent=1)

    def plot(self, title: str = "") -> Figure:
        """Output and reference, control input, and states against time.

        Parameters
        ----------
        title : str
            Figure title (none when empty).

        Returns
        -------
        matplotlib.figure.Figure
            Three stacked axes; save it with ``fig.savefig(path)`` (see :func:`simulation_figure`).
        """
        return simulation_figure(self, title)


#: Relative size below which a steady-state or tracking error is the simulation's rounding.
ROUNDING = 1e-9


def _scaled(e: np.ndarray, power: int) -> float:
    """The mean of ``e`` (``power`` 1) or its root mean square (2), without overflow.

    ``e`` is divided through by its largest magnitude first: a diverging loop's output (past about
    1e154 its square overflows, past 1e305 its sum) gives its value, or ``inf``.
    """
    top = float(np.max(np.abs(e), initial=0.0))
    if top == 0.0 or not np.isfinite(top):
        return top  # 0, inf, or nan
    if power == 1:
        return top * float(np.mean(e / top))
    return top * float(np.sqrt(np.mean((e / top) ** 2)))


def response_metrics(time_s: np.ndarray, output_v: np.ndarray, reference_v: np.ndarray,
                     control_v: np.ndarray, step: bool) -> ResponseMetrics:
    """Rise/settling time, overshoot, steady-state error, tracking RMS and peak control.

    For a step the change is measured from the output at the step (``y0``) to the final
    reference ``r_f``; the settling band is ±2 % of ``|r_f − y0|``.

    Parameters
    ----------
    time_s : ndarray
        Sample times in s.
    output_v : ndarray
        The controlled output in volts.
    reference_v : ndarray
        The reference in volts.
    control_v : ndarray
        The control input in volts.
    step : bool
        Whether the reference is a step (step metrics) or another signal (tracking metrics).

    Returns
    -------
    ResponseMetrics
        The metrics.
    """
    t, y, r = (np.asarray(v, dtype=float) for v in (time_s, output_v, reference_v))
    n = t.size
    half = slice(n // 2, None)
    rms = _scaled(r[half] - y[half], 2)
    peak_u = float(np.max(np.abs(control_v)))
    rf = float(r[-1])
    ess = float(rf - _scaled(y[-max(1, n // 20):], 1))
    # an error below a billionth of the reference is the simulation's rounding (a loop with
    # integral action ends on r to 1e-15): it is 0, not "1.776e-15 rpm"
    scale = float(np.max(np.abs(r), initial=0.0))
    ess = 0.0 if abs(ess) <= ROUNDING * scale else ess
    rms = 0.0 if rms <= ROUNDING * scale else rms
    nan = float("nan")
    if not step or not np.all(np.isfinite(y)):
        return ResponseMetrics(nan, nan, nan, ess if step else nan, rms, peak_u)
    k0 = int(np.argmax(r == rf)) if np.any(r != r[0]) else 0
    y0 = float(y[k0])
    delta = rf - y0
    if abs(delta) < 1e-12:
        return ResponseMetrics(nan, nan, nan, ess, rms, peak_u)
    frac = (y[k0:] - y0) / delta
    if not np.any(frac >= 0.9):
        # never reaches 90 %: no rise time, not settled, no overshoot (step_info would fail on
        # the empty crossing; these are the values it gives a response that gets there late)
        return ResponseMetrics(nan, nan, 0.0, ess, rms, peak_u)
    import control

    # python-control's step_info on the change since the step (its definitions are ours: rise
    # 10 → 90 % of the step, settling = first sample after the last one outside ±2 % of it,
    # overshoot = peak beyond the final value in % of the step), with the final *reference*
    # as the final value, so a steady-state error shows as an unsettled response
    with np.errstate(over="ignore"):  # a diverging loop's overshoot past 1e306: inf, not a warning
        info = control.step_info(y[k0:] - y0, T=t[k0:] - t[k0], yfinal=delta, SettlingTimeThreshold=0.02,
                                 RiseTimeLimits=(0.1, 0.9))
    return ResponseMetrics(float(info["RiseTime"]), float(info["SettlingTime"]), float(info["Overshoot"]), ess,
                           rms, peak_u)


def _sampled_loop_poles(phi: np.ndarray, gam: np.ndarray, c: np.ndarray, k: np.ndarray, ki: float | None,
                        dt: float, observer: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    """Eigenvalues (``z``) of the linear sampled loop: plant, held command, observer of the sampled plant, integrator.

    The design is continuous; the simulation samples it.  This is the loop the simulation runs,
    without saturation: above 1 it diverges whatever the continuous poles say.
    """
    n = phi.shape[0]
    g = gam[:, :1]
    kz = np.array([[0.0 if ki is None else float(ki)]])
    if observer is None:  # u = −K x − ki z
        top = np.hstack([phi - g @ k, -g @ kz])
        blocks = [top, np.hstack([dt * c, np.ones((1, 1))])]
        m = np.vstack(blocks) if ki is not None else phi - g @ k
    else:
        phi_o, gam_o = observer
        gu, gy = gam_o[:, :1], gam_o[:, 1:2]
        rows = [np.hstack([phi, -g @ k, -g @ kz]),
                np.hstack([gy @ c, phi_o - gu @ k, -gu @ kz]),
                np.hstack([dt * c, np.zeros((1, n)), np.ones((1, 1))])]
        m = np.vstack(rows)
        if ki is None:
            m = m[: 2 * n, : 2 * n]
    with np.errstate(all="ignore"):
        return np.linalg.eigvals(m) if np.all(np.isfinite(m)) else np.array([np.inf + 0j])


def _reduced_loop_poles(phi: np.ndarray, gam: np.ndarray, c: np.ndarray, ki: float | None, dt: float,
                        reduced: _Reduced) -> np.ndarray:
    """Eigenvalues (``z``) of the sampled loop with a reduced-order observer, states ``[x, w(, z)]``."""
    n, nu = phi.shape[0], reduced.phi.shape[0]
    g = gam[:, :1]
    size = n + nu + (1 if ki is not None else 0)
    f = np.zeros((1, size))  # the held command u_k as a row on the states
    f[:, :n] = reduced.kz @ reduced.sel
    f[:, n:n + nu] = reduced.kw
    if ki is not None:
        f[0, -1] = -float(ki)
    gm, gu = reduced.gam[:, :-1], reduced.gam[:, -1:]
    m = np.zeros((size, size))
    m[:n, :n] = phi
    m[:n] += g @ f
    m[n:n + nu, :n] = gm @ reduced.sel
    m[n:n + nu, n:n + nu] = reduced.phi
    m[n:n + nu] += gu @ f
    if ki is not None:
        m[-1, :n] = dt * c.ravel()
        m[-1, -1] = 1.0
    with np.errstate(all="ignore"):
        return np.linalg.eigvals(m) if np.all(np.isfinite(m)) else np.array([np.inf + 0j])


@dataclass(frozen=True, slots=True)
class _Reduced:
    """A reduced-order observer as the simulation runs it: the held-input ZOH of ``ẇ = F w + G z_m + H u``."""

    measured: list[int]
    estimated: list[int]
    sel: np.ndarray  # z_m = sel · x
    gain: np.ndarray  # ẑ_u = w + gain · z_m
    kz: np.ndarray
    kw: np.ndarray
    phi: np.ndarray
    gam: np.ndarray  # on [z_m, u]

    @classmethod
    def of(cls, design: Design, a: np.ndarray, b: np.ndarray, dt: float) -> _Reduced | None:
        """The design's reduced-order observer placed on the motor sampled every ``dt`` (None without one)."""
        if design.reduced is None:
            return None
        from motorid.control.reduced_observer import command_rows
        from motorid.control.sampled import sampled_reduced_observer

        states = tuple(design.states)
        red = sampled_reduced_observer(a, b, design.reduced, states, dt)
        mi, ui = red.split(states)
        kz, kw, _ = command_rows(design.K, design.ki, red, states)
        return cls(mi, ui, np.eye(a.shape[0])[mi], red.L, kz, kw, red.F, np.hstack([red.G, red.H]))


def _zoh(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    from motorid.model.lti import zoh

    return zoh(a, b, dt)


def _vector(values: tuple[float, ...] | None, n: int, option: str) -> np.ndarray:
    if values is None:
        return np.zeros(n)
    v = np.asarray(values, dtype=float).ravel()
    if v.size != n or not np.all(np.isfinite(v)):
        raise OptionError(f"{option} needs {n} finite values (one per state), got {list(values)}")
    return v


class ClosedLoopPlant(Protocol):
    """A plant other than the linear model, advanced one control interval at a time.

    The virtual trainer's nonlinear plant (:class:`motorid.trainer.closed_loop.TrainerLoop`)
    is one: it is passed in, so this module does not depend on the trainer.
    """

    def start(self, model: MotorModel, settings: SimulationSettings, x0: np.ndarray) -> list[str]:
        """Start from the model-state vector ``x0``; return warnings about the run."""

    def measured(self) -> np.ndarray:
        """The measured states, in the model's state order."""

    def output(self, name: str) -> float:
        """The measured channel ``name`` (volts)."""

    def advance(self, u: float, t: float) -> None:
        """Hold ``u`` for one control interval starting at time ``t``."""


@single_blas_thread
def simulate_closed_loop(model: MotorModel, design: Design | PidDesign, settings: SimulationSettings, *,
                         plant: ClosedLoopPlant | None = None) -> SimulationResult:
    """Run the designed controller in closed loop.

    A :class:`~motorid.control.pid.PidDesign` runs as its state space (:meth:`PidDesign.matrices`),
    sampled like state feedback, its integrator held against the rails the same way.

    Parameters
    ----------
    model : MotorModel
        The plant for ``plant='linear'``; the observer's model in every case.  A design made
        in measurable coordinates (:func:`motorid.control.design_controller`) runs on the
        model re-expressed in them (:func:`motorid.control.design.design_model`), so the
        states, ``x0`` and ``xhat0`` are the design's (position, velocity, …).
    design : Design or PidDesign
        Gains (``K``, ``kr`` or ``ki``, optional ``L``) for this model, or a PID.
    settings : SimulationSettings
    plant : ClosedLoopPlant, optional
        The plant of a ``plant='trainer'`` run (required then; see
        :func:`motorid.trainer.closed_loop.simulate_on_trainer`, which passes it).

    Returns
    -------
    SimulationResult

    Raises
    ------
    OptionError
        Mismatched design/model, bad initial conditions, or a trainer run whose controller
        needs states the trainer does not measure (use an observer).

    References
    ----------
    Tsiolakis 2022, §2.2 (step, brake, sinusoid), §3.2 (integral action, z(0)), §4.2 (observer).
    """
    if isinstance(design, PidDesign):
        return _simulate_pid(model, design, settings, plant)
    # the level in the output's unit: given, or the model's own (a 5 V step on scope volts)
    reference, level = with_level(model, design.output, settings.reference)
    s = replace(settings, reference=reference)
    # a design in measurable coordinates runs on the model re-expressed in them
    model = design_model(model, design)
    a, b = model.A, model.B
    n = a.shape[0]
    if tuple(design.states) != tuple(model.states) or design.K.size != n:
        raise OptionError(f"the design is for states {list(design.states)}, the model has {list(model.states)}")
    _, c = output_row(model, design.output)
    k = design.K.reshape(1, n)
    ki = design.ki
    kr = 0.0 if design.kr is None else float(design.kr)
    use_obs = design.L is not None
    l_col = None if design.L is None else design.L.reshape(n, 1)
    steps = round(s.duration_s / s.dt_s)
    t = np.arange(steps + 1) * s.dt_s
    r = reference_values(s.reference, t)
    d = np.where(t >= s.disturbance_start_s, -s.disturbance_v, 0.0)
    x = _vector(s.x0, n, "--x0")
    xh = _vector(s.xhat0, n, "--xhat0")
    z = float(s.z0)
    sat = math.inf if s.saturation_v is None else float(s.saturation_v)
    hold = ki is not None and (s.anti_windup if s.anti_windup is not None else s.saturation_v is not None)
    warnings: list[str] = []

    phi, gam = _zoh(a, b, s.dt_s)
    # the identified dead time is part of the plant (not of the state-space matrices): the
    # linear plant receives u delayed by whole control steps
    lag = round(model.delay_s / s.dt_s) if s.plant != "trainer" else 0
    if lag:
        warnings.append(f"the model's dead time of {1e3 * model.delay_s:.3g} ms is applied to the plant input "
                        f"({lag} step(s) of {s.dt_s:g} s)")
    if l_col is not None:  # (use_obs): the observer placed on the motor as the sampled controller sees it
        from motorid.control.sampled import design_observer_poles, sampled_observer

        phi_o, gam_o = sampled_observer(a, b, c, design_observer_poles(design, a, c), s.dt_s)
    reduced = _Reduced.of(design, a, b, s.dt_s)
    if reduced is not None:
        z_poles = _reduced_loop_poles(phi, gam, c, ki, s.dt_s, reduced)
        # the estimate starts at xhat0 (default: the motor at rest, so exact)
        w = _vector(s.xhat0, n, "--xhat0")[reduced.estimated] - reduced.gain @ x[reduced.measured]
        feed = np.empty(len(reduced.measured) + 1)  # the observer's inputs [z_m, u], one buffer
    else:
        z_poles = _sampled_loop_poles(phi, gam, c, k, ki, s.dt_s, (phi_o, gam_o) if l_col is not None else None)
    rho = float(np.max(np.abs(z_poles)))
    if rho > 1.0 + 1e-9 and s.plant != "trainer":
        warnings.append(f"at dt = {s.dt_s:g} s the sampled loop is unstable (spectral radius {rho:.4g}) although the "
                        "continuous design is stable: the controller or observer gains are too large for this rate "
                        "(observer poles slower than a plant pole need such gains); use a smaller --dt, or other poles")
    nl, trainer = _plant_setup(model, s, plant, x, warnings)
    if trainer is not None:
        read = ([model.states[i] for i in reduced.measured] if reduced is not None
                else [] if use_obs else list(model.states))
        if any(name not in ("position", "velocity") for name in read):
            raise OptionError("the trainer measures only position and velocity; this design reads "
                              f"{read} (design with --sensors position,velocity, or an observer)")

    xs = np.empty((steps + 1, n))
    xhs = np.empty((steps + 1, n)) if use_obs or reduced is not None else None
    zs = np.empty(steps + 1) if ki is not None else None
    ys = np.empty(steps + 1)
    us = np.empty(steps + 1)
    uraw = np.empty(steps + 1)
    with np.errstate(over="ignore", invalid="ignore"):
        for i in range(steps + 1):
            meas = trainer.measured() if trainer is not None else x
            y = float((c @ meas)[0]) if trainer is None else trainer.output(design.output)
            xs[i], ys[i] = meas, y
            fb = xh if use_obs else meas
            if reduced is not None:  # the measured states, and the estimate of the others
                fb = meas.copy()
                fb[reduced.estimated] = w + reduced.gain @ meas[reduced.measured]
            u_req = float(-(k @ fb)[0]) + (-ki * z if ki is not None else kr * r[i])
            if s.dead_zone_compensation and nl is not None and math.isfinite(u_req):
                u_req = float(nl.compensate(u_req))
            u = min(max(u_req, -sat), sat) if math.isfinite(u_req) else u_req
            us[i], uraw[i] = u, u_req
            if xhs is not None:  # (use_obs, or the reduced observer's measured + estimated states)
                xhs[i] = xh if use_obs else fb
            if zs is not None:
                zs[i] = z
            if i == steps:
                break
            if trainer is not None:
                trainer.advance(u, t[i])
            else:
                u_plant = u if not lag else (us[i - lag] if i >= lag else 0.0)
                if nl is not None:  # the dead-zone and rails in front of the linear part
                    u_plant = float(nl.effective_input(u_plant))
                x = phi @ x + gam[:, 0] * (u_plant + d[i])
            if zs is not None:
                e = y - r[i]
                # conditional integration: integrating e moves the command by −ki·e·dt; hold
                # the integrator while the command is beyond a rail and e would push it further
                if hold and ki is not None and integrator_holds(u_req, sat, -ki * e):
                    e = 0.0
                z += s.dt_s * e  # exact: y − r is held over the interval
            if use_obs:
                u_obs = u if nl is None else float(nl.effective_input(u))
                xh = phi_o @ xh + gam_o @ np.array([u_obs, y])
            if reduced is not None:
                u_obs = u if nl is None else float(nl.effective_input(u))
                feed[:-1] = meas[reduced.measured]
                feed[-1] = u_obs
                w = reduced.phi @ w + reduced.gam @ feed
    warnings += _run_warnings(ys, r, xs, us, uraw, s, sat, integral=ki is not None, held=hold,
                              unit=channel_unit(model.units, "input"))
    metrics = response_metrics(t, ys, r, us, s.reference.kind == "step")
    designed = np.r_[design.closed_loop_poles, [] if design.observer_poles is None else design.observer_poles,
                     [] if design.reduced is None else design.reduced.poles]
    return SimulationResult(t, r, ys, us, uraw, xs, xhs, zs, tuple(model.states), design.output, metrics,
                            tuple(warnings), dict(model.units), bool(hold), level,
                            SampledDamping.of(z_poles, designed, s.dt_s, lag))


def _plant_setup(model: MotorModel, s: SimulationSettings, plant: ClosedLoopPlant | None, x: np.ndarray,
                 warnings: list[str]) -> tuple[Any, ClosedLoopPlant | None]:
    """The model's static nonlinearity and the trainer's loop, checked and started (either controller's run)."""
    nl = model.static_nonlinearity
    if s.dead_zone_compensation and nl is None:
        raise OptionError("dead-zone compensation needs a model with a static nonlinearity (identify several "
                          "step levels: --velocity once per level)")
    if nl is not None and nl.dead_zone_v > 0:
        warnings.append(f"the model's dead-zone of {nl.dead_zone_v:.3g} {channel_unit(model.units, 'input')} acts on "
                        "the plant input"
                        + (" and is compensated by feed-forward" if s.dead_zone_compensation else ""))
    if s.plant != "trainer":
        return nl, None
    if plant is None:
        raise OptionError("plant='trainer' needs the trainer's loop: use "
                          "motorid.trainer.closed_loop.simulate_on_trainer")
    warnings += plant.start(model, s, x)
    return nl, plant


def _run_warnings(ys: np.ndarray, r: np.ndarray, xs: np.ndarray, us: np.ndarray, uraw: np.ndarray,
                  s: SimulationSettings, sat: float, *, integral: bool, held: bool, unit: str = "V") -> list[str]:
    """What a finished run says: divergence, saturation, a limit cycle between the rails (in the command's ``unit``)."""
    out: list[str] = []
    if not np.all(np.isfinite(ys)):
        out.append("the response diverged (non-finite values): the closed loop is unstable")
    elif (np.max(np.abs(ys))
          > 1e3 * max(float(np.max(np.abs(r))), 1.0) + 1e3 * float(np.max(np.abs(xs[0]), initial=0.0))):
        out.append("the response diverged (it grew a thousandfold beyond the reference): the closed loop is "
                   "unstable")
    if s.saturation_v is not None and np.any(np.abs(uraw) > sat):
        out.append(f"the actuator saturated (|u| reached {np.nanmax(np.abs(uraw)):.3g} {unit} > {sat:g} {unit})")
        out += _rail_to_rail(us, sat, integral=integral, held=held, unit=unit)
    return out


def _simulate_pid(model: MotorModel, pid: PidDesign, s: SimulationSettings,
                  plant: ClosedLoopPlant | None) -> SimulationResult:
    """:func:`simulate_closed_loop` of a PID: its state space advanced exactly for a held ``r`` and ``y``.

    ``u = C_c x_c + D_c [r, y]``; the integrator ``z`` of ``r − y`` holds (conditional
    integration) while the command is beyond a rail and ``r − y`` would push it further.
    """
    a, b = model.A, model.B
    n = a.shape[0]
    if pid.output not in model.outputs:
        raise OptionError(f"the PID reads the {pid.output}, and the model has no {pid.output} output "
                          f"(its outputs are {list(model.outputs)})")
    reference, level = with_level(model, pid.output, s.reference)
    s = replace(s, reference=reference)
    _, c = output_row(model, pid.output)
    ac, bc, cc, dc, i_z = pid.matrices()
    nc = ac.shape[0]
    steps = round(s.duration_s / s.dt_s)
    t = np.arange(steps + 1) * s.dt_s
    r = reference_values(s.reference, t)
    d = np.where(t >= s.disturbance_start_s, -s.disturbance_v, 0.0)
    x = _vector(s.x0, n, "--x0")
    xc = np.zeros(nc)
    if i_z is not None:
        xc[i_z] = float(s.z0)
    sat = math.inf if s.saturation_v is None else float(s.saturation_v)
    hold = i_z is not None and (s.anti_windup if s.anti_windup is not None else s.saturation_v is not None)
    warnings: list[str] = []
    phi, gam = _zoh(a, b, s.dt_s)
    phi_c, gam_c = _zoh(ac, bc, s.dt_s)
    lag = round(model.delay_s / s.dt_s) if s.plant != "trainer" else 0
    if lag:
        warnings.append(f"the model's dead time of {1e3 * model.delay_s:.3g} ms is applied to the plant input "
                        f"({lag} step(s) of {s.dt_s:g} s)")
    # the linear sampled loop (no rails, no dead time): states [x, x_c]
    g = gam[:, :1]
    loop = np.block([[phi + g @ dc[:, 1:] @ c, g @ cc], [gam_c[:, 1:] @ c, phi_c]])
    with np.errstate(all="ignore"):
        z_poles = np.linalg.eigvals(loop) if np.all(np.isfinite(loop)) else np.array([np.inf + 0j])
    rho = float(np.max(np.abs(z_poles)))
    continuous_stable = bool(np.all(np.asarray(pid.closed_loop_poles).real < 0))
    if rho > 1.0 + 1e-9 and s.plant != "trainer" and continuous_stable:
        warnings.append(f"at dt = {s.dt_s:g} s the sampled loop is unstable (spectral radius {rho:.4g}) although the "
                        "continuous design is stable: the PID's gains (or its derivative filter) are too fast for "
                        "this rate; use a smaller --dt")
    nl, trainer = _plant_setup(model, s, plant, x, warnings)
    xs = np.empty((steps + 1, n))
    zs = np.empty(steps + 1) if i_z is not None else None
    ys = np.empty(steps + 1)
    us = np.empty(steps + 1)
    uraw = np.empty(steps + 1)
    with np.errstate(over="ignore", invalid="ignore"):
        for i in range(steps + 1):
            meas = trainer.measured() if trainer is not None else x
            y = float((c @ meas)[0]) if trainer is None else trainer.output(pid.output)
            xs[i], ys[i] = meas, y
            u_req = float((cc @ xc)[0]) + float(dc[0, 0]) * r[i] + float(dc[0, 1]) * y
            if s.dead_zone_compensation and nl is not None and math.isfinite(u_req):
                u_req = float(nl.compensate(u_req))
            u = min(max(u_req, -sat), sat) if math.isfinite(u_req) else u_req
            us[i], uraw[i] = u, u_req
            if zs is not None and i_z is not None:
                zs[i] = xc[i_z]
            if i == steps:
                break
            if trainer is not None:
                trainer.advance(u, t[i])
            else:
                u_plant = u if not lag else (us[i - lag] if i >= lag else 0.0)
                if nl is not None:
                    u_plant = float(nl.effective_input(u_plant))
                x = phi @ x + gam[:, 0] * (u_plant + d[i])
            if nc:
                e = r[i] - y
                new = phi_c @ xc + gam_c @ np.array([r[i], y])
                # conditional integration: ż = e moves the command by ki·e·dt; hold z while the
                # command is beyond a rail and e would push it further
                if hold and i_z is not None and integrator_holds(u_req, sat, pid.ki * e):
                    new[i_z] = xc[i_z]
                xc = new
    warnings += _run_warnings(ys, r, xs, us, uraw, s, sat, integral=i_z is not None, held=hold,
                              unit=channel_unit(model.units, "input"))
    metrics = response_metrics(t, ys, r, us, s.reference.kind == "step")
    return SimulationResult(t, r, ys, us, uraw, xs, None, zs, tuple(model.states), pid.output, metrics,
                            tuple(warnings), dict(model.units), bool(hold), level,
                            SampledDamping.of(z_poles, np.asarray(pid.closed_loop_poles), s.dt_s, lag))


def step_check(model: MotorModel, pid: PidDesign, level: float = 1.0) -> SimulationResult:
    """A unit step of the reference through the linear loop (no rails), long enough to settle.

    The record is ten times the closed loop's slowest time constant (1–120 s), the control
    interval at most 1 ms and a tenth of the derivative filter's time constant.

    Parameters
    ----------
    model : MotorModel
        The model the PID was designed for (its dead time applied).
    pid : PidDesign
    level : float
        The step, in the output's unit.

    Returns
    -------
    SimulationResult
        Its ``metrics`` hold the overshoot and the settling time.
    """
    poles = np.asarray(pid.closed_loop_poles, complex)
    stable = poles[poles.real < 0]
    slowest = float(np.min(-stable.real)) if stable.size else 1.0
    duration = min(max(10.0 / slowest, 1.0), 120.0)
    dt = min(1e-3, pid.tf_s / 10 if pid.tf_s > 0 else 1e-3)
    dt = max(dt, duration / 300_000)
    return simulate_closed_loop(model, pid, SimulationSettings(duration_s=duration, dt_s=dt,
                                                               reference=ReferenceSignal(level_v=level)))


#: Rail-to-rail swings of the applied command in the last half of a run that make a limit cycle
#: (two: from one rail to the other and back, a whole period still going on).
LIMIT_CYCLE_SWINGS = 2


def _rail_to_rail(u: np.ndarray, sat: float, *, integral: bool, held: bool, unit: str = "V") -> list[str]:
    """A warning when the command swings from rail to rail in the last half of the run (a limit cycle)."""
    tail = u[u.size // 2:]
    rails = np.where(tail >= sat * (1 - 1e-9), 1, np.where(tail <= -sat * (1 - 1e-9), -1, 0))
    visits = rails[rails != 0]
    swings = int(np.count_nonzero(np.diff(visits))) if visits.size else 0
    if swings < LIMIT_CYCLE_SWINGS:
        return []
    why = ("the integrator winds up while the command sits on a rail; simulate with anti-windup (the default "
           "with --saturation) or ask for slower poles" if integral and not held else
           "the loop is too fast for the rails: ask for slower poles, a smaller step, or wider rails")
    return [f"the loop limit-cycles between the rails: the command swung from ±{sat:g} {unit} to ∓{sat:g} {unit} "
            f"{swings} times in the last half of the run — {why}"]


def simulation_figure(result: SimulationResult, title: str = "", *, rails_v: float | None = None,
                      disturbance_s: float | None = None) -> Figure:
    """Draw output and reference, control input, and true vs estimated states.

    The figure is a :class:`matplotlib.figure.Figure` made without pyplot: no backend is
    chosen and no global figure state is touched, so it shows in a notebook and saves anywhere.

    Parameters
    ----------
    result : SimulationResult
        A closed-loop run.
    title : str
        Figure title (none when empty).
    rails_v : float, optional
        Actuator rails ±V, drawn on the control axes.
    disturbance_s : float, optional
        When the load disturbance starts, marked on every axes.

    Returns
    -------
    matplotlib.figure.Figure
        Three stacked axes sharing the time axis; the headline metrics under the title.
    """
    from matplotlib.figure import Figure

    t = result.time_s
    fig = Figure(figsize=(8, 8))
    axes = fig.subplots(3, 1, sharex=True)
    ax = axes[0]
    ax.plot(t, result.reference_v, "k--", label="reference r")
    ax.plot(t, result.output_v, label=f"output y ({result.output})")
    ax.set_ylabel(result.output_unit)
    ax.legend(loc="best")
    ax = axes[1]
    ax.plot(t, result.control_v, label="u applied")
    if np.any(result.control_raw_v != result.control_v):
        ax.plot(t, result.control_raw_v, ":", label="u requested")
    if result.integrator is not None:
        ax.plot(t, result.integrator, label="z")
    ax.set_ylabel(result.input_unit)
    ax.legend(loc="best")
    ax = axes[2]
    for i, name in enumerate(result.state_names):
        line, = ax.plot(t, result.states[:, i], label=name)
        if result.estimates is not None:
            ax.plot(t, result.estimates[:, i], "--", color=line.get_color(), label=f"{name} estimate")
    ax.set_ylabel("states" if result.units else "states (V)")
    ax.set_xlabel("time (s)")
    ax.legend(loc="best")
    if rails_v is not None:
        for sign in (1, -1):
            axes[1].axhline(sign * rails_v, color="0.4", ls="--", lw=0.8,
                            label="actuator rails" if sign == 1 else None)
        axes[1].legend(loc="best")
    if disturbance_s is not None:
        for a in axes:
            a.axvline(disturbance_s, color="C3", ls=":", lw=1.0)
        axes[0].annotate("load applied", (disturbance_s, 0.02), xycoords=("data", "axes fraction"), color="C3",
                         fontsize=9)
    m = result.metrics
    settling = f"{m.settling_time_s:.3g} s" if math.isfinite(m.settling_time_s) else "not reached"
    metrics = (f"rise {m.rise_time_s:.3g} s, settling (2 %) {settling}, overshoot "
               f"{m.overshoot_pct:.3g} %, steady-state error {m.steady_state_error_v:.3g} {result.output_unit}, "
               "peak |u| "
               f"{m.peak_control_v:.3g} {result.input_unit}")
    fig.suptitle(f"{title}\n{metrics}" if title else metrics, fontsize=10)
    fig.tight_layout()
    return fig


def plot_simulation(result: SimulationResult, path: str | Path, title: str = "", *, rails_v: float | None = None,
                    disturbance_s: float | None = None) -> None:
    """Write a PNG of :func:`simulation_figure` (output, control input, states).

    Parameters
    ----------
    result : SimulationResult
        A closed-loop run.
    path : str or Path
        PNG file to write (overwritten; the caller checks ``--force``).
    title : str
        Figure title (none when empty).
    rails_v : float, optional
        Actuator rails ±V, drawn on the control axes.
    disturbance_s : float, optional
        When the load disturbance starts, marked on every axes.
    """
    simulation_figure(result, title, rails_v=rails_v, disturbance_s=disturbance_s).savefig(str(path), dpi=100)
