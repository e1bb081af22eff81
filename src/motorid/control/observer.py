"""Luenberger observer ``x̂' = A x̂ + B u + L (y − C x̂)`` and output feedback (Tsiolakis 2022, §4)."""

from __future__ import annotations

import numpy as np

from motorid.control.feedback import UNCONTROLLABLE_TOL, ControlDesignError, pbh_margins, place_gains

__all__ = ["check_observable", "observer_gain", "output_feedback_matrix"]


def check_observable(a: np.ndarray, c: np.ndarray, output: str = "output") -> None:
    """Raise ControlDesignError when ``(A, C)`` is not observable.

    The PBH test on the dual pair with the tolerance of
    :func:`~motorid.control.feedback.check_controllable` (scale-free).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    c : ndarray, shape (1, n)
        Output row ``C`` of the measured channel.
    output : str
        The channel's name, used in the error (default ``output``).

    References
    ----------
    Tsiolakis 2022, eq. 48.
    """
    # duality: (A, C) is observable iff (Aᵀ, Cᵀ) is controllable; same scale-free PBH test
    margins, _ = pbh_margins(np.asarray(a, dtype=float).T, np.asarray(c, dtype=float).T)
    rank = a.shape[0] - int(np.sum(margins < UNCONTROLLABLE_TOL))
    if rank < a.shape[0]:
        raise ControlDesignError(
            f"the model is not observable from its {output} (rank of [C; CA; ...] is {rank} < "
            f"{a.shape[0]}): an observer cannot estimate every state; measure another channel"
        )


def observer_gain(a: np.ndarray, c: np.ndarray, poles: np.ndarray, output: str = "output") -> np.ndarray:
    """Observer gain column ``L`` with ``eig(A − L C) = poles`` (placement on the dual ``(Aᵀ, Cᵀ)``).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    c : ndarray, shape (1, n)
        Output row ``C`` of the measured channel.
    poles : ndarray
        The ``n`` observer poles.
    output : str
        The channel's name, used in errors (default ``output``).

    Returns
    -------
    ndarray, shape (n, 1)
        The observer gain ``L``.

    References
    ----------
    Tsiolakis 2022, eqs. 49–57 (the report's ``W⁻¹ W̃ (p − a)`` formula is Ackermann's; the
    result is the same ``L``).
    """
    check_observable(a, c, output)
    return place_gains(a.T, c.T, poles).T


def output_feedback_matrix(a: np.ndarray, b: np.ndarray, c: np.ndarray, k: np.ndarray, l_col: np.ndarray,
                           ki: float | None = None) -> np.ndarray:
    """System matrix of plant + observer + feedback from the estimate, states ``[x, x̂(, z)]``.

    ``u = −K x̂ (− ki z)``; its eigenvalues are ``eig(A − BK) ∪ eig(A − LC)`` (separation
    principle) — with integral action, the augmented loop's poles ∪ the observer's.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    b : ndarray, shape (n, 1)
        Input column ``B``.
    c : ndarray, shape (1, n)
        Output row ``C`` of the measured channel.
    k : ndarray, shape (1, n)
        State-feedback gain row ``K``.
    l_col : ndarray, shape (n, 1)
        Observer gain column ``L``.
    ki : float, optional
        Integral gain; ``None`` without integral action.

    Returns
    -------
    ndarray
        Shape (2n, 2n), or (2n + 1, 2n + 1) with integral action.
    """
    n = a.shape[0]
    top = np.hstack([a, -b @ k])
    bot = np.hstack([l_col @ c, a - b @ k - l_col @ c])
    m = np.vstack([top, bot])
    if ki is None:
        return m
    big = np.zeros((2 * n + 1, 2 * n + 1))
    big[: 2 * n, : 2 * n] = m
    big[:n, 2 * n] = -b[:, 0] * ki
    big[n: 2 * n, 2 * n] = -b[:, 0] * ki
    big[2 * n, :n] = c.ravel()
    return big
