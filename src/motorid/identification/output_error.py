"""Continuous-time output-error fit of a servo's step responses (beyond the paper).

The paper fits an equation error (pseudo-inverse on numerically differentiated, sub-sampled
states), which is biased when the regressors are noisy.  Here the transfer function itself —
gain, real time constants, zeros, optionally a delay — is fitted to the *measured* step
responses by nonlinear least squares (``scipy.optimize.least_squares``), every channel
weighted by its own noise level, velocity and position tied together through the integrator
(``P(s) = c·G(s)/s``) and the current sharing the poles.  Responses are evaluated in closed
form (partial fractions: a few exponentials), so a fit on thousands of samples takes tens of
milliseconds; the parameter covariance is the Gauss–Newton one, ``s²(JᵀJ)⁻¹``, and the
uncertainty of derived quantities (DC gain, time constant, poles, zeros) follows by the delta
method.  No library fits continuous-time models with shared poles across channels, hence
this module.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike
import scipy.linalg
import scipy.optimize

from motorid.conditioning.edge import quantisation_step
from motorid.identification.closed_form import (
    PartialFractions,
    ResponseBasis,
    WindowBasis,
    position_closed_form,
    separate,
    slope_closed_form,
    step_response_closed_form,
)
from motorid.identification.method_options import FIT_TOLERANCE, MAX_NFEV
from motorid.identification.metrics import bic
from motorid.identification.quantiser import harmonic_variances, sawtooth_basis
from motorid.identification.result import STOPPED_EARLY, IdentificationError

__all__ = [
    "FRACTION_63",
    "GAVE_UP",
    "OeResult",
    "OeSettings",
    "PlannedUncertainty",
    "ar_noise_model",
    "output_error_fit",
    "planned_uncertainty",
    "position_closed_form",
    "position_scale_fit",
    "step_63_time",
    "step_response_closed_form",
]


@dataclass(frozen=True, slots=True)
class OeSettings:
    """Structure of the fitted velocity transfer function.

    Attributes
    ----------
    n_poles : int
        Real poles ``-1/τ_i`` (1–3 for a servo).
    n_zeros : int
        Zeros ``-1/Tz_j`` (fewer than the poles).
    delay : bool
        Fit a pure delay too.
    max_nfev : int
        Most model evaluations of the optimiser.
    tolerance : float
        Relative change of the cost and of the parameters that ends the fit (``ftol`` and
        ``xtol`` of ``scipy.optimize.least_squares``; its default 1e-8).  The structure search
        compares candidates at 1e-6 (their BIC then moves by about 1e-6 of the sample count,
        far under the differences it decides on) and refits the chosen one at 1e-8.
    shifts : bool
        Fit time shifts (of the channels in ``shift_groups``).
    shift_bound_s : float or None
        Largest shift; 1.5 samples of the fitted grid when ``None``.
    shift_groups : tuple of tuple of str, or None
        Channels whose step instant is not known from a recorded input, grouped by
        acquisition: each group shares one fitted shift (the channels of one scope
        acquisition saw one step).  Channels in no group have a fixed step instant (a logged
        or sampled input gives it), so nothing can trade their lags for a time shift.
        ``None``: every channel has a shift of its own.
    instant_std : tuple of (str, float)
        Channels whose step instant is fixed to within their sample interval but not fitted (a
        scope samples the input's edge: the step lies in the interval before the edge sample),
        or to within their stamps' resolution (a log stamped by ``millis()``), with that
        instant's standard deviation (s, ``dt/√12``).  Its effect on the parameters (the fit's
        sensitivity to a shift of that channel's instant) is added to their covariance.
    instant_shared : tuple of tuple of str
        Channels of ``instant_std`` outside ``phase_group`` whose step instant is one stamp (the
        columns of one log): their instants move together.
    phase_group : tuple of str
        Channels of ``instant_std`` (separate scope acquisitions) whose sub-sample phases are
        fitted *relative to each other* (they sum to zero): their differences are what makes the
        captures disagree near the step, while their common part is what trades against the lags
        of the dynamics, so it stays at the intervals' middles (its ``dt/√(12·n)`` in the
        covariance).
    current_direct : bool or None
        Let the current jump at the step (a biproper current TF, ``n_poles + 1`` numerator
        coefficients): what a model that leaves out an electrical pole faster than the
        sampling must do, since the current then follows the voltage at once
        (``I/U = (Js + b)/(R(Js + b) + K²)``).  ``None``: only for a one-pole model (with more
        poles the electrical one is in the model and the current is strictly proper; a jump
        would also make the fit discontinuous in the capture's time shift).
    windows : tuple of (str, float)
        Channels whose every sample is the mean over the window (s) before its time — a speed
        counted over each sample interval — fitted as such means
        (:class:`~motorid.identification.closed_form.WindowBasis`) instead of samples.
    differenced : tuple of str
        Channels whose steps are not a reading rounded to its codes but a difference of two
        counts (a speed counted from encoder edges, however it is fitted): their quantiser's
        errors telescope, so the covariance leaves out the rounding's error along the record
        (:mod:`~motorid.identification.quantiser`), which a windowed channel never gets.
    """

    n_poles: int = 2
    n_zeros: int = 0
    delay: bool = False
    max_nfev: int = MAX_NFEV
    tolerance: float = FIT_TOLERANCE
    shifts: bool = True
    shift_bound_s: float | None = None
    current_direct: bool | None = None
    shift_groups: tuple[tuple[str, ...], ...] | None = None
    instant_std: tuple[tuple[str, float], ...] = ()
    phase_group: tuple[str, ...] = ()
    instant_shared: tuple[tuple[str, ...], ...] = ()
    windows: tuple[tuple[str, float], ...] = ()
    differenced: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class OeResult:
    """An output-error fit.

    Attributes
    ----------
    params, param_names, cov : the raw parameters (``K``, ``log_tau_i``, ``Tz_j``, ``delay``,
        ``c``, ``cur_j``, ``off_<channel>`` (pre-step levels)) and their covariance.
    velocity_num, velocity_den : ndarray
        Velocity TF, highest power first, ``den[0] == 1``.
    dc_gain, time_constant_s : float
        DC gain and the mean residence time ``Στ_i − ΣTz_j``.
    poles, zeros : ndarray
        Of the velocity TF (poles slowest first).
    delay_s : float or None
        Fitted delay.
    position_scale : float or None
        ``c`` of ``P(s) = c·G(s)/s`` when a position channel was fitted.
    current_num : ndarray or None
        Numerator of the current TF (same denominator) when fitted.
    std, ci95 : dict
        Standard deviation and 95% interval of ``dc_gain``, ``time_constant``, ``pole_i``,
        ``zero_j`` (real parts), ``delay`` and each fitted shift ``shift_<channel>``.
    shifts : dict[str, float]
        Fitted time shift of each channel that has one (s; positive: the response is later
        than the step instant read off the data), keyed by channel; the channels of one
        group share a value.
    residual_rms, sigma : dict
        Per channel: RMS residual (V) and the noise level used as weight.
    n_samples, nfev : int
    cost : float
        Half the weighted residual sum of squares.
    bic, aic : float
        ``N ln(RSS_w/N) + p ln N`` and ``N ln(RSS_w/N) + 2p``.
    settings : OeSettings
    warnings : tuple of str
    residuals : dict[str, ndarray]
        Per channel: measured minus fitted (block means when the record was averaged),
        before any whitening.
    quantum : dict[str, float]
        Each channel whose quantiser's error along the record is in ``cov``: its step (one code).
    """

    params: np.ndarray
    param_names: tuple[str, ...]
    cov: np.ndarray
    velocity_num: np.ndarray
    velocity_den: np.ndarray
    dc_gain: float
    time_constant_s: float
    poles: np.ndarray
    zeros: np.ndarray
    delay_s: float | None
    position_scale: float | None
    current_num: np.ndarray | None
    std: dict[str, float]
    ci95: dict[str, tuple[float, float]]
    residual_rms: dict[str, float]
    sigma: dict[str, float]
    n_samples: int
    nfev: int
    cost: float
    bic: float
    aic: float
    settings: OeSettings
    warnings: tuple[str, ...] = field(default=())
    residuals: dict[str, np.ndarray] = field(default_factory=dict)
    shifts: dict[str, float] = field(default_factory=dict)
    quantum: dict[str, float] = field(default_factory=dict)


def _block_mean(x: np.ndarray, ratio: int, *, from_end: bool = False) -> np.ndarray:
    """Means of consecutive blocks of ``ratio`` samples.

    A partial block is dropped: at the start of ``x`` when ``from_end``.
    """
    if ratio == 1:
        return x
    m = x.size // ratio
    x = x[x.size - m * ratio :] if from_end else x[: m * ratio]
    return x.reshape(m, ratio).mean(axis=1)


def ar_noise_model(residual: np.ndarray, max_order: int = 12) -> tuple[np.ndarray, float]:
    """Autoregressive model of a residual series, order by BIC (Yule–Walker).

    Parameters
    ----------
    residual : ndarray
        Residuals of a preliminary fit (one channel).
    max_order : int
        Highest order tried.

    Returns
    -------
    (ndarray, float)
        The whitening polynomial ``[1, a_1, …, a_p]`` (``e_k + Σ a_i e_{k−i}`` is white) and
        the innovation standard deviation.  Order 0 (``[1.0]``) for white residuals.

    Notes
    -----
    A few lines of Levinson–Durbin (``scipy.linalg.solve_toeplitz``) instead of an
    econometrics dependency: only the polynomial and its innovation variance are needed.
    """
    x = np.asarray(residual, dtype=float)
    x = x - x.mean()
    n = x.size
    top = int(min(max_order, max(0, n // 10)))
    acov = np.array([x[: n - k] @ x[k:] / n for k in range(top + 1)])
    best = (bic({"residual": n}, {"residual": float(acov[0])}, 0), np.array([1.0]), float(acov[0]))
    for p in range(1, top + 1):
        phi = scipy.linalg.solve_toeplitz(acov[:p], acov[1 : p + 1])
        var = float(acov[0] - phi @ acov[1 : p + 1])
        if not np.isfinite(var) or var <= 0:
            break
        score = bic({"residual": n}, {"residual": var}, p)  # the AR order by the same criterion
        if score < best[0]:
            best = (score, np.r_[1.0, -phi], var)
    return best[1], float(np.sqrt(best[2]))


def _vel_num(k: float, tz: np.ndarray) -> np.ndarray:
    """``K·Π(Tz_j s + 1)``, highest power first (np.polymul's result, without its poly1d round trips)."""
    num = np.array([k], dtype=float)
    if k == 0:
        return num
    for z in tz:
        if z != 0:  # (0·s + 1) = 1: np.polymul drops the leading zero too
            num = np.convolve(num, [z, 1.0])
    return num


class _Layout:
    """Where each parameter sits in the vector."""

    def __init__(self, settings: OeSettings, channels: Sequence[str], *, wrapped: bool = False) -> None:
        n, m = settings.n_poles, settings.n_zeros
        names = ["K"] + [f"log_tau_{i}" for i in range(n)] + [f"Tz_{j}" for j in range(m)]
        if settings.delay:
            names.append("delay")
        # without a velocity capture the velocity is the position's derivative (position volts
        # per second): c = 1, not a parameter (K and c would only be known as a product)
        if "position" in channels and "velocity" in channels:
            names.append("c")
        direct = settings.current_direct if settings.current_direct is not None else n == 1
        self.n_current = n + 1 if direct else n
        #: a current that jumps at the step carries no timing information (its sample at
        #: the edge is left out of every fit): no shift for it
        self.current_jumps = direct and "current" in channels
        if "current" in channels:
            names += [f"cur_{j}" for j in range(self.n_current)]  # current numerator, highest power first
        # each channel's pre-step level is a nuisance parameter: subtracting the mean of the
        # pre-step samples instead would add its error to every sample (and, read off a
        # quantised noise-free record, up to half an LSB that shifts the position ramp)
        names += [f"off_{c}" for c in channels]
        # a capture whose step instant was read off its own response (no input channel) is
        # known to a sample at best: its time shift is a nuisance parameter, or the read-off's
        # error would leak into τ.  The channels of one acquisition share one shift.
        self.shift_of = self._shift_params(settings, channels)
        self.shifted = list(dict.fromkeys(self.shift_of.values()))
        names += [f"shift_{c}" for c in self.shifted]
        # separately sampled captures: phases relative to each other (the last one is minus the
        # sum of the others)
        timed = [c for c in channels if not (c == "current" and self.current_jumps)]
        self.phased = [c for c in settings.phase_group if c in timed and c not in self.shift_of]
        if len(self.phased) < 2:
            self.phased = []
        names += [f"phase_{c}" for c in self.phased[:-1]]
        if wrapped and "position" in channels:
            names.append("span_position")
        self.names = tuple(names)
        self.channels = tuple(channels)
        self.n, self.m = n, m
        self.idx = {nm: i for i, nm in enumerate(names)}

    def _phases(self, th: np.ndarray) -> dict[str, float]:
        """Each phased channel's shift (the last is minus the sum of the others)."""
        if not self.phased:
            return {}
        free = {c: float(th[self.idx[f"phase_{c}"]]) for c in self.phased[:-1]}
        return {**free, self.phased[-1]: -sum(free.values())}

    def _shift_params(self, settings: OeSettings, channels: Sequence[str]) -> dict[str, str]:
        """Channel → the channel whose ``shift_`` parameter it uses."""
        if not settings.shifts:
            return {}
        timed = [c for c in channels if not (c == "current" and self.current_jumps)]
        groups: list[tuple[str, ...]]
        if settings.shift_groups is None:
            groups = [(c,) for c in channels]
        else:
            groups = [tuple(c for c in g if c in channels) for g in settings.shift_groups]
        groups = [tuple(c for c in g if c in timed) for g in groups]
        groups = [g for g in groups if g]
        free = {c for g in groups for c in g}
        if settings.delay and groups and all(c in free for c in timed):
            # no channel has a fixed step instant: the first group's shift is the delay (the others'
            # are relative to it)
            groups = groups[1:]
        return {c: g[0] for g in groups for c in g}

    def unpack(self, th: np.ndarray) -> dict[str, Any]:
        n, m = self.n, self.m
        out = {
            "K": th[0],
            "taus": np.exp(th[1 : 1 + n]),
            "tz": th[1 + n : 1 + n + m],
            "delay": th[self.idx["delay"]] if "delay" in self.idx else 0.0,
            "c": th[self.idx["c"]] if "c" in self.idx else (1.0 if "position" in self.channels else None),
            "off": {k[4:]: th[i] for k, i in self.idx.items() if k.startswith("off_")},
            "shift": {**{c: th[self.idx[f"shift_{g}"]] for c, g in self.shift_of.items()}, **self._phases(th)},
            "cur": th[self.idx["cur_0"] : self.idx["cur_0"] + self.n_current] if "cur_0" in self.idx else None,
        }
        return out


def _channel_bases(q: Mapping[str, Any], t: np.ndarray | Mapping[str, np.ndarray], channels: Sequence[str],
                   block: Mapping[str, tuple[int, float]] | None, poles: np.ndarray,
                   windows: Mapping[str, float] | None = None) -> dict[str, ResponseBasis | WindowBasis]:
    """Each channel's exponentials on its grid, from the step as the dead time and its shift place it.

    A channel of ``windows`` (a counted speed) gets the means over its window instead of samples.
    """
    out: dict[str, ResponseBasis | WindowBasis] = {}
    for ch in channels:
        times = (t[ch] if isinstance(t, Mapping) else t) - q["delay"] - q["shift"].get(ch, 0.0)
        window = (windows or {}).get(ch, 0.0)
        out[ch] = (WindowBasis(times, poles, window, (block or {}).get(ch)) if window > 0
                   else ResponseBasis(times, poles, (block or {}).get(ch)))
    return out


def _predict(
    layout: _Layout, th: np.ndarray, t: np.ndarray | Mapping[str, np.ndarray], step: float, channels: Sequence[str],
    block: Mapping[str, tuple[int, float]] | None = None,
    bases: Mapping[str, ResponseBasis | WindowBasis] | None = None, windows: Mapping[str, float] | None = None,
) -> dict[str, np.ndarray]:
    """Every channel's response, on ``bases`` (the grids' exponentials for these parameters) when given."""
    q = layout.unpack(th)
    num = _vel_num(q["K"], q["tz"])
    out = {}
    pf = PartialFractions(q["taus"])
    if bases is None:
        bases = _channel_bases(q, t, channels, block, pf.p, windows)
    _, r, n0 = pf.residues(num)
    if "velocity" in channels:
        out["velocity"] = step * bases["velocity"].step(r, n0)
    if "position" in channels:
        # only a velocity is windowed (OeSettings.windows), so a position's basis samples
        out["position"] = q["c"] * (step * cast(ResponseBasis, bases["position"]).position(r, n0))
    if "current" in channels:
        _, rc, nc0 = pf.residues(q["cur"])
        out["current"] = step * bases["current"].step(rc, nc0)
    return {c: y + q["off"].get(c, 0.0) for c, y in out.items()}


#: The fraction of the final change that defines the 63 % time: ``1 − e⁻¹``.
FRACTION_63 = 1.0 - np.exp(-1.0)


def step_63_time(num: ArrayLike, taus: ArrayLike, delay_s: float = 0.0) -> float:
    """Seconds from the step until ``N(s)/Π(1 + τ_i s)·e^{−s·delay}`` first reaches 63.2 % of its final change.

    The classic read-off of a step response, here of the model: the "time constant" a student
    reads off the scope, which for more than one pole (or a dead time) is not the mean residence
    time ``Στ_i − ΣTz_j + delay``.

    Parameters
    ----------
    num : array_like
        Numerator ``N(s)``, highest power first.
    taus : array_like
        Time constants of the denominator.
    delay_s : float
        Dead time.

    Returns
    -------
    float
        The 63 % time (s); NaN for a zero DC gain or a response that never gets there.
    """
    taus = separate(np.asarray(taus, dtype=float))
    num = np.atleast_1d(np.asarray(num, dtype=float))
    k = float(num[-1])
    if k == 0 or not np.all(np.isfinite(taus)) or taus.size == 0:
        return float("nan")
    horizon = 10.0 * max(float(np.sum(np.abs(taus))), float(np.max(np.abs(taus))))
    t = np.linspace(0.0, horizon, 1001)
    y = step_response_closed_form(t, num, taus, 1.0) / k
    above = np.flatnonzero(y >= FRACTION_63)
    if above.size == 0 or above[0] == 0:
        return float("nan")
    i = int(above[0])

    def gap(x: float) -> float:
        return float(step_response_closed_form(np.array([x]), num, taus, 1.0)[0] / k - FRACTION_63)

    return float(scipy.optimize.brentq(gap, t[i - 1], t[i], xtol=1e-12 * horizon)) + float(delay_s)


def _derived(layout: _Layout, th: np.ndarray, *, t63: bool = True) -> dict[str, float]:
    """The quantities reported from a parameter vector (``t63``: with the 63 % time, a root search)."""
    q = layout.unpack(th)
    taus = np.sort(q["taus"])[::-1]
    d = {"dc_gain": float(q["K"]), "time_constant": float(np.sum(q["taus"]) - np.sum(q["tz"]))}
    d["residence_time"] = d["time_constant"] + float(q["delay"])
    if t63:
        d["t63"] = step_63_time(_vel_num(q["K"], q["tz"]), q["taus"], float(q["delay"]))
    for i, tau in enumerate(taus):
        d[f"pole_{i}"] = float(-1.0 / tau)
    # neighbouring poles as a pair: two nearly equal poles are known as a pair (their sum and
    # product: natural frequency and damping) long before each one is
    for i in range(taus.size - 1):
        wn = float(1.0 / np.sqrt(taus[i] * taus[i + 1]))
        d[f"pair_{i}_wn"] = wn
        d[f"pair_{i}_zeta"] = float(0.5 * (1.0 / taus[i] + 1.0 / taus[i + 1]) / wn)
    tz = [z for z in q["tz"] if abs(z) > 1e-12]
    for j, z in enumerate(sorted(tz, key=abs, reverse=True)):
        d[f"zero_{j}"] = float(-1.0 / z)
    if "delay" in layout.idx:
        d["delay"] = float(q["delay"])
    for c, value in q["shift"].items():
        d[f"shift_{c}"] = float(value)
    return d


def output_error_fit(
    time_s: np.ndarray | Mapping[str, np.ndarray],
    step_volts: float,
    channels: Mapping[str, np.ndarray],
    sigma: Mapping[str, float],
    init_taus: Sequence[float],
    init_dc_gain: float,
    settings: OeSettings = OeSettings(),
    *,
    init_zeros: Sequence[float] = (),
    init_delay_s: float = 0.0,
    pre: Mapping[str, np.ndarray] | None = None,
    step_std: float = 0.0,
    level_rel_std: float = 0.0,
    block: Mapping[str, int] | None = None,
    whiten: Mapping[str, np.ndarray] | None = None,
    pre_sigma: Mapping[str, float] | None = None,
    wrap_count: Mapping[str, np.ndarray] | None = None,
    give_up: tuple[int, float] | None = None,
) -> OeResult:
    """Fit the velocity TF (and the position scale, the current numerator) to step responses.

    Parameters
    ----------
    time_s : ndarray or Mapping[str, ndarray]
        Time from the step (t ≥ 0): one grid for every channel, or each channel's own (so
        that every capture contributes all the samples it recorded after its step).
    step_volts : float
        Step level.
    channels : Mapping[str, ndarray]
        Measured increments: ``velocity`` and/or ``position`` (required), ``current``.
    sigma : Mapping[str, float]
        Noise standard deviation of each channel (weights).
    init_taus, init_dc_gain, init_zeros :
        Starting point (from a paper method).
    init_delay_s : float
        Starting delay (with ``settings.delay``): the dead time read off the data.  From 0
        the fit cannot find a dead time: before the response starts its slope, hence the
        delay's gradient, is zero.
    settings : OeSettings
        Structure.
    pre : Mapping[str, ndarray], optional
        Samples of each channel before the step (same baseline convention): they pin the
        channel's offset, fitted with everything else.
    step_std : float
        Standard error of ``step_volts`` (it is measured on the noisy input channel): every
        gain scales with ``1/step``, so ``(K·step_std/step)²`` adds to the DC gain's variance.
    level_rel_std : float
        Relative systematic error of the velocity's recorded change (a quantiser's error that
        the noise does not average out, :func:`~motorid.identification.stages.output_level_rel_std`):
        ``(K·level_rel_std)²`` adds to the DC gain's variance.
    block : Mapping[str, int], optional
        Fit block means of this many consecutive samples of a channel (and of its pre-step
        samples) instead of every sample: the model is evaluated on every recorded time and
        averaged the same way, so the averaging is exact even where the response jumps.
    whiten : Mapping[str, ndarray], optional
        AR polynomial ``[1, a_1, …, a_p]`` of a channel's noise (:func:`ar_noise_model`): its
        residuals are filtered by it before weighting (generalised least squares for
        coloured noise — tacho ripple, aliased PWM), and ``sigma`` is then the innovation
        standard deviation.
    pre_sigma : Mapping[str, float], optional
        Noise level of the pre-step samples (default ``sigma``; they are not filtered).
    wrap_count : Mapping[str, ndarray], optional
        ``position``: turns the unwrapping added to each sample after the step.  An encoder
        span estimated a little off leaves a step of ``wraps × error`` in the position; the
        error is fitted as a nuisance parameter ``span_position``.
    give_up : (int, float), optional
        ``(evaluations, bic)``: once the fit has made that many evaluations, it stops at the first
        iteration whose BIC is still at least ``bic`` (an order search's candidate that cannot
        come near the best; the warnings then start with :data:`GAVE_UP`).  Up to that point, and
        for a fit that gets there, the iterates are those of a fit without it.  Needs scipy ≥
        1.16 (the solver's ``callback``); ignored with an older scipy.

    Returns
    -------
    OeResult

    Raises
    ------
    IdentificationError
        Impossible structure, no velocity/position channel, too few samples.
    """
    n, m = settings.n_poles, settings.n_zeros
    if n < 1 or m < 0 or m >= n:
        raise IdentificationError(f"output-error structure needs 1 ≤ zeros + 1 ≤ poles, got {n} poles and {m} zeros")
    prob = _OeProblem.build(time_s, step_volts, channels, sigma, settings, pre=pre, block=block, whiten=whiten,
                            pre_sigma=pre_sigma, wrap_count=wrap_count)
    th0 = np.clip(prob.initial_parameters(init_taus, init_dc_gain, init_zeros, init_delay_s),
                  prob.lower + 1e-9, prob.upper - 1e-9)
    warnings: list[str] = []
    small = _Compressed(prob)
    extra = {}
    if give_up is not None and _SOLVER_CALLBACK:
        extra["callback"] = _GiveUp(give_up[0], give_up[1], prob.n_total, len(prob.layout.names))
    with np.errstate(over="ignore", invalid="ignore"):
        sol = scipy.optimize.least_squares(small.residuals, th0, jac=small.jacobian, bounds=(prob.lower, prob.upper),
                                           x_scale="jac", max_nfev=settings.max_nfev, method="trf",
                                           ftol=settings.tolerance, xtol=settings.tolerance, **extra)
    sol.fun, sol.jac = small.full(sol.x)
    if sol.status == -2 and give_up is not None:
        warnings.append(f"{GAVE_UP} after {sol.nfev} evaluations, its BIC still {give_up[1]:.4g} or more")
    elif not sol.success:
        warnings.append(f"{STOPPED_EARLY}: {sol.message}")
    return prob.result(sol, step_std, warnings, level_rel_std=level_rel_std)


#: The start of a fit's warning when it stopped on its ``give_up`` rule (:func:`output_error_fit`).
GAVE_UP = "output-error fit given up"

#: Whether scipy's least squares takes a ``callback`` (scipy 1.16).
_SOLVER_CALLBACK = "callback" in inspect.signature(scipy.optimize.least_squares).parameters


class _GiveUp:
    """The solver's callback of :func:`output_error_fit`'s ``give_up``: stop a fit still far above a BIC.

    scipy calls it after each iteration with the iterate's cost (half the sum of squares of the
    whitened residuals); raising ``StopIteration`` ends the fit there (status −2).
    """

    __slots__ = ("bic", "n_params", "n_samples", "nfev")

    def __init__(self, nfev: int, bic_limit: float, n_samples: int, n_params: int) -> None:
        self.nfev, self.bic, self.n_samples, self.n_params = nfev, bic_limit, n_samples, n_params

    def __call__(self, intermediate_result: Any) -> None:
        if int(intermediate_result.nfev) < self.nfev:
            return
        rss = 2.0 * float(intermediate_result.cost)
        if rss > 0 and bic({"r": self.n_samples}, {"r": rss / self.n_samples}, self.n_params) >= self.bic:
            raise StopIteration


class _Compressed:
    """The least-squares problem handed to scipy as ``n + 1`` rows with the same normal equations.

    scipy's ``trf`` takes an SVD of the Jacobian at every iteration: on three captures of 2000
    samples (6000 rows × a dozen parameters) that SVD alone was a third of a fit.  Each step
    of the method depends on the residuals ``f`` and the Jacobian ``J`` only through ``JᵀJ``,
    ``Jᵀf`` and ``‖f‖`` (the trust-region subproblem, the gradient, the predicted and actual
    reductions, the column scaling), so the fit is the same on the triangular factor ``R`` of
    ``[J f]`` (``RᵀR = [J f]ᵀ[J f]``): ``J̃ = R[:, :n]``, ``f̃ = R[:, n]``.  ``R`` comes from the
    Cholesky factor of the column-equilibrated Gram matrix (a few µs) when that is well
    conditioned, else from a QR decomposition (as accurate as the SVD).  scipy offers no such
    option (its ``lsmr`` solver is for large sparse problems), hence this class.

    ``f̃`` must agree with the Jacobian at the same point, so :meth:`residuals` computes both;
    the full ``f`` and ``J`` of the last points are kept for :meth:`full`.
    """

    __slots__ = ("_cache", "prob")

    #: Equilibrated Gram matrices whose Cholesky factor has a diagonal ratio under this are
    #: factorised by QR instead (their condition number squared would cost the step digits).
    MIN_PIVOT = 1e-6

    def __init__(self, prob: _OeProblem) -> None:
        self.prob = prob
        self._cache: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def _at(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        key = np.asarray(x, dtype=float).tobytes()
        hit = self._cache.get(key)
        if hit is None:
            f = self.prob.residuals(x)
            jac = self.prob.jacobian(x)
            hit = (f, jac, _triangular_factor(jac, f, self.MIN_PIVOT))
            if len(self._cache) >= 2:
                self._cache.pop(next(iter(self._cache)))
            self._cache[key] = hit
        return hit

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """``f̃``: the last column of the factor."""
        return self._at(x)[2][:, -1].copy()

    def jacobian(self, x: np.ndarray, *_: Any) -> np.ndarray:
        """``J̃``: the factor's other columns."""
        return self._at(x)[2][:, :-1].copy()

    def full(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The full residuals and Jacobian at ``x`` (for the covariance)."""
        f, jac, _ = self._at(x)
        return f, jac


class _Gain:
    """``(JᵀJ)⁺Jᵀ``, the parameters' response to a change of the residuals: formed once, when first asked for."""

    __slots__ = ("_inverse", "_jac", "_value")

    def __init__(self, inverse: np.ndarray, jac: np.ndarray) -> None:
        self._inverse, self._jac = inverse, jac
        self._value: np.ndarray | None = None

    def __call__(self) -> np.ndarray:
        if self._value is None:
            self._value = self._inverse @ self._jac.T
        return self._value


def _triangular_factor(jac: np.ndarray, f: np.ndarray, min_pivot: float) -> np.ndarray:
    """Upper-triangular ``R`` (``(n+1)×(n+1)``) with ``RᵀR = AᵀA`` for ``A = [jac f]``."""
    k = jac.shape[1] + 1
    gram = np.empty((k, k))
    gram[:-1, :-1] = jac.T @ jac
    gram[:-1, -1] = gram[-1, :-1] = jac.T @ f
    gram[-1, -1] = f @ f
    if not np.all(np.isfinite(gram)):
        # the optimiser handles a non-finite point (it shrinks the step): keep it non-finite
        return np.full((k, k), np.nan)
    d = np.sqrt(np.diag(gram))
    if np.all(d > 0):
        g = gram / np.outer(d, d)
        try:
            r = np.linalg.cholesky(g).T
        except np.linalg.LinAlgError:
            r = None
        if r is not None:
            piv = np.abs(np.diag(r))
            if piv[:-1].min() >= min_pivot * piv[:-1].max():
                return r * d[None, :]
    r = scipy.linalg.qr(np.column_stack([jac, f]), mode="r", check_finite=False)[0]
    out = np.zeros((k, k))
    rows = min(r.shape[0], k)
    out[:rows] = r[:rows]
    return out


#: Relative step of the central differences of the delta method (derived quantities).
DELTA_METHOD_STEP = 1e-6
#: Fisher information worse conditioned than this: the parameters are poorly determined.
MAX_FISHER_CONDITION = 1e14
#: Time constants are searched between these bounds (s).
TAU_BOUNDS_S = (1e-5, 1e3)
#: A dead time is searched up to this fraction of the longest record.
MAX_DELAY_FRACTION = 0.2
#: Per-capture timing shifts are searched within this many sample intervals (default bound).
SHIFT_BOUND_SAMPLES = 1.5


@dataclass(slots=True)
class _OeProblem:
    """The least-squares problem of :func:`output_error_fit`: data, weights and the model.

    Named steps: :meth:`build` (check and block-average the channels), :meth:`initial_parameters`,
    :meth:`residuals` / :meth:`jacobian` (what scipy's ``least_squares`` calls) and
    :meth:`result` (covariance, delta-method intervals, the :class:`OeResult`).
    """

    settings: OeSettings
    layout: _Layout
    names: list[str]
    step_volts: float
    tc: dict[str, np.ndarray]
    raw: dict[str, np.ndarray]
    data: dict[str, np.ndarray]
    ratio: dict[str, int]
    fast: dict[str, tuple[int, float]]
    wraps: np.ndarray | None
    #: Each channel's pre-step samples as their count, mean and spread ``√Σ(x − x̄)²``: their
    #: residuals against a fitted offset enter the fit as two rows with the same sum of squares,
    #: the same Jacobian product and the same gradient (``Σ(x − o)² = Σ(x − x̄)² + n(x̄ − o)²``)
    #: instead of one row per sample (a sixth of the rows of a three-capture fit).
    pre_stats: dict[str, tuple[int, float, float]]
    sigma: Mapping[str, float]
    w: dict[str, float]
    w_pre: dict[str, float]
    filt: dict[str, np.ndarray]
    n_total: int
    lower: np.ndarray
    upper: np.ndarray
    #: Each channel's quantiser step (one code) where its error enters the covariance
    #: (:meth:`_quantiser_covariance`); a channel not in it is not quantised (or not so counted).
    quantum: dict[str, float] = field(default_factory=dict)
    #: The last parameters' grid exponentials (the residuals and the Jacobian at one point share them).
    basis_key: bytes = b""
    basis: dict[str, ResponseBasis | WindowBasis] = field(default_factory=dict)

    @classmethod
    def build(cls, time_s: np.ndarray | Mapping[str, np.ndarray], step_volts: float,
              channels: Mapping[str, np.ndarray], sigma: Mapping[str, float], settings: OeSettings, *,
              pre: Mapping[str, np.ndarray] | None, block: Mapping[str, int] | None,
              whiten: Mapping[str, np.ndarray] | None, pre_sigma: Mapping[str, float] | None,
              wrap_count: Mapping[str, np.ndarray] | None,
              quantum: Mapping[str, float] | None = None) -> _OeProblem:
        """Check the channels, drop the current's edge sample, block-average, set weights and bounds.

        ``quantum``: each channel's quantiser step; by default each one's smallest change between
        samples (:func:`_detected_quantum`).
        """
        names = [c for c in ("velocity", "position", "current") if c in channels]
        if "velocity" not in names and "position" not in names:
            raise IdentificationError("the output-error fit needs a velocity or a position capture")
        for c, window in settings.windows:
            if c != "velocity" or not (math.isfinite(window) and window > 0):
                raise IdentificationError(f"only a velocity is fitted as means over a window > 0, got {c} {window!r}")
        tc = {c: np.asarray(time_s[c] if isinstance(time_s, Mapping) else time_s, dtype=float) for c in names}
        raw = {c: np.asarray(channels[c], dtype=float) for c in names}
        for c in names:
            if tc[c].shape != raw[c].shape:
                raise IdentificationError(f"{c}: {raw[c].size} samples on a grid of {tc[c].size} times")
        wraps = None
        if wrap_count is not None and "position" in wrap_count and "position" in names:
            wraps = np.asarray(wrap_count["position"], dtype=float)
            if wraps.shape != raw["position"].shape:
                raise IdentificationError(f"position: {wraps.size} wrap counts for {raw['position'].size} samples")
            if not np.any(wraps):
                wraps = None
        layout = _Layout(settings, names, wrapped=wraps is not None)
        if "current" in names:
            # the current's sample at the edge sees it mid-jump when the electrical pole is faster
            # than the sampling (how far depends on where the step fell between samples): leave it
            # out — for every structure, so that their fits (and BIC) see the same data
            first = tc["current"] > 0.5 * float(np.median(np.diff(tc["current"])))
            tc["current"], raw["current"] = tc["current"][first], raw["current"][first]
        ratio = {c: max(1, int((block or {}).get(c, 1))) for c in names}
        tc = {c: tc[c][: tc[c].size // ratio[c] * ratio[c]] for c in names}
        if wraps is not None:
            # the turns added to each fitted value: block means, as the data are
            wraps = _block_mean(wraps[: tc["position"].size], ratio["position"])
        data = {c: _block_mean(raw[c], ratio[c]) for c in names}
        n_par = len(layout.names)
        shortest = min(v.size for v in data.values())
        if shortest <= n_par + 2:
            raise IdentificationError(f"only {shortest} samples for {n_par} parameters: record more after the step")
        pre_data = {c: _block_mean(np.asarray(pre[c], dtype=float), ratio[c], from_end=True)
                    for c in names if pre is not None and c in pre and len(pre[c]) >= ratio[c]}
        n_total = sum(v.size for v in data.values()) + sum(v.size for v in pre_data.values())
        w = {c: 1.0 / max(float(sigma.get(c, 1.0)), 1e-12) for c in names}
        w_pre = {c: 1.0 / max(float((pre_sigma or sigma).get(c, 1.0)), 1e-12) for c in names}
        filt = {c: np.asarray(whiten[c], dtype=float) for c in names if whiten is not None and c in whiten
                and len(whiten[c]) > 1}
        lower, upper = _bounds(layout, settings, tc)
        # channels averaged over blocks of a uniform grid: their block means in closed form
        fast = {}
        for c in names:
            gaps = np.diff(tc[c])
            if ratio[c] > 1 and gaps.size and np.ptp(gaps) <= 1e-6 * float(np.mean(gaps)):
                fast[c] = (ratio[c], float(tc[c][-1] - tc[c][0]) / (tc[c].size - 1))
        pre_stats = {}
        for c, v in pre_data.items():
            mean = float(np.mean(v))
            pre_stats[c] = (v.size, mean, float(np.linalg.norm(v - mean)))
        if quantum is None:
            # not: block means, counted speeds (the count's quantum differenced, not a rounded value),
            # a position that wraps (each turn moves it on the code grid)
            counted = {*dict(settings.windows), *settings.differenced}
            quantum = {c: _detected_quantum(raw[c], float(sigma.get(c, 1.0))) for c in names
                       if ratio[c] == 1 and c not in counted and not (c == "position" and wraps is not None)}
        return cls(settings, layout, names, step_volts, tc, raw, data, ratio, fast, wraps, pre_stats, sigma,
                   w, w_pre, filt, n_total, lower, upper, quantum={c: q for c, q in quantum.items() if q > 0})

    def initial_parameters(self, init_taus: Sequence[float], init_dc_gain: float, init_zeros: Sequence[float],
                           init_delay_s: float) -> np.ndarray:
        """The starting point: a paper method's gain, poles and zeros; the rest by least squares."""
        n, m = self.settings.n_poles, self.settings.n_zeros
        tc, raw, names, step_volts = self.tc, self.raw, self.names, self.step_volts
        taus0 = list(init_taus)[:n]
        while len(taus0) < n:
            taus0.append((taus0[-1] if taus0 else 0.3) / 8.0)
        tz0 = list(init_zeros)[:m] + [0.5 * taus0[min(1, n - 1)]] * (m - len(list(init_zeros)[:m]))
        th0_list = [init_dc_gain, *list(np.log(np.maximum(taus0, 1e-06))), *list(tz0)]
        if self.settings.delay:
            th0_list.append(max(float(init_delay_s), 0.0))
        if "c" in self.layout.idx:
            # c by least squares given the initial velocity model
            base = position_closed_form(tc["position"], _vel_num(init_dc_gain, np.array(tz0)), taus0, step_volts)
            c0 = float(base @ raw["position"][: base.size] / max(base @ base, 1e-300))
            th0_list.append(c0 if np.isfinite(c0) and c0 != 0 else 1.0)
        if "current" in names:
            # current numerator: linear least squares on the responses of s^j/D(s)
            nc = self.layout.n_current
            cols = [step_response_closed_form(tc["current"], np.r_[1.0, np.zeros(nc - 1 - j)], taus0, step_volts)
                    for j in range(nc)]
            a = np.column_stack(cols)
            coef, *_ = np.linalg.lstsq(a, raw["current"][: a.shape[0]], rcond=None)
            th0_list += list(coef)
        th0_list += [self.pre_stats[c][1] if c in self.pre_stats else 0.0 for c in names]
        th0_list += [0.0] * (len(self.layout.shifted) + max(len(self.layout.phased) - 1, 0))
        if self.wraps is not None:
            th0_list.append(0.0)
        return np.asarray(th0_list, dtype=float)

    def _white(self, c: str, e: np.ndarray, into: np.ndarray | None = None) -> np.ndarray:
        """The channel's FIR whitening from rest, along axis 0 (residuals or Jacobian columns).

        A vector goes through np.convolve; a matrix as one shifted sum per filter tap over all
        its columns at once (lfilter filters column by column through apply_along_axis: twice
        the time for the dozen columns of a Jacobian), written into ``into`` when given (a
        matrix of ``e``'s shape, not ``e`` itself).
        """
        if c not in self.filt:
            if into is None:
                return e
            into[...] = e
            return into
        f = self.filt[c]
        if e.ndim == 1 and into is None:
            return np.convolve(e, f)[: e.size]
        out = np.multiply(f[0], e, out=into)
        for k in range(1, min(f.size, e.shape[0])):
            out[k:] += f[k] * e[:-k]
        return out

    def _grid(self, tc: Mapping[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
        """Each channel's sample times (``tc`` or its own), or its blocks' first times where :attr:`fast`."""
        tc = self.tc if tc is None else tc
        return {c: tc[c][:: self.ratio[c]] if c in self.fast else tc[c] for c in self.names}

    def predict(self, th: np.ndarray, tc: Mapping[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
        """Every channel's model response for the parameters ``th``, block means as fitted.

        On the sample times ``tc`` (default: the channels' own).
        """
        pred = _predict(self.layout, th, self._grid(tc), self.step_volts, self.names, self.fast,
                        bases=self.bases(th) if tc is None else None, windows=dict(self.settings.windows))
        pred = {c: v if c in self.fast else _block_mean(v, self.ratio[c]) for c, v in pred.items()}
        if self.wraps is not None:
            pred["position"] = pred["position"] + th[self.layout.idx["span_position"]] * self.wraps
        return pred

    def residuals(self, th: np.ndarray, tc: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
        """Whitened, weighted residuals of every channel and of the pre-step samples."""
        pred = self.predict(th, tc)
        idx = self.layout.idx
        parts = [self._white(c, self.data[c] - pred[c]) * self.w[c] for c in self.names]
        parts += [np.array([np.sqrt(k) * (mean - th[idx[f"off_{c}"]]), spread]) * self.w_pre[c]
                  for c, (k, mean, spread) in self.pre_stats.items()]
        return np.concatenate(parts)

    def bases(self, th: np.ndarray) -> dict[str, ResponseBasis | WindowBasis]:
        """Each channel's :class:`ResponseBasis` on its own grid for the parameters ``th`` (the last one kept)."""
        key = np.asarray(th, dtype=float).tobytes()
        if key != self.basis_key:
            q = self.layout.unpack(th)
            self.basis = _channel_bases(q, self._grid(), self.names, self.fast, PartialFractions(q["taus"]).p,
                                        dict(self.settings.windows))
            self.basis_key = key
        return self.basis

    def jacobian(self, th: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`residuals`.

        Analytic: the gain, scale, current numerator, offsets, shifts, delay and span error enter
        the responses linearly or as a time shift; the time constants and zeros through the closed
        forms' own derivatives (:meth:`~motorid.identification.closed_form.ResponseBasis.shape`).
        """
        layout, names, u, fast = self.layout, self.names, self.step_volts, self.fast
        tc = self._grid()
        n, m = self.settings.n_poles, self.settings.n_zeros
        n_par = len(layout.names)
        q = layout.unpack(th)
        pf = PartialFractions(q["taus"])  # every numerator's residues below on the same time constants
        num1 = _vel_num(1.0, q["tz"])
        _, r1, n01 = pf.residues(num1)
        # one basis per channel: every column below is a product with it (the residuals' own)
        basis = self.bases(th)
        d = {c: np.zeros((tc[c].size, n_par)) for c in names}
        slope: dict[str, np.ndarray] = {}
        shape = [layout.idx[f"log_tau_{i}"] for i in range(n)] + [layout.idx[f"Tz_{j}"] for j in range(m)]
        num = _vel_num(q["K"], q["tz"])
        dnums = [np.append(_vel_num(q["K"], np.delete(q["tz"], j)), 0.0) for j in range(m)]  # · s
        if "velocity" in names:
            bv = basis["velocity"]
            d["velocity"][:, 0] = u * bv.step(r1, n01)
            slope["velocity"] = q["K"] * u * bv.slope(r1, n01)
            d["velocity"][:, shape] = u * bv.shape("step", num, pf, dnums)
        if "position" in names:
            bp = cast(ResponseBasis, basis["position"])  # only a velocity is windowed
            p1 = u * bp.position(r1, n01)
            d["position"][:, 0] = q["c"] * p1
            if "c" in layout.idx:
                d["position"][:, layout.idx["c"]] = q["K"] * p1
            slope["position"] = q["c"] * q["K"] * u * bp.step(r1, n01)
            d["position"][:, shape] = q["c"] * u * bp.shape("position", num, pf, dnums)
        if "current" in names:
            bc = basis["current"]
            nc = layout.n_current
            unit = [pf.residues(np.eye(nc)[j]) for j in range(nc)]  # the responses of s^k/D(s)
            r_unit = np.column_stack([x[1] for x in unit])
            cols = [layout.idx[f"cur_{j}"] for j in range(nc)]
            d["current"][:, cols] = u * bc.step(r_unit, np.array([x[2] for x in unit]))
            slope["current"] = u * bc.slope(r_unit @ q["cur"])
            d["current"][:, shape[:n]] = u * bc.shape("step", q["cur"], pf)
        for c in names:
            d[c][:, layout.idx[f"off_{c}"]] = 1.0
            if c in layout.shift_of:
                d[c][:, layout.idx[f"shift_{layout.shift_of[c]}"]] = -slope[c]
            if c in layout.phased[:-1]:
                d[c][:, layout.idx[f"phase_{c}"]] = -slope[c]
            elif layout.phased and c == layout.phased[-1]:
                for other in layout.phased[:-1]:
                    d[c][:, layout.idx[f"phase_{other}"]] = slope[c]
            if "delay" in layout.idx:
                d[c][:, layout.idx["delay"]] = -slope[c]
        blocks = {}
        for c in names:
            block = d[c] if self.ratio[c] == 1 or c in fast else d[c].reshape(-1, self.ratio[c], n_par).mean(axis=1)
            if c == "position" and self.wraps is not None:
                block[:, layout.idx["span_position"]] = self.wraps
            blocks[c] = block
        # each channel's whitened, weighted rows written into their place (no stack of copies)
        out = np.zeros((sum(b.shape[0] for b in blocks.values()) + 2 * len(self.pre_stats), n_par))
        start = 0
        for c, block in blocks.items():
            rows = out[start : start + block.shape[0]]
            self._white(c, block, into=rows)
            np.multiply(-self.w[c], rows, out=rows)
            start += block.shape[0]
        for c, (k, _, _) in self.pre_stats.items():
            out[start, layout.idx[f"off_{c}"]] = -np.sqrt(k) * self.w_pre[c]
            start += 2
        return out

    def _instant_covariance(self, th: np.ndarray, gain: _Gain) -> np.ndarray:
        """Parameter covariance from step instants known only to within their sample interval.

        A channel's instant off by ``δ`` moves its residuals by ``j·δ`` (``j``: their derivative in
        the instant, central differences); least squares then moves the parameters by
        ``−(JᵀJ)⁻¹Jᵀj·δ``, of variance ``(JᵀJ)⁻¹Jᵀj jᵀJ(JᵀJ)⁻¹·σ_δ²``.  ``gain()``: ``(JᵀJ)⁺Jᵀ``
        (asked for only when an instant is uncertain).
        """
        cov = np.zeros((th.size, th.size))
        present = [(c, sd) for c, sd in self.settings.instant_std if c in self.names and sd > 0]
        phased = set(self.layout.phased)
        # phases fitted relative to each other: only their common part is unknown, the mean of
        # n independent instants (dt/√(12·n))
        common = [(c, sd) for c, sd in present if c in phased]
        moves: list[tuple[tuple[str, ...], float]] = []
        alone = [(c, sd) for c, sd in present if c not in phased]
        for shared in self.settings.instant_shared:  # one stamp for the columns of one log
            members = [(c, sd) for c, sd in alone if c in shared]
            if members:
                moves.append((tuple(c for c, _ in members), members[0][1]))
        grouped = {c for chans, _ in moves for c in chans}
        moves += [((c,), sd) for c, sd in alone if c not in grouped]
        if common:
            moves.append((tuple(c for c, _ in common),
                          float(np.sqrt(np.mean([sd**2 for _, sd in common]) / len(common)))))
        for chans, sd in moves:
            h = 0.01 * sd
            up, down = dict(self.tc), dict(self.tc)
            for c in chans:
                up[c], down[c] = self.tc[c] + h, self.tc[c] - h
            col = (self.residuals(th, up) - self.residuals(th, down)) / (2 * h)
            g = gain() @ col
            cov += np.outer(g, g) * sd**2
        return cov

    def _quantiser_covariance(self, th: np.ndarray, gain: np.ndarray, dither_rms: Mapping[str, float],
                              pred: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
        """Parameter covariance from each quantised channel's sawtooth error along its fitted signal.

        :mod:`motorid.identification.quantiser`: each harmonic of the code grid, at an unknown
        phase, moves the parameters by ``gain·b`` (``b``: its cosine or sine on the channel's rows,
        whitened and weighted as the residuals; its pre-step level's row too), with the harmonic's
        variance for the channel's dither.  ``pred``: :meth:`predict` at ``th`` when at hand.
        """
        cov = np.zeros((th.size, th.size))
        if not self.quantum:
            return cov
        pred = self.predict(th) if pred is None else pred
        start, starts = 0, {}
        for c in self.names:
            starts[c] = start
            start += self.data[c].size
        pre_row = {c: start + 2 * i for i, c in enumerate(self.pre_stats)}
        for c, q in self.quantum.items():
            var = harmonic_variances(q, dither_rms.get(c, 0.0))
            var = np.repeat(var[var >= MIN_HARMONIC_SHARE * var[0]], 2)  # the harmonics that count
            count = var.size // 2
            rows = self._white(c, sawtooth_basis(pred[c], q, count)) * self.w[c]
            g = gain[:, starts[c] : starts[c] + rows.shape[0]] @ rows
            if c in self.pre_stats:
                # the level before the step: its samples' mean row, at the fitted offset
                level = sawtooth_basis(np.array([th[self.layout.idx[f"off_{c}"]]]), q, count)[0]
                g = g + np.outer(gain[:, pre_row[c]], np.sqrt(self.pre_stats[c][0]) * self.w_pre[c] * level)
            cov += (g * var) @ g.T
        return cov

    def result(self, sol: Any, step_std: float, warnings: list[str], *, level_rel_std: float = 0.0) -> OeResult:
        """Covariance (Gauss–Newton, scaled by the residual variance), delta-method intervals."""
        layout, names, n = self.layout, self.names, self.settings.n_poles
        n_par = len(layout.names)
        n_total = self.n_total
        th = sol.x
        r = sol.fun
        rss = float(r @ r)
        dof = max(n_total - n_par, 1)
        s2 = rss / dof
        jac_m = sol.jac
        jtj = jac_m.T @ jac_m
        cond = np.linalg.cond(jtj) if np.all(np.isfinite(jtj)) else np.inf
        if not np.isfinite(cond) or cond > MAX_FISHER_CONDITION:
            warnings.append(f"parameters poorly determined (Fisher information condition number {cond:.2g}): "
                            "a lower order may do")
        pred = self.predict(th)
        resid = {c: self.data[c] - pred[c] for c in names}  # before any whitening
        inverse = np.linalg.pinv(jtj)
        gain = _Gain(inverse, jac_m)
        cov = inverse * s2 + self._instant_covariance(th, gain)
        if self.quantum:
            # the dither: what the residuals hold besides the quantiser's own q²/12
            dither = {c: math.sqrt(max(float(np.var(resid[c])) - q * q / 12.0, 0.0))
                      for c, q in self.quantum.items()}
            cov = cov + self._quantiser_covariance(th, gain(), dither, pred)
            if "velocity" in self.quantum:
                level_rel_std = 0.0  # the velocity's levels are in it (their quantiser error)
        d0, std, ci = _delta_method(layout, th, cov, float(np.hypot(step_std / self.step_volts, level_rel_std)))
        q = layout.unpack(th)
        num = _vel_num(q["K"], q["tz"])
        den = np.array([1.0])
        for tau in q["taus"]:
            den = np.polymul(den, [tau, 1.0])
        lead = den[0]
        return OeResult(
            params=th, param_names=layout.names, cov=cov,
            velocity_num=num / lead, velocity_den=den / lead,
            dc_gain=d0["dc_gain"], time_constant_s=d0["time_constant"],
            poles=np.array([d0[f"pole_{i}"] for i in range(n)], dtype=complex),
            zeros=np.array([d0[k] for k in d0 if k.startswith("zero_")], dtype=complex),
            delay_s=float(q["delay"]) if self.settings.delay else None,
            position_scale=None if q["c"] is None else float(q["c"]),
            current_num=None if q["cur"] is None else np.asarray(q["cur"], dtype=float) / lead,
            std=std, ci95=ci,
            residual_rms={c: float(np.sqrt(np.mean(resid[c] ** 2))) for c in names},
            sigma={c: float(self.sigma.get(c, 1.0)) for c in names},
            n_samples=n_total, nfev=int(sol.nfev), cost=0.5 * rss,
            bic=bic({"whitened residuals": n_total}, {"whitened residuals": rss / n_total}, n_par),
            aic=n_total * np.log(rss / n_total) + 2 * n_par,
            settings=self.settings, warnings=tuple(warnings),
            residuals=resid,
            shifts={c: float(v) for c, v in q["shift"].items()},
            quantum=dict(self.quantum),
        )


#: A quantiser step under this fraction of a channel's noise level is not counted: its error is
#: under 1/300 of the noise.
NEGLIGIBLE_QUANTUM = 0.01
#: The quantiser's harmonics whose variance is under this share of the first's are left out of
#: the covariance: with a ripple's dither (variances as ``1/k³``) the first four hold 98 %.
MIN_HARMONIC_SHARE = 0.01


def _detected_quantum(y: np.ndarray, sigma: float) -> float:
    """A channel's quantiser step: its smallest change between samples (0 when negligible).

    Changes of a quarter of the trace's range or more (the step itself) are not a code.
    """
    y = np.asarray(y, dtype=float)
    if y.size < 2:
        return 0.0
    q = quantisation_step(y, below=0.25 * float(np.ptp(y)))
    return q if q >= NEGLIGIBLE_QUANTUM * sigma else 0.0


def _bounds(layout: _Layout, settings: OeSettings, tc: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the parameters: time constants, the dead time and the per-capture shifts."""
    n_par = len(layout.names)
    n = settings.n_poles
    lower = np.full(n_par, -np.inf)
    upper = np.full(n_par, np.inf)
    lower[1 : 1 + n] = np.log(TAU_BOUNDS_S[0])
    upper[1 : 1 + n] = np.log(TAU_BOUNDS_S[1])
    if settings.delay:
        lower[layout.idx["delay"]] = 0.0
        upper[layout.idx["delay"]] = MAX_DELAY_FRACTION * max(float(v[-1]) for v in tc.values())
    if settings.shifts:
        bound = settings.shift_bound_s
        if bound is None:
            bound = SHIFT_BOUND_SAMPLES * max(float(np.median(np.diff(v))) for v in tc.values())
        for c in layout.shifted:
            lower[layout.idx[f"shift_{c}"]] = -bound
            upper[layout.idx[f"shift_{c}"]] = bound
        for c in layout.phased[:-1]:
            lower[layout.idx[f"phase_{c}"]] = -bound
            upper[layout.idx[f"phase_{c}"]] = bound
    return lower, upper


def _delta_method(layout: _Layout, th: np.ndarray, cov: np.ndarray, step_rel_std: float,
                  ) -> tuple[dict[str, float], dict[str, float], dict[str, tuple[float, float]]]:
    """Derived quantities (gain, τ, poles, zeros...) with standard errors and 95 % intervals.

    Central differences of :func:`_derived` give the gradients; the measured step level's
    relative error adds ``(K·σ_u/u)²`` to the DC gain's variance (every gain scales with 1/u), and
    so does the velocity level's (``step_rel_std`` holds both, in quadrature).
    """
    n_par = th.size
    d0 = _derived(layout, th)
    keys = list(d0)
    grads = np.zeros((len(keys), n_par))
    # offsets, the position's scale, the current's numerator and the span error enter none of them
    moving = [i for i, nm in enumerate(layout.names) if nm == "K" or nm == "delay"
              or nm.startswith(("log_tau_", "Tz_", "shift_", "phase_"))]
    for i in moving:
        h = DELTA_METHOD_STEP * max(abs(th[i]), 1e-3)
        tp, tm = th.copy(), th.copy()
        tp[i] += h
        tm[i] -= h
        dp, dm = _derived(layout, tp, t63=False), _derived(layout, tm, t63=False)
        grads[:, i] = [(dp.get(k, d0[k]) - dm.get(k, d0[k])) / (2 * h) for k in keys]
    grads[keys.index("t63")] = _t63_gradient(layout, th, d0["t63"])
    var = np.einsum("ij,jk,ik->i", grads, cov, grads)
    # the step level is measured, not known: its error scales the fitted gain
    var[keys.index("dc_gain")] += (d0["dc_gain"] * step_rel_std) ** 2
    std = {k: float(np.sqrt(max(v, 0.0))) for k, v in zip(keys, var, strict=False)}
    ci = {k: (d0[k] - 1.96 * std[k], d0[k] + 1.96 * std[k]) for k in keys}
    return d0, std, ci


def _t63_gradient(layout: _Layout, th: np.ndarray, t63: float) -> np.ndarray:
    """Gradient of the 63 % time in the parameters, by the implicit function theorem.

    ``t63`` solves ``g(t, θ) = y(t − delay; θ)/K − 0.632 = 0``, so ``∂t63/∂θ = −(∂g/∂θ)/(∂g/∂t)``:
    central differences of the normalised response at the one instant found (no root search
    per perturbed parameter, which cost a fit's uncertainty 2·n root searches); the dead time
    moves it one for one, the gain not at all.
    """
    grad = np.zeros(th.size)
    q = layout.unpack(th)
    if not np.isfinite(t63):
        return np.full(th.size, np.nan)
    at = np.array([t63 - float(q["delay"])])

    def level(x: np.ndarray) -> float:
        qx = layout.unpack(x)
        return float(step_response_closed_form(at, _vel_num(1.0, qx["tz"]), separate(qx["taus"]), 1.0)[0])

    slope = float(slope_closed_form(at, _vel_num(1.0, q["tz"]), separate(q["taus"]), 1.0)[0])
    for i, nm in enumerate(layout.names):
        if nm.startswith(("log_tau_", "Tz_")):
            h = DELTA_METHOD_STEP * max(abs(th[i]), 1e-3)
            tp, tm = th.copy(), th.copy()
            tp[i] += h
            tm[i] -= h
            grad[i] = -(level(tp) - level(tm)) / (2 * h) / slope
    if "delay" in layout.idx:
        grad[layout.idx["delay"]] = 1.0
    return grad


def position_scale_fit(
    res: OeResult,
    time_s: np.ndarray,
    position: np.ndarray,
    step_volts: float,
    *,
    pre: np.ndarray | None = None,
    wrap_count: np.ndarray | None = None,
) -> float:
    """Scale ``c`` of ``P(s) = c·G(s)/s`` for a velocity model fitted without the position.

    Linear least squares of the position samples on the integrated velocity response, with
    the position's pre-step level (pinned by its pre-step samples) and, for an unwrapped
    record, a span error times the turns added, as nuisance columns.

    Parameters
    ----------
    res : OeResult
        The fit of the other channels (its velocity TF).
    time_s, position : ndarray
        Position samples from the step.
    step_volts : float
        Step level.
    pre : ndarray, optional
        Position samples before the step.
    wrap_count : ndarray, optional
        Turns added to each sample by the unwrapping.

    Returns
    -------
    float
        ``c``.
    """
    names = list(res.param_names)
    n, m = res.settings.n_poles, res.settings.n_zeros
    k = res.params[names.index("K")]
    taus = np.exp(res.params[1 : 1 + n])
    tz = res.params[1 + n : 1 + n + m]
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(position, dtype=float)
    cols = [position_closed_form(t, _vel_num(k, tz), taus, step_volts), np.ones(t.size)]
    if wrap_count is not None and np.any(wrap_count):
        cols.append(np.asarray(wrap_count, dtype=float))
    a = np.column_stack(cols)
    if pre is not None and len(pre):
        rows = np.zeros((len(pre), a.shape[1]))
        rows[:, 1] = 1.0
        a = np.vstack([a, rows])
        y = np.r_[y, np.asarray(pre, dtype=float)]
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    return float(coef[0])


@dataclass(frozen=True, slots=True)
class PlannedUncertainty:
    """What a fit of the same model would know from a record not yet taken.

    Attributes
    ----------
    values : dict[str, float]
        The derived quantities at the fitted parameters (``dc_gain``, ``time_constant``,
        ``pole_i``, ``delay``…), as :attr:`OeResult.std` names them.
    std : dict[str, float]
        Their predicted standard deviations.
    responses : dict[str, ndarray]
        Each channel's model increment on the planned grid (for a check of the screen's range).
    condition : float
        Condition number of the planned Fisher information.
    """

    values: dict[str, float]
    std: dict[str, float]
    responses: dict[str, np.ndarray]
    condition: float


def planned_uncertainty(
    res: OeResult,
    time_s: Mapping[str, np.ndarray],
    step_volts: float,
    sigma: Mapping[str, float],
    *,
    whiten: Mapping[str, np.ndarray] | None = None,
    pre_samples: Mapping[str, int] | None = None,
    pre_sigma: Mapping[str, float] | None = None,
    instant_std: tuple[tuple[str, float], ...] = (),
    step_rel_std: float = 0.0,
    variance_scale: float = 1.0,
    quantum: Mapping[str, float] | None = None,
    dither_rms: Mapping[str, float] | None = None,
) -> PlannedUncertainty:
    """Intervals of the fitted model's quantities predicted for another record of the same motor.

    The Fisher information of the fit's own problem (:func:`output_error_fit`'s residuals and
    analytic Jacobian, whitened and weighted the same way) at the fitted parameters, on the
    planned sample times and noise levels: its inverse, with the step instants' covariance and
    the delta method of the fit itself, is the covariance a fit of that record would report.

    Parameters
    ----------
    res : OeResult
        The fit on the record in hand.
    time_s : Mapping[str, ndarray]
        Each fitted channel's planned sample times from the step (as the fit takes them).
    step_volts : float
        The planned step level.
    sigma : Mapping[str, float]
        Each channel's planned innovation standard deviation.
    whiten : Mapping[str, ndarray], optional
        AR whitening polynomials per channel.
    pre_samples : Mapping[str, int], optional
        Samples before the step per channel (they pin its offset).
    pre_sigma : Mapping[str, float], optional
        Noise level of those samples.
    instant_std : tuple of (str, float)
        Step instants known to within a sample interval: :attr:`OeSettings.instant_std` of the
        planned sampling.
    step_rel_std : float
        Relative standard error of the measured step (and of the velocity's level) that scales the DC gain.
    variance_scale : float
        Factor of the covariance (the fit's residual variance over the noise model's, ``s²``).
    quantum : Mapping[str, float], optional
        The planned quantiser step of each channel whose error the fit counts
        (:attr:`OeResult.quantum`); none by default.
    dither_rms : Mapping[str, float], optional
        What dithers each of those channels (its residuals' RMS besides the quantiser's ``q/√12``).

    Returns
    -------
    PlannedUncertainty
        Values, predicted standard deviations, the model's increments on the grid.

    Raises
    ------
    IdentificationError
        A grid too short for the parameters.
    """
    names = [c for c in ("velocity", "position", "current") if c in time_s]
    settings = replace(res.settings, instant_std=instant_std, shift_bound_s=None)
    # the model's own increments stand in for the data: the Jacobian does not depend on them
    layout0 = _Layout(res.settings, names)
    th0 = np.array([res.params[res.param_names.index(n)] if n in res.param_names else 0.0 for n in layout0.names])
    resp = _predict(layout0, th0, {c: np.asarray(time_s[c], dtype=float) for c in names}, step_volts, names)
    pre = {c: np.zeros(int((pre_samples or {}).get(c, 0))) for c in names}
    prob = _OeProblem.build(dict(time_s), step_volts, resp, sigma, settings, pre=pre, block=None, whiten=whiten,
                            pre_sigma=pre_sigma, wrap_count=None, quantum=dict(quantum or {}))
    th = np.array([res.params[res.param_names.index(n)] if n in res.param_names else 0.0
                   for n in prob.layout.names])
    jac_m = prob.jacobian(th)
    jtj = jac_m.T @ jac_m
    cond = float(np.linalg.cond(jtj)) if np.all(np.isfinite(jtj)) else float("inf")
    inverse = np.linalg.pinv(jtj)
    gain = _Gain(inverse, jac_m)
    cov = (inverse * variance_scale + prob._instant_covariance(th, gain)
           + prob._quantiser_covariance(th, gain(), dither_rms or {}))
    # an ill-conditioned information matrix is inverted as the fit's own is (pseudo-inverse): its
    # poorly determined directions come out with large variances, as the fit would report them
    d0, std, _ = _delta_method(prob.layout, th, cov, step_rel_std)
    return PlannedUncertainty(d0, std, {c: v - th[prob.layout.idx[f"off_{c}"]] for c, v in resp.items()}, cond)
