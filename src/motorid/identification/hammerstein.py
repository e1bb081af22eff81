"""Several step levels → a Hammerstein motor model: static law in front of shared dynamics.

1. Each capture gives a point of the static characteristic (:mod:`motorid.identification.static`):
   its step level and steady output; the law ``y_ss = K·(u − u₀)`` is fitted with intervals,
   levels inside the dead-zone and levels at the rails are flagged and left out.
2. Each moving, unsaturated capture gives a first-order time constant with its standard error
   (scipy's ``curve_fit``); the levels' time constants are compared (a χ² test on the
   per-level means, repeats pooled): if one level differs, it is named and by how much.
3. The linear dynamics are fitted jointly on every moving, unsaturated capture: one unit-DC
   transfer function shared by all, each capture with its own amplitude (solved in closed form
   inside the fit: variable projection), orders 1 and 2 compared by BIC.  The model's gain is
   the static characteristic's ``K``, so ``y = K·G(s)·f(u)`` with ``f`` the dead-zone (and
   rails) of :class:`~motorid.model.nonlinearity.StaticNonlinearity`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize

from motorid.capture import Capture
from motorid.conditioning.edge import quantisation_step
from motorid.conditioning.response import StepResponse, refreshed, step_response
from motorid.conditioning.timescale import response_times
from motorid.errors import OptionError
from motorid.identification.metrics import bic
from motorid.identification.static import (
    LevelPoint,
    StaticCharacteristic,
    fit_static_characteristic,
    level_groups,
    steady_state,
)
from motorid.model.motor import MotorModel, model_from_velocity_tf
from motorid.model.nonlinearity import StaticNonlinearity
from motorid.model.units import units_of

__all__ = ["LevelDynamics", "MultiLevelResult", "identify_levels", "level_response"]

#: A step starts from rest when the input before it is within this fraction of the step (or
#: three noise levels, or FROM_REST_MIN_V); otherwise the points are absolute levels.
FROM_REST_FRACTION = 0.02
FROM_REST_MIN_V = 0.05
#: Samples per capture used by the joint dynamic fit (the record after the step, thinned).
JOINT_SAMPLES = 400
#: The dynamic fit uses the record up to this many 63 % times after the step.
JOINT_TIME_CONSTANTS = 8.0
#: Levels whose time constants differ by more than this many standard errors AND by more than
#: DYNAMICS_MIN_DIFFERENCE (relative) do not share their dynamics.
DYNAMICS_SIGMAS = 4.0
DYNAMICS_MIN_DIFFERENCE = 0.05


@dataclass(frozen=True, slots=True)
class LevelDynamics:
    """First-order time constant of one level (repeats pooled).

    Attributes
    ----------
    step_volts : float
    time_constant_s : float
    stderr : float
        Standard error (the larger of the fits' own and the repeats' scatter).
    count : int
        Captures pooled.
    """

    step_volts: float
    time_constant_s: float
    stderr: float
    count: int


@dataclass(frozen=True, slots=True)
class MultiLevelResult:
    """The Hammerstein model identified from several step levels.

    Attributes
    ----------
    model : MotorModel
        Linear part (DC gain ``K``) with ``static_nonlinearity`` set.
    static : StaticCharacteristic
        The static law with intervals and every level's status.
    dynamics : tuple of LevelDynamics
        Per-level time constants (moving, unsaturated levels).
    shared_dynamics : bool
        Whether all levels' time constants agree.
    dynamics_note : str
        The comparison in one sentence (which level differs and how, when one does).
    warnings : tuple of str
    responses : tuple of (LevelPoint, StepResponse)
        Every capture's point (with its status) and step response, for plots.
    """

    model: MotorModel
    static: StaticCharacteristic
    dynamics: tuple[LevelDynamics, ...]
    shared_dynamics: bool
    dynamics_note: str
    warnings: tuple[str, ...] = field(default=())
    responses: tuple[tuple[LevelPoint, StepResponse], ...] = field(default=())


def _start_level(capture: Capture, resp: StepResponse) -> float | None:
    """The input before the step when it is clearly not 0 (the step does not start from rest).

    Only a recorded input channel tells: without one the level given is the step itself.
    """
    if capture.input_v is None or resp.edge.method == "onset":
        return None
    start = float(resp.edge.baseline_v)
    tolerance = max(FROM_REST_FRACTION * abs(resp.step_volts), 3.0 * resp.edge.noise_v, FROM_REST_MIN_V)
    return start if abs(start) > tolerance else None


def level_response(capture: Capture, *, step_volts: float | None = None) -> tuple[LevelPoint, StepResponse, float]:
    """One capture's step response, its static-characteristic point and its 63 % time.

    Parameters
    ----------
    capture : Capture
        A velocity step capture (CH1 = input when recorded).
    step_volts : float, optional
        The level, for a capture without input channel.

    Returns
    -------
    tuple of (LevelPoint, StepResponse, float)
        The point (status ``moving`` until the fit classifies it), the response and its 63 %
        time (NaN when the output did not move).
    """
    resp = step_response(capture, "velocity", step_volts=step_volts)
    t, y = resp.time_s, resp.output_v
    after = t >= 0
    times = response_times(t[after], y[after], pre=y[~after])
    quantum = quantisation_step(y, below=0.25 * abs(times.final)) if times.final else 0.0
    value, stderr, settled = steady_state(t, y, times.t63_s, times.noise, quantum)
    level = resp.step_volts
    start = _start_level(capture, resp)
    if start is not None:
        # a step that does not start from rest (5 V → 15 V): the static law holds for absolute
        # levels, not for increments — the motor already turned before the step
        level = start + resp.step_volts
        value += float(np.mean(capture.output_v[: max(resp.edge.index, 1)]))
    point = LevelPoint(step_volts=level, steady_state=value, stderr=stderr, noise=times.noise,
                       settled=settled, source=capture.source)
    return point, resp, times.t63_s


def _first_order_tau(resp: StepResponse, t63: float) -> tuple[float, float]:
    t, y = resp.time_s, resp.output_v
    keep = (t >= 0) & (t <= JOINT_TIME_CONSTANTS * t63)
    t, y = t[keep], y[keep]

    def f(tt: np.ndarray, a: float, tau: float) -> np.ndarray:
        return a * (1.0 - np.exp(-tt / tau))

    popt, pcov = scipy.optimize.curve_fit(f, t, y, p0=(float(np.mean(y[-max(2, y.size // 10):])), t63))
    return float(popt[1]), float(math.sqrt(max(pcov[1, 1], 0.0)))


def _compare_dynamics(per_capture: list[tuple[float, float, float]]) -> tuple[tuple[LevelDynamics, ...], bool, str]:
    """Pool repeats per level, then test that all levels share one time constant."""
    levels: dict[int, list[tuple[float, float]]] = {}
    nominal: dict[int, list[float]] = {}
    for g, (u, tau, se) in zip(level_groups([p[0] for p in per_capture]), per_capture, strict=True):
        levels.setdefault(g, []).append((tau, se))
        nominal.setdefault(g, []).append(u)
    out = []
    for g, vals in sorted(levels.items()):
        u = float(np.mean(nominal[g]))
        taus = np.array([v[0] for v in vals])
        ses = np.array([v[1] for v in vals])
        mean = float(np.mean(taus))
        formal = float(math.sqrt(np.sum(ses**2)) / len(vals))
        scatter = float(np.std(taus, ddof=1) / math.sqrt(len(vals))) if len(vals) > 1 else 0.0
        out.append(LevelDynamics(u, mean, max(formal, scatter), len(vals)))
    if len(out) < 2:
        return tuple(out), True, "one moving level: the dynamics cannot be compared across levels"
    taus = np.array([d.time_constant_s for d in out])
    ses = np.array([d.stderr for d in out])
    w = 1.0 / ses**2
    pooled = float(np.sum(w * taus) / np.sum(w))
    # each level against the others' pooled mean
    worst, worst_z = None, 0.0
    for i, d in enumerate(out):
        others = np.delete(np.arange(len(out)), i)
        wm = float(np.sum(w[others] * taus[others]) / np.sum(w[others]))
        sem = float(math.sqrt(1.0 / np.sum(w[others]) + ses[i] ** 2))
        z = abs(d.time_constant_s - wm) / sem
        if abs(d.time_constant_s - wm) > DYNAMICS_MIN_DIFFERENCE * wm and z > worst_z:
            worst, worst_z = (d, wm), z
    if worst is not None and worst_z > DYNAMICS_SIGMAS:
        d, wm = worst
        return tuple(out), False, (
            f"the {d.step_volts:g} V level has τ = {d.time_constant_s:.4g} s against {wm:.4g} s for the others "
            f"({100 * (d.time_constant_s / wm - 1):+.1f} %, {worst_z:.1f} standard errors): the dynamics depend "
            "on the level (rails during the transient, or a load that changes with speed)")
    spread = 100 * (taus.max() - taus.min()) / pooled
    return tuple(out), True, (f"the levels share one time constant (τ = {pooled:.4g} s; levels within "
                              f"{spread:.1f} %, consistent with their errors)")


def _unit_step(den: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Step response of ``den[-1]/den(s)`` (unit DC gain, order 1 or 2) at times ``t >= 0``.

    Closed forms (the fit evaluates this thousands of times on each capture's own grid):
    ``1 − e^{−a t}``, and for poles ``p₁ ≠ p₂`` (real or a complex pair)
    ``1 + (p₂ e^{p₁t} − p₁ e^{p₂t})/(p₁ − p₂)``; a double pole is split by 1e-6 relative.
    """
    if den.size == 2:
        return -np.expm1(-den[1] * t)
    p1, p2 = _two_poles(den)
    with np.errstate(over="ignore", invalid="ignore"):
        s = 1.0 + (p2 * np.exp(p1 * t) - p1 * np.exp(p2 * t)) / (p1 - p2)
    return np.real(s)


def _two_poles(den: np.ndarray) -> tuple[complex, complex]:
    """The roots of a second-order ``den``, a double pole split by 1e-6 relative.

    The closed forms divide by ``p₁ − p₂``.
    """
    p1, p2 = np.roots(den).astype(complex)
    if abs(p1 - p2) < 1e-6 * abs(p1):
        p2 = p1 * (1 + 1e-6)
    return complex(p1), complex(p2)


def _unit_step_integral(den: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``∫₀ᵗ`` of :func:`_unit_step`, 0 before the step.

    ``t + (e^{−at} − 1)/a``, and for two poles ``t + (p₂(e^{p₁t} − 1)/p₁ − p₁(e^{p₂t} − 1)/p₂)/(p₁ − p₂)``.
    """
    t = np.clip(t, 0.0, None)
    if den.size == 2:
        return t + np.expm1(-den[1] * t) / den[1]
    p1, p2 = _two_poles(den)
    with np.errstate(over="ignore", invalid="ignore"):
        s = t + (p2 * np.expm1(p1 * t) / p1 - p1 * np.expm1(p2 * t) / p2) / (p1 - p2)
    return np.real(s)


def _recorded_unit_step(den: np.ndarray, t: np.ndarray, window: float) -> np.ndarray:
    """:func:`_unit_step` as a speed counted over ``window`` records it.

    Its mean over the window before each time (:attr:`~motorid.capture.Capture.sample_window_s`);
    the samples themselves when the window is 0.
    """
    if window <= 0:
        return _unit_step(den, t)
    return (_unit_step_integral(den, t) - _unit_step_integral(den, t - window)) / window


def _joint_fit(responses: list[tuple[StepResponse, float]], order: int, t63: float) -> tuple[np.ndarray, float, int]:
    """Shared unit-DC dynamics of ``order`` with per-capture amplitudes: den, RSS, samples.

    A counted speed (a response with a ``sample_window_s``) is fitted as the model's means over
    its windows.
    """
    data = []
    for resp, noise in responses:
        t, y = resp.time_s, resp.output_v
        fresh = refreshed(resp)  # a count kept over several lines: the lines that logged it
        keep = np.flatnonzero((t >= 0) & (t <= JOINT_TIME_CONSTANTS * t63) & (True if fresh is None else fresh))
        keep = keep[np.unique(np.linspace(0, keep.size - 1, min(JOINT_SAMPLES, keep.size)).astype(int))]
        data.append((t[keep], y[keep], 1.0 / max(noise, 1e-12), resp.sample_window_s))

    def den_of(theta: np.ndarray) -> np.ndarray:
        if order == 1:
            return np.array([1.0, math.exp(theta[0])])
        # s² + 2ζω s + ω² with ω, ζ positive: real or complex poles alike
        wn, zeta = math.exp(theta[0]), math.exp(theta[1])
        return np.array([1.0, 2 * zeta * wn, wn * wn])

    def residuals(theta: np.ndarray) -> np.ndarray:
        den = den_of(theta)
        out = []
        for t, y, w, window in data:
            s = _recorded_unit_step(den, t, window)
            a = float(s @ y / (s @ s)) if s @ s > 0 else 0.0  # the capture's amplitude, closed form
            out.append(w * (y - a * s))
        return np.concatenate(out)

    p0 = np.array([math.log(1.0 / t63)]) if order == 1 else np.array([math.log(1.5 / t63), math.log(1.0)])
    sol = scipy.optimize.least_squares(residuals, p0, method="lm")
    n = sum(d[0].size for d in data)
    return den_of(sol.x), float(np.sum(sol.fun**2)), n


def _common_units(captures: Sequence[Capture]) -> dict[str, str]:
    """The data units the captures share (a log in rpm: the gain reads rpm/V), or an error."""
    found = {tuple(sorted(units_of({"velocity": c}).items())) for c in captures}
    if len(found) > 1:
        raise OptionError("the captures record the velocity in different units ("
                          + "; ".join(", ".join(f"{k} {v}" for k, v in u) or "volts" for u in sorted(found))
                          + "): give every level in one unit")
    return dict(found.pop()) if found else {}


def identify_levels(
    captures: Sequence[Capture],
    *,
    step_volts: Sequence[float | None] | None = None,
) -> MultiLevelResult:
    """Identify a Hammerstein model from velocity steps at several levels.

    Parameters
    ----------
    captures : sequence of Capture
        Velocity step captures, one per acquisition (repeats of a level are separate captures).
    step_volts : sequence of float or None, optional
        The level of each capture without an input channel (same length as ``captures``).

    Returns
    -------
    MultiLevelResult

    Raises
    ------
    OptionError
        Fewer than two captures, mismatched ``step_volts``, or fewer than two moving levels.
    """
    if len(captures) < 2:
        raise OptionError("a dead-zone needs at least two step levels that move the motor; got one capture")
    levels = list(step_volts) if step_volts is not None else [None] * len(captures)
    if len(levels) != len(captures):
        raise OptionError(f"step_volts has {len(levels)} levels for {len(captures)} captures")
    measured = [level_response(c, step_volts=v) for c, v in zip(captures, levels, strict=True)]
    static = fit_static_characteristic([m[0] for m in measured])
    status = {(p.source, p.step_volts): p.status for p in static.points}
    usable = [m for m in measured if status.get((m[0].source, m[0].step_volts)) == "moving"
              and math.isfinite(m[2])]
    warnings = list(static.warnings)
    per_capture = []
    for point, resp, t63 in usable:
        try:
            tau, se = _first_order_tau(resp, t63)
        except (RuntimeError, ValueError):
            warnings.append(f"{point.source}: no first-order fit of its response; left out of the comparison")
            continue
        per_capture.append((point.step_volts, tau, se))
    dynamics, shared, note = _compare_dynamics(per_capture)
    if not shared:
        warnings.append(note)
    windows = sorted({resp.sample_window_s for _, resp, _ in usable if resp.sample_window_s > 0})
    if windows:
        note += (f"; the speeds are counted over each {', '.join(f'{1e3 * w:.4g}' for w in windows)} ms interval "
                 "(--counted-velocity): the shared dynamics are fitted to their means over each interval, so they "
                 "are the motor's, without the counting's lag")
    t63 = float(np.median([m[2] for m in usable]))
    joint_in = [(resp, point.noise) for point, resp, _ in usable]
    fits = {order: _joint_fit(joint_in, order, t63) for order in (1, 2)}
    scores = {o: bic({"y": n}, {"y": rss / n}, o + len(joint_in)) for o, (_, rss, n) in fits.items()}
    order = min(scores, key=lambda o: scores[o])
    den = fits[order][0]
    nl = StaticNonlinearity(
        dead_zone_v=static.dead_zone_v, dead_zone_ci95=static.dead_zone_ci95,
        dead_zone_negative_v=None if static.negative is None else static.negative.dead_zone_v,
        gain=static.gain, gain_ci95=static.gain_ci95,
        saturation_input_v=static.saturation_input_v, saturation_output_v=static.saturation_output_v,
        levels=tuple(p.to_json() for p in static.points),
    )
    model = model_from_velocity_tf(
        [static.gain * den[-1]], den, with_position=True, method="hammerstein",
        step_volts=float(max(p.step_volts for p in static.points if p.status == "moving")),
        settings={"levels": len(set(level_groups([p.step_volts for p in static.points]))),
                  "captures": len(captures),
                  "order_by_bic": order},
        warnings=tuple(warnings), static_nonlinearity=nl, units=_common_units(captures),
    )
    classified = {(p.source, p.step_volts): p for p in static.points}
    responses = tuple((classified.get((m[0].source, m[0].step_volts), m[0]), m[1]) for m in measured)
    return MultiLevelResult(model, static, dynamics, shared, note, tuple(warnings), responses)
