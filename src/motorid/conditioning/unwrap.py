"""Unwrapping of the position potentiometer/encoder sawtooth, with glitch removal.

The output-shaft potentiometer jumps from about +10 V to about −10 V at each turn, often
through a few near-zero samples while the wiper crosses the gap (Masoud 2019, Figs. 22/24;
lab report Fig. 2).  The paper unwraps with two spreadsheet snippets that add a hard-coded
20.4 V at each jump.  This generalises them: jumps are found from the data, samples inside a
jump are treated as glitches and interpolated, and the span is estimated from all samples at
once as the value that makes the unwrapped signal smooth — a linear least-squares problem:
``y_i = s(t_i) − span · W_i`` with ``s`` a cubic B-spline and ``W_i`` the cumulative wrap
count.  ``numpy.unwrap`` needs the period in advance and knows nothing about glitches, hence
this module.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.conditioning.edge import noise_level, quantisation_step
from motorid.errors import ConditioningError

__all__ = ["UnwrapResult", "count_wraps", "unwrap_position"]


@dataclass(frozen=True, slots=True)
class UnwrapResult:
    """An unwrapped position record.

    Attributes
    ----------
    position_v : ndarray
        Continuous position in the channel's volts (glitch samples interpolated).
    wraps : int
        Number of wraps (jumps of one span) found.
    span_v : float or None
        The span of one turn in volts (``None`` when there was no wrap and none was given).
    jump_indices : ndarray of int
        Index of the first good sample after each wrap.
    glitch_indices : ndarray of int
        Samples replaced by interpolation (inside jumps, or isolated spikes).
    warnings : tuple of str
        Ambiguous jumps and the like.
    wrap_count : ndarray of int or None
        Turns added to each sample (``position_v = y + span_v·wrap_count`` outside glitches):
        a span a little off leaves a step of ``wrap_count × error`` that a model fit can take
        up as a nuisance parameter.  ``None`` when nothing was unwrapped.
    """

    position_v: np.ndarray
    wraps: int
    span_v: float | None
    jump_indices: np.ndarray
    glitch_indices: np.ndarray
    warnings: tuple[str, ...]
    wrap_count: np.ndarray | None = None


def _events(y: np.ndarray, threshold: float, max_glitch: int) -> list[tuple[int, int]]:
    """Group large first differences into events (a, b): a = last good, b = first good."""
    big = np.flatnonzero(np.abs(np.diff(y)) > threshold)
    events: list[tuple[int, int]] = []
    for j in big:
        if events and j - events[-1][1] < max_glitch + 1:
            events[-1] = (events[-1][0], int(j) + 1)
        else:
            events.append((int(j), int(j) + 1))
    return events


def _fit_span(t: np.ndarray, y: np.ndarray, w: np.ndarray, good: np.ndarray) -> float:
    """Least-squares span with a smooth cubic B-spline for the continuous position.

    The number of knots is chosen by BIC among a few spacings: too many knots let the spline
    follow the 8-bit quantisation staircase and bias the span; too few cannot follow the
    acceleration of the motor.
    """
    from scipy.interpolate import BSpline  # loads on use (start-up)

    tg, yg, wg = t[good], y[good], w[good]
    best: tuple[float, float] | None = None
    for spacing in (100, 50, 25):
        n_knots = int(np.clip(tg.size // spacing, 2, 400))
        inner = np.linspace(tg[0], tg[-1], n_knots)
        knots = np.r_[[tg[0]] * 3, inner, [tg[-1]] * 3]
        # the design is banded (four B-splines per sample) and the wraps one dense column: the normal
        # equations from the sparse design cost a fifth of a dense least squares on 2 500 samples and
        # give the same span (to 1e-15 on the paper's capture; cubic B-splines are well conditioned)
        design = BSpline.design_matrix(tg, knots, 3)
        rows = design.T.tocsr()
        gram = np.empty((design.shape[1] + 1,) * 2)
        gram[:-1, :-1] = (rows @ design).toarray()
        gram[:-1, -1] = gram[-1, :-1] = -(rows @ wg)
        gram[-1, -1] = wg @ wg
        sol = np.linalg.lstsq(gram, np.r_[rows @ yg, -(wg @ yg)], rcond=None)[0]
        resid = design @ sol[:-1] - wg * sol[-1] - yg
        rss = float(resid @ resid)
        bic = tg.size * np.log(max(rss, 1e-300) / tg.size) + gram.shape[0] * np.log(tg.size)
        if best is None or bic < best[0]:
            best = (bic, float(sol[-1]))
    assert best is not None
    return best[1]


def unwrap_position(
    y: np.ndarray,
    *,
    span_v: float | None = None,
    jump_fraction: float = 0.5,
    max_glitch: int = 4,
    file: str | None = None,
) -> UnwrapResult:
    """Unwrap a sawtooth position record.

    Parameters
    ----------
    y : ndarray
        Position channel samples (uniformly sampled).
    span_v : float, optional
        Volts per turn; estimated from the data when omitted.
    jump_fraction : float
        A jump is a change of more than this fraction of the span (of the signal's range
        while the span is unknown) within ``max_glitch + 1`` samples.
    max_glitch : int
        Most glitch samples expected inside one jump.
    file : str, optional
        Named in error messages.

    Returns
    -------
    UnwrapResult
        The continuous position and what was done to get it.

    Raises
    ------
    ConditioningError
        When the record is too short or the span cannot be estimated.

    References
    ----------
    Masoud 2019, section V-2 (the two unwrapping snippets, generalised).
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    if n < 8:
        raise ConditioningError(f"position record of {n} samples is too short to unwrap", file=file)
    lo, hi = np.percentile(y, [0.5, 99.5])
    rng = float(hi - lo)
    noise = noise_level(y)
    warnings: list[str] = []
    ref = span_v if span_v is not None else rng
    d = np.abs(np.diff(y))
    quantum = quantisation_step(y)
    # a wrap is a change far above the ordinary sample-to-sample motion (noise, one code of
    # the 8-bit quantiser, the motion itself); with glitches a jump is split into several
    # steps of about half the span each, hence 0.3 of the span
    typical = float(np.percentile(d, 90)) if d.size else 0.0
    threshold = max(0.3 * ref, 10.0 * noise, 10.0 * quantum, 5.0 * typical)
    if rng <= threshold:
        return UnwrapResult(y.copy(), 0, span_v, np.array([], int), np.array([], int), ())
    events = _events(y, threshold, max_glitch)
    t = np.arange(n, dtype=float)
    glitches: list[int] = []
    for a, b in events:
        glitches.extend(range(a + 1, b))
    steps = []
    continuous = []
    bounds = [0] + [b for _, b in events]
    ends = [a for a, _ in events] + [n - 1]
    noise_eff = max(noise, quantum / np.sqrt(12.0))
    for k, (a, b) in enumerate(events):
        # the shaft moves on through a wrap: the slopes on both sides agree.  A step of a
        # velocity or current signal (flat before, rising or decaying after) does not.
        left = y[max(bounds[k], a - 19) : a + 1]
        right = y[b : min(ends[k + 1], b + 19) + 1]
        s_left = np.polyfit(np.arange(left.size), left, 1)[0] if left.size >= 3 else np.nan
        s_right = np.polyfit(np.arange(right.size), right, 1)[0] if right.size >= 3 else np.nan
        if np.isnan(s_left) or np.isnan(s_right):
            slope = 0.0 if np.isnan(s_left) and np.isnan(s_right) else float(np.nanmean([s_left, s_right]))
            continuous.append(True)
        else:
            m = min(left.size, right.size)
            se = noise_eff * np.sqrt(12.0 / m**3)
            continuous.append(abs(s_left - s_right) <= 0.5 * max(abs(s_left), abs(s_right)) + 6.0 * se)
            slope = 0.5 * (s_left + s_right)
        steps.append(float(y[b] - y[a] - slope * (b - a)))
    steps_arr = np.asarray(steps)
    keep = [i for i, c in enumerate(continuous) if c]
    for i, c in enumerate(continuous):
        if not c:
            warnings.append(f"jump at sample {events[i][1]} is a step of the signal, not a wrap: left as is")
    events = [events[i] for i in keep]
    steps_arr = steps_arr[keep]
    glitches = [g for a, b in events for g in range(a + 1, b)]
    if span_v is None:
        wrapping = np.abs(steps_arr) > jump_fraction * rng
        span0 = None if not np.any(wrapping) else float(np.median(np.abs(steps_arr[wrapping])))
    else:
        span0 = float(span_v)
    counts = np.zeros(len(events), dtype=int)
    if span0 is not None:
        ratio = -steps_arr / span0
        counts = np.rint(ratio).astype(int)
        frac = np.abs(ratio - counts)
        for (_a, b), fr in zip(events, frac, strict=False):
            if fr > 0.25:
                warnings.append(f"ambiguous jump at sample {b} ({fr:.2f} of a span off a whole turn)")
    w = np.zeros(n)
    for (_a, b), c in zip(events, counts, strict=False):
        w[b:] += c
    glitch_idx = np.array(sorted(set(glitches)), dtype=int)
    good = np.ones(n, dtype=bool)
    good[glitch_idx] = False
    wraps = int(np.sum(np.abs(counts)))
    span = span0
    if wraps and span_v is None:
        span = _fit_span(t, y, w, good)
        if not np.isfinite(span) or span <= 0:
            raise ConditioningError("could not estimate the encoder span from the jumps; give it", file=file)
    out = y + (span or 0.0) * w
    if glitch_idx.size:
        out[glitch_idx] = np.interp(t[glitch_idx], t[good], out[good])
    if len(glitch_idx) > max_glitch * max(1, len(events)):
        warnings.append(f"{len(glitch_idx)} glitch samples interpolated")
    jump_idx = np.array([b for (a, b), c in zip(events, counts, strict=False) if c != 0], dtype=int)
    return UnwrapResult(out, wraps, span, jump_idx, glitch_idx, tuple(warnings), w.astype(int) if wraps else None)


def count_wraps(y: np.ndarray, **kwargs: object) -> int:
    """Number of wraps in a position record (see :func:`unwrap_position`).

    Parameters
    ----------
    y : ndarray
        Position samples in volts.
    **kwargs
        Passed on to :func:`unwrap_position`.

    Returns
    -------
    int
        The number of wraps removed.
    """
    return unwrap_position(y, **kwargs).wraps  # type: ignore[arg-type]
