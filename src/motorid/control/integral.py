"""Integral action (state dynamic feedback): ``u = −K x − ki z``, ``ż = y − r``.

The report prints the integrator as ``u̇ = y − r`` (eq. 40); the state it adds is ``z`` and the
matrices of eq. 41 use ``ż = x1 − r``, which is what is implemented.
"""

from __future__ import annotations

import numpy as np

from motorid.control.feedback import check_controllable, place_gains
from motorid.control.routh import AffinePoly, affine_char_poly, routh_conditions

__all__ = ["augment_integral", "integral_gains", "integral_poly", "routh_violations"]


def augment_integral(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plant plus integrator ``ż = C x − r``: ``Aa = [[A, 0], [C, 0]]``, ``Ba = [B; 0]``.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    b : ndarray, shape (n, 1)
        Input column ``B``.
    c : ndarray, shape (1, n)
        Output row ``C`` of the measured channel.

    Returns
    -------
    (ndarray, ndarray)
        ``Aa`` (n + 1, n + 1) and ``Ba`` (n + 1, 1).

    References
    ----------
    Tsiolakis 2022, eq. 41 (with ``ż = y − r``; printed as ``u̇``).
    """
    n = a.shape[0]
    aa = np.zeros((n + 1, n + 1))
    aa[:n, :n] = a
    aa[n, :n] = c.ravel()
    ba = np.vstack([b, [[0.0]]])
    return aa, ba


def integral_gains(a: np.ndarray, b: np.ndarray, c: np.ndarray, poles: np.ndarray) -> tuple[np.ndarray, float]:
    """``K`` and ``ki`` placing the ``n + 1`` poles of the augmented loop.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    b : ndarray, shape (n, 1)
        Input column ``B``.
    c : ndarray, shape (1, n)
        Output row ``C`` of the measured channel.
    poles : ndarray
        The ``n + 1`` poles of the augmented loop.

    Returns
    -------
    (ndarray, float)
        ``K`` (shape (1, n)) and ``ki``.

    Raises
    ------
    ControlDesignError
        When the augmented system is not controllable (e.g. the plant has a zero at ``s = 0``
        from ``u`` to ``y``, which the integrator cancels).
    """
    aa, ba = augment_integral(a, b, c)
    check_controllable(aa, ba, "model with the integrator z")
    g = place_gains(aa, ba, poles)
    return g[:, :-1], float(g[0, -1])


def integral_poly(a: np.ndarray, b: np.ndarray, c: np.ndarray, names: tuple[str, ...]) -> AffinePoly:
    """Characteristic polynomial of the loop with integral action, affine in ``(K, ki)``.

    For the report's model: ``s³ + (1 + kT km k2)/Tm s² + kμ k0 km k1/Tm s + kμ k0 km ki/Tm``
    (eq. 42).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    b : ndarray, shape (n, 1)
        Input column ``B``.
    c : ndarray, shape (1, n)
        Output row ``C`` of the measured channel.
    names : tuple of str
        Names of the gains ``K`` (``k1``, ``k2``, ...), used in the conditions' text.

    Returns
    -------
    AffinePoly
        The closed-loop characteristic polynomial, affine in ``(K, ki)``.
    """
    aa, ba = augment_integral(a, b, c)
    return affine_char_poly(aa, ba, (*tuple(names), "ki"))


def routh_violations(poly: AffinePoly, gains: np.ndarray) -> list[str]:
    """The Routh conditions (as text) that the given gains violate; empty when Hurwitz.

    Parameters
    ----------
    poly : AffinePoly
        The characteristic polynomial, affine in the gains.
    gains : ndarray
        The gains ``[k1, …, kn, ki]``.

    Returns
    -------
    list of str
        The violated conditions.

    References
    ----------
    Tsiolakis 2022, eqs. 43–47.
    """
    from motorid.control.routh import routh_array

    coeffs = poly.at(gains)
    col = routh_array(coeffs)
    if np.all(col > 0):
        return []
    conds = routh_conditions(poly)
    m = coeffs.size - 1
    bad: list[str] = []
    a = coeffs[1:]
    if m == 3:
        checks = [a[0] > 0, a[2] > 0, a[0] * a[1] > a[2]]
        bad = [c for c, ok in zip(conds, checks, strict=False) if not ok]
    elif m <= 2:
        bad = [c for c, ok in zip(conds, a > 0, strict=False) if not ok]
    return bad or ["the Routh array has a sign change (closed loop unstable)"]
