"""Reductions over a long record done a block at a time, so that no temporary is as long as it.

A 10 M-sample log is 80 MB a column; numpy's one-liners over it (``np.polyfit`` builds its
Vandermonde matrix and a scaled copy, ``(y − m)**2`` a temporary of the record's length) hold
two or three such arrays for a moment, and that moment is the command's peak memory.  The
functions here give the same results (to rounding) holding one block at a time.  numpy has no
streaming reductions of this kind, hence these few lines.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BLOCK", "centred_sum_of_squares", "line_slope", "max_abs", "sum_of_squares_about", "variance"]

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
    mx, my = _mean(x), _mean(y)
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
    return centred_sum_of_squares(y) / y.size if y.size else float("nan")


def centred_sum_of_squares(y: np.ndarray) -> float:
    """``Σ(y − ȳ)²``, two passes a block at a time (0 for no samples).

    Parameters
    ----------
    y : ndarray
        One-dimensional samples.

    Returns
    -------
    float
        The sum of squared deviations from the mean.
    """
    return sum_of_squares_about(y, _mean(y)) if y.size else 0.0


def sum_of_squares_about(y: np.ndarray, level: float) -> float:
    """``Σ(y − level)²``, a block at a time (no temporary of the record's length; 0 for no samples).

    Parameters
    ----------
    y : ndarray
        One-dimensional samples.
    level : float
        The level the deviations are taken from.

    Returns
    -------
    float
        The sum of squared deviations from ``level``.
    """
    total = 0.0
    for i in range(0, y.size, BLOCK):
        d = y[i : i + BLOCK] - level
        total += float(np.dot(d, d))
    return total


def max_abs(y: np.ndarray) -> float:
    """``max(|y|)`` without the array ``|y|``: the larger of ``|max|`` and ``|min|`` (0 when empty).

    Parameters
    ----------
    y : ndarray
        Samples.

    Returns
    -------
    float
        The largest magnitude.
    """
    return max(abs(float(y.max())), abs(float(y.min()))) if y.size else 0.0


def _mean(y: np.ndarray) -> float:
    """The mean, its sum taken a block at a time."""
    return sum(float(np.sum(y[i : i + BLOCK])) for i in range(0, y.size, BLOCK)) / y.size
