"""Reductions over a long record done a block at a time, so that no temporary is as long as it.

A 10 M-sample log is 80 MB a column; numpy's one-liners over it (``np.polyfit`` builds its
Vandermonde matrix and a scaled copy, ``(y − m)**2`` a temporary of the record's length) hold
two or three such arrays for a moment, and that moment is the command's peak memory.  The
functions here give the same results (to rounding) holding one block at a time.  numpy has no
streaming reductions of this kind, hence these few lines.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BLOCK", "line_slope", "variance"]

#: Samples per block: 2 MB of float64, small beside a long record and large enough that the
#: per-block overhead of a few numpy calls is lost in the arithmetic.
BLOCK = 1 << 18


def line_slope(x: np.ndarray, y: np.ndarray) -> float:
    """Slope of the least-squares straight line through ``(x, y)``, as ``np.polyfit(x, y, 1)[0]``.

    Two passes, each a block at a time: the means, then the centred sums
    ``Σ(x − x̄)(y − ȳ) / Σ(x − x̄)²``; centring first keeps the sums free of the cancellation that
    ``Σxy − n·x̄·ȳ`` suffers on a long record far from ``x = 0``.

    Parameters
    ----------
    x, y : ndarray
        Abscissae and ordinates, one-dimensional, of the same length (at least two).

    Returns
    -------
    float
        The slope; NaN when every ``x`` is the same.
    """
    n = x.size
    if n != y.size or n < 2:
        raise ValueError(f"line_slope needs two arrays of the same length >= 2, got {x.size} and {y.size}")
    sx = sy = 0.0
    for start in range(0, n, BLOCK):
        sx += float(np.sum(x[start : start + BLOCK]))
        sy += float(np.sum(y[start : start + BLOCK]))
    mx, my = sx / n, sy / n
    sxy = sxx = 0.0
    for start in range(0, n, BLOCK):
        dx = x[start : start + BLOCK] - mx
        sxx += float(np.dot(dx, dx))
        sxy += float(np.dot(dx, y[start : start + BLOCK] - my))
    return sxy / sxx if sxx > 0.0 else float("nan")


def variance(y: np.ndarray) -> float:
    """``np.var(y)`` (population variance), two passes a block at a time.

    Parameters
    ----------
    y : ndarray
        One-dimensional samples (at least one).

    Returns
    -------
    float
        The mean square deviation from the mean; NaN for no samples.
    """
    n = y.size
    if n == 0:
        return float("nan")
    mean = sum(float(np.sum(y[i : i + BLOCK])) for i in range(0, n, BLOCK)) / n
    total = 0.0
    for i in range(0, n, BLOCK):
        d = y[i : i + BLOCK] - mean
        total += float(np.dot(d, d))
    return total / n
