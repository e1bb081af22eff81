"""Step responses of ``N(s)/Π(1 + τ_i s)`` in closed form, and their derivatives, for the output-error fit.

After the step every response the fit uses is ``a + b·t + Σ_i c_i e^{p_i t}`` (partial
fractions, ``p_i = −1/τ_i``): the velocity's and the current's step responses, the position
(their integral), the slope (for time shifts and the dead time), and every Jacobian column.
:class:`ResponseBasis` holds the exponentials of one grid for one set of poles once, and each of
those is a product with it — the fit's cost is a few such products per iteration.  Exact block
means (a long record fitted as means of ``m`` samples) come from the same basis.  scipy and
python-control simulate a transfer function sample by sample (``lsim``) and give no
derivatives in its parameters, hence this module.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "PartialFractions",
    "ResponseBasis",
    "WindowBasis",
    "position_closed_form",
    "residue_derivatives",
    "residues",
    "separate",
    "slope_closed_form",
    "step_response_closed_form",
]


def separate(taus: ArrayLike) -> np.ndarray:
    """Nudge equal time constants apart: partial fractions need distinct poles.

    The response is continuous in τ, so a 1e-6 relative split changes it by ~1e-6.

    Parameters
    ----------
    taus : array_like
        Time constants (s).

    Returns
    -------
    ndarray
        The same time constants, those within 1e-6 of another moved 2e-6 apart.
    """
    t = np.array(taus, dtype=float)
    if t.size < 2:
        return t
    order = np.argsort(t)
    ts = t[order]
    close = ts[1:] - ts[:-1] < 1e-6 * ts[1:]
    if close.any():
        for j in np.flatnonzero(close):
            ts[j + 1] = ts[j] * (1 + 2e-6)
        t[order] = ts
    return t


def _horner(num: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``np.polyval`` for short numerators, without its per-call conversions (called thousands of times a fit)."""
    y = np.full(x.shape, num[0], dtype=x.dtype)
    for c in num[1:]:
        y = y * x + c
    return y


class PartialFractions:
    """The partial fractions of ``N(s)/(s·D(s))`` for one ``D(s) = Π(1 + τ_i s)``, any numerator.

    The poles and the denominators of the residues depend on the time constants only: computed
    once here, every numerator's residues are one polynomial evaluation (a Jacobian of the
    output-error fit takes a dozen numerators' residues on the same time constants).

    Parameters
    ----------
    taus : array_like
        Time constants τ_i (equal ones are split by :func:`separate`).
    """

    __slots__ = ("denom", "f", "p", "taus")

    def __init__(self, taus: ArrayLike) -> None:
        t = separate(taus)
        p = -1.0 / t
        f = 1.0 + p[:, None] * t[None, :]  # f[i, k] = 1 + τ_k p_i
        np.fill_diagonal(f, 1.0)
        self.taus, self.p, self.f = t, p, f
        self.denom = p * t * f.prod(axis=1)

    def residues(self, num: ArrayLike) -> tuple[np.ndarray, np.ndarray, float]:
        """Poles, residues of ``N(s)/(s·D(s))`` and ``N(0)``: :func:`residues`.

        Parameters
        ----------
        num : array_like
            Numerator ``N(s)``, highest power first.

        Returns
        -------
        (ndarray, ndarray, float)
            The poles ``p_i = −1/τ_i``, the residues ``R_i`` and ``N(0)``.
        """
        num = np.atleast_1d(np.asarray(num, dtype=float))
        return self.p, _horner(num, self.p) / self.denom, float(num[-1])

    def derivatives(self, num: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """``∂p_i/∂ln τ_i`` and ``∂R_i/∂ln τ_j``: :func:`residue_derivatives`.

        Parameters
        ----------
        num : array_like
            Numerator ``N(s)``, highest power first.

        Returns
        -------
        (ndarray, ndarray)
            ``∂p_i/∂ln τ_i`` (shape ``(n,)``) and ``∂R_i/∂ln τ_j`` (shape ``(n, n)``).
        """
        num = np.atleast_1d(np.asarray(num, dtype=float))
        taus, p, f = self.taus, self.p, self.f
        _, r, _ = self.residues(num)
        n = taus.size
        # the residue with N'(p_i) in place of N(p_i): no division by N(p_i), which a zero may cancel
        dnum = _horner(num[:-1] * np.arange(num.size - 1, 0, -1), p) if num.size > 1 else np.zeros(n)
        rd = dnum / self.denom
        # j ≠ i: only the factor (1 + τ_j p_i) moves
        dr = -r[:, None] * taus[None, :] * p[:, None] / f
        for i in range(n):
            # p_i moves (∂p_i/∂ln τ_i = −p_i) while p_i·τ_i = −1 stays
            dr[i, i] = -p[i] * (rd[i] - r[i] * float((taus / f[i]).sum() - taus[i]))  # f[i, i] = 1: k ≠ i
        return -p, dr


def _fractions(taus: ArrayLike | PartialFractions) -> PartialFractions:
    return taus if isinstance(taus, PartialFractions) else PartialFractions(taus)


def residues(num: ArrayLike, taus: ArrayLike | PartialFractions) -> tuple[np.ndarray, np.ndarray, float]:
    """Poles p_i, residues of N(s)/(s·D(s)) at p_i, and N(0), for D(s) = Π(1 + τ_i s).

    Parameters
    ----------
    num : array_like
        Numerator ``N(s)``, highest power first.
    taus : array_like or PartialFractions
        Time constants τ_i (equal ones are split by :func:`separate`), or their partial fractions.

    Returns
    -------
    (ndarray, ndarray, float)
        The poles ``p_i = −1/τ_i``, the residues ``R_i`` and ``N(0)``.
    """
    return _fractions(taus).residues(num)


def residue_derivatives(num: ArrayLike, taus: ArrayLike | PartialFractions) -> tuple[np.ndarray, np.ndarray]:
    """``∂p_i/∂ln τ_i`` and ``∂R_i/∂ln τ_j`` of :func:`residues` (``R_i = N(p_i)/(p_i τ_i Π_{k≠i}(1 + τ_k p_i))``).

    Analytic: nearly equal time constants have huge residues of opposite sign whose
    derivatives no finite difference resolves (a step small against their gap drowns in
    rounding, a larger one swaps their roles).

    Parameters
    ----------
    num : array_like
        Numerator ``N(s)``, highest power first.
    taus : array_like or PartialFractions
        Time constants τ_i, or their partial fractions.

    Returns
    -------
    (ndarray, ndarray)
        ``∂p_i/∂ln τ_i`` (shape ``(n,)``) and ``∂R_i/∂ln τ_j`` (shape ``(n, n)``).
    """
    return _fractions(taus).derivatives(num)


def _false_prefix(mask: np.ndarray) -> int | None:
    """The length of ``mask``'s leading ``False`` run when every later value is ``True``, else None."""
    first = int(np.argmax(mask)) if mask.size and mask.any() else mask.size
    return first if bool(np.all(mask[first:])) else None


def _exp_basis(t: np.ndarray, p: np.ndarray, block: tuple[int, float] | None,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The exponentials of a closed form, the time of its linear term, the mask after the step.

    ``e^{p_i t}`` at each time (``t`` clipped at 0); the mask is ``t ≥ 0``.  With ``block =
    (m, dt)``, each ``t`` is the first of ``m`` samples ``dt`` apart and the basis is the mean over
    them: the mean of ``e^{p(t₀ + k·dt)}`` over ``k = 0…m−1`` is ``e^{p t₀}·(e^{p m dt} − 1)/(m
    (e^{p dt} − 1))``, that of ``t`` the block's middle (averaging the model sample by sample cost a
    1 M-sample capture 90 s).  Only blocks wholly after the step are "after"
    (:class:`ResponseBasis` averages the others sample by sample).
    """
    if block is None:
        tt = np.clip(t, 0.0, None)
        return np.exp(np.outer(tt, p)), tt, t >= 0
    m, dt = int(block[0]), float(block[1])
    after = t > 0
    tt = np.where(after, t, 0.0)
    mean = np.expm1(p * m * dt) / (m * np.expm1(p * dt))
    return np.exp(np.outer(tt, p)) * mean, tt + 0.5 * (m - 1) * dt, after


class ResponseBasis:
    """``e^{p_i t}`` on one grid for one set of poles (or its block means), shared by every closed form.

    Parameters
    ----------
    time_s : ndarray
        Times from the step (s); with ``block``, the first time of each block.
    poles : ndarray
        ``p_i = −1/τ_i`` (from :func:`residues`, distinct).
    block : (int, float), optional
        ``(m, dt)``: every value is the mean over ``m`` samples ``dt`` apart.

    Notes
    -----
    Each method takes residues ``r`` of shape ``(n,)`` or ``(n, k)`` (then ``k`` columns at once)
    and returns the response divided by the step level (zero before the step).  A block that
    holds the step instant is averaged sample by sample.
    """

    __slots__ = ("_de", "_zeroed", "after", "block", "e", "lin", "p", "strict", "sub", "t")

    def __init__(self, time_s: np.ndarray, poles: np.ndarray, block: tuple[int, float] | None = None) -> None:
        t = np.asarray(time_s, dtype=float)
        self.t, self.p, self.block = t, np.asarray(poles, dtype=float), block
        self.e, self.lin, self.after = _exp_basis(t, self.p, block)
        # the slope has no value at a jump: strictly after the step
        self.strict = self.after if block is not None else t > 0
        self.sub: list[tuple[int, ResponseBasis]] = []
        if block is not None:
            m, dt = int(block[0]), float(block[1])
            self.sub = [(int(i), ResponseBasis(t[i] + dt * np.arange(m), self.p))
                        for i in np.flatnonzero((t <= 0) & (t + (m - 1) * dt >= 0))]
        self._de: np.ndarray | None = None
        # the times increase, so each mask is "false, then true": the rows it zeroes are a prefix,
        # zeroed in place in the fresh array each method builds (np.where made a second array of
        # it; every Jacobian of a fit builds a dozen); a mask of another pattern keeps np.where
        self._zeroed = {id(m): _false_prefix(m) for m in (self.after, self.strict)}

    def _masked(self, y: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """``y`` where ``mask`` holds, 0 elsewhere (``y`` is a fresh array: it may be written)."""
        first = self._zeroed.get(id(mask))
        if first is None:
            return np.where(mask if y.ndim == 1 else mask[:, None], y, 0.0)
        y[:first] = 0.0
        return y

    def step(self, r: np.ndarray, n0: float | np.ndarray) -> np.ndarray:
        """``N(0) + Σ R_i e^{p_i t}``: the step response (per volt).

        Parameters
        ----------
        r : ndarray
            Residues, ``(n,)`` or ``(n, k)``.
        n0 : float or ndarray
            ``N(0)`` (per column with ``k`` columns).

        Returns
        -------
        ndarray
            The response at each time, zero before the step.
        """
        out = self._masked(n0 + self.e @ r, self.after)
        for i, sub in self.sub:
            out[i] = sub.step(r, n0).mean(axis=0)
        return out

    def slope(self, r: np.ndarray, n0: float | np.ndarray = 0.0) -> np.ndarray:
        """``Σ R_i p_i e^{p_i t}``: the step response's time derivative (a jump at 0 excluded).

        Parameters
        ----------
        r : ndarray
            Residues, ``(n,)`` or ``(n, k)``.
        n0 : float or ndarray
            ``N(0)``: not needed here (a sample's slope has no jump), taken for
            :meth:`WindowBasis.slope`'s sake.

        Returns
        -------
        ndarray
            The slope at each time, zero up to the step.
        """
        rp = r * (self.p if r.ndim == 1 else self.p[:, None])
        out = self._masked(self.e @ rp, self.strict)
        for i, sub in self.sub:
            out[i] = sub.slope(r).mean(axis=0)
        return out

    def position(self, r: np.ndarray, n0: float | np.ndarray) -> np.ndarray:
        """``N(0)·t + Σ R_i (e^{p_i t} − 1)/p_i``: the step response's integral.

        Parameters
        ----------
        r : ndarray
            Residues, ``(n,)`` or ``(n, k)``.
        n0 : float or ndarray
            ``N(0)`` (per column with ``k`` columns).

        Returns
        -------
        ndarray
            The integral at each time, zero before the step.
        """
        rp = r / (self.p if r.ndim == 1 else self.p[:, None])
        lin = self.lin if np.ndim(n0) == 0 else self.lin[:, None]
        out = self._masked(n0 * lin + (self.e - 1.0) @ rp, self.after)
        for i, sub in self.sub:
            out[i] = sub.position(r, n0).mean(axis=0)
        return out

    def _basis_slope(self) -> np.ndarray:
        """``∂(basis)/∂p_i``: ``t·e^{p t}``, and for block means the derivative of their factor."""
        if self._de is None:
            de = self.e * np.where(self.after, self.t, 0.0)[:, None] if self.block is not None else \
                self.e * np.clip(self.t, 0.0, None)[:, None]
            if self.block is not None:
                m, dt = int(self.block[0]), float(self.block[1])
                p = self.p
                whole = m * dt * np.exp(p * m * dt) / np.expm1(p * m * dt)
                de = de + self.e * (whole - dt * np.exp(p * dt) / np.expm1(p * dt))
            self._de = de
        return self._de

    def shape(self, kind: str, num: np.ndarray, taus: np.ndarray | PartialFractions,
              dnums: Sequence[np.ndarray] = ()) -> np.ndarray:
        """Derivatives of :meth:`step` (``kind="step"``) or :meth:`position` in each ``ln τ_j``, then each ``dnums``.

        The basis functions' derivative in their pole is analytic, the residues' too
        (:func:`residue_derivatives`; they are linear in the numerator).  Finite differences of
        the whole response instead cost one model evaluation per time constant and zero in
        every Jacobian, most of a fit's time.

        Parameters
        ----------
        kind : str
            ``"step"`` or ``"position"``.
        num : ndarray
            Numerator ``N(s)`` (highest power first).
        taus : ndarray or PartialFractions
            The time constants whose poles this basis holds (or their partial fractions).
        dnums : sequence of ndarray
            Numerator directions ``∂N/∂θ`` (e.g. in a zero's time constant).

        Returns
        -------
        ndarray
            ``(len(time_s), len(taus) + len(dnums))``, per volt of step.
        """
        p = self.p
        pf = _fractions(taus)
        _, r, _ = pf.residues(num)
        dp, dr = pf.derivatives(num)
        position = kind == "position"
        if position:
            coef = r / p
            dcoef = dr / p[:, None]
            dcoef[np.diag_indices_from(dcoef)] -= r * dp / p**2
            cols = [(self.e - 1.0) @ dcoef + self._basis_slope() * (coef * dp)]
        else:
            cols = [self.e @ dr + self._basis_slope() * (r * dp)]
        for dnum in dnums:
            _, rn, n0 = pf.residues(dnum)
            cols.append((n0 * self.lin + (self.e - 1.0) @ (rn / p) if position else n0 + self.e @ rn)[:, None])
        out = self._masked(np.hstack(cols), self.after)
        for i, sub in self.sub:
            out[i] = sub.shape(kind, num, pf, dnums).mean(axis=0)
        return out


class WindowBasis:
    """The means of a closed form over the ``window`` before each time: a counted speed.

    A speed computed from the encoder edges counted since the last sample (what Arduino
    sketches print as rpm) is the mean speed over that interval, not a sample of it: the
    difference of the position over the interval, divided by it.  So each mean is
    ``(P(t) − P(t − T))/T`` with ``P`` the step response's integral (zero before the step,
    exact across it), and so are its derivatives: two :class:`ResponseBasis`, at ``t`` and at
    ``t − T``, with their block means when ``block`` is given (a block mean of window means is
    the difference of the two block means of the integral).  Without it, a fit puts the
    interval's lag (half of it, with the boxcar's shape) into the motor's dead time and time
    constants.

    Parameters
    ----------
    time_s : ndarray
        Times from the step (s), each the end of its window (or of its block's first window).
    poles : ndarray
        ``p_i = −1/τ_i``.
    window : float
        The window ``T`` (s), > 0.
    block : (int, float), optional
        ``(m, dt)``: every value is the mean over ``m`` such means ``dt`` apart.

    Notes
    -----
    It answers :meth:`step`, :meth:`slope` and :meth:`shape` with ``kind="step"``, what the
    output-error fit asks of a velocity channel's basis.
    """

    __slots__ = ("hi", "lo", "p", "window")

    def __init__(self, time_s: np.ndarray, poles: np.ndarray, window: float,
                 block: tuple[int, float] | None = None) -> None:
        t = np.asarray(time_s, dtype=float)
        self.window = float(window)
        self.hi = ResponseBasis(t, poles, block)
        self.lo = ResponseBasis(t - self.window, poles, block)
        self.p = self.hi.p

    def step(self, r: np.ndarray, n0: float | np.ndarray) -> np.ndarray:
        """The step response's mean over each window (per volt).

        Parameters
        ----------
        r : ndarray
            Residues, ``(n,)`` or ``(n, k)`` (as :meth:`ResponseBasis.step`).
        n0 : float or ndarray
            ``N(0)`` (per column with ``k`` columns).

        Returns
        -------
        ndarray
            ``(P(t) − P(t − T))/T`` at each time, zero up to the step.
        """
        return (self.hi.position(r, n0) - self.lo.position(r, n0)) / self.window

    def slope(self, r: np.ndarray, n0: float | np.ndarray = 0.0) -> np.ndarray:
        """The means' time derivative, ``(y(t) − y(t − T))/T``.

        Parameters
        ----------
        r : ndarray
            Residues, ``(n,)`` or ``(n, k)``.
        n0 : float or ndarray
            ``N(0)``: the step's jump enters every window that holds it.

        Returns
        -------
        ndarray
            The slope at each time.
        """
        return (self.hi.step(r, n0) - self.lo.step(r, n0)) / self.window

    def shape(self, kind: str, num: np.ndarray, taus: np.ndarray | PartialFractions,
              dnums: Sequence[np.ndarray] = ()) -> np.ndarray:
        """The means' derivatives in each ``ln τ_j``, then each ``dnums``.

        Parameters
        ----------
        kind : str
            ``"step"`` (a window mean of a position is not modelled).
        num : ndarray
            Numerator ``N(s)`` (highest power first).
        taus : ndarray or PartialFractions
            The time constants whose poles this basis holds (or their partial fractions).
        dnums : sequence of ndarray
            Numerator directions ``∂N/∂θ``.

        Returns
        -------
        ndarray
            ``(len(time_s), len(taus) + len(dnums))``, per volt of step.

        Raises
        ------
        ValueError
            For another ``kind``.
        """
        if kind != "step":
            raise ValueError(f"a window mean is modelled for a step response only, not {kind!r}")
        hi = self.hi.shape("position", num, taus, dnums)
        return (hi - self.lo.shape("position", num, taus, dnums)) / self.window


def step_response_closed_form(
    time_s: np.ndarray, num: ArrayLike, taus: ArrayLike, step_volts: float, block: tuple[int, float] | None = None
) -> np.ndarray:
    """Step response of ``N(s)/Π(1 + τ_i s)`` (strictly proper or biproper, distinct τ).

    ``y(t) = step·[N(0) + Σ_i R_i e^{p_i t}]`` with ``R_i`` the residues of ``N(s)/(s D(s))``
    (a biproper numerator's direct term is in the residues).  Zero for ``t < 0``.

    Parameters
    ----------
    time_s : ndarray
        Times in s (the step at 0).
    num : array_like
        Numerator ``N(s)``, highest power first.
    taus : array_like
        Time constants τ_i of the denominator, distinct.
    step_volts : float
        Step level in volts.
    block : (int, float), optional
        ``(m, dt)``: each of ``time_s`` is the first of ``m`` samples ``dt`` apart, and the
        result is their mean.

    Returns
    -------
    ndarray
        The response at ``time_s`` (or its block means).
    """
    p, r, n0 = residues(num, taus)
    return step_volts * ResponseBasis(time_s, p, block).step(r, n0)


def slope_closed_form(
    time_s: np.ndarray, num: ArrayLike, taus: ArrayLike, step_volts: float, block: tuple[int, float] | None = None
) -> np.ndarray:
    """Time derivative of :func:`step_response_closed_form` for ``t > 0``.

    The impulse response times the step; a jump at ``t = 0`` is not included.

    Parameters
    ----------
    time_s : ndarray
        Times in s (the step at 0).
    num : array_like
        Numerator ``N(s)``, highest power first.
    taus : array_like
        Time constants τ_i of the denominator.
    step_volts : float
        Step level in volts.
    block : (int, float), optional
        ``(m, dt)``: block means, as in :func:`step_response_closed_form`.

    Returns
    -------
    ndarray
        The slope at ``time_s`` (zero up to the step).
    """
    p, r, _ = residues(num, taus)
    return step_volts * ResponseBasis(time_s, p, block).slope(r)


def position_closed_form(
    time_s: np.ndarray, num: ArrayLike, taus: ArrayLike, step_volts: float, block: tuple[int, float] | None = None
) -> np.ndarray:
    """Integral from 0 of :func:`step_response_closed_form`: ``N(0)t + Σ R_i (e^{p_i t} − 1)/p_i``.

    Parameters
    ----------
    time_s : ndarray
        Times in s (the step at 0).
    num : array_like
        Numerator ``N(s)``, highest power first.
    taus : array_like
        Time constants τ_i of the denominator, distinct.
    step_volts : float
        Step level in volts.
    block : (int, float), optional
        ``(m, dt)``: block means, as in :func:`step_response_closed_form`.

    Returns
    -------
    ndarray
        The position (integral of the response), zero for ``t < 0``.
    """
    p, r, n0 = residues(num, taus)
    return step_volts * ResponseBasis(time_s, p, block).position(r, n0)
