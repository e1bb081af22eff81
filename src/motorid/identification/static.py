"""The static characteristic of a motor from steps at several levels: dead-zone, gain, rails.

Each step experiment gives one point: the input level ``u`` and the steady output ``y_ss``.
Above a threshold the points lie on a line, ``y_ss = K·(u − u₀)`` (``u₀``: the dead-zone of
the amplifier plus the Coulomb friction referred to the input); a level that never leaves its
noise band lies inside the dead-zone, and levels above the rails fall short of the line.

The line is a weighted least-squares fit (numpy's ``lstsq`` on whitened rows): each point is
weighted by the standard error of its steady state (from block means of the settled part, so
tacho ripple averages out), and the covariance is scaled by the Birge ratio ``χ²/dof`` when
the points scatter more than their own errors say (repeat-to-repeat friction changes).  The
dead-zone is ``u₀ = −a/K`` for the fit ``y = a + K·u``; its interval comes from the exact
Fieller construction (the ratio of two correlated normal estimates), not a delta-method
approximation: with a few levels near the threshold the ratio is visibly skewed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.stats

from motorid.errors import OptionError

__all__ = [
    "SETTLED_TIME_CONSTANTS",
    "LevelPoint",
    "StaticCharacteristic",
    "fit_static_characteristic",
    "level_groups",
    "steady_state",
]

#: The steady state is read after this many 63 % times (e⁻⁶ ≈ 0.25 % of the change remains: after
#: four, the 2 % still missing biased the gain by −0.3 % on the trainer).
SETTLED_TIME_CONSTANTS = 6.0
#: Blocks the settled part is split into for the standard error of its mean.
STEADY_BLOCKS = 8
#: A level whose steady change is below this many noise standard deviations did not move.
STILL_NOISE_FACTOR = 4.0
#: A level falls short of the line (saturated) when below it by this many standard errors
#: and by more than SATURATION_MIN_SHORTFALL of its predicted value.
SATURATION_SIGMAS = 4.0
SATURATION_MIN_SHORTFALL = 0.01
#: Repeats of one level: measured step levels within this fraction (or LEVEL_TOLERANCE_V) of
#: each other are one level (CH1 reads a 5 V step as 4.998–5.002 V).
LEVEL_TOLERANCE_REL = 0.02
LEVEL_TOLERANCE_V = 0.02


def level_groups(levels: Sequence[float]) -> list[int]:
    """Group measured step levels into nominal levels (repeats of one setting).

    Parameters
    ----------
    levels : sequence of float
        Measured step levels.

    Returns
    -------
    list of int
        A group number per level, in the order given; groups are numbered by rising level.
    """
    order = np.argsort(levels)
    groups = [0] * len(levels)
    current, anchor = -1, None
    for i in order:
        u = float(levels[i])
        if anchor is None or abs(u - anchor) > max(LEVEL_TOLERANCE_REL * abs(anchor), LEVEL_TOLERANCE_V):
            current += 1
            anchor = u
        groups[i] = current
    return groups


def _count_levels(points: Sequence[LevelPoint]) -> int:
    return len(set(level_groups([p.step_volts for p in points]))) if points else 0


@dataclass(frozen=True, slots=True)
class LevelPoint:
    """One step experiment's point of the static characteristic.

    Attributes
    ----------
    step_volts : float
        Input step level.
    steady_state : float
        Steady output change (volts).
    stderr : float
        Standard error of ``steady_state``.
    noise : float
        Noise level of the output (pre-step standard deviation).
    settled : bool
        Whether the record lasts ``SETTLED_TIME_CONSTANTS`` 63 % times after the step.
    source : str
        The capture it came from.
    status : str
        ``moving``, ``still`` (inside the dead-zone) or ``saturated``; set by the fit.
    """

    step_volts: float
    steady_state: float
    stderr: float
    noise: float
    settled: bool
    source: str = ""
    status: str = "moving"

    def to_json(self) -> dict[str, object]:
        """The point as the model JSON's ``static_nonlinearity.levels`` entry.

        Returns
        -------
        dict
            ``step_volts``, ``steady_state``, ``stderr``, ``status``, ``source``.
        """
        return {"step_volts": self.step_volts, "steady_state": self.steady_state, "stderr": self.stderr,
                "status": self.status, "source": self.source}


def steady_state(time_s: np.ndarray, output_v: np.ndarray, t63_s: float, noise: float,
                 quantum: float = 0.0) -> tuple[float, float, bool]:
    """Steady output change of one step response, robust to ripple.

    Parameters
    ----------
    time_s : ndarray
        Time from the step edge.
    output_v : ndarray
        Output change (pre-step baseline removed).
    t63_s : float
        The response's 63 % time.
    noise : float
        Output noise level.
    quantum : float
        The scope's code step (volts per code); 0 for unquantised data.

    Returns
    -------
    tuple of (float, float, bool)
        Mean of the settled part, its standard error (from ``STEADY_BLOCKS`` block means, so
        periodic ripple shorter than a block averages out; at least ``quantum/√12``, the
        error of a mean over codes the noise does not dither, which averaging does not remove:
        on the trainer, levels read at different volts/div were off the line by up to 9 block
        standard errors without it) and whether the record lasted
        ``SETTLED_TIME_CONSTANTS`` 63 % times (else the last quarter is used, and the value
        is flagged as possibly unsettled).
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(output_v, dtype=float)
    after = t > 0
    t, y = t[after], y[after]
    start = SETTLED_TIME_CONSTANTS * t63_s if math.isfinite(t63_s) and t63_s > 0 else math.inf
    settled = bool(t.size and start < t[-1] - 0.1 * (t[-1] - t[0]))
    if not settled:
        start = t[0] + 0.75 * (t[-1] - t[0])
    tail = y[t >= start]
    if tail.size < STEADY_BLOCKS * 2:
        tail = y[-max(STEADY_BLOCKS * 2, y.size // 4):]
    blocks = np.array([b.mean() for b in np.array_split(tail, STEADY_BLOCKS)])
    stderr = float(np.std(blocks, ddof=1) / math.sqrt(STEADY_BLOCKS))
    floor = max(noise / math.sqrt(tail.size), quantum / math.sqrt(12.0))
    return float(tail.mean()), math.hypot(stderr, floor), settled


@dataclass(frozen=True, slots=True)
class StaticCharacteristic:
    """The fitted law ``y_ss = K·(u − u₀)`` (and its negative-side twin), with intervals.

    Attributes
    ----------
    gain, gain_stderr : float
        ``K`` and its standard error (positive side).
    gain_ci95 : tuple of float
    dead_zone_v, dead_zone_stderr : float
        ``u₀`` (clipped at 0 when the fit crosses the origin) and its standard error.
    dead_zone_ci95 : tuple of float
        Fieller interval of ``−a/K``.
    negative : StaticCharacteristic or None
        The same fit on negative steps (``dead_zone_v`` is then ``u₀⁻``, positive).
    saturation_input_v, saturation_output_v : float or None
        Where the rails were seen: the output of the saturated levels and the input at which
        the law reaches it (``u₀ + y_sat/K``; at most the lowest saturated level).
    birge_ratio : float
        ``sqrt(χ²/dof)`` of the fit (> 1: the points scatter more than their errors).
    points : tuple of LevelPoint
        All points with their status.
    warnings : tuple of str
    """

    gain: float
    gain_stderr: float
    gain_ci95: tuple[float, float]
    dead_zone_v: float
    dead_zone_stderr: float
    dead_zone_ci95: tuple[float, float]
    birge_ratio: float
    points: tuple[LevelPoint, ...]
    negative: StaticCharacteristic | None = None
    saturation_input_v: float | None = None
    saturation_output_v: float | None = None
    warnings: tuple[str, ...] = field(default=())

    def predict(self, u: float | np.ndarray) -> np.ndarray:
        """Steady output the law predicts for input ``u`` (rails not applied).

        Parameters
        ----------
        u : float or ndarray
            Input levels.

        Returns
        -------
        ndarray
        """
        u = np.asarray(u, dtype=float)
        pos = self.gain * np.clip(u - self.dead_zone_v, 0.0, None)
        if self.negative is None:
            neg = self.gain * np.clip(u + self.dead_zone_v, None, 0.0)
        else:
            neg = self.negative.gain * np.clip(u + self.negative.dead_zone_v, None, 0.0)
        return np.where(u >= 0, pos, neg)


def _line_fit(u: np.ndarray, y: np.ndarray, se: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Weighted LS of ``y = a + K u``: coefficients, covariance (Birge-scaled), ratio, dof."""
    w = 1.0 / se
    design = np.column_stack([np.ones_like(u), u]) * w[:, None]
    coef, *_ = np.linalg.lstsq(design, y * w, rcond=None)
    cov = np.linalg.inv(design.T @ design)
    dof = u.size - 2
    chi2 = float(np.sum(((y - (coef[0] + coef[1] * u)) * w) ** 2))
    birge = math.sqrt(chi2 / dof) if dof > 0 else 1.0
    return coef, cov * max(1.0, birge) ** 2, birge, dof


def _fieller(a: float, k: float, cov: np.ndarray, q: float) -> tuple[float, float]:
    """95 % interval of ``−a/k`` (Fieller): the ``x`` with ``(a + k x)² ≤ q² var(a + k x)``."""
    va, vk, cak = cov[0, 0], cov[1, 1], cov[0, 1]
    # (k² − q² vk) x² + 2 (a k − q² cak) x + (a² − q² va) ≤ 0
    qa, qb, qc = k * k - q * q * vk, 2 * (a * k - q * q * cak), a * a - q * q * va
    disc = qb * qb - 4 * qa * qc
    if qa <= 0 or disc < 0:
        return (-math.inf, math.inf)  # the slope is not significantly non-zero: unbounded
    r = math.sqrt(disc)
    return ((-qb - r) / (2 * qa), (-qb + r) / (2 * qa))


def _fit_side(points: list[LevelPoint], sign: float) -> tuple[StaticCharacteristic | None, list[LevelPoint], list[str]]:
    """Fit one side (``sign`` = +1 or −1): classify still/saturated points, fit the line."""
    warnings: list[str] = []
    out: list[LevelPoint] = []
    moving: list[LevelPoint] = []
    for p in points:
        if abs(p.steady_state) < STILL_NOISE_FACTOR * max(p.noise, p.stderr):
            out.append(_with_status(p, "still"))
        else:
            moving.append(p)
    moving.sort(key=lambda p: abs(p.step_volts))
    saturated: list[LevelPoint] = []
    while _count_levels(moving) >= 3:
        u = np.array([sign * p.step_volts for p in moving])
        y = np.array([sign * p.steady_state for p in moving])
        se = np.array([p.stderr for p in moving])
        # test the highest level (all its repeats) against the line through the levels below it
        groups = np.array(level_groups(list(u)))
        below = groups < groups.max()
        coef, cov, _, _ = _line_fit(u[below], y[below], se[below])
        pred = coef[0] + coef[1] * u[~below]
        spread = np.sqrt(cov[0, 0] + 2 * cov[0, 1] * u[~below] + cov[1, 1] * u[~below] ** 2 + se[~below] ** 2)
        short = float(np.mean(pred - y[~below]))
        if short > SATURATION_SIGMAS * np.mean(spread) and short > SATURATION_MIN_SHORTFALL * np.mean(pred):
            saturated = [p for p, keep in zip(moving, below, strict=True) if not keep] + saturated
            moving = [p for p, keep in zip(moving, below, strict=True) if keep]
        else:
            break
    out += [_with_status(p, "saturated") for p in saturated]
    if _count_levels(moving) < 2:
        return None, out + moving, warnings
    u = np.array([sign * p.step_volts for p in moving])
    y = np.array([sign * p.steady_state for p in moving])
    se = np.array([p.stderr for p in moving])
    coef, cov, birge, dof = _line_fit(u, y, se)
    a, k = float(coef[0]), float(coef[1])
    q = float(scipy.stats.t.ppf(0.975, dof)) if dof > 0 else 1.96
    if k <= 0:
        warnings.append("the steady output does not grow with the step level: no static characteristic")
        return None, out + moving, warnings
    u0 = -a / k
    u0_se = math.sqrt(max(cov[0, 0] / k**2 + a**2 * cov[1, 1] / k**4 - 2 * a * cov[0, 1] / k**3, 0.0))
    lo, hi = _fieller(a, k, cov, q)
    if u0 < 0:
        warnings.append(f"the fitted threshold is below 0 ({u0:.3g} V): no dead-zone is seen; taken as 0")
    if birge > 2:
        warnings.append(f"the levels scatter {birge:.1f}× more than their own errors: the intervals are widened "
                        "by that factor (friction that changes from run to run, or a level that did not settle)")
    unsettled = [p for p in moving if not p.settled]
    if unsettled:
        warnings.append(f"{len(unsettled)} level(s) may not have settled (record shorter than "
                        f"{SETTLED_TIME_CONSTANTS:g} time constants): their steady state is the last quarter's mean")
    sat_in = sat_out = None
    if saturated:
        # the rails cap the output: the input where the law reaches the saturated output
        sat_out = float(np.mean([abs(p.steady_state) for p in saturated]))
        sat_in = min(max(u0, 0.0) + sat_out / k, min(abs(p.step_volts) for p in saturated))
        names = sorted({round(p.step_volts, 2) for p in saturated}, key=abs)
        warnings.append(f"level(s) {', '.join(f'{u:g} V' for u in names)} fall short of the line "
                        f"(output ≈ {sat_out:.3g} V): saturation (amplifier rails) — excluded from the fit")
    ks = math.sqrt(cov[1, 1])
    fit = StaticCharacteristic(
        gain=k, gain_stderr=ks, gain_ci95=(k - q * ks, k + q * ks),
        dead_zone_v=max(u0, 0.0), dead_zone_stderr=u0_se, dead_zone_ci95=(lo, hi),
        birge_ratio=birge, points=tuple(out + moving),
        saturation_input_v=sat_in, saturation_output_v=sat_out, warnings=tuple(warnings),
    )
    return fit, out + moving, warnings


def _with_status(p: LevelPoint, status: str) -> LevelPoint:
    return LevelPoint(p.step_volts, p.steady_state, p.stderr, p.noise, p.settled, p.source, status)


def fit_static_characteristic(points: Sequence[LevelPoint]) -> StaticCharacteristic:
    """Fit ``y_ss = K·(u − u₀)`` to the points of several step levels.

    Levels that never move are marked ``still``; the highest levels are tested one by one
    against the line through the levels below them and marked ``saturated`` when they fall
    short (then excluded).  Negative steps, when present, get their own fit (``negative``).

    Parameters
    ----------
    points : sequence of LevelPoint
        One per step experiment (repeats of a level are separate points).

    Returns
    -------
    StaticCharacteristic

    Raises
    ------
    OptionError
        When fewer than two distinct moving levels are available on the positive side (or on
        the negative side when only negative steps were given).
    """
    pos = [p for p in points if p.step_volts > 0]
    neg = [p for p in points if p.step_volts < 0]
    side_pos = _fit_side(pos, 1.0) if pos else (None, [], [])
    side_neg = _fit_side(neg, -1.0) if neg else (None, [], [])
    main, other = (side_pos, side_neg) if side_pos[0] is not None or not neg else (side_neg, side_pos)
    if main[0] is None:
        moving = _count_levels([p for p in main[1] if p.status == "moving"])
        raise OptionError(
            f"a dead-zone needs at least two step levels that move the motor; got {moving} "
            f"moving level(s) of {_count_levels(points)} "
            "(add steps at other levels: --velocity once per level, or --experiment DIR per level)")
    fit = main[0]
    negative = other[0]
    points_all = tuple(sorted([*main[1], *other[1]], key=lambda p: p.step_volts))
    warnings = list(fit.warnings) + [f"negative steps: {w}" for w in (negative.warnings if negative else ())]
    return StaticCharacteristic(
        gain=fit.gain, gain_stderr=fit.gain_stderr, gain_ci95=fit.gain_ci95,
        dead_zone_v=fit.dead_zone_v, dead_zone_stderr=fit.dead_zone_stderr, dead_zone_ci95=fit.dead_zone_ci95,
        birge_ratio=fit.birge_ratio, points=points_all, negative=negative,
        saturation_input_v=fit.saturation_input_v, saturation_output_v=fit.saturation_output_v,
        warnings=tuple(warnings),
    )
