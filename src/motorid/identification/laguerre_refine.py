"""The output-error refinement of the Laguerre–Hankel estimate (:mod:`.laguerre`).

Each order's realisation from the Laguerre basis is the start of an output-error fit on the same
samples: a continuous dead time, the current sharing the poles, channel offsets pinned by the
pre-step samples, an AR noise model when the residuals are coloured; the order is the least BIC
of the polished fits, compared on a common effective sample size (:func:`laguerre_polish`,
:func:`_polish_orders`).
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from motorid.identification.method_options import FIT_TOLERANCE, MAX_NFEV, SEARCH_TOLERANCE
from motorid.identification.metrics import bic
from motorid.identification.result import IdentificationError
from motorid.model import lti
from motorid.model.forced import DelayedHold, delayed_discretisation, zero_hold_delayed

if TYPE_CHECKING:
    from motorid.identification.laguerre import _Candidate

__all__ = ["POLISH_CHANNELS", "LaguerrePolish", "laguerre_polish"]


@dataclass(frozen=True)
class _Realisation:
    """``A``, ``B``, ``C`` of a transfer function (what the polish reads of a state-space object)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray


def _state_space(num: np.ndarray, den: np.ndarray) -> _Realisation:
    """The controllable realisation of ``num/den``: python-control's ``ss(tf(num, den))``.

    Without its import cost; a numerator with a tiny leading coefficient is expected here.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", lti.BadCoefficients)
        a, b, c, _ = lti.tf2ss(num, den)
    return _Realisation(a, b, c)


def _transfer_function(a: Any, b: Any, c: Any) -> tuple[np.ndarray, np.ndarray]:
    """``num, den`` of ``c (sI − a)⁻¹ b`` (SISO), exact leading zeros of ``num`` dropped.

    What python-control's ``ss2tf`` runs (without slycot), without building its objects.
    """
    nums, den = lti.ss2tf(np.asarray(a, float), np.asarray(b, float).reshape(-1, 1),
                                   np.asarray(c, float).reshape(1, -1), np.zeros((1, 1)))
    num = np.trim_zeros(np.atleast_1d(np.squeeze(nums[0])).astype(float), "f")
    return num, np.atleast_1d(np.squeeze(den)).astype(float)


def _polish_orders(candidates: list[_Candidate], t: np.ndarray, outputs: dict[str, np.ndarray],
                   u: np.ndarray | None, step_volts: float, primary: str,
                   pre_step: dict[str, np.ndarray] | None = None, phase_s: float = 0.0,
                   ) -> tuple[list[tuple[Any, ...]], int, str]:
    """The best realisation of each order, polished, and the order chosen among them.

    Returns ``(rows, chosen, note)``: a row (BIC, candidate, polish, A, B, C) per stable order; the
    index of the chosen one, the least-BIC order the data support (:func:`_resolved_choice`), or the
    least-BIC order when none is; and ``note``, what was passed over and why ('' when nothing listed
    with a lower BIC was).  An order with poles to spare can win BIC by hundreds on a record with a
    tone in its noise (a tacho's ripple fitted as a complex pair of damping 1e-5): that pair is the
    noise, not the motor.  When neither of the two orders compared under the shared noise model is
    supported, every order is compared under it.
    """
    best: dict[int, _Candidate] = {}
    for c in candidates:
        if c.stable and (c.order not in best or c.score < best[c.order].score):
            best[c.order] = c
    chosen: list[tuple[_Candidate, list[LaguerrePolish]]] = []
    # the candidates stop at the output-error order search's tolerance, the chosen one at the final fit's (below)
    run = functools.partial(laguerre_polish, t, outputs, input_v=u, step_volts=step_volts, primary=primary,
                            pre_step=pre_step, phase_s=phase_s, tolerance=SEARCH_TOLERANCE)
    for m, c in sorted(best.items()):
        fits = _polish_order(m, [{"A": c.A, "B": c.B, "C": c.C, "delay_s": c.coefficients.delay_s}],
                             chosen[-1][1][0] if chosen else None, float(t[1] - t[0]), run)
        if fits:
            chosen.append((c, fits))
    if not chosen:
        return [], -1, ""
    final, noise = _with_shared_noise_model(chosen, t, outputs, u, step_volts, primary, pre_step, phase_s)
    fastest = 2.0 / float(t[1] - t[0])
    final, pick, resolved, note = _resolved_choice(final, noise, run, fastest)
    if not resolved and len(final) < len(chosen):
        # none of the two best orders is resolved: every order under the same noise model (a simpler one
        # that trailed both, e.g. one pole where two and three each have a pole the data cannot place)
        every, _ = _with_shared_noise_model(chosen, t, outputs, u, step_volts, primary, pre_step, phase_s,
                                            every=True)
        if len(every) > len(final):
            final, pick, resolved, note = _resolved_choice(every, noise, run, fastest)
    out: list[tuple[Any, ...]] = []
    for c, pol in final:
        sys = _state_space(pol.num, pol.den)
        out.append((pol.bic, c, pol, *(np.asarray(x, dtype=float) for x in (sys.A, sys.B, sys.C))))
    return out, pick, note


def _resolved_choice(final: list[tuple[_Candidate, LaguerrePolish]], noise: dict[str, np.ndarray] | None,
                     run: Callable[..., LaguerrePolish], fastest: float = np.inf,
                     ) -> tuple[list[tuple[_Candidate, LaguerrePolish]], int, bool, str]:
    """The least-BIC order the data support, refitted at the final tolerance, and what it passed over.

    Orders are taken by BIC; one whose poles are not all resolved where its search fit stopped is passed
    over, as is one that no longer resolves them once refitted at the final tolerance, and one with a
    pole faster than ``fastest`` (``2/dt``: half a sample, which the samples do not see; a tacho's
    ripple above the Nyquist frequency was fitted as a lightly damped pair there).  The output-error
    method's structure choice applies the same rules.  When no order is supported the least-BIC order
    is refitted and kept (the sanity gate then says which pole the data do not resolve).  Returns the
    fits (the chosen one refitted), its index, whether it is supported, and the words for what was
    passed over ('' when nothing listed with a lower BIC was).
    """
    from motorid.identification.laguerre_uncertainty import unresolved_poles

    def why(pol: LaguerrePolish) -> str:
        # poles only: a zero the polish leaves far out (a numerator term near rounding) changes nothing the
        # samples see, and the polish drops a zero the data do not determine when BIC agrees
        if np.max(np.abs(np.roots(pol.den)), initial=0.0) > fastest:
            return "a pole beyond the sampling rate"
        loose = unresolved_poles(pol)
        return "the data do not resolve its pole(s) " + ", ".join(str(i + 1) for i in loose) if loose else ""

    def words(pol: LaguerrePolish, reason: str, refitted: bool) -> str:
        return (f"order {pol.den.size - 1} (BIC {pol.bic:.1f}: " + ("refitted at the final tolerance, " if refitted
                                                                   else "") + reason + ")")

    ranked = sorted(range(len(final)), key=lambda k: final[k][1].bic)
    passed: list[tuple[float, str]] = []
    refits: dict[int, list[tuple[_Candidate, LaguerrePolish]]] = {}
    for k in ranked:
        reason = why(final[k][1])
        if reason:
            passed.append((final[k][1].bic, words(final[k][1], reason, False)))
            continue
        refits[k] = _chosen_refitted(final, noise, run, k)
        reason = why(refits[k][k][1])
        if not reason:
            # what the reader sees passed over: an order listed with a lower BIC than the chosen one's
            named = [text for bic, text in passed if bic < refits[k][k][1].bic]
            note = "" if not named else (
                f"order {final[k][1].den.size - 1} is the least BIC among the orders the data support, "
                "passed over: " + "; ".join(named))
            return refits[k], k, True, note
        passed.append((refits[k][k][1].bic, words(refits[k][k][1], reason, True)))
    k = ranked[0]
    return (refits[k] if k in refits else _chosen_refitted(final, noise, run, k)), k, False, ""


def _chosen_refitted(final: list[tuple[_Candidate, LaguerrePolish]], noise: dict[str, np.ndarray] | None,
                     run: Callable[..., LaguerrePolish], i: int) -> list[tuple[_Candidate, LaguerrePolish]]:
    """The chosen order (``final[i]``) refitted at the final fit's tolerance, resumed where its candidate fit stopped.

    As the output-error method does: the candidates of the order search stop at
    :data:`SEARCH_TOLERANCE` (an order with a pole to spare creeps along a ridge for its whole
    budget at 1e-8, the cost moving by 1e-7 of itself), the chosen structure at :data:`FIT_TOLERANCE`.
    ``run`` is the candidates' :func:`laguerre_polish` (its tolerance is overridden here).
    """
    if not final:
        return final
    pol = final[i][1]
    sys = _state_space(pol.num, pol.den)
    try:
        again = run(A=sys.A, B=sys.B, C=sys.C, delay_s=pol.delay_s, start=pol, noise=noise, tolerance=FIT_TOLERANCE)
    except (IdentificationError, np.linalg.LinAlgError, ValueError):
        return final
    if not _usable(again, pol.den.size - 1):
        return final
    polishes = [p for _, p in final]
    polishes[i] = again
    if noise is None:  # scored on one effective sample size per channel, as the orders were compared
        polishes = _on_common_inflation(polishes)
    return [(cc, p) for (cc, _), p in zip(final, polishes, strict=True)]


def _with_shared_noise_model(orders: list[tuple[_Candidate, list[LaguerrePolish]]], t: np.ndarray,
                             outputs: dict[str, np.ndarray], u: np.ndarray | None, step_volts: float, primary: str,
                             pre_step: dict[str, np.ndarray] | None,
                             phase_s: float = 0.0, *, every: bool = False,
                             ) -> tuple[list[tuple[_Candidate, LaguerrePolish]], dict[str, np.ndarray] | None]:
    """The orders compared, refitted by generalised least squares under one noise model when residuals are coloured.

    ``orders`` holds each order's polished fits (best first).  Their best ones are scored on one effective
    sample size per channel.  The noise model (an AR polynomial per channel, order by BIC) comes from the
    residuals of the fit that score prefers; tacho ripple and aliased PWM are coloured, and a lag-1 inflation
    alone leaves most of what they hide unused (a 7 ms pole beside 4 ms samples was told from a dead time in
    half the realistic runs).  The two best orders are then refitted under it, each resumed from every fit it
    had (a fit in the wrong valley can win under the lag-1 inflation), and compared on the whitened residuals.
    With white residuals everywhere the first scores stand.  ``every`` refits every order, not the two best.
    """
    from motorid.identification.output_error import ar_noise_model  # the output-error method's own Yule–Walker AR

    scored = list(zip([c for c, _ in orders], _on_common_inflation([fits[0] for _, fits in orders]), strict=True))
    ranked = sorted(range(len(orders)), key=lambda i: scored[i][1].bic)
    noise = {ch: ar_noise_model(r)[0] for ch, r in scored[ranked[0]][1].residuals.items()}
    if all(poly.size == 1 for poly in noise.values()):
        return scored, None
    run = functools.partial(laguerre_polish, t, outputs, input_v=u, step_volts=step_volts, primary=primary,
                            pre_step=pre_step, noise=noise, phase_s=phase_s, tolerance=SEARCH_TOLERANCE)
    out: list[tuple[_Candidate, LaguerrePolish]] = []
    # the two best orders compete again (a third one behind both under the lag-1 inflation has not come back in
    # the bench's runs, and each GLS refit costs a full fit)
    for i in sorted(ranked if every else ranked[:2]):
        c, fits = orders[i]
        m = fits[0].den.size - 1
        starts = []
        for f in fits:
            sys = _state_space(f.num, f.den)
            starts.append({"A": sys.A, "B": sys.B, "C": sys.C, "start": f})  # resumed where it left every parameter
        gls = _polish_order(m, starts, out[-1][1] if out else None, float(t[1] - t[0]), run)
        if gls:
            out.append((c, gls[0]))
    return (out, noise) if out else (scored, None)


def _polish_order(m: int, firsts: list[dict[str, Any]], prev: LaguerrePolish | None, h: float,
                  run: Callable[..., LaguerrePolish]) -> list[LaguerrePolish]:
    """Order ``m`` polished from each of ``firsts`` (keywords of :func:`laguerre_polish`) and from ``prev``.

    ``prev``, the best fit of order ``m − 1``, starts order ``m`` with its dead time made a pole
    (:func:`_one_pole_more`).  Both kinds of start are needed: a start that fits better than order ``m − 1``
    may still sit in the wrong valley (third-order trainer, white seed 22: −179 1/s with a 10 ms dead time for
    order 2, against −7.9 1/s and 5 ms; electrical-7ms, realistic seed 0: a 6.7 ms dead time beside a
    −6400 1/s pole, against −152 1/s).  Returns the usable fits on one effective sample size, best first.
    """
    fits: list[LaguerrePolish] = []

    def attempt(**kw: Any) -> None:
        try:
            pol = run(**kw)
        except (IdentificationError, np.linalg.LinAlgError, ValueError):
            return
        if _usable(pol, m):
            fits.append(pol)

    for first in firsts:
        attempt(**first)
    if prev is not None and prev.den.size == m:
        sysp = _state_space(*_one_pole_more(prev, h))
        attempt(A=sysp.A, B=sysp.B, C=sysp.C, delay_s=0.0)
    # a zero the data do not determine (the numerator's top coefficient inside its own error: a far zero on
    # either side of the imaginary axis by chance) is dropped when BIC agrees: refitted with one zero fewer
    while fits and (fewer := _one_zero_fewer(best := min(_on_common_inflation(fits), key=lambda f: f.bic))):
        count = len(fits)
        attempt(**fewer)
        if len(fits) == count:
            break
        pair = _on_common_inflation([best, fits[-1]])
        if pair[1].bic > pair[0].bic:
            fits.pop()
            break
        fits[:] = [f for f in fits if f.n_zeros == fits[-1].n_zeros]  # the fewer zeros stand for the order
    return sorted(_on_common_inflation(fits), key=lambda f: f.bic)


def _usable(pol: LaguerrePolish, m: int) -> bool:
    """Whether a polished fit is of order ``m``, finite and stable."""
    return bool(pol.den.size - 1 == m and np.all(np.isfinite(pol.den)) and np.all(np.isfinite(pol.num))
                and np.all(np.real(np.roots(pol.den)) < 0))


def _one_zero_fewer(fit: LaguerrePolish) -> dict[str, Any] | None:
    """Keywords of :func:`laguerre_polish` for ``fit`` with one zero fewer, or None when its zeros are determined.

    The numerator's highest free coefficient is inside its 95 % interval of 0 (a t-ratio under 1.96):
    the data do not say on which side of the imaginary axis, or how far, that zero lies.  Refitted
    from ``fit``'s poles, dead time and the rest of its numerator.
    """
    m = fit.den.size - 1
    free = m if fit.n_zeros is None else fit.n_zeros + 1
    if free <= 1 or fit.covariance is None:
        return None
    top = m + free - 1
    value, std = float(fit.params[top]), float(np.sqrt(max(fit.covariance[top, top], 0.0)))
    if not abs(value) < 1.96 * std:
        return None
    num = np.trim_zeros(np.asarray(fit.params[m:top], dtype=float)[::-1], "f")
    sys = _state_space(num if num.size else np.zeros(1), fit.den)
    return {"A": sys.A, "B": sys.B, "C": sys.C, "delay_s": fit.delay_s, "n_zeros": free - 2}


def _one_pole_more(fit: LaguerrePolish, h: float) -> tuple[np.ndarray, np.ndarray]:
    """A start for one order more: the fit with its dead time made a pole, ``e^(−θs) ≈ 1/(1 + θs)``.

    A dead time and a fast pole look alike on a step; without a dead time (or one under a sample) the new pole
    is a one-sample lag, where the realisation of the higher order, from the velocity alone, may have nothing to
    offer (the third-order trainer's fast pair nearly cancels its zero).
    """
    return fit.num, np.polymul(fit.den, [max(fit.delay_s, h), 1.0])


def _on_common_inflation(fits: list[LaguerrePolish]) -> list[LaguerrePolish]:
    """The fits with their BIC on one effective sample size per channel.

    Each fit counts a channel's samples as ``n/inflation`` from its own residual's correlation;
    compared across fits that is no likelihood comparison: a model whose residual is a little
    whiter gains ``Δn·log(RSS/n)``, tens of BIC units for a 0.3 % change of the inflation and a
    value that depends on the channel's units (behind most of the extra poles of the white-noise
    runs, 18–25 % of them on three presets).  Scored here with every channel's least inflation
    among the fits.
    """
    if not fits:
        return []
    common = {ch: min(f.inflation[ch] for f in fits) for ch in fits[0].channels}
    return [replace(f, bic=_polish_bic(f.n_samples, f.sigma, common, f.n_params)) for f in fits]


def _polish_bic(n_samples: dict[str, int], sigma: dict[str, float], inflation: dict[str, float],
                n_params: int) -> float:
    """:func:`~motorid.identification.metrics.bic` on each channel's effective samples ``n_ch/f_ch``."""
    return bic({ch: n_samples[ch] / inflation[ch] for ch in n_samples}, {ch: sigma[ch] ** 2 for ch in n_samples},
               n_params)


#: Sampled systems the polish keeps (:func:`laguerre_polish`): enough for a Jacobian's columns of the
#: denominator (one new system per channel each) to leave the point's own in place for its other columns.
SAMPLED_KEPT = 16


#: Channels the polish can use besides the primary one, and how they relate to the velocity TF ``G = n/d``:
#: the position is ``c·G/s`` (the integrator known, the scale ``c`` fitted), the current ``n_c/d + D_c`` (the
#: poles shared, its own numerator with a direct term for an electrical pole faster than the sampling).
POLISH_CHANNELS = ("velocity", "position", "current")


@dataclass(frozen=True, slots=True)
class LaguerrePolish:
    """Output-error polish of a realisation on the same samples (:func:`laguerre_polish`).

    Attributes
    ----------
    num, den : ndarray
        Velocity transfer function ``n(s)/d(s)`` (``d`` monic), highest power first; for a
        position-only experiment the position channel's derivative.
    delay_s : float
        Dead time fitted (continuous, ≥ 0).
    channels : tuple of str
        Channels fitted, the primary one first.
    sigma : dict
        Per channel: RMS residual, volts (of the whitened residual: the innovation, with a noise model).
    inflation : dict
        Per channel: ``(1 + ρ)/(1 − ρ)`` of the residual's lag-1 autocorrelation ρ; the
        channel's weight is ``1/(σ·√inflation)`` and it counts ``n/inflation`` samples.
    position_scale : float
        ``c`` (position volts per velocity volt-second), nan without a position channel
        besides the primary.
    current_tf : tuple of ndarray or None
        ``(num, den)`` of the current channel, None without one.
    bic : float
        ``Σ (n_ch/inflation_ch)·log(RSS_ch/n_ch) + p·log Σ n_ch/inflation_ch``; in a
        :func:`laguerre_identify` result, scored on the inflation shared by the fits compared.
    n_params : int
        Parameters fitted (the channels' offsets included).
    residuals : dict
        Per channel: the residual, post-step samples then pre-step ones (not whitened).
    ar_order : dict
        Per channel: order of the AR noise model the residual was whitened by (0: none).
    params : ndarray
        The fitted parameter vector (to resume from, :func:`laguerre_polish`'s ``start``).
    shifts : dict
        Per channel after the primary: its fitted trigger shift against the primary's step
        instant (s, within one grid step), reported with the model (``extras.laguerre_polish``).
    covariance : ndarray or None
        Covariance of ``params`` (Gauss–Newton at the fit, scaled by the weighted residual's
        variance; :func:`_covariance`); ``None`` when the Fisher information is singular.
    n_zeros : int or None
        Zeros of the velocity transfer function the fit had free (``None``: one fewer than the
        poles, every numerator coefficient); ``params`` holds that many numerator coefficients plus one.
    """

    num: np.ndarray
    den: np.ndarray
    delay_s: float
    channels: tuple[str, ...]
    sigma: dict[str, float]
    inflation: dict[str, float]
    position_scale: float
    current_tf: tuple[np.ndarray, np.ndarray] | None
    bic: float
    n_params: int
    residuals: dict[str, np.ndarray]
    ar_order: dict[str, int]
    params: np.ndarray
    shifts: dict[str, float] = field(default_factory=dict)
    covariance: np.ndarray | None = None
    n_zeros: int | None = None

    @property
    def n_samples(self) -> dict[str, int]:
        """Per channel: residual samples (the pre-step ones included)."""
        return {ch: int(r.size) for ch, r in self.residuals.items()}


def _lag1_inflation(r: np.ndarray) -> float:
    r = r - r.mean()
    rr = float(r @ r)
    rho = float(r[1:] @ r[:-1] / rr) if rr > 0 else 0.0
    rho = min(max(rho, 0.0), 0.99)
    return (1 + rho) / (1 - rho)


def _covariance(jac: np.ndarray, fun: np.ndarray, inflation: float = 1.0) -> np.ndarray | None:
    """Gauss–Newton covariance of a least-squares fit: ``s²·(JᵀJ)⁻¹·inflation``.

    ``J`` and the residual ``fun`` are those of the weighted (whitened) residual at the solution,
    ``s² = ‖fun‖²/(N − p)`` its variance; ``inflation`` the lag-1 factor of a residual left
    correlated (one channel, no noise model).  A Jacobian whose smallest singular value, its
    columns scaled to unit norm, is at the rounding of the largest (a direction the data do not
    move) gives ``None``, not a pseudo-inverse's small variance for a parameter nothing determines.
    """
    jac = np.asarray(jac, dtype=float)
    if jac.ndim != 2 or not np.all(np.isfinite(jac)) or fun.size <= jac.shape[1]:
        return None
    # columns scaled to unit norm first: the parameters' units differ by orders of magnitude (a numerator in rpm
    # beside a dead time in seconds), and the rank test is then one of the data, not of the units
    norms = np.linalg.norm(jac, axis=0)
    if np.any(norms == 0.0):
        return None
    _, sv, vt = np.linalg.svd(jac / norms, full_matrices=False)
    if sv.size == 0 or sv[-1] <= np.finfo(float).eps * max(jac.shape) * sv[0]:
        return None
    s2 = float(fun @ fun) / (fun.size - jac.shape[1])
    return ((vt.T / sv**2) @ vt) / np.outer(norms, norms) * s2 * inflation


def _full_jacobian(resid: Callable[[np.ndarray], np.ndarray], sol: Any) -> np.ndarray:
    """The Jacobian at a bounded least-squares solution, the columns of parameters at a bound included.

    scipy's ``trf`` returns those columns as zeros (its "modified" Jacobian); a dead time that
    ends at 0 would then get no variance and leave a singular Fisher information.  Each is a
    one-sided difference into the feasible side, with the fit's own relative step.
    """
    jac = np.array(sol.jac, dtype=float)
    for i in np.flatnonzero(sol.active_mask):
        h = 1e-6 * max(1.0, abs(float(sol.x[i]))) * (1.0 if sol.active_mask[i] < 0 else -1.0)
        moved = sol.x.copy()
        moved[i] += h
        jac[:, i] = (resid(moved) - sol.fun) / h
    return jac


def _input_for_polish(t: np.ndarray, input_v: Any, step_volts: float) -> np.ndarray:
    """The recorded input, or the step level when it is a step plus white noise.

    A current channel's direct term passes the recorded input's noise straight into the
    prediction (and every channel gets it low-passed): a recorded step whose variation after the
    edge is uncorrelated noise is replaced by ``step_volts``, the level read off every capture's
    whole record (whose error the DC gain's interval carries), or by its own mean when that is
    not within 5 % of it; an input with a shape (droop, overshoot, a ramp) is kept sample by
    sample.
    """
    if input_v is None:
        return np.full(t.size, float(step_volts))
    u = np.asarray(input_v, dtype=float).ravel()
    after = u[1:]
    if after.size < 8:
        return u
    level = float(np.mean(after))
    r = after - level
    if level and float(np.sqrt(np.mean(r**2))) < 0.05 * abs(level) and _lag1_inflation(r) < 1.5:
        # the window's own mean is a noisier level (its thinned samples, one capture's baseline): with it the
        # DC gain's white-noise interval, which carries the level's error from all captures, was a fifth too narrow
        read_off = float(step_volts)
        return np.full(t.size, read_off if abs(read_off - level) <= 0.05 * abs(level) else level)
    return u


class _PolishModel:
    """Parameter vector ↔ augmented state space of every fitted channel."""

    def __init__(self, order: int, channels: tuple[str, ...], n_zeros: int | None = None) -> None:
        self.m = order
        # the velocity numerator's free coefficients, lowest powers first (the higher ones are 0): n_zeros + 1
        self.n_num = order if n_zeros is None else min(max(int(n_zeros), 0) + 1, order)
        self.channels = channels
        self.primary = channels[0]
        self.integrate = "position" in channels
        self.free_scale = self.integrate and self.primary != "position"
        self.current = "current" in channels
        # each other capture has its own sub-sample trigger time: a shift against the primary's dead time
        self.n_shifts = len(channels) - 1
        self.n_params = (order + self.n_num + 1 + int(self.free_scale) + (order + 1) * int(self.current)
                         + self.n_shifts)

    @property
    def delay_index(self) -> int:
        """Index of the dead time in the parameter vector (after the denominator and the numerator)."""
        return self.m + self.n_num

    def unpack(self, x: np.ndarray) -> dict[str, Any]:
        m, k = self.m, self.n_num
        n = x[m:m + k] if k == m else np.r_[x[m:m + k], np.zeros(m - k)]
        q: dict[str, Any] = {"d": x[:m], "n": n, "delay": float(x[m + k])}
        i = m + k + 1
        q["c"] = float(x[i]) if self.free_scale else 1.0
        i += int(self.free_scale)
        if self.current:
            q["nc"], q["dc"] = x[i:i + m], float(x[i + m])
            i += m + 1
        q["shifts"] = np.r_[0.0, x[i:i + self.n_shifts]] if x.size >= i + self.n_shifts else np.zeros(1)
        return q

    def system(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        q = self.unpack(x)
        m = self.m
        a_c = np.zeros((m, m))
        a_c[:-1, 1:] = np.eye(m - 1)
        a_c[-1, :] = -q["d"]  # controllable companion form: x_1 … x_m, d = [d_0 … d_(m−1)]
        b_c = np.zeros((m, 1))
        b_c[-1, 0] = 1.0
        ns = m + int(self.integrate)
        a_s = np.zeros((ns, ns))
        a_s[:m, :m] = a_c
        b_s = np.zeros((ns, 1))
        b_s[:m] = b_c
        if self.integrate:
            a_s[m, :m] = q["n"]
        rows, dcol = [], []
        for ch in self.channels:
            row = np.zeros(ns)
            if ch == "velocity":
                row[:m] = q["n"]
            elif ch == "position":
                row[m] = q["c"]
            else:
                row[:m] = q["nc"]
            rows.append(row)
            dcol.append(q["dc"] if ch == "current" else 0.0)
        shifts = q["shifts"] if q["shifts"].size == len(self.channels) else np.zeros(len(self.channels))
        return a_s, b_s, np.array(rows), np.array(dcol), q["delay"] + shifts


def laguerre_polish(
    time_s: Any,
    outputs: dict[str, Any],
    A: Any,
    B: Any,
    C: Any,
    *,
    input_v: Any = None,
    step_volts: float = 1.0,
    delay_s: float = 0.0,
    primary: str = "velocity",
    rounds: int = 1,
    pre_step: dict[str, Any] | None = None,
    noise: dict[str, Any] | None = None,
    start: LaguerrePolish | None = None,
    phase_s: float = 0.0,
    n_zeros: int | None = None,
    tolerance: float = FIT_TOLERANCE,
) -> LaguerrePolish:
    """Polish a realisation by output-error least squares on every channel given.

    The realisation's poles are a consistent but not an efficient estimate (the truncated
    expansion and the ERA's rank cut lose information); a Gauss–Newton polish on the same
    samples, started there, reaches the efficiency of a prediction-error fit.  The primary
    channel carries ``G = n/d`` (or ``G/s`` for a position-only experiment); a position
    channel besides a velocity one is ``c·G/s`` (integrator known), a current channel
    ``n_c/d + D_c`` (poles shared).  Each channel is weighted by ``1/(σ·√inflation)`` from its
    residual (re-estimated after each round), so a quantised or rippled channel does not
    dominate with correlated errors.

    Parameters
    ----------
    time_s : array_like
        Uniform times from the step edge.
    outputs : dict
        Channel name (``velocity``, ``position``, ``current``) → increment, volts.
    A, B, C : array_like
        Realisation of ``G`` (no direct term).
    input_v : array_like, optional
        Recorded input increment on ``time_s`` (held); None: the ideal step.
    step_volts : float
        Ideal step level.
    delay_s : float
        Starting dead time.
    primary : {"velocity", "position"}
        Channel that ``A, B, C`` describe (``position``: ``G`` is its derivative).
    rounds : int
        Reweighting rounds of the joint fit.
    pre_step : dict, optional
        Channel name → its samples before the step (baseline removed, as ``outputs``).  Given,
        every channel with pre-step samples gets an output offset fitted on its pre-step and
        post-step samples together (in closed form: the mean residual over both), so an error
        of the baseline read off before the step is a nuisance parameter instead of a
        misfit that an extra slow pole takes up.  Without the pre-step samples an offset is
        nearly collinear with the DC gain (projected out of the post-step residual alone it
        multiplied the white-noise DC-gain RMSE by 8–19), so none is fitted.
    noise : dict, optional
        Channel name → AR whitening polynomial ``[1, a_1, …, a_p]`` of its noise
        (:func:`motorid.identification.output_error.ar_noise_model`).  Given, each channel's residual
        is whitened by it before weighting (generalised least squares: tacho ripple and aliased
        PWM then count for what they are), the fit starts at ``A, B, C`` itself (no
        primary-alone round) and the BIC is that of the whitened residuals, so fits polished
        with the same noise model compare on one likelihood.
    start : LaguerrePolish, optional
        A polish of the same order and channels to resume from: every parameter starts where it
        left it (``A, B, C`` and ``delay_s`` are then not used).
    phase_s : float
        Seconds from the step instant to the first sample (half a sample for a scope's sampled
        edge, whose step lies anywhere in the interval before it): every sample is that much
        later after the step than ``time_s`` says, so the fitted dead time counts from the step
        instant and is ≥ 0 from there (read from the edge sample, the response of a motor with
        no dead time starts half a sample early, and a dead time held at 0 left τ short by it).
    n_zeros : int, optional
        Zeros of the velocity transfer function (its numerator's higher coefficients held at 0);
        default one fewer than the poles (every coefficient free), or ``start``'s.
    tolerance : float
        Relative change of the cost and of the parameters that ends the fit (``ftol``, ``xtol``).

    Returns
    -------
    LaguerrePolish

    Raises
    ------
    IdentificationError
        If the primary channel is missing.
    """
    import scipy.optimize
    from scipy.signal import lfilter  # as in zero_hold_delayed

    t = np.asarray(time_s, dtype=float).ravel()
    if primary not in outputs:
        raise IdentificationError(f"the polish needs the {primary} channel")
    channels = (primary, *[ch for ch in POLISH_CHANNELS if ch in outputs and ch != primary])
    ys = {ch: np.asarray(outputs[ch], dtype=float).ravel() for ch in channels}
    u = _input_for_polish(t, input_v, step_volts)
    h = float(t[1] - t[0])
    num, den = _transfer_function(A, B, C)
    m = den.size - 1
    num, den = num / den[0], den / den[0]
    num = np.r_[np.zeros(m - num.size), num][-m:]
    # a realisation whose numerator's leading terms are at the rounding of the rest (~1e-13 of it) has that many
    # zeros fewer: fitted as free coefficients they never moved (scipy's finite-difference step is relative to the
    # parameter, 1e-6 of 1e-13), left a zero column in the Jacobian and no covariance; freed from exactly 0 they
    # opened slow pole-zero pairs on a first-order record.  Any other such coefficient starts at exactly 0.
    tiny = np.abs(num) < 1e-9 * np.max(np.abs(num), initial=0.0)
    num[tiny] = 0.0
    if start is not None and n_zeros is None:
        n_zeros = start.n_zeros
    elif n_zeros is None and not np.all(tiny):
        n_zeros = m - 1 - int(np.argmin(tiny))  # the leading coefficients that are 0 are not zeros to fit
    pm = _PolishModel(m, channels, n_zeros)
    x = np.r_[den[1:][::-1], num[::-1][:pm.n_num], max(float(delay_s), 0.0)]
    lower = np.full(pm.n_params, -np.inf)
    lower[pm.delay_index] = 0.0

    # the sampled systems of the last evaluations, by their A and delay: a finite-difference column of a
    # numerator, a scale or a direct term moves neither, and the exponentials and Φ's eigenvalue problem
    # are most of a prediction's cost (the same numbers: the same function of the same arguments)
    sampled: dict[tuple[bytes, float], DelayedHold] = {}

    def predict(model: _PolishModel, xx: np.ndarray) -> np.ndarray:
        a_s, b_s, rows, dcol, dls = model.system(xx)
        dls = dls - phase_s
        cols = []
        for i in range(rows.shape[0]):
            key = (a_s.tobytes(), float(dls[i]))
            if key not in sampled:
                if len(sampled) >= SAMPLED_KEPT:
                    del sampled[next(iter(sampled))]  # the oldest
                sampled[key] = delayed_discretisation(a_s, b_s, h, float(dls[i]))
            cols.append(zero_hold_delayed(a_s, b_s, rows[i:i + 1], dcol[i:i + 1], h, u, dls[i],
                                          discretisation=sampled[key])[:, 0])
        return np.column_stack(cols)

    # the current jumps at the step: its sample at the edge depends on the sub-sample trigger time
    # discontinuously, so it is left out (as in the output-error method)
    mask_of = {ch: (t > 1.5 * h) if ch == "current" else np.ones(t.size, dtype=bool) for ch in channels}

    pre = {ch: np.asarray(v, dtype=float).ravel() for ch, v in (pre_step or {}).items()
           if ch in channels and np.size(v) > 0}

    def offset(r: np.ndarray, mask: np.ndarray, channel: str) -> float:
        # the channel's output offset (its pre-step level is only estimated), fitted by exact least squares on the
        # pre-step samples (where the response is zero) and the post-step residual together
        y0 = pre[channel]
        return (float(np.sum(r[mask])) + float(np.sum(y0))) / (np.count_nonzero(mask) + y0.size)

    whiten = {ch: np.atleast_1d(np.asarray(noise[ch], dtype=float)) for ch in channels
              if noise is not None and ch in noise}

    def residual(r: np.ndarray, channel: str, white: bool) -> np.ndarray:
        # post-step (masked) then pre-step residual of one channel, each segment whitened by the channel's AR model
        mk = mask_of[channel]
        if channel in pre:
            off = offset(r, mk, channel)
            post, before = r[mk] - off, pre[channel] - off
        else:
            post, before = r[mk], np.zeros(0)
        if white and channel in whiten and whiten[channel].size > 1:
            poly = whiten[channel]
            post = lfilter(poly, [1.0], post)
            before = lfilter(poly, [1.0], before) if before.size else before
        return np.r_[post, before]

    def fit(model: _PolishModel, x0: np.ndarray, w: np.ndarray) -> tuple[Any, Callable[[np.ndarray], np.ndarray]]:
        y_all = np.column_stack([ys[ch] for ch in model.channels])

        def resid(xx: np.ndarray) -> np.ndarray:
            with np.errstate(all="ignore"):
                r = y_all - predict(model, xx)
                out = np.concatenate([residual(r[:, i], ch, True) * wi
                                      for i, (ch, wi) in enumerate(zip(model.channels, w, strict=True))])
            return np.nan_to_num(out, nan=1e6, posinf=1e6, neginf=-1e6)

        lo, hi = lower[:x0.size].copy(), np.full(x0.size, np.inf)
        if model.n_shifts:
            lo[-model.n_shifts:], hi[-model.n_shifts:] = -h, h
        # diff_step: the sampled response carries ~1e-11 of rounding (polynomial filters with poles
        # near z = 1), too much for the default √eps finite-difference step.  The output-error fit's
        # tolerance and evaluation budget: at 1e-10 and 100 evaluations a parameter, an order with a
        # pole–zero pair to spare crept on for 900 evaluations (8 s) and changed no order chosen
        with np.errstate(over="ignore"):  # a trial step far off: its cost overflows and the step is refused
            sol = scipy.optimize.least_squares(resid, x0, bounds=(lo, hi), x_scale="jac", method="trf",
                                               diff_step=1e-6, xtol=tolerance, ftol=tolerance,
                                               max_nfev=MAX_NFEV)
        return sol, resid

    def stats(pred: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # RMS and lag-1 inflation (1 when whitened) of the residuals as fitted (whitened when a noise model is given)
        res = [residual(ys[ch] - pred[:, i], ch, True) for i, ch in enumerate(channels)]
        sig = np.array([np.sqrt(np.mean(r**2)) for r in res])
        infl = np.array([1.0 if whiten else _lag1_inflation(r) for r in res])
        return sig, infl

    # 1. the primary channel alone: the channels' weights must come from a model that fits, not from the
    #    realisation (reweighting from a poor start locks onto whichever channel happens to fit best); with a noise
    #    model the start is already a polished fit
    resumed = start is not None and start.channels == channels and start.params.size == pm.n_params
    # the covariance comes from the last fit of every channel: (its solution, its residual, whether its weights
    # left the residual's correlation out)
    last: tuple[Any, Callable[[np.ndarray], np.ndarray], bool] | None = None
    if resumed:
        assert start is not None
        x = start.params.copy()  # every parameter where that fit left it (the other channels', the shifts too)
    elif not whiten:
        sol, resid = fit(_PolishModel(m, (primary,), n_zeros), x, np.ones(1))
        x, last = sol.x, (sol, resid, len(channels) == 1)
    # 2. the other channels' linear parameters by least squares with those poles
    if (pm.free_scale or pm.current) and not resumed:
        alone = _PolishModel(m, (primary,), n_zeros)
        a_s, b_s, _, _, dls = alone.system(x)
        dl = float(dls[0]) - phase_s
        basis = zero_hold_delayed(a_s, b_s, np.eye(m), np.zeros(m), h, u, dl)  # the state responses
        if pm.free_scale:
            vel = basis @ alone.unpack(x)["n"]
            pos = np.cumsum(np.r_[0.0, (vel[1:] + vel[:-1]) / 2]) * h
            x = np.r_[x, float(pos @ ys["position"] / max(pos @ pos, 1e-300))]
        if pm.current:
            udel = zero_hold_delayed(np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), np.ones(1), h, u, dl)[:, 0]
            keep = mask_of["current"]
            coef, *_ = np.linalg.lstsq(np.column_stack([basis, udel])[keep], ys["current"][keep], rcond=None)
            x = np.r_[x, coef]
        x = np.r_[x, np.zeros(pm.n_shifts)]
    # 3. every channel, weighted by its residual level and correlation, re-estimated each round
    pred = predict(pm, x)
    sig, infl = stats(pred)
    if len(channels) > 1 or whiten:
        for _ in range(max(1, rounds)):
            sol, resid = fit(pm, x, 1.0 / (np.maximum(sig, 1e-12 * np.max(sig)) * np.sqrt(infl)))
            x, last = sol.x, (sol, resid, False)
            pred = predict(pm, x)
            sig, infl = stats(pred)
    elif resumed:  # one channel, no noise model: the fit resumed, unweighted as its first round was
        sol, resid = fit(pm, x, np.ones(1))
        x, last = sol.x, (sol, resid, True)
        pred = predict(pm, x)
        sig, infl = stats(pred)
    if last is None:  # nothing fitted (cannot happen: kept for the type checker)
        cov = start.covariance if start is not None else None
    else:
        # one channel without a noise model is fitted unweighted: its residual's correlation inflates the variance
        cov = _covariance(_full_jacobian(last[1], last[0]), last[0].fun, float(infl[0]) if last[2] else 1.0)
    q = pm.unpack(x)
    raw = {ch: residual(ys[ch] - pred[:, i], ch, False) for i, ch in enumerate(channels)}
    n_fitted = pm.n_params + len(pre)  # the offsets too
    n_samples = {ch: int(r.size) for ch, r in raw.items()}
    sigma = {ch: float(sg) for ch, sg in zip(channels, sig, strict=True)}
    inflation = {ch: float(f) for ch, f in zip(channels, infl, strict=True)}
    num_out = np.trim_zeros(q["n"][::-1], "f")
    den_out = np.r_[1.0, q["d"][::-1]]
    cur = (np.r_[q["dc"], q["nc"][::-1] + q["dc"] * q["d"][::-1]], den_out) if pm.current else None
    return LaguerrePolish(num=num_out if num_out.size else np.zeros(1), den=den_out, delay_s=q["delay"],
                          channels=channels, sigma=sigma, inflation=inflation,
                          position_scale=q["c"] if pm.free_scale else float("nan"), current_tf=cur,
                          bic=_polish_bic(n_samples, sigma, inflation, n_fitted), n_params=n_fitted,
                          residuals=raw, params=x,
                          ar_order={ch: int(whiten[ch].size - 1) if ch in whiten else 0 for ch in channels},
                          shifts={ch: float(v) for ch, v in zip(channels[1:], q["shifts"][1:], strict=False)},
                          covariance=cov, n_zeros=None if pm.n_num == m else pm.n_num - 1)
