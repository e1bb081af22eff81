"""Transfer function ↔ state space and a recursive filter, in numpy and scipy.linalg.

What the identification and :class:`~motorid.model.motor.MotorModel` used of ``scipy.signal``:
``tf2ss``, ``ss2tf`` and ``lfilter``.  Importing ``scipy.signal`` costs about 0.4 s of CPU (it
imports ``scipy.stats``, ``scipy.interpolate`` and more), more than half of what ``motorid
identify`` spends starting up, for three functions of a few lines each.  :func:`tf2ss` and
:func:`ss2tf` are scipy's own arithmetic (the same operations in the same order, so the same
bits: a test compares them with ``scipy.signal`` on random systems), restricted to the real SISO
and single-input cases used here.  :func:`lfilter` is the same filter run as compiled code that is
already loaded: the FIR part by :func:`numpy.convolve`, the recursion as the banded lower-triangular
Toeplitz system it is, solved by LAPACK's ``dtbtrs`` (:func:`scipy.linalg.lapack.dtbtrs`); equal to
``scipy.signal.lfilter`` to rounding (the sums run in another order), which a test checks.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg
import scipy.linalg.lapack
from numpy.typing import ArrayLike

__all__ = ["BadCoefficients", "lfilter", "ss2tf", "tf2ss", "zoh"]


class BadCoefficients(UserWarning):
    """A numerator's leading coefficients are zero to 1e-14 (``scipy.signal.BadCoefficients``'s case)."""


def _normalize(num: ArrayLike, den: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.signal.normalize`` for real coefficients: monic ``den``, ``num``'s zero leading columns dropped."""
    return _normalized(np.atleast_2d(np.asarray(num)), np.atleast_1d(np.asarray(den)))


def _normalized(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_normalize` of arrays."""
    if den.ndim != 1:
        raise ValueError("Denominator polynomial must be rank-1 array.")
    if num.ndim > 2:
        raise ValueError("Numerator polynomial must be rank-1 or rank-2 array.")
    if np.all(den == 0):
        raise ValueError("Denominator must have at least on nonzero element.")
    first = 0
    while first < den.shape[0] - 1 and den[first] == 0.0:
        first += 1
    den = den[first:]
    num, den = num / den[0], den / den[0]
    leading_zeros = 0
    for j in range(num.shape[-1]):
        if np.all(np.abs(num[:, j]) <= 1e-14):
            leading_zeros += 1
        else:
            break
    if leading_zeros > 0:
        warnings.warn("Badly conditioned filter coefficients (numerator): the results may be meaningless",
                      BadCoefficients, stacklevel=3)
        if leading_zeros == num.shape[1]:
            leading_zeros -= 1
        num = num[:, leading_zeros:]
    return num, den


def tf2ss(num: ArrayLike, den: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Controller-canonical state space of ``num/den``: :func:`scipy.signal.tf2ss`, real coefficients.

    Parameters
    ----------
    num : array_like
        Numerator coefficients in descending powers (1-D, or 2-D: one row per output).
    den : array_like
        Denominator coefficients in descending powers, at least as long as ``num``.

    Returns
    -------
    A, B, C, D : ndarray
        The realisation, with ``A``'s first row ``−den[1:]`` (den made monic).

    Raises
    ------
    ValueError
        If ``num`` is longer than ``den`` (improper).

    Warns
    -----
    BadCoefficients
        If ``num``'s leading coefficients are zero to 1e-14 (they are dropped, as scipy does).
    """
    nums, den = _normalize(num, den)
    nums = np.atleast_2d(nums)
    m, k = nums.shape[1], len(den)
    if m > k:
        raise ValueError("Improper transfer function. `num` is longer than `den`.")
    if m == 0 or k == 0:
        return np.array([], float), np.array([], float), np.array([], float), np.array([], float)
    padded = np.hstack((np.zeros((nums.shape[0], k - m)), nums))
    d = np.atleast_2d(padded[:, 0])
    if k == 1:
        d = d.reshape(padded.shape)
        return np.zeros((1, 1)), np.zeros((1, padded.shape[1])), np.zeros((padded.shape[0], 1)), d
    a = np.r_[-np.array([den[1:]]), np.eye(k - 2, k - 1)]
    b = np.eye(k - 1, 1)
    c = padded[:, 1:] - np.outer(padded[:, 0], den[1:])
    return a, b, c, d.reshape((c.shape[0], b.shape[1]))


def ss2tf(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Numerators (one row per output) and denominator of ``C (sI − A)⁻¹ B + D``: :func:`scipy.signal.ss2tf`.

    For one input (``B`` with one column), as used here.

    Parameters
    ----------
    A, B, C, D : array_like
        The state-space matrices (``n×n``, ``n×1``, ``p×n``, ``p×1``).

    Returns
    -------
    num : ndarray
        ``p × (n + 1)``: ``poly(A − B C_k) + (D_k − 1) poly(A)`` for each output ``k``.
    den : ndarray
        ``poly(A)``, length ``n + 1``.

    Raises
    ------
    ValueError
        If the matrices are not 2-D of matching sizes with one input.
    """
    return _ss2tf(*(np.atleast_2d(np.asarray(m)) for m in (A, B, C, D)))


def _ss2tf(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`ss2tf` of 2-D arrays."""
    n = A.shape[0]
    if n == 0 and B.size == 0 and C.size == 0:  # a static gain
        return np.ravel(D), np.array([1.0])
    if A.shape != (n, n) or B.shape != (n, 1) or C.shape[1] != n or D.shape != (C.shape[0], 1):
        raise ValueError(f"ss2tf needs A n×n, B n×1, C p×n, D p×1 ; got {A.shape}, {B.shape}, "
                         f"{C.shape}, {D.shape}")
    den = np.poly(A)
    nout = D.shape[0]
    type_test = A[:, 0] + B[:, 0] + C[0, :] + D + 0.0
    num = np.empty((nout, n + 1), type_test.dtype)
    for k in range(nout):
        num[k] = np.poly(A - np.dot(B, np.atleast_2d(C[k, :]))) + (D[k] - 1) * den
    return num, den


def lfilter(b: ArrayLike, a: ArrayLike, x: ArrayLike) -> np.ndarray:
    """``y`` with ``Σ a_j y[k−j] = Σ b_i x[k−i]`` from rest: :func:`scipy.signal.lfilter` along the last axis.

    Parameters
    ----------
    b : array_like
        Numerator (FIR) coefficients, 1-D.
    a : array_like
        Denominator (recursive) coefficients, 1-D, ``a[0] ≠ 0``.
    x : array_like
        The signal, 1-D, or several as the rows of a 2-D array (one triangular solve for all).

    Returns
    -------
    ndarray
        The filtered signal(s), ``x``'s shape, float.

    Raises
    ------
    ValueError
        If a coefficient array is not 1-D and non-empty, ``a[0]`` is zero, or ``x`` is not 1-D or 2-D.

    Notes
    -----
    ``w = b * x`` (:func:`numpy.convolve`, truncated), then ``L y = w`` with ``L`` the lower
    triangular band Toeplitz matrix of ``a`` (unit diagonal once ``a`` is monic), solved by
    forward substitution in LAPACK (``dtbtrs``): the recursion, compiled, without importing
    ``scipy.signal``. Equal to ``scipy.signal.lfilter`` to rounding, not bit for bit (another
    order of the same sums).
    """
    return _lfilter(np.asarray(b, dtype=float), np.asarray(a, dtype=float), np.asarray(x, dtype=float))


def _lfilter(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """:func:`lfilter` of float arrays."""
    if b.ndim != 1 or a.ndim != 1 or b.size == 0 or a.size == 0 or x.ndim not in (1, 2):
        raise ValueError(f"lfilter needs 1-D b and a, and a 1-D or 2-D x; got shapes {b.shape}, {a.shape}, {x.shape}")
    if a[0] == 0.0:
        raise ValueError("lfilter needs a[0] != 0")
    b, a = b / a[0], a / a[0]
    if x.shape[-1] == 0:
        return x.copy()
    rows = np.atleast_2d(x)
    n = rows.shape[1]
    w = np.column_stack([np.convolve(r, b)[:n] for r in rows])  # one right-hand side per signal
    order = a.size - 1
    if order == 0:
        y = w
    else:
        # LAPACK band storage of the lower band: row j holds the j-th subdiagonal (a_j on all of it);
        # dtbtrs solves each right-hand side by itself, as one call each would
        band = np.zeros((order + 1, n))
        band[:, :] = a[:, None]
        y, info = scipy.linalg.lapack.dtbtrs(band, w, uplo="L", trans="N", diag="U")
        if info != 0:  # pragma: no cover - a unit diagonal is never singular
            raise ValueError(f"dtbtrs failed (info {info})")
    out = np.ascontiguousarray(np.asarray(y).T)
    return out if x.ndim == 2 else out[0]


def zoh(a: ArrayLike, b: ArrayLike, h: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The exact zero-order-hold discretisation ``Φ = e^{A h}``, ``Γ = ∫₀ʰ e^{A s} ds·B``.

    One ``expm`` of the augmented matrix ``[[A, B], [0, 0]]·h`` (Van Loan 1978), the
    discretisation every simulator of the project steps with: the identification's
    responses, the closed loop, the robustness check and the trainer.  Stacks of systems
    (leading dimensions of ``a`` and ``b``) are discretised in one call.

    Parameters
    ----------
    a : array_like, shape (..., n, n)
        State matrix (or a stack of them).
    b : array_like, shape (..., n, m)
        Input matrix (or a stack, matching ``a``).
    h : float or ndarray
        The hold interval [s] (any real: 0 gives the identity and zero); an array of shape
        ``(k, 1, 1)`` gives the ``k`` discretisations of one system at once.

    Returns
    -------
    phi : ndarray, shape (..., n, n)
    gamma : ndarray, shape (..., n, m)

    Examples
    --------
    >>> phi, gamma = zoh([[-2.0]], [[2.0]], 0.5)
    >>> round(float(phi[0, 0]), 6), round(float(gamma[0, 0]), 6)
    (0.367879, 0.632121)
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n, m = b.shape[-2], b.shape[-1]
    aug = np.zeros((*a.shape[:-2], n + m, n + m))
    aug[..., :n, :n], aug[..., :n, n:] = a, b
    e = scipy.linalg.expm(aug * h)
    return e[..., :n, :n], e[..., :n, n:]
