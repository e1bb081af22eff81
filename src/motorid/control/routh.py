"""Routh–Hurwitz conditions of a closed loop whose characteristic polynomial is affine in gains.

With one input, ``det(sI − A + B G)`` is affine in the gain row ``G`` (``B G`` has rank one), so
each coefficient is ``a_j = c_j + Σ m_ji g_i``; the coefficients are found numerically from
``np.poly`` at ``G = 0`` and at unit gains, and the Routh conditions written as inequalities in
the gains' names.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["AffinePoly", "affine_char_poly", "routh_array", "routh_conditions", "routh_stable"]


@dataclass(frozen=True, slots=True)
class AffinePoly:
    """Monic polynomial ``s^m + a_1 s^(m−1) + … + a_m`` with ``a = const + coef @ gains``.

    Attributes
    ----------
    const : ndarray, shape (m,)
        ``a_1..a_m`` at zero gains.
    coef : ndarray, shape (m, g)
        Sensitivity of ``a_j`` to gain ``i``.
    names : tuple of str
        Gain names (``k1``, ``k2``, ``ki``).
    """

    const: np.ndarray
    coef: np.ndarray
    names: tuple[str, ...]

    def at(self, gains: np.ndarray) -> np.ndarray:
        """Coefficients ``[1, a_1, …, a_m]`` for the given gains.

        Parameters
        ----------
        gains : ndarray
            One value per gain, in the order of the polynomial's gain names.

        Returns
        -------
        ndarray
            The coefficients, highest power first.
        """
        return np.concatenate([[1.0], self.const + self.coef @ np.asarray(gains, dtype=float)])


def affine_char_poly(a: np.ndarray, b: np.ndarray, names: tuple[str, ...]) -> AffinePoly:
    """Characteristic polynomial of ``A − B G`` as an affine function of ``G``.

    Parameters
    ----------
    a : ndarray, shape (m, m)
    b : ndarray, shape (m, 1)
    names : tuple of str
        One name per gain (column of ``G``).

    Returns
    -------
    AffinePoly
    """
    m = a.shape[0]
    c0 = np.real(np.poly(a))[1:]
    coef = np.empty((m, m))
    for i in range(m):
        e = np.zeros((1, m))
        e[0, i] = 1.0
        coef[:, i] = np.real(np.poly(a - b @ e))[1:] - c0
    # round-off of np.poly (eigenvalue based) is ~1e-12 relative; zero it for clean inequalities
    scale = max(1.0, float(np.max(np.abs(coef))))
    coef[np.abs(coef) < 1e-10 * scale] = 0.0
    c0 = c0.copy()
    c0[np.abs(c0) < 1e-10 * max(1.0, float(np.max(np.abs(c0))))] = 0.0
    return AffinePoly(c0, coef, tuple(names))


def routh_array(coeffs: np.ndarray) -> np.ndarray:
    """First column of the Routh array of ``coeffs`` (highest power first).

    Written out (a few lines) because neither numpy/scipy nor python-control has it; a zero
    pivot is replaced by a tiny ε as in the textbook rule, which is enough to count sign changes.

    Parameters
    ----------
    coeffs : ndarray
        Polynomial coefficients, highest power first.

    Returns
    -------
    ndarray
        The first column, one entry per power.
    """
    c = np.asarray(coeffs, dtype=float)
    n = c.size
    width = (n + 1) // 2
    rows = np.zeros((n, width))
    rows[0, : c[0::2].size] = c[0::2]
    rows[1, : c[1::2].size] = c[1::2]
    for i in range(2, n):
        piv = rows[i - 1, 0]
        if piv == 0.0:
            piv = 1e-12
            rows[i - 1, 0] = piv
        for j in range(width - 1):
            rows[i, j] = (piv * rows[i - 2, j + 1] - rows[i - 2, 0] * rows[i - 1, j + 1]) / piv
    return rows[:, 0]


def routh_stable(coeffs: np.ndarray) -> bool:
    """True when the polynomial is Hurwitz: all Routh first-column entries > 0 (leading > 0).

    Parameters
    ----------
    coeffs : ndarray
        Polynomial coefficients, highest power first.

    Returns
    -------
    bool
        Whether every root has a negative real part.
    """
    col = routh_array(coeffs)
    if col[0] < 0:
        col = -col
    return bool(np.all(col > 0))


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def _linear(poly: AffinePoly, j: int, scale: float) -> str:
    """``a_j/scale`` written as ``1 + 0.9·k2``."""
    terms: list[str] = []
    c = poly.const[j] / scale
    for name, m in zip(poly.names, poly.coef[j] / scale, strict=False):
        if m == 0.0:
            continue
        if abs(m - 1.0) < 1e-12:
            terms.append(name)
        elif abs(m + 1.0) < 1e-12:
            terms.append(f"-{name}")
        else:
            terms.append(f"{_fmt(m)}·{name}")
    if c != 0.0 or not terms:
        terms = [_fmt(c), *terms]
    text = " + ".join(terms)
    return text.replace("+ -", "- ")


def _one_sided(poly: AffinePoly, j: int) -> str:
    """``a_j > 0`` as an inequality; a single gain is isolated (``k2 > -1.111``)."""
    nz = np.flatnonzero(poly.coef[j])
    c = poly.const[j]
    if nz.size == 0:
        return f"{_fmt(c)} > 0 (independent of the gains)"
    if nz.size == 1:
        m = poly.coef[j, nz[0]]
        bound = -c / m
        return f"{poly.names[nz[0]]} {'>' if m > 0 else '<'} {_fmt(bound + 0.0)}"
    return f"{_linear(poly, j, 1.0)} > 0"


def _norm(poly: AffinePoly, j: int) -> float:
    """A positive scale that makes ``a_j`` read simply (its constant, or its largest gain coefficient)."""
    c = poly.const[j]
    if c != 0.0:
        return abs(c)
    return float(np.max(np.abs(poly.coef[j]))) or 1.0


def routh_conditions(poly: AffinePoly) -> list[str]:
    """The Routh–Hurwitz conditions on the gains, as human-readable inequalities.

    Orders 1–3 are written in closed form: ``a_1 > 0`` (order 1); ``a_1 > 0, a_2 > 0``
    (order 2); ``a_1 > 0, a_3 > 0, a_1·a_2 > a_3`` (order 3, report eqs. 43–47, where
    ``a_2 > 0`` follows).  Higher orders return the coefficient positivity conditions only,
    with a note that the full Routh array must be checked numerically.

    Parameters
    ----------
    poly : AffinePoly
        The characteristic polynomial, affine in the gains.

    Returns
    -------
    list of str
        The conditions, one per entry.

    References
    ----------
    Tsiolakis 2022, eqs. 42–47.
    """
    m = poly.const.size
    if m <= 2:
        return [_one_sided(poly, j) for j in range(m)]
    if m == 3:
        s1, s2 = _norm(poly, 0), _norm(poly, 1)
        f1, f2, f3 = _linear(poly, 0, s1), _linear(poly, 1, s2), _linear(poly, 2, s1 * s2)
        wrap = lambda t: t if (" + " not in t and " - " not in t) else f"({t})"  # noqa: E731
        return [_one_sided(poly, 0), _one_sided(poly, 2), f"{wrap(f1)}·{wrap(f2)} > {f3}"]
    return [_one_sided(poly, j) for j in range(m)] + [
        f"order {m}: the remaining Routh first-column entries are checked numerically"
    ]
