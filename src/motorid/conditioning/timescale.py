"""The time scales of a step response, read off the data.

Every default of the pipeline that is a duration (sample reduction, record trimming, the dead time's
starting value) comes from here rather than from the paper's bench (the paper's
0.1 s left three samples of a 15 ms motor).

Read-offs, not fits: the 63 % time and the apparent dead time of the smoothed response are
robust on any record that shows a step response, and the fits that follow refine them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.blockwise import BLOCK
from motorid.conditioning.edge import noise_level, quantisation_step

__all__ = ["SAMPLES_PER_TIME_CONSTANT", "ResponseTimes", "auto_reduction_ratio", "response_times"]

#: Reduced samples per 63 % time chosen by ``--sample-interval auto``: the paper's 0.1 s on
#: its 0.43 s motor is 4.3; a little finer keeps the five-point derivative's truncation error
#: small without amplifying the noise of the difference quotients much more.
SAMPLES_PER_TIME_CONSTANT = 5.0
#: Fewest reduced samples after the step that the automatic choice keeps (pinv fits up to
#: four coefficients per row and drops two samples at each end).
MIN_REDUCED_SAMPLES = 25
#: Samples after the step that must stay above the noise band for the response to count as
#: started (a lone spike or a ripple peak does not).
PERSISTENCE = 3


@dataclass(frozen=True, slots=True)
class ResponseTimes:
    """Time scales of one step response (time 0 at the step).

    Attributes
    ----------
    t63_s : float
        First time the (lightly smoothed) response reaches 63.2 % of its final change; the
        time constant of a first-order response, plus any dead time.
    dead_time_s : float
        Apparent dead time: the last time before the response leaves its noise band for
        good (0 when it leaves at once).
    final : float
        Final change (mean of the last 10 % of the record).
    noise : float
        Noise level of the record used for the band (pre-step standard deviation, at least
        a quantisation level).
    """

    t63_s: float
    dead_time_s: float
    final: float
    noise: float


def response_times(time_s: np.ndarray, y: np.ndarray, *, pre: np.ndarray | None = None) -> ResponseTimes:
    """63 % time and apparent dead time of a step response.

    Parameters
    ----------
    time_s : ndarray
        Times from the step (≥ 0).
    y : ndarray
        Response increment (baseline removed), same length.
    pre : ndarray, optional
        Pre-step samples (baseline removed) for the noise level; the first differences of
        ``y`` otherwise.

    Returns
    -------
    ResponseTimes
        NaN times when the response never reaches 63 % or is flat.
    """
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(y, dtype=float)
    n = v.size
    if n < 4:
        return ResponseTimes(float("nan"), float("nan"), float("nan"), float("nan"))
    final = float(np.mean(v[-max(2, n // 10):]))
    quantum = quantisation_step(v, below=0.25 * abs(final)) if final else 0.0
    sd = float(np.std(pre)) if pre is not None and np.asarray(pre).size >= 5 else noise_level(v)
    noise = max(sd, quantum / np.sqrt(12.0), 1e-12)
    if final == 0.0 or abs(final) < 4.0 * noise:
        return ResponseTimes(float("nan"), float("nan"), final, noise)
    # the response normalised, z = v·sign/|final|, a block at a time, and first hits by argmax: no
    # array of the record's length on a 10 M-sample log
    norm = (float(np.sign(final)), abs(final))
    # a running median over a few samples takes ripple and spikes out without a phase lag
    width = int(min(max(3, n // 200 * 2 + 1), 31))
    import scipy.ndimage  # loads on use (start-up)

    first = _first_filtered_hit(v, width, 1.0 - np.exp(-1.0), scipy.ndimage.median_filter, norm=norm)
    t63 = float(t[first]) if first >= 0 else float("nan")
    band = (3.0 * noise + quantum) / abs(final)
    k = _first_run_above(v, band, norm)
    dead = float(t[k - 1]) if k > 0 else 0.0
    return ResponseTimes(t63, max(dead, 0.0), final, noise)


def _normalised(v: np.ndarray, norm: tuple[float, float] | None) -> np.ndarray:
    """``v·sign/|final|`` for ``norm = (sign, |final|)`` (a new array), ``v`` itself without one."""
    if norm is None:
        return v
    z = v * norm[0]
    z /= norm[1]
    return z


def _first_run_above(v: np.ndarray, band: float, norm: tuple[float, float]) -> int:
    """First sample from which :data:`PERSISTENCE` normalised samples in a row are above ``band`` (0 if none).

    The response has started there.  In blocks of :data:`BLOCK` (each with the ``PERSISTENCE − 1``
    samples after it): the same index as the test on the whole record.
    """
    n = v.size
    for start in range(0, max(n - PERSISTENCE + 1, 0), BLOCK):
        hi = min(n, start + BLOCK + PERSISTENCE - 1)
        out = _normalised(v[start:hi], norm) > band
        started = out[: hi - start - PERSISTENCE + 1].copy()
        for j in range(1, PERSISTENCE):
            started &= out[j : j + started.size]
        if started.any():
            return start + int(np.argmax(started))
    return 0


def _first_filtered_hit(z: np.ndarray, width: int, level: float, median_filter,
                        norm: tuple[float, float] | None = None) -> int:
    """First index where the running median of ``z`` (``width`` samples, ``mode="nearest"``) is ≥ ``level``; −1 if none.

    In blocks of :data:`BLOCK`, each filtered with ``width // 2`` samples of its neighbours on
    either side (at the record's ends, its own edge as the whole record's): a median is one of its
    window's samples, so every value is the whole record's, and the search stops at the block of
    the first hit instead of filtering a 10 M-sample record whole.  With ``norm = (sign, |final|)``
    each block is normalised, ``z·sign/|final|``, before it is filtered (the same bits as normalising
    the whole record first).
    """
    half = width // 2
    for start in range(0, z.size, BLOCK):
        lo, hi = max(0, start - half), min(z.size, start + BLOCK + half)
        filtered = median_filter(_normalised(z[lo:hi], norm), size=width, mode="nearest")
        filtered = filtered[start - lo : start - lo + BLOCK]
        hit = filtered >= level
        if hit.any():
            return start + int(np.argmax(hit))
    return -1


def auto_reduction_ratio(sample_interval_s: float, record_s: float, t63_s: float) -> tuple[int, str]:
    """The sample-reduction ratio chosen from the data, and why.

    Parameters
    ----------
    sample_interval_s : float
        Recorded sample interval.
    record_s : float
        Record length after the step.
    t63_s : float
        The response's 63 % time (:func:`response_times`).

    Returns
    -------
    (int, str)
        The ratio (≥ 1) and a sentence for the user.
    """
    if not np.isfinite(t63_s) or t63_s <= 0:
        target = record_s / MIN_REDUCED_SAMPLES
        why = "63 % time not found"
    else:
        target = t63_s / SAMPLES_PER_TIME_CONSTANT
        why = f"63 % time {t63_s:.4g} s / {SAMPLES_PER_TIME_CONSTANT:g}"
    target = min(target, record_s / MIN_REDUCED_SAMPLES)
    ratio = max(1, round(target / sample_interval_s))
    chosen = ratio * sample_interval_s
    text = (f"sample interval {chosen:.4g} s chosen from the data ({why}, at least "
            f"{MIN_REDUCED_SAMPLES} samples after the step; reduction by {ratio}); the paper's "
            "setting is --sample-interval 0.1")
    return ratio, text
