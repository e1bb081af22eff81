"""Numerical differentiation of uniformly sampled signals (Masoud 2019, eqs. 15–17).

The paper's three finite-difference formulas are written out because they are what the
paper's method is defined by; Savitzky–Golay (``scipy.signal.savgol_filter``) is the
better-behaved option: a local polynomial least-squares fit that differentiates and smooths
at once.  Finite differences return ``NaN`` where the stencil does not fit, so that the array
keeps the length and alignment of its input.
"""

from __future__ import annotations

import numpy as np

from motorid.errors import OptionError

__all__ = [
    "DERIVATIVE_METHODS",
    "central_derivative",
    "derivative",
    "euler_derivative",
    "five_point_derivative",
    "savgol_derivative",
]

#: Names accepted by :func:`derivative`.
DERIVATIVE_METHODS: tuple[str, ...] = ("euler", "central", "five_point", "savgol")


def euler_derivative(y: np.ndarray, dt: float) -> np.ndarray:
    """Backward Euler difference ``(y[i] − y[i−1]) / dt``; ``NaN`` at index 0.

    Parameters
    ----------
    y : ndarray
        Evenly sampled signal.
    dt : float
        Sample interval in s.

    Returns
    -------
    ndarray
        The derivative, same length as ``y``.

    References
    ----------
    Masoud 2019, eq. 15.
    """
    y = np.asarray(y, dtype=float)
    out = np.full(y.shape, np.nan)
    out[1:] = (y[1:] - y[:-1]) / dt
    return out


def central_derivative(y: np.ndarray, dt: float) -> np.ndarray:
    """Central difference ``(y[i+1] − y[i−1]) / (2 dt)``; ``NaN`` at both ends.

    Parameters
    ----------
    y : ndarray
        Evenly sampled signal.
    dt : float
        Sample interval in s.

    Returns
    -------
    ndarray
        The derivative, same length as ``y``.

    References
    ----------
    Masoud 2019, eq. 16.
    """
    y = np.asarray(y, dtype=float)
    out = np.full(y.shape, np.nan)
    out[1:-1] = (y[2:] - y[:-2]) / (2.0 * dt)
    return out


def five_point_derivative(y: np.ndarray, dt: float) -> np.ndarray:
    """Five-point stencil ``(−y[i+2] + 8y[i+1] − 8y[i−1] + y[i−2]) / (12 dt)``.

    Exact for polynomials up to degree 4; ``NaN`` at the first and last two samples (the
    paper drops them).

    Parameters
    ----------
    y : ndarray
        Evenly sampled signal.
    dt : float
        Sample interval in s.

    Returns
    -------
    ndarray
        The derivative, same length as ``y``.

    References
    ----------
    Masoud 2019, eq. 17.
    """
    y = np.asarray(y, dtype=float)
    out = np.full(y.shape, np.nan)
    out[2:-2] = (-y[4:] + 8.0 * y[3:-1] - 8.0 * y[1:-3] + y[:-4]) / (12.0 * dt)
    return out


def savgol_derivative(y: np.ndarray, dt: float, *, window: int = 7, polyorder: int = 3) -> np.ndarray:
    """Savitzky–Golay first derivative (local cubic fit over ``window`` samples).

    Defined on every sample (polynomial fit at the ends), so nothing is dropped.

    Parameters
    ----------
    y : ndarray
        Evenly sampled signal.
    dt : float
        Sample interval in s.
    window : int
        Odd window length in samples (default 7).
    polyorder : int
        Order of the local polynomial (default 3).

    Returns
    -------
    ndarray
        The derivative, same length as ``y``.
    """
    y = np.asarray(y, dtype=float)
    window = min(window, y.size if y.size % 2 else y.size - 1)
    if window <= polyorder:
        return central_derivative(y, dt)
    from scipy.signal import savgol_filter  # scipy.signal loads on use (start-up)

    return savgol_filter(y, window, polyorder, deriv=1, delta=dt, mode="interp")


def derivative(y: np.ndarray, dt: float, method: str = "five_point") -> np.ndarray:
    """Differentiate ``y`` sampled every ``dt`` seconds with the named method.

    Parameters
    ----------
    y : ndarray
        Uniformly sampled signal.
    dt : float
        Sample interval in seconds.
    method : str
        One of :data:`DERIVATIVE_METHODS`; the paper's default is ``"five_point"``.

    Returns
    -------
    ndarray
        Same length as ``y``; ``NaN`` where a finite-difference stencil does not fit.

    Raises
    ------
    OptionError
        For an unknown method.
    """
    funcs = {
        "euler": euler_derivative,
        "central": central_derivative,
        "five_point": five_point_derivative,
        "savgol": savgol_derivative,
    }
    if method not in funcs:
        raise OptionError(f"unknown derivative method {method!r}; use one of {', '.join(DERIVATIVE_METHODS)}")
    return funcs[method](y, dt)
