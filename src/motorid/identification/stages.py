"""Beyond the paper: output-error refinement, SRIVC, order selection and uncertainty.

Stage functions on a :class:`~motorid.conditioning.pipeline.ConditionedExperiment`: they take
the full-rate synchronised step responses (no sample reduction, no numerical
differentiation — the two sources of the paper's bias), weight each channel by its own noise
level measured before the step, and start from a model of the paper's methods so that no
user guess is needed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from motorid.blockwise import variance
from motorid.conditioning.edge import noise_level, quantisation_step
from motorid.conditioning.pipeline import ConditionedExperiment
from motorid.conditioning.response import counting_lag, refreshed, split_at
from motorid.identification.output_error import (  # _block_mean: the fit's own block averaging
    GAVE_UP,
    OeResult,
    _block_mean,
    OeSettings,
    ar_noise_model,
    output_error_fit,
    position_scale_fit,
)
from motorid.identification.method_options import (
    DEFAULT_OUTPUT_ERROR,
    FIT_TOLERANCE,
    MAX_NFEV,
    OutputErrorOptions,
)
from motorid.identification.noise_json import SCALE_ONLY, ChannelNoise
from motorid.identification.quantiser import QUANTISER_CLAUSE, harmonic_variances
from motorid.identification.result import IdentificationError
from motorid.identification.sanity import pole_unresolved, zero_undemanded
from motorid.identification.srivc import SrivcSettings, srivc_fit
from motorid.model import MotorModel
from motorid.model.motor import realise_tfs
from motorid.model.uncertainty import (
    TIMING_SOURCES,
    ChannelTiming,
    JointCovariance,
    ParameterEstimate,
    PolePair,
    Uncertainty,
)

__all__ = [
    "STRUCTURES",
    "NoiseModel",
    "OrderSelection",
    "channel_sigma",
    "dead_time_shows",
    "instant_std",
    "noise_model",
    "oe_stage",
    "oe_uncertainty",
    "output_level_rel_std",
    "pairs_at_the_edge",
    "quantisation_bias_std",
    "refine_noise",
    "select_order",
    "srivc_stage",
    "step_instant",
    "step_level_std",
]

#: Model structures (velocity poles, zeros) tried for each order; the first is the default.
STRUCTURES: Mapping[int, tuple[tuple[int, int], ...]] = {
    1: ((1, 0),),
    2: ((2, 0), (2, 1)),
    3: ((3, 1), (3, 0)),
}

#: Longest record (per capture) handed to the nonlinear fit: longer ones are fitted as block
#: means (the model averaged the same way) down to this many samples, so the fit time stays
#: bounded.  A TDS1000/2000 record (2500 points) is fitted sample by sample: block means
#: would hide a misfit of the first samples after the step, where a fast pole shows.
MAX_FIT_SAMPLES = 2500


def channel_sigma(cond: ConditionedExperiment, role: str, block: int = 1) -> float:
    """Noise standard deviation of a channel, from its samples before the step.

    The pre-step part of a capture holds only noise (the motor is at rest); samples
    interpolated over wrap glitches are left out.  An 8-bit scope can show it as a constant
    code; the quantisation noise ``LSB/√12`` (from the smallest step between codes) is then
    the floor.  With ``block > 1``: of means of ``block`` samples, as the fit sees them.

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.
    role : str
        The channel (``velocity``, ``position`` or ``current``).
    block : int
        Block length of the means the fit sees (default 1).

    Returns
    -------
    float
        The standard deviation in volts.
    """
    r = cond.responses[role]
    good = r.time_s < 0
    if r.glitches is not None:
        good[r.glitches] = False
    means = _block_mean(r.output_v[good], block, from_end=True)
    sd = float(np.std(means)) if means.size >= 5 else noise_level(r.output_v) / np.sqrt(block)
    return max(sd, _code_step(r) / np.sqrt(12.0 * block), 1e-9)


#: Harmonics of the sawtooth summed for a level's error (a sum, not a covariance: all of them that matter).
LEVEL_HARMONICS = 32


def _quantiser_words(quantum: Mapping[str, float]) -> str:
    """What the covariance holds of the quantiser (:attr:`OeResult.quantum`), as a clause ('' for none)."""
    if not quantum:
        return ""
    return f"; {QUANTISER_CLAUSE} ({', '.join(quantum)}), its code grid at an unknown place"


def quantisation_bias_std(y: np.ndarray, quantum: float) -> float:
    """RMS error of a quantised plateau's mean that no number of samples averages out.

    A quantiser of step ``q`` returns, for a level ``x`` plus a dither, samples whose mean is off
    by ``Σₖ (−1)ᵏ⁺¹ (q/πk)·φ(2πk/q)·sin(2πkx/q)``: the sawtooth error's Fourier series, each
    harmonic smoothed by the dither's characteristic function ``φ``.  Gaussian noise makes
    ``φ`` vanish once ``σ`` passes ``q/2``; a periodic ripple (a tacho's) only like
    ``√(q/A)`` (``φ = J₀(2πkA/q)`` for a sinusoid of amplitude ``A``, whose square averages
    ``q/(2π²kA)`` over its oscillation), and the samples do not tell the two apart, so the
    ripple's is used, with ``A = √2·σ``.  Over a level at
    an unknown place on the code grid the RMS is ``√(Σₖ (q/πk)²·φₖ²/2)``, ``q/√12`` for a
    trace on one code.  ``σ²`` is the samples' variance less the quantiser's ``q²/12``.  A trace
    that reads exactly 0 throughout is a sensor at rest on the zero code: its level is 0.
    The harmonics are :func:`~motorid.identification.quantiser.harmonic_variances` (the same
    error along a whole record enters the output-error fit's covariance).

    Parameters
    ----------
    y : ndarray
        The plateau's samples.
    quantum : float
        The quantiser's step (0: not quantised).

    Returns
    -------
    float
        The RMS error of the mean, in ``y``'s unit.
    """
    if quantum <= 0.0 or y.size < 2 or not np.any(y):
        return 0.0
    dither = math.sqrt(max(variance(y) - quantum**2 / 12.0, 0.0))
    return float(np.sqrt(np.sum(harmonic_variances(quantum, dither, LEVEL_HARMONICS))))


def step_level_std(cond: ConditionedExperiment) -> float:
    """Standard error of the experiment's step level.

    Each capture's step is the mean of its input channel after the edge minus the mean
    before it: the noise ``σ_u`` gives ``σ_u²(1/n_before + 1/n_after)``, averaged over the
    captures; the quantiser's error of each mean (:func:`quantisation_bias_std`) does not
    average out, neither over the samples nor over captures of the same level on the same
    scale.  A step given by the user (no input channel) counts as exact.

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.

    Returns
    -------
    float
        The standard error in volts (0.0 for a step given by the user).
    """
    random, systematic = [], []
    for r in cond.responses.values():
        u = r.input_v
        before, after = split_at(r.time_s, u)
        if before.size < 2 or after.size < 2:
            continue
        quantum = quantisation_step(u, below=0.5 * abs(r.step_volts))
        random.append(variance(before) * (1.0 / before.size + 1.0 / after.size))
        systematic.append(quantisation_bias_std(before, quantum) ** 2 + quantisation_bias_std(after, quantum) ** 2)
    if not random:
        return 0.0
    return float(np.sqrt(np.sum(random) / len(random) ** 2 + np.mean(systematic)))


#: The velocity's last part taken as its settled level (for the quantiser's error of the level).
SETTLED_FRACTION = 0.25


def output_level_rel_std(cond: ConditionedExperiment) -> float:
    """Relative error of the velocity's recorded change that the quantiser leaves in any fit.

    The pre-step level and the settled level (the last :data:`SETTLED_FRACTION` of the
    record) each carry :func:`quantisation_bias_std`; relative to the change between them,
    that is the DC gain's relative error that the fit's own covariance does not see (it treats
    every sample's quantisation error as independent noise).  0 without a velocity capture or
    when the trace is not quantised.

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.

    Returns
    -------
    float
        The relative standard error (dimensionless).
    """
    r = cond.responses.get("velocity")
    if r is None:
        return 0.0
    y = r.output_v
    before, after = split_at(r.time_s, y)
    settled = after[int((1.0 - SETTLED_FRACTION) * after.size):]
    if before.size < 2 or settled.size < 2:
        return 0.0
    change = float(np.mean(settled) - np.mean(before))
    quantum = quantisation_step(y, below=0.25 * abs(change)) if change else 0.0
    if quantum == 0.0 or change == 0.0:
        return 0.0
    q = np.hypot(quantisation_bias_std(before, quantum), quantisation_bias_std(settled, quantum))
    return float(q / abs(change))


#: Structures tried, in turn, for the preliminary fit of the noise model.
PRELIMINARY: tuple[tuple[int, int], ...] = ((2, 0), (1, 0))

#: SRIVC filters the data several times per iteration with ``lsim``: fewer samples suffice.
SRIVC_SAMPLES = 1000


def _srivc_data(cond: ConditionedExperiment, max_samples: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The synchronised record sub-sampled to at most ``max_samples``.

    SRIVC simulates its filters from rest at ``t = 0``, so the grid stays anchored there (no block
    centres).
    """
    t = cond.full_time_s
    length = fit_record_length(cond)
    # the output-error fit's record (at most MAX_RECORD_TIME_CONSTANTS 63 % times): a 10 000 s log of a
    # 0.3 s motor sub-sampled whole to 1000 samples left one sample per 10 s, and SRIVC read τ 0.9 s
    keep = t.size if length is None else max(int(np.searchsorted(t, length, side="right")), min(t.size, 6))
    t = t[:keep]
    ratio = max(1, int(np.ceil(t.size / max_samples)))
    outs = {}
    for k, v in cond.full_outputs.items():
        v = v[:keep]
        # a scope-sampled step happened about half a sample before its edge sample: the record is
        # read on a grid that starts at that instant (where the response is still 0), so that the
        # filters' step at t = 0 is the motor's
        phase = _sampled_phase(cond.responses[k]) if k in cond.responses else 0.0
        outs[k] = np.interp(t, np.r_[0.0, t + phase], np.r_[0.0, v]) if phase > 0 else v
    return t[::ratio], {k: v[::ratio] for k, v in outs.items()}


def _shift_bound(cond: ConditionedExperiment) -> float:
    """How far a capture's time zero can be off: 1.5 recorded samples."""
    return 1.5 * max(r.sample_interval_s for r in cond.responses.values())


def timing_groups(cond: ConditionedExperiment) -> tuple[tuple[str, ...], ...]:
    """The channels whose step instant was read off a response, grouped by acquisition.

    Each group gets one fitted time shift in the output-error fit (the channels of one scope
    acquisition share one onset, see :func:`motorid.conditioning.pipeline.condition_experiment`).
    A channel whose step instant a recorded input or ``--t0`` fixes gets none, so nothing can
    trade its lags (a dead time, an electrical pole) for a shift (see :func:`oe_settings`).

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.

    Returns
    -------
    tuple of tuple of str
        Channel groups, in the order of ``cond.responses``.
    """
    return _on_one_time_axis(cond, [role for role, r in cond.responses.items()
                                    if r.timing == "onset" and role in cond.full_outputs])


def _on_one_time_axis(cond: ConditionedExperiment, roles: list[str]) -> tuple[tuple[str, ...], ...]:
    """``roles`` grouped by identical time axes (the channels of one acquisition or one log), in order."""
    groups: list[list[str]] = []
    for role in roles:
        t = cond.responses[role].time_s
        for g in groups:
            other = cond.responses[g[0]].time_s
            if other.shape == t.shape and np.array_equal(other, t):
                g.append(role)
                break
        else:
            groups.append([role])
    return tuple(tuple(g) for g in groups)


def _sampled_phase(r: Any) -> float:
    """Seconds from a channel's step instant to its edge sample: half a sample for a scope input.

    A scope samples the input's edge: the step lies, uniformly, in the sample interval before
    the first sample at the new level; its best estimate is the interval's middle (its standard
    deviation ``dt/√12`` goes into the intervals, see :func:`oe_settings`).
    """
    return 0.5 * r.sample_interval_s if r.timing == "sampled" else 0.0


def instant_std(r: Any) -> float:
    """Standard error of a channel's step instant (its source's resolution over √12).

    ``dt/√12`` for a scope's sampled edge, ``q/√12`` for a logged change stamped by a clock of
    resolution ``q`` (``millis()``), else 0.

    Parameters
    ----------
    r : StepResponse
        The channel's conditioned response.

    Returns
    -------
    float
        Seconds.
    """
    if r.timing == "sampled":
        return r.sample_interval_s / np.sqrt(12.0)
    if r.timing == "logged":
        return r.stamp_resolution_s / np.sqrt(12.0)
    return 0.0


def step_instant(r: Any) -> tuple[str, float]:
    """Where a channel's step instant comes from, and the instant on the file's time axis.

    Parameters
    ----------
    r : StepResponse
        The channel's conditioned response.

    Returns
    -------
    tuple of (str, float)
        The source in words (:data:`~motorid.model.uncertainty.TIMING_SOURCES`) and the instant in seconds.
    """
    source = TIMING_SOURCES.get(r.timing, r.timing)
    if r.timing == "logged" and r.stamp_resolution_s > 0:
        source = (f"the logged input's change, its stamp rounded to the clock's {1e3 * r.stamp_resolution_s:.3g} ms "
                  "(±resolution/√12 in the intervals)")
    return source, float(r.edge.time_s) - _sampled_phase(r)


def oe_settings(cond: ConditionedExperiment, structure: tuple[int, int], *, delay: bool = False,
                tolerance: float = FIT_TOLERANCE, max_nfev: int = MAX_NFEV) -> OeSettings:
    """The output-error settings of one structure on these captures: their timing.

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.
    structure : tuple of int
        ``(poles, zeros)`` of the velocity transfer function.
    delay : bool
        Fit a dead time.
    tolerance : float
        The fit's stopping tolerance (:attr:`OeSettings.tolerance`).
    max_nfev : int
        Most model evaluations (:attr:`OeSettings.max_nfev`).

    Returns
    -------
    OeSettings
        Shift groups from :func:`timing_groups`; the channels whose input a scope sampled have
        their common instant at the middle of the interval before their edge samples (each
        one's ``dt/√12`` as ``instant_std``) and their phases relative to each other fitted
        (``phase_group``); a counted speed is fitted as its means over its window (``windows``); a speed
        in a counted-speed unit has no rounding error along the record (``differenced``).
    """
    # a sub-sample phase cannot be told from the lags of the dynamics (an electrical pole, a
    # dead time): fitted, it took them up and τ came out short; so the captures' common instant
    # stays at the intervals' middle (unbiased: the switch is thrown at any instant) with its
    # uncertainty in the intervals, and only their phases relative to each other are fitted (left
    # fixed, their disagreement near the step bought a spurious pole-zero pair)
    stds = {role: instant_std(r) for role, r in cond.responses.items() if role in cond.full_outputs}
    uncertain = tuple((role, sd) for role, sd in stds.items() if sd > 0)
    # a log's columns share one stamp of the step: their instants move together
    stamped = [role for role, _ in uncertain if cond.responses[role].timing == "logged"]
    return OeSettings(n_poles=structure[0], n_zeros=structure[1], delay=delay, tolerance=tolerance,
                      max_nfev=max_nfev, shift_bound_s=_shift_bound(cond),
                      shift_groups=timing_groups(cond), instant_std=uncertain,
                      phase_group=tuple(role for role, r in cond.responses.items()
                                        if r.timing == "sampled" and role in cond.full_outputs),
                      instant_shared=_on_one_time_axis(cond, stamped),
                      windows=tuple((role, r.sample_window_s) for role, r in cond.responses.items()
                                    if r.sample_window_s > 0 and role in cond.full_outputs),
                      differenced=tuple(role for role, r in cond.responses.items()
                                        if not r.rounded and role in cond.full_outputs))


@dataclass(frozen=True, slots=True)
class _ChannelData:
    """What the output-error fit sees of each capture.

    Its own grid from its step (every sample it recorded after the step, not only the part common to
    all captures), its pre-step samples, and the block length that keeps the fitted record at most
    :data:`MAX_FIT_SAMPLES` long; for an unwrapped position, the turns added to each sample (samples
    interpolated over wrap glitches are left out).
    """

    time_s: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    pre: dict[str, np.ndarray]
    block: dict[str, int]
    wrap_count: dict[str, np.ndarray]


#: The output-error fit uses at most this many 63 % times of record after the step: a
#: 3000 s log of a 0.35 s motor was otherwise fitted as 1.2 s block means (longer than τ,
#: interval ±0.64 s); fifty time constants show the steady state to 1e-20.
MAX_RECORD_TIME_CONSTANTS = 50.0


def fit_record_length(cond: ConditionedExperiment) -> float | None:
    """Seconds after the step the output-error fit uses (``None``: all of it)."""
    length = cond.settings.record_length_s
    t63 = cond.response_time_s
    if np.isfinite(t63) and t63 > 0:
        cap = MAX_RECORD_TIME_CONSTANTS * t63
        if cap < float(cond.full_time_s[-1]):
            length = cap if length is None else min(length, cap)
    return length


def _read_only(a: np.ndarray) -> np.ndarray:
    """``a`` (a view or a copy) made read-only: the fit's data are never written."""
    a = a.view()
    a.flags.writeable = False
    return a


def _channel_data(cond: ConditionedExperiment, max_samples: int = MAX_FIT_SAMPLES) -> _ChannelData:
    length = fit_record_length(cond)
    times, outs, pre, block, wraps = {}, {}, {}, {}, {}
    for role in cond.full_outputs:
        r = cond.responses[role]
        # the times increase: the record before the step and the part fitted are ranges (views, not the
        # masks and masked copies of a long record), less the interpolated glitches of a position
        t, dt = r.time_s, r.sample_interval_s
        k_pre = int(np.searchsorted(t, 0.0, side="left"))
        k0 = int(np.searchsorted(t, -1e-9 * dt, side="left"))
        k1 = t.size if length is None else max(k0, int(np.searchsorted(t, length + 0.5 * dt, side="right")))
        fitted, before = slice(k0, k1), slice(0, k_pre)
        keep_pre: np.ndarray | slice = before
        keep: np.ndarray | slice = fitted
        if r.glitches is not None:
            good = np.ones(t.size, dtype=bool)
            good[r.glitches] = False
            keep, keep_pre = np.flatnonzero(good[fitted]) + k0, np.flatnonzero(good[before])
        fresh = refreshed(r)
        if fresh is not None:
            # a count kept over several lines: the lines that logged it (the others repeat it), each the
            # mean over the window that ends at its stamp
            keep, keep_pre = np.flatnonzero(fresh[fitted]) + k0, np.flatnonzero(fresh[before])
        times[role], outs[role] = t[keep] + _sampled_phase(r), _read_only(r.output_v[keep])
        pre[role] = _read_only(r.output_v[keep_pre])
        block[role] = max(1, int(np.ceil(times[role].size / max_samples)))
        if r.wrap_count is not None:
            wraps[role] = _read_only(r.wrap_count[keep])
    return _ChannelData(times, outs, pre, block, wraps)


def _init_from(model: MotorModel, n_poles: int, n_zeros: int) -> tuple[list[float], float, list[float]]:
    """Time constants, DC gain and zero time constants of a model, padded to a structure."""
    fo = model.first_order()
    poles = [p for p in model.poles() if np.real(p) < 0]
    taus = sorted((float(-1.0 / np.real(p)) for p in poles), reverse=True)
    dc = fo.dc_gain if np.isfinite(fo.dc_gain) and fo.dc_gain != 0 else 1.0
    tau1 = fo.time_constant_s if np.isfinite(fo.time_constant_s) and fo.time_constant_s > 0 else 0.3
    taus = [t for t in taus if 1e-4 < t < 100.0]
    if not taus:
        taus = [tau1]
    taus[0] = tau1 if len(taus) == 1 else taus[0]
    while len(taus) < n_poles:
        taus.append(taus[-1] / 8.0)  # faster poles start well separated from the dominant one
    taus = taus[:n_poles]
    zeros = [0.5 * taus[1]] * n_zeros if n_poles > 1 else []
    return taus, float(dc), zeros[:n_zeros]


def _oe_to_model(
    res: OeResult, cond: ConditionedExperiment, structure: tuple[int, int], noise: NoiseModel | None = None
) -> MotorModel:
    r = realise_tfs(res.velocity_num, res.velocity_den, current_num=res.current_num,
                    position_scale=res.position_scale)
    return MotorModel(
        A=r.A, B=r.B, C=r.C, D=r.D, states=r.states, outputs=r.outputs,
        step_volts=cond.step_volts, method="oe",
        # the record's length: first_order() cancels only pole-zero pairs the record cannot show
        # (a candidate with a pole at the sampling rate otherwise had its dominant pole cancelled
        # against a zero 128× faster, and a DC gain of 0.002 widened the chosen model's interval)
        settings={"n_poles": structure[0], "n_zeros": structure[1],
                  "delay": res.delay_s is not None and res.delay_s > 0,
                  "record_length_s": float(cond.full_time_s[-1])},
        sample_interval_s=float(cond.full_time_s[1] - cond.full_time_s[0]),
        warnings=tuple(res.warnings),
        uncertainty=oe_uncertainty(res, cond),
        extras={"bic": res.bic, "aic": res.aic, "sigma": dict(res.sigma), "delay_s": res.delay_s,
                **({"noise": noise.to_json()} if noise is not None else {})},
        delay_s=res.delay_s or 0.0,
    )


def oe_uncertainty(res: OeResult, cond: ConditionedExperiment | None = None) -> Uncertainty:
    """The typed uncertainty (the model JSON's ``uncertainty`` and ``timing``) of an output-error result.

    Parameters
    ----------
    res : OeResult
        An output-error result.
    cond : ConditionedExperiment, optional
        The captures it was fitted to (each channel's step instant: :func:`channel_timing`).

    Returns
    -------
    Uncertainty
        Estimates, standard errors and 95 % intervals.
    """
    def item(key: str, value: float | complex) -> ParameterEstimate:
        return _estimate_of(res, key, value)

    def root(key: str, value: complex) -> ParameterEstimate:
        return item(key, complex(float(np.real(value)), float(np.imag(value))))

    pairs = unresolved_pairs(res)
    return Uncertainty(
        dc_gain=item("dc_gain", res.dc_gain),
        time_constant=item("time_constant", res.time_constant_s),
        residence_time_s=item("residence_time", res.time_constant_s + (res.delay_s or 0.0)),
        t63_s=item("t63", float(np.mean(res.ci95["t63"])) if "t63" in res.ci95 else float("nan")),
        poles=tuple(root(f"pole_{i}", p) for i, p in enumerate(res.poles)),
        zeros=tuple(root(f"zero_{i}", z) for i, z in enumerate(res.zeros)),
        method="Gauss-Newton covariance of the output-error fit (delta method), 95% = ±1.96 std"
               + _quantiser_words(res.quantum),
        quantiser=dict(res.quantum),
        pole_pairs=tuple(PolePair((i, i + 1), item(f"pair_{i}_wn", res_value(res, f"pair_{i}_wn")),
                                  _pair_damping(res, i, item(f"pair_{i}_zeta", res_value(res, f"pair_{i}_zeta"))))
                         for i in pairs),
        delay=None if res.delay_s is None else item("delay", res.delay_s),
        joint=joint_covariance(res),
        timing={} if cond is None else channel_timing(res, cond),
    )


def _pair_damping(res: OeResult, i: int, estimate: ParameterEstimate) -> ParameterEstimate:
    """A pair's damping, without an interval where the fit holds the two poles at their double pole.

    The damping of two real poles is at least 1: 1 where they are equal, growing with the square
    of their difference.  Near there the delta method's interval is the linearisation of a function
    at its minimum: exactly on each other it collapses to ±0 (±3.7e-6 on a real log whose fit
    landed on a double pole), just apart it straddles 1 (±0.09 on the HSLU log's pair −14.24,
    −14.25), half of it where real poles cannot go.  At that edge (:func:`pairs_at_the_edge`) the
    damping is reported with no interval (JSON ``null``), and the printout says why; apart, the
    delta method's interval stands.
    """
    if _damping(res, i) - 1.0 < EDGE_DAMPING:
        return ParameterEstimate(float(np.real(estimate.value)), float("nan"), None)
    return estimate


def _damping(res: OeResult, i: int) -> float:
    """The damping of the fit's neighbouring real poles ``i`` and ``i + 1``: ``−(p₁ + p₂)/(2√(p₁p₂))``."""
    pa, pb = float(np.real(res.poles[i])), float(np.real(res.poles[i + 1]))
    return -(pa + pb) / (2.0 * np.sqrt(pa * pb)) if pa * pb > 0 else float("inf")


def _estimate_of(res: OeResult, key: str, value: float | complex) -> ParameterEstimate:
    """``value`` with the fit's standard error and 95 % interval of ``key`` (none when not finite)."""
    lo, hi = res.ci95.get(key, (float("nan"), float("nan")))
    ci = (float(lo), float(hi)) if math.isfinite(lo) and math.isfinite(hi) else None
    value = value if isinstance(value, complex) else float(value)
    return ParameterEstimate(value, float(res.std.get(key, float("nan"))), ci)


def joint_covariance(res: OeResult) -> JointCovariance:
    """The motor's parameters and their joint covariance, as the model JSON's ``uncertainty.joint``.

    The chosen structure's Gauss–Newton covariance restricted to the parameters that define
    the motor (a Gaussian's marginal is that sub-matrix): what a robustness check samples
    plausible motors from (:func:`motorid.model.motor.realise_tfs` rebuilds each).

    Parameters
    ----------
    res : OeResult
        An output-error result.

    Returns
    -------
    JointCovariance
        ``parameters`` (``K``, ``log_tau_i``, ``Tz_j``, ``delay``, ``c``, ``cur_j``), ``values``,
        ``covariance`` (rows in the same order).
    """
    keep = [i for i, name in enumerate(res.param_names)
            if name in ("K", "delay", "c") or name.startswith(("log_tau_", "Tz_", "cur_"))]
    cov = np.asarray(res.cov, float)[np.ix_(keep, keep)]
    return JointCovariance(tuple(res.param_names[i] for i in keep), np.asarray(res.params, float)[keep], cov)


def res_value(res: OeResult, key: str) -> float:
    """A derived quantity's estimate: the centre of its (symmetric) 95 % interval."""
    lo, hi = res.ci95.get(key, (float("nan"), float("nan")))
    return 0.5 * (lo + hi)


def unresolved_pairs(res: OeResult) -> list[int]:
    """Neighbouring poles ``i, i+1`` (slowest first) that the data know only as a pair.

    Each pole's 95 % interval holds the other pole, while the pair's natural frequency is known
    to better than its own size: report the pair (natural frequency, damping), not two poles of
    ±(more than their value).

    Parameters
    ----------
    res : OeResult
        An output-error result.

    Returns
    -------
    list of int
        The index of each pair's first pole.
    """
    out: list[int] = []
    n = res.poles.size
    for i in range(n - 1):
        if out and out[-1] == i - 1:
            continue
        a, b = f"pole_{i}", f"pole_{i + 1}"
        if a not in res.ci95 or b not in res.ci95 or f"pair_{i}_wn" not in res.std:
            continue
        pa, pb = float(np.real(res.poles[i])), float(np.real(res.poles[i + 1]))
        (lo_a, hi_a), (lo_b, hi_b) = res.ci95[a], res.ci95[b]
        overlap = lo_a <= pb <= hi_a or lo_b <= pa <= hi_b
        wn = res_value(res, f"pair_{i}_wn")
        if overlap and 1.96 * res.std[f"pair_{i}_wn"] < abs(wn):
            out.append(i)
    return out


#: A pair of the fit's real poles whose damping is within this of 1 sits at their double pole
#: (poles about 3 % apart or closer): the edge of what real poles can represent.
EDGE_DAMPING = 1e-4


def pairs_at_the_edge(res: OeResult) -> list[int]:
    """Neighbouring poles ``i, i+1`` (slowest first) held at a double pole, the edge of the fit's real poles.

    The output-error fit parameterises its poles by real time constants, so a pair's damping is
    at least 1.  When the data want a lightly damped complex pair (damping below 1), the best the
    fit can do is the double pole, damping 1 (on the HSLU lab's rig log: −14.25 and −14.24 with a
    damping of 1 + 6e-8, where SRIVC, whose polynomial allows complex poles, finds −15.8 ± 4.4j,
    damping 0.96).  Such a pair is at a boundary of the model, not at a point the data chose.

    Parameters
    ----------
    res : OeResult
        An output-error result.

    Returns
    -------
    list of int
        The index of each such pair's first pole.
    """
    return [i for i in range(res.poles.size - 1) if _damping(res, i) - 1.0 < EDGE_DAMPING]


def channel_timing(res: OeResult, cond: ConditionedExperiment) -> dict[str, ChannelTiming]:
    """Per channel of the fit: where its step instant comes from, and its fitted shift with interval.

    Parameters
    ----------
    res : OeResult
        An output-error result.
    cond : ConditionedExperiment
        The captures it was fitted to.

    Returns
    -------
    dict of str to ChannelTiming
        Keyed by channel: the step instant in words, the instant on the file's time axis, and a
        fitted shift with its interval (positive: the model's step is that much later than the
        edge read off the data).
    """
    out: dict[str, ChannelTiming] = {}
    for role, r in cond.responses.items():
        if role not in res.residuals:
            continue
        shift, note = None, None
        if role in res.shifts:
            shift = _estimate_of(res, f"shift_{role}", res.shifts[role])
        elif r.timing == "onset" and res.delay_s is not None:
            note = "its shift is the dead time (a step instant read off the response cannot be told from it)"
        out[role] = ChannelTiming(*step_instant(r), shift, note, kind=r.timing, window_s=r.sample_window_s,
                                  count_hold=r.count_hold if r.count_held else 1)
    return out


@dataclass(frozen=True, slots=True)
class NoiseModel:
    """What the output-error fit assumes about each channel's noise.

    Attributes
    ----------
    sigma : dict[str, float]
        Innovation standard deviation of the (whitened) post-step residuals.
    whiten : dict[str, ndarray]
        AR whitening polynomial ``[1, a_1, …, a_p]`` (``[1.0]``: white noise).
    pre_sigma : dict[str, float]
        Standard deviation of the pre-step samples (motor at rest).
    scale_only : tuple of str
        Channels fitted for their scale only, not for the dynamics (an undithered
        quantised position, see :func:`noise_model`).
    preliminary : MotorModel or None
        The fit the noise model comes from (a starting point for the others).
    step_std : float
        Standard error of the step level (:func:`step_level_std`).
    level_rel_std : float
        The velocity change's relative error the quantiser leaves (:func:`output_level_rel_std`).
    """

    sigma: dict[str, float]
    whiten: dict[str, np.ndarray]
    pre_sigma: dict[str, float]
    scale_only: tuple[str, ...] = ()
    preliminary: MotorModel | None = None
    step_std: float = 0.0
    level_rel_std: float = 0.0

    @property
    def ar_order(self) -> dict[str, int]:
        """AR order of each channel's noise model."""
        return {k: len(v) - 1 for k, v in self.whiten.items()}

    def to_json(self) -> dict[str, Any]:
        """Per channel: innovation std, AR order, pre-step std and how it is used.

        Returns
        -------
        dict
            JSON-able, keyed by channel.
        """
        return {role: ChannelNoise(self.sigma[role], self.ar_order.get(role, 0), self.pre_sigma.get(role),
                                   SCALE_ONLY if role in self.scale_only else "dynamics").to_json()
                for role in self.sigma}


def _code_step(r: Any) -> float:
    """Smallest code step of a capture (its 8-bit quantum), away from wraps and glitches.

    An unwrapped or interpolated sample is no longer on the code grid.
    """
    ok = np.ones(r.output_v.size - 1, dtype=bool)
    if r.wrap_count is not None:
        ok &= np.diff(r.wrap_count) == 0
    if r.glitches is not None:
        bad = np.asarray(r.glitches, dtype=int)
        ok[np.clip(np.r_[bad, bad - 1], 0, ok.size - 1)] = False
    return quantisation_step(r.output_v, valid=ok)


def _structure_of(res: OeResult) -> tuple[int, int]:
    """(poles, zeros) of an output-error result."""
    return res.settings.n_poles, res.settings.n_zeros


def noise_model(cond: ConditionedExperiment, init: MotorModel,
                options: OutputErrorOptions = DEFAULT_OUTPUT_ERROR) -> NoiseModel:
    """Noise model of each channel for the output-error fit.

    The pre-step samples (motor at rest) give each channel's level before the step, with
    the quantisation ``LSB/√12`` as a floor.  After the step the noise is coloured (tacho
    ripple at the commutation frequency, aliased PWM, quantisation that follows the
    signal): the residuals of a first output-error fit (two poles) get an
    autoregressive model (order by BIC), whose polynomial whitens the residuals of every
    later fit and whose innovation variance weights them — generalised least squares, so
    that ripple neither biases the weights nor makes the intervals too narrow.

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.
    init : MotorModel
        The model the fit starts from (a paper method's).
    options : OutputErrorOptions
        The output-error fit's evaluations and (search) tolerance.

    Returns
    -------
    NoiseModel
        Per-channel noise levels and whitening filters.
    """
    data = _channel_data(cond)
    pre_sigma = {role: channel_sigma(cond, role, data.block[role]) for role in data.outputs}
    # the levels' errors depend on the captures only: once here, not in every structure's fit
    step_std, level_rel_std = step_level_std(cond), output_level_rel_std(cond)
    sigma = dict(pre_sigma)
    white = {role: np.array([1.0]) for role in data.outputs}
    res = None
    # two poles (quick and robust from any paper model); one if that cannot be fitted.  Its
    # residuals may hold some model error besides the noise: select_order re-estimates the
    # noise model from the chosen structure's residuals and refits it
    for structure in PRELIMINARY:
        taus, dc, zeros = _init_from(init, *structure)
        try:
            res = output_error_fit(data.time_s, cond.step_volts, data.outputs, sigma, taus, dc,
                                   oe_settings(cond, structure, tolerance=options.search_tolerance,
                                               max_nfev=options.max_nfev), pre=data.pre,
                                   block=data.block, wrap_count=data.wrap_count, init_zeros=zeros)
        except IdentificationError:
            continue
        if np.isfinite(res.cost) and np.all(np.real(res.poles) < 0):
            break
    if res is None:
        return NoiseModel(sigma, white, pre_sigma, step_std=step_std, level_rel_std=level_rel_std)
    # an 8-bit position whose noise is well under a code does not average its quantisation
    # out: the error follows the motion (a slow sawtooth while the shaft speeds up, where
    # the time constants show) and would pull them as if it were signal.  With a velocity
    # capture to carry the dynamics, such a position is fitted for its scale only.
    scale_only: tuple[str, ...] = ()
    if "position" in res.residuals and "velocity" in res.residuals:
        quantum = _code_step(cond.responses["position"])
        spread = res.residual_rms["position"] * np.sqrt(data.block["position"])
        if quantum > 0 and spread < 0.5 * quantum:
            scale_only = ("position",)
    first = NoiseModel(sigma, white, pre_sigma, scale_only, _oe_to_model(res, cond, _structure_of(res)),
                       step_std=step_std, level_rel_std=level_rel_std)
    return refine_noise(first, res)


def refine_noise(noise: NoiseModel, res: OeResult) -> NoiseModel:
    """The noise model re-estimated from the residuals of a fit.

    Channels it did not fit keep theirs.

    Parameters
    ----------
    noise : NoiseModel
        The current noise model.
    res : OeResult
        An output-error fit whose residuals are used.

    Returns
    -------
    NoiseModel
        The updated noise model.
    """
    sigma, white = dict(noise.sigma), dict(noise.whiten)
    for role, e in res.residuals.items():
        white[role], sd = ar_noise_model(e)
        sigma[role] = max(sd, 1e-9)
    return replace(noise, sigma=sigma, whiten=white)


def oe_stage(
    cond: ConditionedExperiment,
    init: MotorModel,
    structure: tuple[int, int],
    *,
    delay: bool = False,
    noise: NoiseModel | None = None,
    white: bool = False,
    tolerance: float = FIT_TOLERANCE,
    max_nfev: int = MAX_NFEV,
    give_up: tuple[int, float] | None = None,
) -> tuple[OeResult, MotorModel]:
    """Output-error fit of one structure, initialised from ``init``.

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.
    init : MotorModel
        The model the fit starts from (a paper method's).
    structure : tuple of int
        ``(poles, zeros)`` of the velocity transfer function.
    delay : bool
        Fit a dead time too, starting from ``init.delay_s`` when it has one, else from the
        apparent dead time read off the data (``cond.dead_time_s``).
    noise : NoiseModel, optional
        Channel noise models (default: :func:`noise_model`).
    white : bool
        Leave the AR whitening out (weights: the pre-step noise levels): the sanity gate
        compares the two estimates, since an AR model can absorb a structural misfit.
    tolerance : float
        The fit's stopping tolerance (:data:`~motorid.identification.method_options.SEARCH_TOLERANCE` for the
        structure search's candidates).
    max_nfev : int
        Most model evaluations of the fit.
    give_up : (int, float), optional
        ``(evaluations, bic)``: stop once past that many evaluations while the BIC is still at
        least ``bic`` (:func:`~motorid.identification.output_error.output_error_fit`).

    Returns
    -------
    (OeResult, MotorModel)
        The raw result and the model (velocity, and position/current rows when captured).
    """
    data = _channel_data(cond)
    noise = noise if noise is not None else noise_model(cond, init, OutputErrorOptions(max_nfev=max_nfev))
    taus, dc, zeros = _init_from(init, *structure)
    settings = oe_settings(cond, structure, delay=delay, tolerance=tolerance, max_nfev=max_nfev)
    fitted = {role: y for role, y in data.outputs.items() if role not in noise.scale_only}
    # a starting model's delay that is the read-off itself (the Markov stage carries it) starts from
    # the middle of its interval too: a fitted one is kept
    carried = init.delay_s > 0 and abs(init.delay_s - cond.dead_time_s) > 1e-9 * max(cond.dead_time_s, 1e-300)
    delay0 = init.delay_s if carried else read_off_delay(cond)
    res = output_error_fit(data.time_s, cond.step_volts, fitted, noise.pre_sigma if white else noise.sigma,
                           taus, dc, settings, init_zeros=zeros, init_delay_s=delay0, pre=data.pre,
                           step_std=noise.step_std, level_rel_std=noise.level_rel_std, block=data.block,
                           whiten=None if white else noise.whiten, pre_sigma=noise.pre_sigma,
                           wrap_count=data.wrap_count, give_up=give_up)
    if "position" in noise.scale_only:
        c = position_scale_fit(res, data.time_s["position"], data.outputs["position"], cond.step_volts,
                               pre=data.pre["position"], wrap_count=data.wrap_count.get("position"))
        res = replace(res, position_scale=c)
    return res, _oe_to_model(res, cond, structure, noise)


def read_off_delay(cond: ConditionedExperiment) -> float:
    """Where the dead-time fit starts: the middle of the sample interval in which the response leaves its noise band.

    The read-off (``cond.dead_time_s``) is the last sample still in the band, so the motor started
    somewhere in the interval after it; its middle is the start of least error.  It is also off the
    grid: at a sample instant the fitted response's kink (0 before the delay, its full slope after)
    sits on a sample, the residuals' derivative with respect to the delay jumps there, and the fit
    from exactly that start ended at 29.3 or at 36.05 ms on the same rig log, depending on the last bit
    of the start (0.030000000000000006 or 0.030000000000000027 s).

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.

    Returns
    -------
    float
        The starting dead time in s (0 when none was read off).
    """
    if not cond.dead_time_s > 0 or cond.full_time_s.size < 2:
        return 0.0
    return float(cond.dead_time_s) + 0.5 * float(cond.full_time_s[1] - cond.full_time_s[0])


def srivc_stage(
    cond: ConditionedExperiment, init: MotorModel, structure: tuple[int, int], *, max_samples: int = SRIVC_SAMPLES,
    settings: SrivcSettings | None = None,
) -> MotorModel:
    """SRIVC estimate of the velocity TF of one structure, initialised from ``init``.

    ``max_samples`` bounds the record SRIVC filters (every iteration runs ``lsim`` on it);
    ``auto`` uses 500 for its second opinion.

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.
    init : MotorModel
        The model the fit starts from (a paper method's).
    structure : tuple of int
        ``(poles, zeros)`` of the velocity transfer function.
    max_samples : int
        Largest number of samples SRIVC filters (default 1000).
    settings : SrivcSettings, optional
        Iterations and tolerance (its poles and zeros are ``structure``'s).

    Returns
    -------
    MotorModel
        The SRIVC model.
    """
    t, outs = _srivc_data(cond, max_samples)
    if "velocity" not in outs:
        raise IdentificationError("SRIVC needs a velocity capture (--velocity)")
    taus, _, _ = _init_from(init, *structure)
    den0 = np.poly([-1.0 / x for x in taus])
    u = np.full(t.size, cond.step_volts)
    given = settings if settings is not None else SrivcSettings()
    res = srivc_fit(t, u, outs["velocity"], replace(given, n_poles=structure[0], n_zeros=structure[1]), init_den=den0)
    from motorid.model import model_from_velocity_tf

    not_converged = () if res.converged else (f"SRIVC did not converge in {res.iterations} iterations",)
    warnings = tuple(res.warnings) + not_converged
    return model_from_velocity_tf(
        res.num, res.den, with_position=False, step_volts=cond.step_volts, method="srivc",
        settings={"n_poles": structure[0], "n_zeros": structure[1], "iterations": res.iterations},
        sample_interval_s=float(t[1] - t[0]), warnings=warnings,
    )


#: Apparent dead time, in recorded samples, from which ``auto`` also tries each structure
#: with a fitted delay and lets BIC decide (the trainer's lags leave one or two quiet
#: samples after the step; a drive's dead time leaves more).
DEAD_TIME_SAMPLES = 3
#: ... or, on a coarse grid (a 100 Hz DAQ), this fraction of the 63 % time.
DEAD_TIME_FRACTION = 0.05


@dataclass(frozen=True, slots=True)
class OrderSelection:
    """The order chosen by BIC on the output-error fits, with the evidence.

    Attributes
    ----------
    structure : tuple of int
        (poles, zeros) of the chosen velocity TF.
    result : OeResult
        Its fit.
    model : MotorModel
        Its model (``uncertainty`` widened by the structure uncertainty, see
        :func:`structure_uncertainty`).
    table : list of dict
        Every structure tried: poles, zeros, delay, BIC, AIC, weighted RMS, BIC weight.
    runner_up : tuple of int or None
        The second-best structure.
    evidence : str
        The choice in words (ΔBIC to the runner-up).
    delay : bool
        Whether the chosen structure has a fitted dead time.
    noise : NoiseModel or None
        The noise model of the final fit.
    """

    structure: tuple[int, int]
    result: OeResult
    model: MotorModel
    table: list[dict[str, Any]]
    runner_up: tuple[int, int] | None
    evidence: str
    delay: bool = False
    noise: NoiseModel | None = None


def _describe(structure: tuple[int, int], delay: bool) -> str:
    return f"{structure[0]} pole(s) and {structure[1]} zero(s)" + (" with a dead time" if delay else "")


def structure_uncertainty(best: MotorModel, fits: list[tuple[float, MotorModel]]) -> Uncertainty | None:
    """The chosen model's uncertainty widened by the spread between candidate structures.

    The Gauss–Newton interval is conditional on the structure.  Each candidate gets its
    BIC weight ``w_i ∝ exp(−ΔBIC_i/2)`` (an approximation of its posterior probability);
    the variance of the DC gain and of the residence time ``τ + delay`` adds
    ``Σ w_i (θ_i − θ_best)²`` to the chosen structure's own (the model-averaging variance
    of Buckland et al. 1997 about the chosen estimate, so the interval stays centred on the
    headline number).  With a clear winner (ΔBIC ≫ 10) nothing changes.

    Parameters
    ----------
    best : MotorModel
        The chosen fit (its ``uncertainty`` from the output-error fit).
    fits : list of (bic, MotorModel)
        Every candidate, the chosen one included.

    Returns
    -------
    Uncertainty or None
        The widened uncertainty (``structure_std`` set on ``dc_gain``, ``time_constant``,
        ``residence_time_s`` and ``t63_s``); ``best``'s own when there is nothing to widen.
    """
    u = best.uncertainty
    if u is None or len(fits) < 2:
        return u
    bics = np.array([b for b, _ in fits], dtype=float)
    w = np.exp(-0.5 * (bics - bics.min()))
    w /= w.sum()
    fo_best = best.first_order()

    def own(key: str) -> Any:
        def value(m: MotorModel) -> float:
            item = None if m.uncertainty is None else m.uncertainty.headline(key)
            return float("nan") if item is None else float(np.real(item.value))
        return value

    changes: dict[str, Any] = {}
    for key, value_of in (("dc_gain", lambda m: m.first_order().dc_gain),
                          ("time_constant", lambda m: m.first_order().time_constant_s + m.delay_s - best.delay_s),
                          ("residence_time_s", own("residence_time_s")), ("t63_s", own("t63_s"))):
        item = u.headline(key)
        if item is None:
            continue
        centre = float(np.real(item.value))
        ref = {"dc_gain": fo_best.dc_gain, "time_constant": fo_best.time_constant_s}.get(key, centre)
        vals = np.array([value_of(m) for _, m in fits], dtype=float)
        ok = np.isfinite(vals)
        extra = float(np.sum(w[ok] * (vals[ok] - ref) ** 2))
        std = float(np.hypot(item.stderr, np.sqrt(extra)))
        changes[key] = replace(item, stderr=std, ci95=(centre - 1.96 * std, centre + 1.96 * std),
                               structure_std=float(np.sqrt(extra)))
    return u.replace(**changes, method=u.method + "; widened by the BIC-weighted spread of the candidate "
                     "structures (dc gain, τ + dead time)")


def reading_allowances(u: Uncertainty | None, cond: ConditionedExperiment) -> Uncertainty | None:
    """The intervals of τ, the residence time and the 63 % time widened by what the data cannot tell apart.

    - **A read-off onset** (upper ends).  A channel without an input has its step instant read
      off its response (``timing == "onset"``) and fitted.  A lag shorter than half a sample (a
      pole beyond ``2/dt``, which no structure the order search keeps can have) moves the response
      as a later instant does: the fit puts it in the instant, and τ and the residence time come
      out short by it (an encoder log at 5 ms of a motor with a 1 ms electrical pole: 2 % short,
      against an interval of ±0.6 %).  Each interval's upper end moves up by half the coarsest
      such channel's sample interval (:attr:`~motorid.model.uncertainty.Uncertainty.onset_lag_s`).
    - **A speed that may count** (lower ends).  A velocity fitted as samples whose values come in
      whole steps (``count_step``: encoder edges counted over each line, or an ADC's codes at a
      steady rate, which look alike) may be the mean over the line before each value: the motor
      is then quicker by half a line, and the model, fitted to samples, cannot be (an rpm log at
      10 ms: +0.05 % against an interval of ±0.03 %, the motor 4 % quicker).  Each interval's
      lower end moves down by that lag, half its sample interval (and half the hold of a value kept
      over several lines: :func:`~motorid.conditioning.response.counting_lag`)
      (:attr:`~motorid.model.uncertainty.Uncertainty.counting_lag_s`); ``--counted-velocity``
      says that it counts, and fits it so.

    The standard errors and the values stay.

    Parameters
    ----------
    u : Uncertainty or None
        The chosen fit's uncertainty.
    cond : ConditionedExperiment
        The captures it was fitted to.

    Returns
    -------
    Uncertainty or None
        ``u`` with the ends moved, or ``u`` itself when neither applies.
    """
    onset = [r.sample_interval_s for r in cond.responses.values() if r.timing == "onset"]
    counting = [counting_lag(r) for r in cond.responses.values() if r.count_step > 0]
    if u is None or not (onset or counting):
        return u
    lag = 0.5 * max(onset, default=0.0)
    early = max(counting, default=0.0)
    changes: dict[str, Any] = {}
    for key in ("time_constant", "residence_time_s", "t63_s"):
        item = u.headline(key)
        if item is not None and item.ci95 is not None:
            changes[key] = replace(item, ci95=(item.ci95[0] - early, item.ci95[1] + lag))
    return u.replace(**changes, onset_lag_s=lag, counting_lag_s=early)


#: Structures whose BIC differ by less than this are a tie (Kass & Raftery 1995: "not worth
#: more than a bare mention"): the one with fewer parameters is kept.
TIE_BIC = 2.0


def _simplest_of_ties(fits: list[Any]) -> tuple[list[Any], bool]:
    """Fits sorted by BIC, with the simplest of those within :data:`TIE_BIC` of the best moved first.

    A fit is ``(bic, (poles, zeros), delay, …)``; its size is poles + zeros + delay.  Returns the
    list and whether a tie decided the first place.
    """
    ties = [f for f in fits if f[0] - fits[0][0] < TIE_BIC]
    simplest = min(ties, key=lambda f: (f[1][0] + f[1][1] + int(f[2]), f[0]))
    if simplest is fits[0]:
        return fits, False
    # the runner-up is then the best by BIC
    return [simplest] + [f for f in fits if f is not simplest], True


def dead_time_shows(cond: ConditionedExperiment) -> bool:
    """Whether the data show an apparent dead time worth fitting.

    At least :data:`DEAD_TIME_SAMPLES` recorded samples in the noise band after the step, or, on
    a coarse grid, one sample and :data:`DEAD_TIME_FRACTION` of the 63 % time.

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.

    Returns
    -------
    bool
    """
    dt_rec = min(r.sample_interval_s for r in cond.responses.values())
    dead = cond.dead_time_s * (1 + 1e-9)
    t63 = cond.response_time_s if np.isfinite(cond.response_time_s) else np.inf
    return bool(dead >= DEAD_TIME_SAMPLES * dt_rec or (dead >= dt_rec and dead >= DEAD_TIME_FRACTION * t63))


def _refit(cond: ConditionedExperiment, fit: Any, noise: NoiseModel,
           options: OutputErrorOptions) -> tuple[Any, NoiseModel]:
    """A fit refitted under the noise model of its own residuals; the fit itself when that fails.

    The preliminary two-pole fit may leave model error that the AR model took for noise.
    """
    refined = refine_noise(noise, fit[3])
    try:
        res, model = oe_stage(cond, fit[4], fit[1], noise=refined, delay=fit[2], tolerance=options.tolerance,
                              max_nfev=options.max_nfev)
    except IdentificationError:
        return fit, refined
    if np.isfinite(res.bic) and np.all(np.real(res.poles) < 0):
        return (fit[0], fit[1], fit[2], res, model), refined
    return fit, refined


#: Why a structure is not one the data support (:func:`unsupported_because`), in the words the
#: choice's evidence uses after "the data do not …".
UNRESOLVED_POLE = ("resolve its extra pole (its interval reaches the right half-plane or is wider than the "
                   "pole)")
UNDEMANDED_ZERO = ("demand its right-half-plane zero (its interval reaches the left half-plane; an inverse "
                   "response, which a DC motor's velocity does not have)")


def unsupported_because(res: OeResult) -> str:
    """Why the data do not support a fit's structure; empty when they do.

    Every pole must be resolved, alone or as a pair (:func:`unresolved_pairs`): its 95 %
    interval stays in the left half-plane and is narrower than the pole itself.  A zero in the
    right half-plane must be demanded: its whole 95 % interval lies there (the sanity gate's
    rule, :func:`motorid.identification.sanity.sanity_checks`); otherwise a structure with
    fewer zeros describes the record as well.

    Parameters
    ----------
    res : OeResult
        An output-error result.

    Returns
    -------
    str
        :data:`UNRESOLVED_POLE`, :data:`UNDEMANDED_ZERO` or ``""``.
    """
    paired = {j for i in unresolved_pairs(res) for j in (i, i + 1)}
    for i, p in enumerate(res.poles):
        lo, hi = res.ci95.get(f"pole_{i}", (float("nan"), float("nan")))
        if i in paired or not np.isfinite(lo + hi):
            continue
        if pole_unresolved(float(np.real(p)), lo, hi):
            return UNRESOLVED_POLE
    for i, z in enumerate(res.zeros):
        lo, _ = res.ci95.get(f"zero_{i}", (float("nan"), float("nan")))
        if zero_undemanded(float(np.real(z)), lo):
            return UNDEMANDED_ZERO
    return ""


def resolved(res: OeResult) -> bool:
    """Whether the data support a fit's structure (:func:`unsupported_because` is empty).

    Parameters
    ----------
    res : OeResult
        An output-error result.

    Returns
    -------
    bool
    """
    return not unsupported_because(res)


def _supported_first(fits: list[Any]) -> tuple[list[Any], str]:
    """Fits with the best one the data support moved first, and why it replaced the first ('' if none)."""
    if not fits or resolved(fits[0][3]):
        return fits, ""
    ok = next((f for f in fits if resolved(f[3])), None)
    if ok is None:
        return fits, ""
    return [ok] + [f for f in fits if f is not ok], _replaced(fits[0])


def _replaced(fit: Any) -> str:
    """The evidence's words for a better-fitting structure the data do not support."""
    return (f"{_describe(fit[1], fit[2])} fits better but the data do not {unsupported_because(fit[3])}: the "
            "structure the data support is kept")


def _order_stalled(best_of: dict[int, float], order: int) -> bool:
    """Whether the search stops before ``order`` poles: the last order fitted did not lower BIC.

    Ascending orders, BIC's penalty grows by ``ln N`` per parameter while the misfit a further
    pole removes shrinks: when ``n`` poles fitted no better than ``n − 1`` (by BIC), ``n + 1``
    would not either, and their fits — slow to converge, their extra poles cancelled by zeros —
    are left out (on a first-order record the three-pole fits were 60 % of the search).
    """
    fitted = sorted(n for n in best_of if n < order)
    return len(fitted) >= 2 and best_of[fitted[-1]] >= best_of[fitted[-2]]


#: Why a candidate whose pole or zero is faster than half a recorded sample is not kept.
BEYOND_SAMPLING = "a pole or zero beyond the sampling rate, faster than the record can show"
#: A candidate structure whose BIC is this much above the best one's is not worth finishing
#: (Kass & Raftery 1995: "very strong" evidence against it; its BIC weight is under 1 %).
FAR_BIC = 10.0


def _most_poles(fits: list[Any], orders: tuple[int, ...]) -> int:
    """The most poles a structure with a dead time is tried with: those of the best fit without one.

    A dead time stands in for the lag of fast poles, it does not need more of them: the delay
    variants with more poles than the best no-delay fit were a third of such a search, and came
    out far above the best or were dropped (the second-order trainer, six seeds: 25–123 BIC above it).
    """
    return min(fits, key=lambda f: f[0])[1][0] if fits else max(orders)


def _candidate_fit(cond: ConditionedExperiment, start: MotorModel, structure: tuple[int, int], noise: NoiseModel,
                   delay: bool, options: OutputErrorOptions, best_bic: float) -> tuple[OeResult, MotorModel, bool]:
    """One candidate of the order search, given up once past ``options.search_nfev`` evaluations if still far.

    A candidate whose BIC is still :data:`FAR_BIC` or more above the best BIC so far once it has
    made ``options.search_nfev`` evaluations stops there, flagged (the last value ``True``:
    :func:`select_order` leaves it out, and says so).  The solver checks after each iteration,
    so a candidate that is not given up takes the same iterates as with no such rule.
    """
    give_up = (options.search_nfev, best_bic + FAR_BIC) if np.isfinite(best_bic) else None
    res, model = oe_stage(cond, start, structure, noise=noise, delay=delay, tolerance=options.search_tolerance,
                          max_nfev=options.max_nfev, give_up=give_up)
    return res, model, any(w.startswith(GAVE_UP) for w in res.warnings)


def select_order(
    cond: ConditionedExperiment,
    init: MotorModel,
    orders: tuple[int, ...] = (1, 2, 3),
    *,
    delay: bool | None = False,
    options: OutputErrorOptions = DEFAULT_OUTPUT_ERROR,
) -> OrderSelection:
    """Fit every structure of the given orders and keep the smallest BIC.

    BIC (``N ln(RSS_w/N) + p ln N`` on the noise-weighted residuals) penalises each extra
    parameter by ``ln N``; with thousands of samples a pole must explain a real part of the
    response to be kept.  What the search leaves out, its evidence says: orders past one that
    did not lower BIC, structures with a dead time and more poles than the best fit without one,
    and candidates still :data:`FAR_BIC` above the best when ``options.search_nfev`` evaluations
    are spent.

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.
    init : MotorModel
        The model the fit starts from (a paper method's).
    orders : tuple of int
        Numbers of poles to try (default 1, 2, 3).
    delay : bool or None
        ``True``: every structure with a fitted dead time; ``False``: none; ``None``: both
        when the data show an apparent dead time of at least :data:`DEAD_TIME_SAMPLES`
        samples (or :data:`DEAD_TIME_FRACTION` of the 63 % time), BIC deciding.
    options : OutputErrorOptions
        Evaluations and tolerances: the candidates stop at ``search_tolerance``, the chosen
        structure's refit at ``tolerance``.

    Returns
    -------
    OrderSelection
        The chosen structure, its model and the table of every fit.

    Raises
    ------
    IdentificationError
        When no structure could be fitted.
    """
    # the structures fitted and not kept, (structure, with a dead time, why): the error when none is kept,
    # the evidence's words when another is
    dropped: list[tuple[tuple[int, int], bool, str]] = []
    skipped: list[str] = []
    left: list[str] = []  # candidates left far from the best when their evaluations ran out
    beyond: list[str] = []  # delay variants with more poles than the best fit without a delay
    noise = noise_model(cond, init, options)
    # every structure starts from the preliminary fit (near its optimum already: a few
    # iterations), except when that had fewer poles than the structure: three poles then
    # start from the paper's model, whose third pole a two-pole fit cannot suggest
    quick = noise.preliminary if noise.preliminary is not None else init
    n_quick = int(quick.settings.get("n_poles", 0)) if noise.preliminary is not None else 0
    dt_rec = min(r.sample_interval_s for r in cond.responses.values())
    fastest = 2.0 / dt_rec
    tried_delay = delay is None and dead_time_shows(cond)
    variants = (False, True) if tried_delay else (bool(delay),)
    fits: list[tuple[float, tuple[int, int], bool, OeResult, MotorModel]] = []
    for with_delay in variants:
        models: dict[tuple[int, int], MotorModel] = {}
        best_of: dict[int, float] = {}  # the smallest BIC of each order fitted so far
        most = _most_poles(fits, orders) if with_delay else max(orders)
        for order in orders:
            if order > most:
                beyond.append(f"{order} poles with a dead time")
                continue
            if _order_stalled(best_of, order):
                skipped.append(f"{order} poles{' with a dead time' if with_delay else ''}")
                continue
            for structure in STRUCTURES[order]:
                # a structure with a zero less starts from the same number of poles with it
                start = models.get((structure[0], structure[1] + 1))
                if start is None:
                    start = quick if structure[0] <= n_quick and not with_delay else init
                best_bic = min((f[0] for f in fits), default=np.inf)
                try:
                    res, model, far = _candidate_fit(cond, start, structure, noise, with_delay, options, best_bic)
                except IdentificationError as exc:
                    dropped.append((structure, with_delay, exc.message))
                    continue
                if not np.isfinite(res.bic) or np.any(np.real(res.poles) >= 0):
                    dropped.append((structure, with_delay, "unstable or failed fit"))
                    continue
                if far:
                    left.append(f"{_describe(structure, with_delay)} (BIC {res.bic - best_bic:.0f} "
                                f"above the best after {res.nfev} evaluations)")
                    continue
                # a pole or zero faster than half a recorded sample is not seen by the data: the
                # fit parked a superfluous parameter there (and its realisation is ill-conditioned)
                roots = np.r_[res.poles, res.zeros]
                if roots.size and np.max(np.abs(roots)) > fastest:
                    dropped.append((structure, with_delay, BEYOND_SAMPLING))
                    continue
                models[structure] = model
                best_of[order] = min(best_of.get(order, np.inf), res.bic)
                fits.append((res.bic, structure, with_delay, res, model))
    if not fits:
        onsets = [f"{role} at {r.edge.time_s:.6g} s" for role, r in cond.responses.items() if r.timing == "onset"]
        hint = ("; the step instant was read off the response itself (" + ", ".join(onsets) + "): if the motion "
                "starts elsewhere, give it with --t0") if onsets else ""
        errors = [f"{structure}{' + delay' if with_delay else ''}: "
                  + ("a pole or zero beyond the sampling rate" if why == BEYOND_SAMPLING else why)
                  for structure, with_delay, why in dropped]
        raise IdentificationError("the output-error fit failed for every order: " + "; ".join(errors) + hint)
    fits.sort(key=lambda f: f[0])
    fits, _ = _simplest_of_ties(fits)
    fits, unsupported = _supported_first(fits)
    bic0 = min(f[0] for f in fits)
    weights = np.exp(-0.5 * (np.array([f[0] for f in fits]) - bic0))
    weights /= weights.sum()
    table = [
        {"poles": s[0], "zeros": s[1], "delay": d, "bic": b, "aic": r.aic,
         "weighted_rms": float(np.sqrt(max(r.cost, 0.0) * 2 / max(r.n_samples, 1))), "bic_weight": float(wt),
         **({"delay_s": r.delay_s} if d else {})}
        for (b, s, d, r, _), wt in zip(fits, weights, strict=False)
    ]
    best, refined = _refit(cond, fits[0], noise, options)
    if not resolved(best[3]):
        # refitted under its own noise model, the chosen structure no longer resolves a pole: the
        # next structure the data support, refitted the same way
        for alt in fits[1:]:
            if resolved(alt[3]):
                cand, cand_noise = _refit(cond, alt, noise, options)
                if resolved(cand[3]):
                    unsupported = unsupported or _replaced(best)
                    fits = [alt] + [f for f in fits if f is not alt]
                    best, refined = cand, cand_noise
                    break
    # only structures the data support are averaged over: an unresolved one's residence time
    # counts a pole–zero pair the data cannot place (it would stretch the interval past zero)
    others = [(b, m) for b, _, _, r, m in fits[1:] if resolved(r)]
    widened = structure_uncertainty(best[4], [(best[0], best[4]), *others])
    model = best[4].replace(uncertainty=reading_allowances(widened, cond))
    runner = fits[1] if len(fits) > 1 else None
    if runner is None:
        evidence = f"only {_describe(best[1], best[2])} {'remained' if dropped else 'could be fitted'}"
    elif abs(runner[0] - best[0]) < TIE_BIC:
        evidence = (f"BIC cannot tell {_describe(best[1], best[2])} from {_describe(runner[1], runner[2])} "
                    f"(|ΔBIC| = {abs(runner[0] - best[0]):.1f} < {TIE_BIC:g}, a tie): the simpler is kept")
    elif runner[0] < best[0]:  # kept because the runner-up's extra pole is not resolved (said below)
        evidence = (f"BIC prefers {_describe(runner[1], runner[2])} over "
                    f"{_describe(best[1], best[2])} by ΔBIC = {best[0] - runner[0]:.1f}")
    else:
        evidence = (f"BIC prefers {_describe(best[1], best[2])} over "
                    f"{_describe(runner[1], runner[2])} by ΔBIC = {runner[0] - best[0]:.1f}")
    if unsupported:
        evidence += f"; {unsupported}"
    if len(variants) == 2:
        evidence += (f" (a dead time was tried: the data stay in their noise band for "
                     f"{1e3 * cond.dead_time_s:.3g} ms after the step)")
    for why in dict.fromkeys(w for _, _, w in dropped):
        evidence += f"; not kept ({why}): {', '.join(_describe(s, d) for s, d, w in dropped if w == why)}"
    if skipped:
        evidence += f"; {', '.join(dict.fromkeys(skipped))} not fitted (one pole fewer did not lower BIC)"
    if beyond:
        evidence += (f"; {', '.join(beyond)} not fitted (a dead time takes the place of fast poles: no more poles "
                     "than the best fit without one)")
    if left:
        evidence += (f"; {', '.join(left)} not fitted further (a candidate still {FAR_BIC:g} or more above the "
                     "best is not worth finishing)")
    return OrderSelection(best[1], best[3], model, table, None if runner is None else runner[1], evidence,
                          best[2], refined)
