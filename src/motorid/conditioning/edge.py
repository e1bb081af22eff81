"""Step-edge detection: where the step happens, its level, and the pre-step baseline.

The paper finds the step instant by eye in Excel (Masoud 2019, section V-1).  Here it is the
least-squares single change point of CH1: the split of the record into two constant levels
with the smallest residual.  With cumulative sums this is exact and O(n); it is the maximum
likelihood edge for white noise and is not fooled by 8-bit quantisation (a threshold crossing
is, by a sample or two, when the level sits between two codes).  scipy has no single
change-point routine, hence the few lines here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.blockwise import BLOCK
from motorid.errors import ResponseNotStepError, StepNotFoundError

__all__ = [
    "MIN_POST_STEP_SAMPLES",
    "MIN_PRE_STEP_SAMPLES",
    "ResponseNotStepError",
    "StepEdge",
    "noise_level",
    "quantisation_step",
    "ramp_onset",
    "response_onset",
    "step_edge",
]

#: Samples needed before a step on the input channel (its baseline); a count, not a share of
#: the record, so that a long log with the step early in it is accepted.
MIN_PRE_STEP_SAMPLES = 10
#: Samples needed after a step on the input channel.
MIN_POST_STEP_SAMPLES = 20
#: A step input goes from 10 % to 90 % of its jump within a couple of samples (the scope's
#: front end); a change spread over more samples than this, and over more than
#: :data:`RESPONSE_RISE_FRACTION` of the record, is a response (tacho, current shunt).
MAX_STEP_RISE_SAMPLES = 8
#: See :data:`MAX_STEP_RISE_SAMPLES`: a slew-limited amplifier on a fast time base stays below.
RESPONSE_RISE_FRACTION = 0.01


# ResponseNotStepError lives in motorid.errors with every other user-facing error


@dataclass(frozen=True, slots=True)
class StepEdge:
    """A step found in a signal.

    Attributes
    ----------
    index : int
        Index of the first sample at the new level (for ``"onset"``: the first sample of
        the response after the onset).
    time_s : float
        Time of the edge on the signal's own time axis.
    baseline_v : float
        Mean level before the edge.
    level_v : float
        Mean level after the edge (for ``"onset"``: the final level, mean of the last 10%).
    amplitude_v : float
        ``level_v - baseline_v`` (signed).
    noise_v : float
        Robust standard deviation of the sample-to-sample noise.
    method : str
        ``"change-point"`` (an input step) or ``"onset"`` (from a response).
    """

    index: int
    time_s: float
    baseline_v: float
    level_v: float
    amplitude_v: float
    noise_v: float
    method: str


def noise_level(y: np.ndarray) -> float:
    """Robust white-noise standard deviation from first differences (MAD of ``diff``).

    Parameters
    ----------
    y : ndarray
        Samples.

    Returns
    -------
    float
        ``1.4826 · median|Δy − median Δy| / √2``; the median ignores edges and jumps.
    """
    d = np.diff(np.asarray(y, dtype=float))
    if d.size == 0:
        return 0.0
    # the deviations in place of the steps, each median taken in place (a median does not depend on the
    # order the partition leaves): one array of the record's length, not five
    d -= np.median(d, overwrite_input=True)
    np.abs(d, out=d)
    return float(1.4826 * np.median(d, overwrite_input=True) / np.sqrt(2.0))


def quantisation_step(y: np.ndarray, *, below: float = np.inf, valid: np.ndarray | None = None) -> float:
    """Smallest non-zero change between consecutive samples (one code of an 8-bit scope).

    Parameters
    ----------
    y : ndarray
        Samples.
    below : float
        Ignore changes at or above this (the step itself, a wrap).
    valid : ndarray of bool, optional
        Which of the ``len(y) − 1`` changes to consider (e.g. not across an unwrapped wrap
        or an interpolated glitch, which are off the code grid).

    Returns
    -------
    float
        The quantum, 0 when every sample is equal.
    """
    y = np.asarray(y, dtype=float)
    ok = None if valid is None else np.asarray(valid, dtype=bool)
    quantum = np.inf
    # in blocks of steps: the smallest is the same, without three arrays of the record's length
    for start in range(0, max(y.size - 1, 0), BLOCK):
        d = np.diff(y[start : start + BLOCK + 1])
        np.abs(d, out=d)
        if ok is not None:
            d = d[ok[start : start + d.size]]
        small = d[(d > 0) & (d < below)]
        if small.size:
            quantum = min(quantum, float(small.min()))
    return quantum if np.isfinite(quantum) else 0.0


def _best_split(y: np.ndarray, lo: int, hi: int) -> tuple[int, float]:
    """Index k in [lo, hi) minimising the residual of two constant levels y[:k], y[k:].

    The candidates are scored in blocks (the same numbers as one full-length pass, the first
    minimum kept as ``argmin`` keeps it): the two running sums are the only arrays of the
    record's length.
    """
    n = y.size
    c1 = np.cumsum(y)
    c2 = np.multiply(y, y)
    np.cumsum(c2, out=c2)  # a running sum is sequential: in place gives the same sums
    best_k, best = lo, np.inf
    for start in range(lo, hi, BLOCK):
        k = np.arange(start, min(hi, start + BLOCK))
        s_left, q_left = c1[k - 1], c2[k - 1]
        s_right, q_right = c1[-1] - s_left, c2[-1] - q_left
        sse = (q_left - s_left**2 / k) + (q_right - s_right**2 / (n - k))
        j = int(np.argmin(sse))
        if np.isnan(sse[j]):
            return int(k[j]), float(sse[j])  # argmin stops at the first NaN
        if sse[j] < best or start == lo:
            best_k, best = int(k[j]), float(sse[j])
    return best_k, best


def step_edge(
    time_s: np.ndarray,
    input_v: np.ndarray,
    *,
    file: str | None = None,
    min_before: int = MIN_PRE_STEP_SAMPLES,
    min_after: int = MIN_POST_STEP_SAMPLES,
) -> StepEdge:
    """Find the step on the input channel (CH1).

    Parameters
    ----------
    time_s, input_v : ndarray
        The record's time axis and input channel.
    file : str, optional
        Named in the error message.
    min_before, min_after : int
        The fewest samples allowed before and after the edge (:data:`MIN_PRE_STEP_SAMPLES`,
        :data:`MIN_POST_STEP_SAMPLES`).

    Returns
    -------
    StepEdge
        The edge, its levels and amplitude (``method="change-point"``).

    Raises
    ------
    StepNotFoundError
        When the record is no step: the residual of the two-level fit is far above the
        sample-to-sample noise (a sine, a ramp) or the jump is below 8 noise standard
        deviations; or the step is within ``min_before``/``min_after`` samples of an end.
    ResponseNotStepError
        When the change is spread over many samples (a tacho or shunt response recorded on
        CH1), see :data:`MAX_STEP_RISE_SAMPLES`.

    References
    ----------
    Masoud 2019, section V-1 (synchronisation of the captures on the step edge).
    """
    t = np.asarray(time_s, dtype=float)
    u = np.asarray(input_v, dtype=float)
    n = u.size
    lo = max(1, int(min_before))
    hi = n - max(1, int(min_after)) + 1
    if hi <= lo:
        raise StepNotFoundError(
            f"only {n} samples: too few to find a step ({lo} before and {n + 1 - hi} after it are needed)",
            file=file,
        )
    k_any, _ = _best_split(u, 1, n)
    k, sse = _best_split(u, lo, hi)
    total = float(np.sum((u - u.mean()) ** 2))
    if not lo <= k_any < hi and total > 0:
        where = "end" if k_any >= hi else "start"
        d_any = float(np.mean(u[k_any:]) - np.mean(u[:k_any]))
        if abs(d_any) > 8.0 * max(noise_level(u), 1e-12):
            need = f"at least {lo} samples before it" if where == "start" else f"at least {n + 1 - hi} after it"
            raise StepNotFoundError(
                f"the step is at the very {where} of the record (sample {k_any} of {n}; {need} "
                "are needed): trigger so that the step sits early in the record, with the response after it",
                file=file,
            )
    base = float(np.mean(u[:k]))
    level = float(np.mean(u[k:]))
    amp = level - base
    noise = noise_level(u)
    quantum = quantisation_step(u, below=0.25 * abs(amp))
    noise_eff = max(noise, quantum / np.sqrt(12.0), 1e-12)
    resid_rms = float(np.sqrt(max(sse, 0.0) / n))
    if total > 0 and amp != 0:
        _refuse_a_response(t, u, k, base, amp, noise_eff, file)
    # a step leaves white residuals at the noise level; a sine, ramp or triangle leaves a
    # structured residual far above the sample-to-sample noise
    if total == 0 or resid_rms > max(4.0 * noise_eff, 0.1 * abs(amp)) or abs(amp) < 8.0 * resid_rms:
        raise StepNotFoundError(
            f"no step in the input channel (two-level fit residual {resid_rms:.3g} V, "
            f"jump {amp:.3g} V, noise {noise_eff:.2g} V): identify needs an open-loop step on the input "
            "(a closed-loop record, a sine or a ramp is not one; motorid validate scores a model on any input)",
            file=file,
        )
    # The change point can land one sample early/late when an edge sample sits halfway
    # (finite rise time of the scope's front end): take the first sample past half-way.
    half = base + 0.5 * amp
    above = (u - half) * np.sign(amp) > 0
    j = k
    while j > lo and above[j - 1]:
        j -= 1
    while j < n - 1 and not above[j]:
        j += 1
    return StepEdge(
        index=j,
        time_s=float(t[j]),
        baseline_v=base,
        level_v=level,
        amplitude_v=amp,
        noise_v=noise,
        method="change-point",
    )


def _refuse_a_response(
    t: np.ndarray, u: np.ndarray, k: int, base: float, amp: float, noise: float, file: str | None
) -> None:
    """Raise :class:`ResponseNotStepError` when the change at ``k`` is a response's rise.

    A response (tacho, current shunt) leaves a flat baseline and rises over many samples,
    fast at first and slowing down (10→50 % quicker than 50→90 %, as an exponential:
    0.59 τ vs 1.61 τ); a step input jumps within a couple of samples, and a triangle or
    slew-limited ramp rises at a constant rate.
    """
    n = u.size
    rel = (u - base) / amp
    j = k
    while j > 1 and rel[j - 1] >= 0.5:
        j -= 1
    while j < n - 1 and rel[j] < 0.5:
        j += 1
    i10 = j - 1
    while i10 > 0 and rel[i10] > 0.1:
        i10 -= 1
    past = np.flatnonzero(rel[j:] >= 0.9)
    i90 = j + int(past[0]) if past.size else n - 1
    rise = max(0, i90 - i10 - 1)
    if rise <= max(MAX_STEP_RISE_SAMPLES, RESPONSE_RISE_FRACTION * n):
        return
    flat_before = float(np.std(u[: max(i10, 1)])) <= max(4.0 * noise, 0.05 * abs(amp))
    slowing = (j - i10) < 0.7 * (i90 - j)
    if not (flat_before and slowing):
        return
    dt = float(t[-1] - t[0]) / max(n - 1, 1)
    raise ResponseNotStepError(
        f"the input channel (CH1) looks like a response (tacho/shunt), not a step input: it takes "
        f"{rise} samples ({rise * dt:.3g} s) to go from 10 % to 90 % of its {amp:.3g} V change; "
        "give each channel as its own capture (e.g. --velocity CH1.CSV --current CH2.CSV) "
        "with --step-volts V (and --t0 T)",
        file=file,
    )


def ramp_onset(time_s: np.ndarray, position_v: np.ndarray, first_guess: StepEdge) -> StepEdge:
    """The onset of a position step response, from a model of the motion.

    A position driven by a step is a delayed, lagged ramp: ``θ0`` before the onset ``t0``, then
    ``θ0 + v·(t − t0 − τ(1 − e^{−(t−t0)/τ}))``.  A line through its early rise (the velocity's
    onset rule) meets the baseline near ``t0 + τ``, a time constant late; this fits ``θ0``, ``v``,
    ``τ`` and ``t0`` (``scipy.optimize.least_squares``) to the record, started from that read-off.

    Parameters
    ----------
    time_s, position_v : ndarray
        The record (an unwrapped position).
    first_guess : StepEdge
        :func:`response_onset`'s answer on the same record.

    Returns
    -------
    StepEdge
        ``method="onset"``, at the fitted ``t0`` (the read-off kept when the fit fails or leaves
        the record).
    """
    import scipy.optimize

    t = np.asarray(time_s, dtype=float)
    y = np.asarray(position_v, dtype=float)
    dt = float(np.median(np.diff(t)))
    i0 = first_guess.index
    tail = max(5, (t.size - i0) // 5)
    slope = float(np.polyfit(t[-tail:], y[-tail:], 1)[0]) if t.size - i0 > 5 else 0.0
    if slope == 0 or not np.isfinite(slope):
        return first_guess
    base = first_guess.baseline_v
    # the read-off is where the asymptote meets the baseline: t0 + τ
    t_hit = first_guess.time_s
    quiet = np.flatnonzero(np.abs(y[:i0 + 1] - base) <= 4.0 * first_guess.noise_v + 1e-12)
    t_quiet = float(t[quiet[-1]]) if quiet.size else float(t[0])
    tau0 = max(t_hit - t_quiet, 2 * dt)

    def model(p: np.ndarray) -> np.ndarray:
        th0, v, tau, t0 = p
        te = np.clip(t - t0, 0.0, None)
        return th0 + v * (te - tau * (1.0 - np.exp(-te / max(tau, 1e-12))))

    p0 = np.array([base, slope, tau0, max(t_hit - tau0, float(t[0]))])
    lower = [-np.inf, -np.inf, 1e-9, float(t[0]) - dt]
    upper = [np.inf, np.inf, float(t[-1] - t[0]), t_hit + dt]
    p0 = np.clip(p0, np.array(lower) + 1e-12, np.array(upper) - 1e-12)
    try:
        fit = scipy.optimize.least_squares(lambda p: model(p) - y, p0, bounds=(lower, upper), x_scale="jac")
    except (ValueError, np.linalg.LinAlgError):
        return first_guess
    t0 = float(fit.x[3])
    if not (fit.success and np.isfinite(t0) and t[0] - dt <= t0 <= t_hit + dt):
        return first_guess
    idx = min(max(int(np.searchsorted(t, t0)), 0), t.size - 1)
    return StepEdge(index=idx, time_s=t0, baseline_v=float(fit.x[0]), level_v=first_guess.level_v,
                    amplitude_v=first_guess.amplitude_v, noise_v=first_guess.noise_v, method="onset")


def response_onset(
    time_s: np.ndarray,
    output_v: np.ndarray,
    *,
    file: str | None = None,
    min_after_fraction: float = 0.05,
) -> StepEdge:
    """Find the instant a step response starts, for captures without an input channel.

    The trigger point is often not the step instant (docs/formats.md), so the onset is found
    from the response: the change point of the record gives its rise; the baseline is the
    mean before it and the onset is where a straight line through the early rise (10–30% of
    the amplitude) meets the baseline — exact for a first-order response, a little late
    (by the fast lags) for higher orders — but never before the last baseline sample.

    Parameters
    ----------
    time_s, output_v : ndarray
        The record's time axis and measured channel.
    file : str, optional
        Named in the error message.
    min_after_fraction : float
        The smallest fraction of the record allowed on either side of the onset.

    Returns
    -------
    StepEdge
        ``method="onset"``; ``level_v`` is the final level (mean of the last 10%).

    Raises
    ------
    StepNotFoundError
        When the response never leaves its baseline by 8 noise standard deviations.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(output_v, dtype=float)
    n = y.size
    lo = max(2, int(np.ceil(min_after_fraction * n)))
    hi = n - lo + 1
    if hi <= lo:
        raise StepNotFoundError(f"only {n} samples: too few to find a step response", file=file)
    k, _ = _best_split(y, lo, hi)
    noise = noise_level(y)
    pre = y[: max(2, k // 2)]
    base = float(np.median(pre))
    final = float(np.mean(y[-max(2, n // 10):]))
    peak_i = int(np.argmax(np.abs(y[k:] - base))) + k
    amp_ref = y[peak_i] - base  # a current response peaks then decays: use the peak
    if abs(amp_ref) < 8.0 * max(noise, 1e-12):
        raise StepNotFoundError(
            f"no step response: the signal never leaves its baseline (change {amp_ref:.3g} "
            f"vs noise {noise:.2g})",
            file=file,
        )
    sgn = np.sign(amp_ref)
    rel = (y - base) * sgn / abs(amp_ref)
    # first crossing of 30% after the baseline part, then walk back
    start = max(1, k // 2)
    i30 = start + int(np.argmax(rel[start:] >= 0.3))
    i10 = i30
    while i10 > 1 and rel[i10 - 1] >= 0.1:
        i10 -= 1
    quiet = np.flatnonzero(np.abs(y[:i10] - base) <= 4.0 * noise + 1e-12)
    last_quiet = int(quiet[-1]) if quiet.size else 0
    onset_t = float(t[i10])
    if i30 > i10:
        slope, icpt = np.polyfit(t[i10 : i30 + 1], y[i10 : i30 + 1], 1)
        if slope != 0:
            onset_t = float((base - icpt) / slope)
    onset_t = min(max(onset_t, float(t[last_quiet])), float(t[i10]))
    idx = int(np.searchsorted(t, onset_t))
    idx = min(max(idx, 0), n - 1)
    return StepEdge(
        index=idx,
        time_s=onset_t,
        baseline_v=base,
        level_v=final,
        amplitude_v=final - base,
        noise_v=noise,
        method="onset",
    )
