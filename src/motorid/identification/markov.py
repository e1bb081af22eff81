"""Markov/Hankel identification from a velocity step response (Masoud 2019, §IV).

The step response on a short window ``Tε`` is fitted by a truncated Taylor series whose
coefficients are Markov parameters (eqs. 21–28); their Hankel matrix gives the order from its
singular values (eq. 29) and a companion realisation ``A = H̃a·Ha⁻¹`` (eqs. 31–37).

Time scaling
------------
Fitted raw, the columns ``t^k/k!`` and the Markov parameters ``h_k`` span many decades and
the Hankel singular values change with the unit of time (README of the seeds: the paper's
printed values for eq. 27 correspond to a different window).  Here the fit is done in the
scaled time ``τ = t/Tε``: the scaled Markov parameters ``h_k·Tε^(k+1)`` are those of the
system ``(Tε·A, Tε·B, C)``, a similarity plus a change of time unit, so the *normalised*
singular values and the detected order do not depend on whether time is in seconds or
milliseconds.  The realisation is computed from the scaled parameters and mapped back
exactly to the paper's companion form (see :func:`markov_identify`).

Two formulations
----------------
``form="velocity"`` (default): the realised system is the *velocity* transfer function
``G`` and ``y(t)/V0 = Σ_k h_k t^(k+1)/(k+1)!`` with ``h_k = C A^k B`` — the paper's eq. 21 with
``q(1) = v(0)/V0 = 0`` imposed (the paper requires ``v(0) = 0``).  The order is that of the
velocity TF.
``form="paper"``: eq. 28 literally, ``v(t)/V0 = Σ_i q(i) t^(i-1)/(i-1)!``; the realised
``H`` has ``v = V0·impulse response of H`` (eq. 19), i.e. ``H`` is the *position* TF and the
order includes the integrator (the paper's experimental case, eqs. 56–60, is third order).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import scipy.linalg

from motorid.identification.arrays import check_step_level, response_arrays
from motorid.errors import OptionError
from motorid.identification.result import IdentificationError, equilibrated_condition

__all__ = [
    "MarkovParameters",
    "MarkovResult",
    "MarkovSettings",
    "companion_realisation",
    "detect_order",
    "hankel_matrix",
    "hankel_noise_floor",
    "hankel_singular_values",
    "markov_identify",
    "markov_parameters",
]

#: Condition number (of the column-equilibrated Taylor regressor) above which the fit warns.
FIT_COND_WARN = 1e10
#: Fit residual (RMS, relative to the response range on the window) above which it warns.
FIT_RESIDUAL_WARN = 0.02


@dataclass(frozen=True, slots=True)
class MarkovSettings:
    """Settings of the Markov method (defaults: the paper's, §VI-2).

    Parameters
    ----------
    n_params : int
        Number of Markov parameters ``Lm`` (paper: 11).
    window_s : float or None
        Fit window ``Tε`` in seconds from the step; None uses the whole record (the
        paper's experimental case, Tε = 6.3 s).
    hankel_size : int or None
        ``K`` of the K×K Hankel matrix; None gives the largest, ``(Lm + 1) // 2`` (eq. 29).
    order : int or "auto"
        Model order ``M``, or ``"auto"`` to detect it from the scaled singular values.
    threshold : float
        Floor on the normalised singular values for order detection (see
        :func:`detect_order`).
    form : {"velocity", "paper"}
        Which transfer function is realised (see the module notes).
    scaled : bool
        Work in scaled time ``t/Tε`` (True) or raw time (False, the paper's literal and
        badly conditioned formulation; kept for comparison).
    """

    n_params: int = 11
    window_s: float | None = None
    hankel_size: int | None = None
    order: int | str = "auto"
    threshold: float = 1e-4
    form: str = "velocity"
    scaled: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.n_params, (int, np.integer)) or self.n_params < 3:
            raise OptionError(f"n_params must be an integer >= 3, got {self.n_params!r}")
        if self.window_s is not None and not (self.window_s > 0 and math.isfinite(self.window_s)):
            raise OptionError(f"window_s must be a positive number of seconds, got {self.window_s!r}")
        k_max = (self.n_params + 1) // 2
        if self.hankel_size is not None and not (2 <= self.hankel_size <= k_max):
            raise OptionError(f"hankel_size must be between 2 and (n_params + 1) // 2 = {k_max}, "
                              f"got {self.hankel_size!r}")
        if self.order != "auto" and not (isinstance(self.order, (int, np.integer)) and self.order >= 1):
            raise OptionError(f"order must be 'auto' or an integer >= 1, got {self.order!r}")
        if not (0 < self.threshold < 1):
            raise OptionError(f"threshold must be between 0 and 1, got {self.threshold!r}")
        if self.form not in ("velocity", "paper"):
            raise OptionError(f"form must be 'velocity' or 'paper', got {self.form!r}")

    @property
    def hankel_k(self) -> int:
        """The Hankel size actually used."""
        return self.hankel_size if self.hankel_size is not None else (self.n_params + 1) // 2


@dataclass(frozen=True, slots=True)
class MarkovParameters:
    """Least-squares Markov parameters of a step response (Masoud 2019, eq. 28).

    Attributes
    ----------
    raw : ndarray
        Markov parameters in the data's time unit: ``raw[j] = C A^j B`` of the realised
        system (``h_j`` for ``form='velocity'``, ``q(j+1)`` for ``form='paper'``).
    scaled : ndarray
        ``raw[j]·Tε^(j+1)``: the Markov parameters in time unit ``Tε``.
    window_s : float
        The window ``Tε`` actually used.
    n_samples : int
        Samples in the window.
    residual_rms : float
        RMS of the fit residual, in the units of ``y/step_volts``.
    condition : float
        Condition number of the column-equilibrated regressor.
    scaled_std : ndarray
        Standard errors of ``scaled`` from the fit residual (``s²·(ΦᵀΦ)⁻¹``); they grow
        roughly like ``k!`` with the index, which is why noisy data give noise-dominated
        high-order parameters.
    """

    raw: np.ndarray
    scaled: np.ndarray
    window_s: float
    n_samples: int
    residual_rms: float
    condition: float
    scaled_std: np.ndarray


@dataclass(frozen=True, slots=True)
class MarkovResult:
    """Outcome of :func:`markov_identify`.

    ``A, B, C`` realise the velocity TF (``form='velocity'``) or the position TF
    (``form='paper'``) in the paper's companion form, ``C = [1 0 … 0]``, ``D = 0``.
    ``sv_raw``/``sv_scaled`` are the normalised singular values of the K×K Hankel matrix of
    the raw and of the time-scaled Markov parameters.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    order: int
    markov: MarkovParameters
    sv_raw: np.ndarray
    sv_scaled: np.ndarray
    sv_noise_floor: float
    step_volts: float
    settings: MarkovSettings
    warnings: tuple[str, ...]

    def to_model(self) -> Any:
        """The result as a :class:`motorid.model.MotorModel` (velocity output always present).

        For ``form='paper'`` the realised output is the position (integral of the velocity
        channel); the velocity row is its derivative, ``C·A`` with ``D = C·B``.

        Returns
        -------
        MotorModel
            The realised model.
        """
        from motorid.model import MotorModel  # model imports nothing from identify

        n = self.order
        states = ("velocity",) if (n == 1 and self.settings.form == "velocity") else tuple(
            f"x{i + 1}" for i in range(n))
        common: dict[str, Any] = dict(
            step_volts=self.step_volts,
            method="markov",
            settings={**asdict(self.settings), "order_detected": self.order,
                      "sv_scaled": self.sv_scaled.tolist(), "sv_raw": self.sv_raw.tolist()},
            sample_interval_s=None,
            warnings=self.warnings,
        )
        if self.settings.form == "velocity":
            return MotorModel(A=self.A, B=self.B, C=self.C, D=np.array([[0.0]]), states=states,
                              outputs=("velocity",), **common)
        c_vel = self.C @ self.A
        d_vel = self.C @ self.B
        return MotorModel(A=self.A, B=self.B, C=np.vstack([self.C, c_vel]),
                          D=np.vstack([[[0.0]], d_vel]), states=states,
                          outputs=("position", "velocity"), **common)


def markov_parameters(
    time_s: Any,
    y_step: Any,
    u_step_volts: float,
    n_params: int,
    window_s: float | None,
    *,
    scaled: bool = True,
    form: str = "velocity",
) -> MarkovParameters:
    """Fit ``n_params`` Markov parameters to a step response on the window ``[0, Tε]``.

    Parameters
    ----------
    time_s : array_like
        Sample times in seconds, 0 at the step edge (earlier samples are ignored).
    y_step : array_like
        The velocity step response in volts, starting from 0.
    u_step_volts : float
        Input step level ``V0``.
    n_params : int
        Number of Markov parameters ``Lm``.
    window_s : float or None
        ``Tε``; None uses the whole record.
    scaled : bool
        Fit in scaled time ``t/Tε`` (well conditioned) or in raw time (paper's eq. 28).
    form : {"velocity", "paper"}
        ``velocity``: ``y/V0 = Σ h_k t^(k+1)/(k+1)!``; ``paper``: ``y/V0 = Σ q(i) t^(i-1)/(i-1)!``.

    Returns
    -------
    MarkovParameters

    Raises
    ------
    IdentificationError
        When the window holds fewer samples than parameters.
    OptionError
        On a zero step level or mismatched arrays.

    References
    ----------
    Masoud 2019, eqs. 21–28.
    """
    t, y = response_arrays(time_s, y_step)
    check_step_level(u_step_volts)
    if form not in ("velocity", "paper"):
        raise OptionError(f"form must be 'velocity' or 'paper', got {form!r}")
    t_end = float(np.max(t)) if window_s is None else float(window_s)
    if not t_end > 0:
        raise IdentificationError("the record has no samples after the step (t > 0)")
    inside = (t >= 0) & (t <= t_end * (1 + 1e-9))
    n = int(np.count_nonzero(inside))
    if n < n_params + 1:
        raise IdentificationError(
            f"the Markov fit of {n_params} parameters needs at least {n_params + 1} samples in the "
            f"{t_end:g} s window, found {n}; lengthen the window or sample faster")
    p0 = 1 if form == "velocity" else 0
    powers = np.arange(n_params) + p0
    log_fact = np.array([math.lgamma(k + 1) for k in powers])
    unit = t_end if scaled else 1.0
    tau = t[inside] / unit
    # Plain powers are safe: τ <= 1 when scaled, and t^Lm stays far from overflow raw.
    phi = np.power.outer(tau, powers) / np.exp(log_fact)
    rhs = y[inside] / u_step_volts
    # Column equilibration: lstsq (SVD) is then accurate even though τ^10/10! ≪ τ.
    norms = np.linalg.norm(phi, axis=0)
    norms[norms == 0] = 1.0
    q_eq = phi / norms
    coef, *_ = np.linalg.lstsq(q_eq, rhs, rcond=None)
    coef = coef / norms
    resid = rhs - phi @ coef
    # Parameter covariance s²·(ΦᵀΦ)⁻¹ through QR of the equilibrated regressor.
    dof = max(n - n_params, 1)
    s2 = float(resid @ resid) / dof
    r_inv = np.linalg.pinv(np.linalg.qr(q_eq, mode="r"))
    coef_std = np.sqrt(s2 * np.sum(r_inv**2, axis=1)) / norms
    # coef[j] multiplies τ^(j+p0)/(j+p0)!  ->  raw[j] = coef[j] / unit^(j+p0).
    j = np.arange(n_params)
    raw = coef / unit ** (j + p0)
    to_scaled = t_end ** (j + 1) / unit ** (j + p0)
    scaled_params = coef * to_scaled
    return MarkovParameters(
        raw=raw,
        scaled=scaled_params,
        window_s=t_end,
        n_samples=n,
        residual_rms=float(np.sqrt(np.mean(resid**2))),
        condition=equilibrated_condition(phi),
        scaled_std=coef_std * to_scaled,
    )


def hankel_matrix(h: Any, rows: int, cols: int | None = None, *, shift: int = 0) -> np.ndarray:
    """Hankel matrix ``H[i, j] = h[i + j + shift]`` (eq. 29; ``shift=1`` gives H̃a, eq. 31).

    Parameters
    ----------
    h : array_like
        Markov parameters, ``h[0] = C·B``.
    rows, cols : int
        Size (``cols`` defaults to ``rows``).
    shift : int
        Index of the top-left entry.

    Returns
    -------
    ndarray, shape (rows, cols)

    Raises
    ------
    OptionError
        When ``h`` is too short (``rows + cols - 1 + shift`` parameters are needed).
    """
    h = np.asarray(h, dtype=float).ravel()
    cols = rows if cols is None else cols
    need = rows + cols - 1 + shift
    if h.size < need:
        raise OptionError(f"a {rows}x{cols} Hankel matrix (shift {shift}) needs {need} Markov "
                          f"parameters, got {h.size}")
    return scipy.linalg.hankel(h[shift:shift + rows], h[shift + rows - 1:need])


def hankel_singular_values(h: Any, size: int) -> np.ndarray:
    """Singular values of the ``size``×``size`` Hankel matrix, divided by the largest.

    Parameters
    ----------
    h : array_like
        Markov parameters (at least ``2·size − 1``).
    size : int
        ``K``.

    Returns
    -------
    ndarray
        Normalised singular values, descending, first one 1 (all zero for a zero matrix).

    References
    ----------
    Masoud 2019, eq. 29 and the text after it.
    """
    sv = np.linalg.svd(hankel_matrix(h, size), compute_uv=False)
    return sv / sv[0] if sv[0] > 0 else sv


def hankel_noise_floor(params: MarkovParameters, size: int) -> float:
    """Estimated size of the noise in the scaled Hankel matrix, relative to its largest value.

    Weyl's inequality bounds the change of every singular value by the 2-norm of the
    perturbation, which is at most its Frobenius norm ``sqrt(Σ_ij var(h_(i+j)))``; singular
    values below this floor cannot be told apart from the fit's noise.

    Parameters
    ----------
    params : MarkovParameters
        A fit from :func:`markov_parameters`.
    size : int
        ``K``.

    Returns
    -------
    float
        Floor relative to the largest singular value of the scaled Hankel matrix.
    """
    var = params.scaled_std**2
    idx = np.add.outer(np.arange(size), np.arange(size))
    frob = float(np.sqrt(np.sum(var[idx])))
    top = float(np.linalg.norm(hankel_matrix(params.scaled, size), 2))
    return frob / top if top > 0 else float("inf")


def detect_order(sv: Any, *, threshold: float = 1e-4, max_order: int | None = None) -> int:
    """Model order from normalised Hankel singular values.

    Rule: among the candidates ``M = 1 … K−1`` whose singular value ``σ_M`` is at least
    ``threshold`` (relative to ``σ_1``), pick the one with the largest drop
    ``log σ_M − log σ_(M+1)`` (a drop to exactly zero counts as infinite).  The floor keeps
    the gaps between round-off-level values out of the contest; the largest-gap rule is
    the paper's "sudden drop" reading (eq. 29 ff.: ``1, 0.426, 0.1, 0.009, …`` → 3).

    Parameters
    ----------
    sv : array_like
        Normalised singular values, descending (``sv[0] == 1``).
    threshold : float
        Floor for candidate orders.
    max_order : int, optional
        Upper bound on the order (default ``K − 1``, since the paper needs ``K > M``).

    Returns
    -------
    int
        The detected order ``M >= 1``.
    """
    s = np.asarray(sv, dtype=float).ravel()
    if s.size < 2 or not s[0] > 0:
        return 1
    s = s / s[0]
    top = s.size - 1 if max_order is None else max(1, min(int(max_order), s.size - 1))
    best_m, best_gap = 1, -np.inf
    for m in range(1, top + 1):
        if s[m - 1] < threshold and m > 1:
            break
        gap = np.inf if s[m] <= 0 else math.log(s[m - 1] / s[m])
        if gap > best_gap:
            best_m, best_gap = m, gap
    return best_m


def companion_realisation(h: Any, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Companion realisation from Markov parameters (observability matrix = I).

    Parameters
    ----------
    h : array_like
        Markov parameters ``h[0] = C·B, h[1] = C·A·B, …`` (at least ``2·order``).
    order : int
        ``M``.

    Returns
    -------
    A, B, C : ndarray
        ``A = H̃a(M,M)·Ha(M,M)⁻¹``, ``B = [h_0 … h_(M−1)]ᵀ``, ``C = [1 0 … 0]``.

    Raises
    ------
    IdentificationError
        When ``Ha(M, M)`` is singular (the order is too high for these parameters).

    References
    ----------
    Masoud 2019, eqs. 31–37.
    """
    ha = hankel_matrix(h, order)
    ha_shift = hankel_matrix(h, order, shift=1)
    if np.linalg.matrix_rank(ha) < order:
        raise IdentificationError(f"the {order}x{order} Hankel matrix is singular; choose a lower order")
    # A·Ha = H̃a  ->  solve Haᵀ·Aᵀ = H̃aᵀ instead of forming the inverse.
    a = np.linalg.solve(ha.T, ha_shift.T).T
    b = ha[:, :1].copy()
    c = np.zeros((1, order))
    c[0, 0] = 1.0
    return a, b, c


def markov_identify(time_s: Any, y: Any, step_volts: float, settings: MarkovSettings | None = None) -> MarkovResult:
    """Identify a state-space model from a velocity step response by the Markov method.

    Steps: fit the Markov parameters on ``[0, Tε]`` in scaled time (eq. 28), normalised
    Hankel singular values of both the scaled and the raw parameters (eq. 29), order from
    the scaled ones, companion realisation of the scaled parameters (eqs. 31–37) mapped back
    to seconds.  With ``S = diag(Tε^i)``, the scaled Hankel matrices are ``Tε·S·Ha·S`` and
    ``Tε²·S·H̃a·S``, so ``A = S⁻¹·A_scaled·S / Tε`` and ``B = S⁻¹·B_scaled / Tε`` give exactly
    the paper's ``A = H̃a·Ha⁻¹``, ``B = [h_0 … h_(M−1)]ᵀ``.

    Parameters
    ----------
    time_s : array_like
        Times in seconds, 0 at the step edge.
    y : array_like
        Velocity channel in volts (starting from 0).
    step_volts : float
        Input step level.
    settings : MarkovSettings, optional
        Defaults to the paper's.

    Returns
    -------
    MarkovResult

    Raises
    ------
    IdentificationError
        Too few samples in the window, or a singular Hankel matrix for the chosen order.
    OptionError
        Inconsistent settings (e.g. ``order >= K``).

    References
    ----------
    Masoud 2019, §IV, eqs. 18–37; §VI-2.
    """
    settings = MarkovSettings() if settings is None else settings
    k = settings.hankel_k
    warnings: list[str] = []
    fit = markov_parameters(time_s, y, step_volts, settings.n_params, settings.window_s,
                            scaled=settings.scaled, form=settings.form)
    if fit.condition > FIT_COND_WARN:
        warnings.append(f"Markov fit regressor is ill-conditioned (condition number {fit.condition:.3g}); "
                        "use fewer parameters")
    t = np.asarray(time_s, dtype=float).ravel()
    yv = np.asarray(y, dtype=float).ravel()
    inside = (t >= 0) & (t <= fit.window_s * (1 + 1e-9))
    span = float(np.ptp(yv[inside]) / abs(step_volts))
    if span > 0 and fit.residual_rms > FIT_RESIDUAL_WARN * span:
        warnings.append(f"Markov series fits the window poorly (residual {100 * fit.residual_rms / span:.1f}% "
                        "of the response); shorten window_s or add parameters")
    if settings.form == "velocity" and span > 0:
        y0 = float(yv[inside][0])
        if abs(y0) > 0.05 * float(np.max(np.abs(yv[inside]))):
            warnings.append(f"velocity does not start from 0 (first sample {y0:.3g} V); the Markov "
                            "series assumes zero initial conditions")
    sv_scaled = hankel_singular_values(fit.scaled, k)
    sv_raw = hankel_singular_values(fit.raw, k)
    floor = hankel_noise_floor(fit, k)
    if settings.order == "auto":
        order = detect_order(sv_scaled, threshold=settings.threshold)
        if sv_scaled[order - 1] < floor:
            warnings.append(
                f"Hankel singular values are dominated by noise (noise floor {floor:.2g} of the largest; "
                f"sigma_{order} = {sv_scaled[order - 1]:.2g}): the detected order {order} is not reliable; "
                "use fewer Markov parameters, a different window or denoise first")
    else:
        order = int(settings.order)
        if order >= k:
            raise OptionError(f"order {order} needs a Hankel size K > {order} (K = {k}; "
                              f"use n_params >= {2 * order + 1})")
    if settings.scaled:
        a_s, b_s, c = companion_realisation(fit.scaled, order)
        s = fit.window_s ** np.arange(order)
        a = (a_s / s[:, None]) * s[None, :] / fit.window_s
        b = b_s / s[:, None] / fit.window_s
    else:
        a, b, c = companion_realisation(fit.raw, order)
    return MarkovResult(
        A=a, B=b, C=c, order=order, markov=fit, sv_raw=sv_raw, sv_scaled=sv_scaled,
        sv_noise_floor=floor,
        step_volts=float(step_volts), settings=settings, warnings=tuple(warnings),
    )
