"""Simplifying a motor model.

Pole-zero cancellation, balanced reduction, the dominant first order, and the transfer-function
normalisation they share.

Hand-written where python-control needs slycot (``balred``/``minreal`` on state space);
the maths of each helper is stated in its docstring.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

if TYPE_CHECKING:
    import control

#: Default relative tolerance of :meth:`MotorModel.cancel_near`: a pole and a zero closer
#: than 2 % of the fastest pole's magnitude are treated as one numerical artefact
#: (paper eq. 39: the pair at -0.0189/-0.0048 is 0.6 % of 2.30 apart).
CANCEL_TOL_REL = 0.02
#: Pole-zero pairs closer than this (relative to the fastest pole) are one and the same
#: root split by round-off, and are always removed from a channel's transfer function.
EXACT_CANCEL_TOL = 1e-8


@dataclass(frozen=True, slots=True)
class FirstOrder:
    """Dominant first-order approximation ``dc_gain / (time_constant_s·s + 1)``.

    The paper writes the same model as ``k / (s + p)`` (Masoud 2019, eqs. 41, 43, 45), so
    ``k = dc_gain / time_constant_s`` and ``p = 1 / time_constant_s``.
    """

    dc_gain: float
    time_constant_s: float

    @property
    def k(self) -> float:
        """The paper's motor coefficient ``k`` in ``k/(s+p)``."""
        if not (math.isfinite(self.dc_gain) and math.isfinite(self.time_constant_s)):
            return float("nan")
        if self.time_constant_s == 0.0:
            return float("inf")
        return self.dc_gain / self.time_constant_s

    @property
    def p(self) -> float:
        """The paper's pole magnitude ``p`` in ``k/(s+p)`` (1/s)."""
        if not math.isfinite(self.time_constant_s):
            return float("nan")
        if self.time_constant_s == 0.0:
            return float("inf")
        return 1.0 / self.time_constant_s


def _normalise_tf(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Strip leading zeros and scale so that ``den[0] == 1``.

    A leading numerator coefficient that is round-off of a state-space → TF conversion
    (``-4e-16 s + 2.1``: a "zero" at 10¹⁶ rad/s) is dropped too: its term weighs less than
    1e-10 of the largest one at the fastest pole's frequency.
    """
    num = np.trim_zeros(np.atleast_1d(np.asarray(num, dtype=float)), "f")
    den = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "f")
    if num.size == 0:
        num = np.zeros(1)
    w = float(np.max(np.abs(np.roots(den)))) if den.size > 1 else 1.0
    w = w if np.isfinite(w) and w > 0 else 1.0
    while num.size > 1:
        weight = np.abs(num) * w ** np.arange(num.size - 1, -1, -1)
        if weight[0] >= 1e-10 * weight.max():
            break
        num = num[1:]
    lead = den[0]
    return num / lead, den / lead


def _tf_coeffs(tf: control.TransferFunction) -> tuple[np.ndarray, np.ndarray]:
    return _normalise_tf(np.asarray(tf.num[0][0]), np.asarray(tf.den[0][0]))


def _roots(poly: np.ndarray) -> np.ndarray:
    poly = np.trim_zeros(np.asarray(poly, dtype=float), "f")
    if poly.size <= 1:
        return np.zeros(0, dtype=complex)
    return np.roots(poly).astype(complex)


def nearest_zeros(poles: np.ndarray, zeros: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each pole, the nearest zero: its distance relative to the pole's magnitude, and its index.

    Unlike :func:`_cancel_pairs` (tolerance relative to the fastest pole), each pole is measured
    against its own magnitude: a slow pole and a slow zero 4 % apart are close however fast the
    other poles are.

    Parameters
    ----------
    poles, zeros : ndarray
        Roots (complex allowed).

    Returns
    -------
    (ndarray, ndarray)
        ``min_j |p_i − z_j| / |p_i|`` (``inf`` with no zeros) and that ``j`` (0 with no zeros),
        one per pole.
    """
    p = np.asarray(poles, dtype=complex).ravel()
    z = np.asarray(zeros, dtype=complex).ravel()
    if z.size == 0:
        return np.full(p.size, np.inf), np.zeros(p.size, dtype=int)
    gaps = np.abs(p[:, None] - z[None, :]) / np.maximum(np.abs(p[:, None]), 1e-300)
    return gaps.min(axis=1), gaps.argmin(axis=1)


def _cancel_pairs(
    num: np.ndarray, den: np.ndarray, tol_rel: float, keep: str, record_s: float | None = None
) -> tuple[np.ndarray, np.ndarray, int]:
    """Cancel pole-zero pairs of ``num/den`` closer than ``tol_rel`` × the fastest pole.

    Real zeros pair only with real poles and complex ones with complex ones (whole
    conjugate pairs), so the polynomials stay real.  ``keep='leading'`` drops the factors
    as the paper does (eq. 39 → 41); ``keep='dc'`` rescales so the DC gain is unchanged;
    ``keep='auto'`` cancels only pairs slower than every pole that remains, as the paper does
    (what an equation-error fit leaves of the position integrator: a record cannot show
    their DC factor ``z/p``), and leaves a faster pair in (the record shows the steady state
    and the time constant it shapes).  With ``record_s`` (the length of the record the model
    was identified from) a pair whose pole the record resolves (``|p|·record ≥ 1``) is left
    in too, however slow against the other poles: the record shows its DC factor, so
    cancelling it would change the gain the data show (a pole at −35.4 and a zero
    at −40.2 beside a 6972 rad/s pole took 12 % off the DC gain).
    """
    zeros = list(_roots(num))
    poles = list(_roots(den))
    if not zeros or not poles:
        return num, den, 0
    scale = max(abs(p) for p in poles)
    if scale == 0.0:
        scale = max(abs(z) for z in zeros)
    if scale == 0.0:
        return num, den, 0
    tol = tol_rel * scale
    imag_tol = 1e-9 * scale

    def is_real(x: complex) -> bool:
        return abs(x.imag) <= imag_tol

    n_cancelled = 0
    pairs: list[tuple[complex, complex]] = []
    while True:
        best: tuple[float, int, int] | None = None
        for iz, z in enumerate(zeros):
            if not is_real(z) and z.imag < 0:
                continue  # the upper-half member stands for the conjugate pair
            for ip, p in enumerate(poles):
                if is_real(z) != is_real(p) or (not is_real(p) and p.imag < 0):
                    continue
                d = abs(z - p)
                if d <= tol and (best is None or d < best[0]):
                    best = (d, iz, ip)
        if best is None:
            break
        _, iz, ip = best
        z, p = zeros[iz], poles[ip]
        drop_z = [iz]
        drop_p = [ip]
        if not is_real(z):
            drop_z.append(int(np.argmin([abs(w - z.conjugate()) if k != iz else np.inf
                                         for k, w in enumerate(zeros)])))
            drop_p.append(int(np.argmin([abs(w - p.conjugate()) if k != ip else np.inf
                                         for k, w in enumerate(poles)])))
        pairs += [(zeros[a], poles[b]) for a, b in zip(drop_z, drop_p, strict=False)]
        zeros = [w for k, w in enumerate(zeros) if k not in drop_z]
        poles = [w for k, w in enumerate(poles) if k not in drop_p]
        n_cancelled += len(drop_z)
    if keep == "auto":
        # a pair at or above the slowest pole that remains is seen by the record: left in
        slowest = min((abs(w) for w in poles), default=np.inf)
        seen = [(z, p) for z, p in pairs
                if abs(p) >= slowest or (record_s is not None and abs(p) * record_s >= 1.0)]
        zeros += [z for z, _ in seen]
        poles += [p for _, p in seen]
        n_cancelled -= len(seen)
    if n_cancelled == 0:
        return num, den, 0
    new_num = num[0] * np.real(np.poly(zeros)) if zeros else np.array([num[0]])
    new_den = np.real(np.poly(poles)) if poles else np.array([1.0])
    if keep == "dc":
        old_dc = _dc(num, den)
        new_dc = _dc(new_num, new_den)
        if math.isfinite(old_dc) and math.isfinite(new_dc) and old_dc != 0 and new_dc != 0:
            new_num = new_num * (old_dc / new_dc)
    return np.atleast_1d(new_num), np.atleast_1d(new_den), n_cancelled


def _dc(num: np.ndarray, den: np.ndarray) -> float:
    if den[-1] == 0.0:
        return float("inf") if num[-1] != 0.0 else float("nan")
    return float(num[-1] / den[-1])


def _balance(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Square-root balanced realisation of a stable system, dropping zero Hankel values.

    Hand-written because python-control's ``balred``/``balreal`` need slycot, which is not
    a dependency; the gramians come from scipy's Lyapunov solver.
    """
    wc = scipy.linalg.solve_continuous_lyapunov(a, -b @ b.T)
    wo = scipy.linalg.solve_continuous_lyapunov(a.T, -c.T @ c)

    def factor(w: np.ndarray) -> np.ndarray:
        lam, vec = np.linalg.eigh((w + w.T) / 2)
        return vec * np.sqrt(np.clip(lam, 0.0, None))

    lc, lo = factor(wc), factor(wo)
    u, hsv, vt = np.linalg.svd(lo.T @ lc)
    keep = hsv > hsv[0] * 1e-12
    u, hsv, v = u[:, keep], hsv[keep], vt[keep].T
    t = lc @ v / np.sqrt(hsv)
    ti = (u / np.sqrt(hsv)).T @ lo.T
    return ti @ a @ t, ti @ b, c @ t

