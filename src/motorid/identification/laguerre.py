"""Markov/Hankel identification on a Laguerre basis: the paper's §IV made to work on captures.

The paper's Markov parameters are the Taylor coefficients of ``G(s)`` about ``s = ∞``
(:mod:`motorid.identification.markov`): fitting them to a step needs a window short against the
fastest pole and the k-th one carries noise growing like ``k!``.  Here the same idea —
parameters, their Hankel matrix, the order from its singular values, a realisation from the
shifted Hankel — is applied to the *generalised* Markov parameters of the Laguerre expansion
about ``s = a``:

    G(s) = Σ_k g_k L_k(s),   L_k(s) = √(2a)/(s + a) · ((s − a)/(s + a))^k.

Under ``w = (s − a)/(s + a)`` the ``g_k = c̃ A_dᵏ b̃`` are the Markov parameters of a
discrete-time system, so Ho–Kalman/ERA applies unchanged; the bilinear map takes the
realisation back to continuous time.  The basis is orthonormal, its step responses are well
conditioned over the whole record, and noise in ``g_k`` does not grow with ``k``.

Steps (Wahlberg 1991; Heuberger, Van den Hof & Wahlberg 2005, ch. 2 and 10):

1. the regressors ``Φ_k`` = response of ``L_k`` to the input (the recorded input channel, or
   the ideal step), simulated exactly (matrix exponential of the Laguerre network);
2. least squares ``y ≈ Φ g`` with covariance ``s²·(ΦᵀΦ)⁻¹`` (inflated for correlated
   residuals);
3. Hankel singular values of ``H[i, j] = g_(i+j)`` against a noise floor (95th percentile of
   ``σ₁`` of Hankel matrices of coefficient-noise draws): the order;
4. ERA on ``[0, g_0, g_1, …]`` (python-control ``eigensys_realization``), mapped back with
   ``A = a(A_d − I)⁻¹(A_d + I)``, ``B = b̃``, ``C = √(2a)·c̃(I − A_d)⁻¹``;
5. DC gain ``√(2/a)·Σ(−1)ᵏ g_k`` with its exact variance.

The pole ``a``, the number of terms ``N`` and the dead time are chosen by BIC over a small
grid around the measured 63 % time (``a`` near ``1/τ``, ``N ≤ a·T/2``).  Each order's best
realisation (up to the number of Hankel singular values above the floor; up to ``max_order``
when a current capture can show what the velocity's Hankel matrix cannot) is the starting point
of an output-error polish on the same samples (:func:`laguerre_polish`: continuous dead time,
the current sharing the poles), and the order is the least BIC of the polished fits.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import scipy.linalg

from motorid.identification.arrays import check_step_level, response_arrays
from motorid.errors import OptionError
from motorid.identification.laguerre_refine import (
    POLISH_CHANNELS,
    LaguerrePolish,
    _polish_orders,
    _transfer_function,
    laguerre_polish,
)
from motorid.identification.metrics import bic
from motorid.identification.result import IdentificationError
from motorid.model import lti
from motorid.model.forced import held_states

__all__ = [
    "LaguerreCoefficients",
    "LaguerrePolish",
    "LaguerreResult",
    "LaguerreSettings",
    "laguerre_coefficients",
    "laguerre_coefficients_of",
    "laguerre_dc_gain",
    "laguerre_hankel_singular_values",
    "laguerre_identify",
    "laguerre_network",
    "laguerre_noise_floor",
    "laguerre_polish",
    "laguerre_realisation",
    "laguerre_regressors",
]

#: Largest number of Laguerre terms tried automatically.
MAX_TERMS = 24
#: Multiples of ``1/τ`` (τ = 63 % time less the dead time) tried for the pole ``a``.
POLE_FACTORS = (0.7, 1.0, 1.5, 2.5)
#: Condition number of the column-equilibrated regressor above which a grid point is skipped.
MAX_CONDITION = 1e7


@dataclass(frozen=True, slots=True)
class LaguerreSettings:
    """Settings of the Laguerre–Hankel method.

    Parameters
    ----------
    pole : float or None
        Laguerre pole ``a`` in 1/s; None chooses it from the data (BIC over
        :data:`POLE_FACTORS` ``/ τ``).
    n_terms : int or None
        Number of coefficients ``N``; None chooses it by BIC (``2·max_order … min(MAX_TERMS, a·T/2)``).
    order : int or "auto"
        Model order, or ``"auto"``: the Hankel singular values above the noise floor.
    max_order : int
        Largest order ``auto`` may return.
    delay_s : float or None
        Dead time in seconds; None chooses between 0 and the apparent dead time by BIC.
    floor_draws : int
        Coefficient-noise draws behind the Hankel noise floor.
    floor_quantile : float
        Quantile of ``σ₁`` of the noise Hankel matrices taken as the floor.
    polish : bool
        Polish each order's realisation by output-error least squares on every channel given
        (:func:`laguerre_polish`) and choose the order by the BIC of the polished fits.
    """

    pole: float | None = None
    n_terms: int | None = None
    order: int | str = "auto"
    max_order: int = 3
    delay_s: float | None = None
    floor_draws: int = 400
    floor_quantile: float = 0.95
    polish: bool = True

    def __post_init__(self) -> None:
        if self.pole is not None and not (math.isfinite(self.pole) and self.pole > 0):
            raise OptionError(f"the Laguerre pole must be a positive number of 1/s, got {self.pole!r}")
        if self.n_terms is not None and not (isinstance(self.n_terms, (int, np.integer)) and self.n_terms >= 2):
            raise OptionError(f"the number of Laguerre terms must be an integer >= 2, got {self.n_terms!r}")
        if self.order != "auto" and not (isinstance(self.order, (int, np.integer)) and self.order >= 1):
            raise OptionError(f"order must be 'auto' or an integer >= 1, got {self.order!r}")
        if not (isinstance(self.max_order, (int, np.integer)) and self.max_order >= 1):
            raise OptionError(f"max_order must be an integer >= 1, got {self.max_order!r}")
        if self.delay_s is not None and not (math.isfinite(self.delay_s) and self.delay_s >= 0):
            raise OptionError(f"delay_s must be a number of seconds >= 0, got {self.delay_s!r}")
        if not (isinstance(self.floor_draws, (int, np.integer)) and self.floor_draws >= 20):
            raise OptionError(f"floor_draws must be an integer >= 20, got {self.floor_draws!r}")
        if not (0.5 <= self.floor_quantile < 1):
            raise OptionError(f"floor_quantile must be in [0.5, 1), got {self.floor_quantile!r}")


@dataclass(frozen=True, slots=True)
class LaguerreCoefficients:
    """Least-squares Laguerre coefficients of one response.

    Attributes
    ----------
    pole : float
        ``a``, 1/s.
    values : ndarray
        ``g_0 … g_(N−1)`` (output volts per input volt, per √(1/s)).
    covariance : ndarray
        Their covariance ``s²·(ΦᵀΦ)⁻¹·inflation``.
    delay_s : float
        Dead time the regressors were shifted by.
    residual_rms : float
        RMS of the fit residual, volts.
    n_samples : int
        Samples fitted.
    condition : float
        Condition number of the column-equilibrated regressor.
    inflation : float
        Factor applied to the covariance for correlated residuals, ``(1 + ρ)/(1 − ρ)`` with
        ρ the lag-1 autocorrelation of the residual (1 for white residuals).
    bic : float
        ``n·log(RSS/n) + N·log n``.
    """

    pole: float
    values: np.ndarray
    covariance: np.ndarray
    delay_s: float
    residual_rms: float
    n_samples: int
    condition: float
    inflation: float
    bic: float

    @property
    def std(self) -> np.ndarray:
        """Standard errors of the coefficients."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))


@dataclass(frozen=True, slots=True)
class LaguerreResult:
    """Outcome of :func:`laguerre_identify`.

    ``A, B, C`` realise the identified transfer function (velocity, or for
    ``output='position'`` the position channel's derivative in position volts per second).
    ``hankel_sv`` are the singular values of the Hankel matrix of the coefficients,
    ``noise_floor`` the floor in the same units; ``dc_gain``/``dc_gain_std`` come straight
    from the coefficients, ``model_dc_gain`` from the model of the chosen order (polished when
    ``polish`` is set).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    order: int
    coefficients: LaguerreCoefficients
    hankel_sv: np.ndarray
    noise_floor: float
    dc_gain: float
    dc_gain_std: float
    model_dc_gain: float
    step_volts: float
    output: str
    choice: str
    settings: LaguerreSettings
    warnings: tuple[str, ...]
    polish: LaguerrePolish | None = None

    @property
    def pole(self) -> float:
        """The Laguerre pole ``a``."""
        return self.coefficients.pole

    @property
    def n_terms(self) -> int:
        """The number of coefficients ``N``."""
        return int(self.coefficients.values.size)

    @property
    def delay_s(self) -> float:
        """The dead time of the model (the polished one when polished)."""
        return self.coefficients.delay_s if self.polish is None else self.polish.delay_s

    def to_model(self) -> Any:
        """The result as a :class:`motorid.model.MotorModel` (velocity output, dead time in ``delay_s``).

        Returns
        -------
        MotorModel
        """
        from motorid.model import model_from_velocity_tf  # model imports nothing from identify

        num, den = _transfer_function(self.A, self.B, self.C)
        num = np.trim_zeros(np.where(np.abs(num) < 1e-12 * np.max(np.abs(num)), 0.0, num), "f")
        coeff = self.coefficients
        sv = self.hankel_sv
        extras = {
            "markov_basis": "laguerre",
            "laguerre_pole": coeff.pole,
            "laguerre_terms": self.n_terms,
            "laguerre_coefficients": [float(x) for x in coeff.values],
            "laguerre_coefficients_std": [float(x) for x in coeff.std],
            "laguerre_dc_gain": self.dc_gain,
            "laguerre_dc_gain_std": self.dc_gain_std,
            "hankel_singular_values": [float(x) for x in sv],
            "hankel_singular_values_scaled": [float(x / sv[0]) if sv[0] > 0 else 0.0 for x in sv],
            "hankel_singular_values_raw": [float(x) for x in sv],
            "hankel_noise_floor": float(self.noise_floor / sv[0]) if sv[0] > 0 else float("inf"),
            "hankel_noise_floor_abs": float(self.noise_floor),
            "markov_choice": self.choice,
        }
        if self.polish is not None:
            pol = self.polish
            extras["laguerre_polish"] = {
                "channels": list(pol.channels), "sigma": dict(pol.sigma), "inflation": dict(pol.inflation),
                "position_scale": pol.position_scale if math.isfinite(pol.position_scale) else None,
                "current_tf": (None if pol.current_tf is None
                               else {"num": [float(x) for x in pol.current_tf[0]],
                                     "den": [float(x) for x in pol.current_tf[1]]}),
                "bic": pol.bic, "n_params": pol.n_params, "ar_order": dict(pol.ar_order),
                "shifts_s": dict(pol.shifts)}
        return model_from_velocity_tf(
            num, den, method="markov", step_volts=self.step_volts,
            settings={**asdict(self.settings), "basis": "laguerre", "pole_chosen": coeff.pole,
                      "n_terms_chosen": self.n_terms, "order_detected": self.order, "output": self.output},
            warnings=self.warnings, extras=extras, delay_s=self.delay_s,
        )


def laguerre_network(pole: float, n_terms: int) -> tuple[np.ndarray, np.ndarray]:
    """State-space form of the Laguerre network: state ``k`` is ``L_k(s)·u``.

    Parameters
    ----------
    pole : float
        ``a`` > 0, 1/s.
    n_terms : int
        ``N``.

    Returns
    -------
    A_L, B_L : ndarray
        ``A_L = −a·I − 2a·tril(1, −1)``, ``B_L = √(2a)·1`` (shapes (N, N), (N, 1)).

    References
    ----------
    Heuberger, Van den Hof & Wahlberg 2005, §2.2 (the network of first-order all-pass sections).
    """
    a = float(pole)
    a_l = -a * np.eye(n_terms) - 2.0 * a * np.tril(np.ones((n_terms, n_terms)), -1)
    b_l = np.full((n_terms, 1), math.sqrt(2.0 * a))
    return a_l, b_l


def laguerre_regressors(
    time_s: Any,
    pole: float,
    n_terms: int,
    *,
    input_v: Any = None,
    step_volts: float = 1.0,
    delay_s: float = 0.0,
    integrate: bool = False,
) -> np.ndarray:
    """Responses ``Φ_k(t)`` of the Laguerre functions to the experiment's input.

    Parameters
    ----------
    time_s : array_like
        Uniform sample times, 0 at the step edge (times < 0 give zero rows).
    pole, n_terms : float, int
        ``a`` and ``N``.
    input_v : array_like, optional
        The recorded input increment on ``time_s`` (held between samples); None: the ideal
        step ``step_volts·1(t)``, simulated exactly.
    step_volts : float
        Level of the ideal step.
    delay_s : float
        Dead time: the input reaches the network ``delay_s`` later.
    integrate : bool
        Integrate each response once more (regressors for a position channel whose
        derivative is expanded).

    Returns
    -------
    ndarray, shape (len(time_s), N)

    Raises
    ------
    OptionError
        On a non-uniform grid or mismatched input.
    """
    t = np.asarray(time_s, dtype=float).ravel()
    a_l, b_l = laguerre_network(pole, n_terms)
    if integrate:
        n = n_terms
        a_l = np.block([[a_l, np.zeros((n, n))], [np.eye(n), np.zeros((n, n))]])
        b_l = np.vstack([b_l, np.zeros((n, 1))])
    ns = a_l.shape[0]
    out = np.zeros((t.size, ns))
    te = t - float(delay_s)
    start = int(np.searchsorted(te, 0.0, side="left"))
    if start >= t.size:
        return out[:, -n_terms:] if integrate else out
    dt = np.diff(t)
    if dt.size and not np.allclose(dt, dt[0], rtol=1e-6, atol=1e-12):
        raise OptionError("the Laguerre regressors need a uniform time grid")
    h = float(dt[0]) if dt.size else 1.0

    def zoh(step: float) -> tuple[np.ndarray, np.ndarray]:
        # exact discretisation of ẋ = A x + B u with u constant over the step
        phi, gamma = lti.zoh(a_l, b_l, step)
        return phi, gamma[:, 0]

    f, g = zoh(h)
    if input_v is None:
        _f0, g0 = zoh(float(te[start]))  # the first sample lies a fraction of a step after the edge
        held = held_states(f, g0[:, None] * step_volts, g[:, None] * step_volts, None, t.size - start)
        out[start:] = held[..., 0]
    else:
        u = np.asarray(input_v, dtype=float).ravel()
        if u.size != t.size:
            raise OptionError(f"the input has {u.size} samples for {t.size} times")
        # the input as the network sees it: delayed by delay_s, held between samples
        ud = np.interp(te, t, u, left=0.0)
        out[start:] = held_states(f, np.zeros((ns, 1)), g[:, None], ud[start:], t.size - start)[..., 0]
    return out[:, -n_terms:] if integrate else out


def _coefficients(phi: np.ndarray, y: np.ndarray, pole: float, delay: float) -> LaguerreCoefficients:
    n, k = phi.shape
    norms = np.linalg.norm(phi, axis=0)
    norms[norms == 0] = 1.0
    q = phi / norms
    u, s, vt = np.linalg.svd(q, full_matrices=False)
    if s[-1] <= 0:
        raise IdentificationError("the Laguerre regressors are rank deficient; use fewer terms")
    coef = (vt.T @ ((u.T @ y) / s)) / norms
    resid = y - phi @ coef
    rss = float(resid @ resid)
    dof = max(n - k, 1)
    s2 = rss / dof
    r = resid - resid.mean()
    rho = float(r[1:] @ r[:-1] / (r @ r)) if r @ r > 0 else 0.0
    rho = min(max(rho, 0.0), 0.99)
    inflation = (1 + rho) / (1 - rho)
    cov_q = (vt.T / s**2) @ vt
    cov = s2 * inflation * cov_q / np.outer(norms, norms)
    score = bic({"y": n}, {"y": rss / n}, k)
    return LaguerreCoefficients(pole=float(pole), values=coef, covariance=cov, delay_s=float(delay),
                                residual_rms=math.sqrt(rss / n), n_samples=n, condition=float(s[0] / s[-1]),
                                inflation=inflation, bic=score)


def laguerre_coefficients(
    time_s: Any,
    y: Any,
    pole: float,
    n_terms: int,
    *,
    input_v: Any = None,
    step_volts: float = 1.0,
    delay_s: float = 0.0,
    integrate: bool = False,
) -> LaguerreCoefficients:
    """Least-squares Laguerre coefficients ``g`` of a response, ``y ≈ Φ g``.

    Parameters
    ----------
    time_s, y : array_like
        Uniform times from the step edge (samples before it are ignored) and the output
        increment, volts.
    pole, n_terms : float, int
        ``a`` and ``N``.
    input_v, step_volts, delay_s, integrate
        As :func:`laguerre_regressors`.

    Returns
    -------
    LaguerreCoefficients

    Raises
    ------
    IdentificationError
        Fewer samples than terms, or rank-deficient regressors.
    """
    t, yy = response_arrays(time_s, y)
    keep = t >= 0
    if np.count_nonzero(keep) < n_terms + 2:
        raise IdentificationError(f"{np.count_nonzero(keep)} samples after the step cannot determine "
                                  f"{n_terms} Laguerre coefficients")
    u = None if input_v is None else np.asarray(input_v, dtype=float).ravel()[keep]
    phi = laguerre_regressors(t[keep], pole, n_terms, input_v=u, step_volts=step_volts,
                              delay_s=delay_s, integrate=integrate)
    return _coefficients(phi, yy[keep], pole, delay_s)


def laguerre_coefficients_of(A: Any, B: Any, C: Any, pole: float, n_terms: int) -> np.ndarray:
    """Exact Laguerre coefficients of a continuous-time system ``(A, B, C)`` (no direct term).

    ``g_k = c̃ A_dᵏ b̃`` with ``A_d = (A + aI)(A − aI)⁻¹``, ``b̃ = B``,
    ``c̃ = C(I − A_d)/√(2a)`` — the inverse of the map in :func:`laguerre_realisation`.

    Parameters
    ----------
    A, B, C : array_like
        The system (SISO).
    pole, n_terms : float, int
        ``a`` and ``N``.

    Returns
    -------
    ndarray, shape (N,)
    """
    a_c = np.atleast_2d(np.asarray(A, dtype=float))
    b = np.asarray(B, dtype=float).reshape(-1, 1)
    c = np.asarray(C, dtype=float).reshape(1, -1)
    eye = np.eye(a_c.shape[0])
    a_d = np.linalg.solve((a_c - pole * eye).T, (a_c + pole * eye).T).T
    c_t = c @ (eye - a_d) / math.sqrt(2.0 * pole)
    g = np.empty(n_terms)
    x = b
    for k in range(n_terms):
        g[k] = float((c_t @ x)[0, 0])
        x = a_d @ x
    return g


def _hankel(g: np.ndarray) -> np.ndarray:
    rows = (g.size + 1) // 2
    return scipy.linalg.hankel(g[:rows], g[rows - 1:])


def laguerre_hankel_singular_values(g: Any) -> np.ndarray:
    """Singular values of the Hankel matrix ``H[i, j] = g_(i+j)`` of all the coefficients.

    Parameters
    ----------
    g : array_like
        ``g_0 … g_(N−1)``; the Hankel matrix is ``⌈N/2⌉ × (N − ⌈N/2⌉ + 1)``.

    Returns
    -------
    ndarray
        Singular values, descending (not normalised).

    References
    ----------
    Masoud 2019, eq. 29 (there on the Taylor Markov parameters).
    """
    return np.linalg.svd(_hankel(np.asarray(g, dtype=float).ravel()), compute_uv=False)


def laguerre_noise_floor(covariance: Any, *, draws: int = 400, quantile: float = 0.95, seed: int = 0) -> float:
    """The largest singular value a Hankel matrix of coefficient noise alone reaches.

    Draws ``e ~ N(0, Σ_g)`` and takes the ``quantile`` of ``σ₁(H(e))``: a singular value of
    the data's Hankel matrix below it cannot be told from the fit's noise.

    Parameters
    ----------
    covariance : array_like
        Covariance of the coefficients.
    draws : int
        Noise draws.
    quantile : float
        Quantile taken.
    seed : int
        Seed of the draws (the floor is reproducible).

    Returns
    -------
    float
        The floor, in the units of the singular values.
    """
    cov = np.asarray(covariance, dtype=float)
    n = cov.shape[0]
    w, v = np.linalg.eigh((cov + cov.T) / 2)
    root = v * np.sqrt(np.clip(w, 0.0, None))
    rng = np.random.default_rng(seed)
    e = rng.standard_normal((draws, n)) @ root.T
    rows = (n + 1) // 2
    cols = n - rows + 1
    hankels = e[:, np.add.outer(np.arange(rows), np.arange(cols))]
    if rows == cols:
        # a square Hankel matrix is symmetric: its largest singular value is its largest |eigenvalue|,
        # which the symmetric eigensolver finds in about half the SVD's time (the floor is computed
        # for every grid point of the Laguerre stage; same value to rounding)
        w = np.linalg.eigvalsh(hankels)
        top = np.maximum(-w[:, 0], w[:, -1])
    else:
        top = np.linalg.norm(hankels, ord=2, axis=(1, 2))
    return float(np.quantile(top, quantile))


def eigensystem_realisation(g: np.ndarray, order: int, rows: int, cols: int,
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ho–Kalman/ERA realisation ``(A, b, c)`` of order ``order`` with ``g_k ≈ c Aᵏ b``.

    python-control's ``eigensys_realization`` on ``[0, g_0, g_1, …]`` (``m = rows``, ``n =
    cols``), the same arithmetic on the same matrices (its result to the last bit, a test checks):
    the Hankel matrix ``H_ij = g_(i+j)`` and its shift, the SVD of the first, balanced factors.
    Written here because importing python-control (it imports matplotlib's pyplot and
    scipy.stats) is half of ``motorid identify``'s CPU, and the realisation is all the
    identification needs from it.

    Parameters
    ----------
    g : ndarray
        ``g_0 … g_(rows+cols−1)``.
    order : int
        Number of states kept.
    rows, cols : int
        The Hankel matrix's block rows and columns.

    Returns
    -------
    A, b, c : ndarray
        Shapes ``(order, order)``, ``(order, 1)``, ``(1, order)``.
    """
    h = scipy.linalg.hankel(g[:rows], g[rows - 1 : rows + cols])  # rows × (cols + 1)
    first, shifted = h[:, :-1], h[:, 1:]
    u, sv, vh = np.linalg.svd(first, True)
    ur, vhr = u[:, :order], vh[:order, :]
    root_inv = np.diag(1.0 / np.sqrt(sv[:order]))
    a = root_inv @ ur.T @ shifted @ vhr.T @ root_inv
    b = root_inv @ ur.T @ first[:, 0:1]
    c = first[0:1, :] @ vhr.T @ root_inv
    return a, b, c


def laguerre_realisation(g: Any, pole: float, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous-time realisation of order ``order`` from Laguerre coefficients.

    ERA (:func:`eigensystem_realisation`: python-control's ``eigensys_realization``) on
    ``[0, g_0, g_1, …]`` gives
    ``(A_d, b̃, c̃)`` with ``g_k = c̃ A_dᵏ b̃``; the bilinear map ``w = (s − a)/(s + a)`` takes it
    back: ``A = a(A_d − I)⁻¹(A_d + I)``, ``B = b̃``, ``C = √(2a)·c̃(I − A_d)⁻¹``.

    Parameters
    ----------
    g : array_like
        Coefficients (at least ``2·order``).
    pole : float
        ``a``.
    order : int
        Number of states.

    Returns
    -------
    A, B, C : ndarray

    Raises
    ------
    IdentificationError
        Too few coefficients, or an ``A_d`` with an eigenvalue at 1 (a pole at infinity).

    References
    ----------
    Heuberger, Van den Hof & Wahlberg 2005, §10; Masoud 2019, eqs. 31–37 (the shifted Hankel).
    """
    g = np.asarray(g, dtype=float).ravel()
    if g.size < 2 * order:
        raise IdentificationError(f"order {order} needs at least {2 * order} Laguerre coefficients, got {g.size}")
    rows = g.size // 2
    a_d, b_t, c_t = eigensystem_realisation(g, order, rows, g.size - rows)
    eye = np.eye(order)
    if np.linalg.cond(eye - a_d) > 1e12:
        raise IdentificationError(
            f"the order-{order} Laguerre realisation has a pole at infinity; choose a lower order")
    inv = np.linalg.inv(eye - a_d)
    a_c = -pole * inv @ (eye + a_d)
    return a_c, b_t.reshape(-1, 1), math.sqrt(2.0 * pole) * c_t.reshape(1, -1) @ inv


def laguerre_dc_gain(coefficients: LaguerreCoefficients) -> tuple[float, float]:
    """DC gain ``G(0) = √(2/a)·Σ(−1)ᵏ g_k`` and its standard deviation ``√(wᵀΣw)``.

    Parameters
    ----------
    coefficients : LaguerreCoefficients

    Returns
    -------
    (float, float)
        Gain and standard deviation (exact for the truncated expansion: the gain is linear
        in ``g``).
    """
    g = coefficients.values
    w = math.sqrt(2.0 / coefficients.pole) * (-1.0) ** np.arange(g.size)
    return float(w @ g), float(math.sqrt(max(w @ coefficients.covariance @ w, 0.0)))


def laguerre_identify(
    time_s: Any,
    y: Any,
    step_volts: float,
    settings: LaguerreSettings | None = None,
    *,
    input_v: Any = None,
    output: str = "velocity",
    response_time_s: float = float("nan"),
    dead_time_s: float = 0.0,
    extra_outputs: dict[str, Any] | None = None,
    pre_step: dict[str, Any] | None = None,
    phase_s: float = 0.0,
) -> LaguerreResult:
    """Identify a transfer function from one step response by Laguerre–Hankel realisation.

    Parameters
    ----------
    time_s, y : array_like
        Uniform times from the step edge and the output increment (velocity or position
        channel), volts.
    step_volts : float
        Input step level (used when ``input_v`` is None, and for the model's record).
    settings : LaguerreSettings, optional
        Defaults: everything chosen from the data.
    input_v : array_like, optional
        Recorded input increment on ``time_s``; used instead of the ideal step.
    output : {"velocity", "position"}
        ``position``: the realised TF is the position channel's derivative (position volts
        per second); the regressors are integrated once.
    response_time_s, dead_time_s : float
        Measured 63 % time and apparent dead time (:class:`ConditionedExperiment`); they set
        the grid of ``a`` and the dead time tried.
    extra_outputs : dict, optional
        Other channels on ``time_s`` (``position`` beside a velocity, ``current``): used by the
        polish (integrator known, poles shared).
    pre_step : dict, optional
        Channel → its samples before the step, baseline removed, at the spacing of ``time_s``:
        the polish fits each such channel's offset on them (:func:`laguerre_polish`).
    phase_s : float
        Seconds from the step instant to the first sample of ``time_s`` (half a sample for a
        scope's sampled edge): the polish's dead time is counted from the step instant.

    Returns
    -------
    LaguerreResult

    Raises
    ------
    IdentificationError
        No grid point could be fitted, or no stable realisation.
    OptionError
        Bad arguments.

    References
    ----------
    Masoud 2019, §IV (Hankel order and realisation); Wahlberg 1991 (Laguerre models).
    """
    settings = LaguerreSettings() if settings is None else settings
    if output not in ("velocity", "position"):
        raise OptionError(f"output must be 'velocity' or 'position', got {output!r}")
    check_step_level(step_volts)
    t, yy = response_arrays(time_s, y)
    keep = t >= 0
    t, yy = t[keep], yy[keep]
    u = None if input_v is None else np.asarray(input_v, dtype=float).ravel()[keep]
    extras = {ch: np.asarray(v, dtype=float).ravel()[keep] for ch, v in (extra_outputs or {}).items()
              if ch in POLISH_CHANNELS and ch != output}
    if t.size < 8:
        raise IdentificationError(f"only {t.size} samples after the step; the Laguerre fit needs at least 8")
    record = float(t[-1])
    dead = float(dead_time_s) if math.isfinite(dead_time_s) and dead_time_s > 0 else 0.0
    tau = float(response_time_s) - dead if math.isfinite(response_time_s) else float("nan")
    if not (tau > 0):
        tau = 0.2 * record
    tau = max(tau, 2.0 * float(t[1] - t[0]))
    poles = [settings.pole] if settings.pole is not None else [f / tau for f in POLE_FACTORS]
    delays = [settings.delay_s] if settings.delay_s is not None else sorted({0.0, dead})
    integrate = output == "position"
    fixed_order = None if settings.order == "auto" else int(settings.order)
    want = fixed_order if fixed_order is not None else settings.max_order
    grid = _Grid(t, yy, u, float(step_volts), integrate, fixed_order, want, bool(extras) and settings.polish)
    candidates: list[_Candidate] = []
    errors: list[str] = []
    for a in poles:
        for delay in delays:
            best = _best_coefficients(grid, a, delay, settings, errors)
            if best is not None:
                candidates += _realised_orders(grid, best, settings, errors)
    if not candidates:
        raise IdentificationError("no stable realisation of the Laguerre coefficients for any pole, number of "
                                  "terms or order" + (f" ({errors[0]})" if errors else ""))
    chosen = min(candidates, key=lambda c: c.score)
    polished, pick, passed_over = (
        _polish_orders(candidates, t, {output: yy, **extras}, u, step_volts, output, pre_step, phase_s)
        if settings.polish else ([], -1, ""))
    polish: LaguerrePolish | None = None
    if polished:
        _, chosen, polish, a_p, b_p, c_p = polished[pick]
    warnings: list[str] = []
    coeff, sv, floor, above, m = chosen.coefficients, chosen.sv, chosen.floor, chosen.above, chosen.order
    if not chosen.stable:
        warnings.append(f"the order-{m} Laguerre realisation is unstable")
    if above == 0:
        warnings.append(f"every Hankel singular value is below the noise floor ({floor:.3g}): the response "
                        "is not told from noise")
    elif fixed_order is not None and m > above:
        warnings.append(f"order {m} asked, but only {above} Hankel singular value(s) stand above the noise "
                        f"floor {floor:.3g}")
    dc, dc_std = laguerre_dc_gain(coeff)
    a_f, b_f, c_f = (chosen.A, chosen.B, chosen.C) if polish is None else (a_p, b_p, c_p)
    model_dc = float(-(c_f @ np.linalg.solve(a_f, b_f))[0, 0])
    if dc_std > 0 and abs(model_dc - dc) > 4 * dc_std + 0.02 * abs(dc):
        warnings.append(f"the order-{m} model's DC gain {model_dc:.4g} differs from the Laguerre coefficients' "
                        f"{dc:.4g} ± {dc_std:.2g}: the order may be too low")
    choice = _choice_text(chosen, len(candidates), tau, settings, polish, polished, pre_step)
    if passed_over:
        choice += f"; {passed_over}"
    return LaguerreResult(
        A=a_f, B=b_f, C=c_f, order=m, coefficients=coeff, hankel_sv=sv, noise_floor=floor,
        dc_gain=dc, dc_gain_std=dc_std, model_dc_gain=model_dc, step_volts=float(step_volts), output=output,
        choice=choice, settings=settings, warnings=tuple(warnings), polish=polish,
    )



@dataclass(frozen=True)
class _Grid:
    """What every grid point of :func:`laguerre_identify` fits: the samples and the order rules."""

    t: np.ndarray
    y: np.ndarray
    u: np.ndarray | None
    step_volts: float
    integrate: bool
    fixed_order: int | None
    want: int
    #: other channels will be polished with shared poles: orders past the velocity's Hankel count
    shared: bool


def _best_coefficients(grid: _Grid, a: float, delay: float, settings: LaguerreSettings,
                       errors: list[str]) -> LaguerreCoefficients | None:
    """The Laguerre coefficients of least BIC over the number of terms, for one pole and dead time."""
    record = float(grid.t[-1])
    # N ≲ a·T/2: the k-th Laguerre function lives until about (2k + 1)/a; later ones are not
    # pinned down by the record and trade off against each other
    cap = int(min(MAX_TERMS, max(2, math.floor(a * record / 2))))
    n_list = [settings.n_terms] if settings.n_terms is not None else list(range(min(2 * grid.want, cap), cap + 1))
    try:
        phi = laguerre_regressors(grid.t, a, max(n_list), input_v=grid.u, step_volts=grid.step_volts,
                                  delay_s=delay, integrate=grid.integrate)
    except (IdentificationError, OptionError) as exc:
        errors.append(exc.message)
        return None
    # the network is lower triangular: the first k columns are the k-term regressors, so one QR
    # of the column-equilibrated regressors gives every k's residual and condition number
    # (those of R[:k, :k]); only the k of least BIC gets its coefficients and covariance
    # (the R factor of [Φ, y]: its last column holds Qᵀy and the residual norm of all the terms,
    # so the k-term residual is ‖r_yy‖² + Σ_{j≥k} (Qᵀy)_j², without forming Q)
    n, big = grid.t.size, phi.shape[1]
    norms = np.linalg.norm(phi, axis=0)
    norms[norms == 0] = 1.0
    r: np.ndarray = np.linalg.qr(np.column_stack([phi / norms, grid.y]), mode="r")  # type: ignore[assignment]
    qty, tail = r[:big, big], float(r[big, big]) ** 2 if r.shape[0] > big else 0.0
    best_k, best_bic = 0, math.inf
    for k in n_list:
        sv = np.linalg.svd(r[:k, :k], compute_uv=False)
        if sv[-1] <= 0 or (settings.n_terms is None and sv[0] / sv[-1] > MAX_CONDITION):
            continue
        rss = tail + float(qty[k:] @ qty[k:])
        score = bic({"y": n}, {"y": rss / n}, k)
        if score < best_bic:
            best_k, best_bic = k, score
    if best_k == 0:
        if settings.n_terms is not None:
            errors.append("the Laguerre regressors are rank deficient; use fewer terms")
        return None
    try:
        return _coefficients(phi[:, :best_k], grid.y, a, delay)
    except IdentificationError as exc:
        errors.append(exc.message)
        return None


def _realised_orders(grid: _Grid, best: LaguerreCoefficients, settings: LaguerreSettings,
                     errors: list[str]) -> list[_Candidate]:
    """Each order's realisation of ``best`` (up to the Hankel count), scored by BIC on the samples."""
    sv, floor = _hankel_order_evidence(best.values, best.covariance, settings)
    above = int(np.count_nonzero(sv > floor))
    top = min(settings.max_order, best.values.size // 2)
    # orders past the velocity's Hankel count only where other channels (shared poles) can decide
    reach = top if grid.shared else min(above, top)
    orders = [grid.fixed_order] if grid.fixed_order is not None else list(range(1, max(1, reach) + 1))
    n, delay = grid.t.size, best.delay_s
    out = []
    for m in orders:
        if m > best.values.size // 2:
            errors.append(f"order {m} needs at least {2 * m} Laguerre terms, {best.values.size} fitted")
            continue
        try:
            a_c, b_c, c_c = laguerre_realisation(best.values, best.pole, m)
        except IdentificationError as exc:
            errors.append(exc.message)
            continue
        stable = bool(np.all(np.real(np.linalg.eigvals(a_c)) < 0))
        if not stable and m > above and grid.shared:
            a_c, c_c = _mirrored(a_c, c_c)  # only a starting point for the polish
            stable = True
        if not stable and grid.fixed_order is None:
            continue
        try:
            b_c, rss = _refit_input_gains(a_c, c_c, grid.t, grid.y, grid.u, grid.step_volts, delay, grid.integrate)
        except IdentificationError as exc:
            errors.append(f"order {m}: {exc.message}")
            continue
        score = bic({"y": n}, {"y": rss / n}, 2 * m + (delay > 0))
        out.append(_Candidate(score, best, sv, floor, above, m, a_c, b_c, c_c, stable))
    return out


def _choice_text(chosen: _Candidate, n_candidates: int, tau: float, settings: LaguerreSettings,
                 polish: LaguerrePolish | None, polished: list[Any], pre_step: Any) -> str:
    """The sentence that says how the basis, the terms, the dead time and the order were chosen."""
    coeff, sv, floor, above, m = chosen.coefficients, chosen.sv, chosen.floor, chosen.above, chosen.order
    n_sig = ", ".join(f"{x / sv[0]:.3g}" for x in sv[: min(sv.size, 5)])
    pole_grid = "/".join(f"{f:g}" for f in POLE_FACTORS) + " × 1/τ" if settings.pole is None else "fixed"
    choice = (f"Laguerre basis a = {coeff.pole:.4g} 1/s, N = {coeff.values.size} terms (least BIC of the coefficient "
              f"fit, N ≤ a·T/2), dead time {1e3 * coeff.delay_s:.3g} ms, order {m}: least BIC of the realised model "
              f"among {n_candidates} (a = {pole_grid}"
              f", τ = {tau:.4g} s from the measured 63 % time; orders up to the Hankel count); "
              f"Hankel σ/σ₁ {n_sig}: {above} above the noise floor {floor / sv[0]:.2g}")
    if coeff.inflation > 1.5:
        choice += f"; coefficient covariance inflated ×{coeff.inflation:.3g} for correlated residuals"
    if polish is not None:
        others = ", ".join(f"{o}: {polish.bic:.1f}" if o == m else f"{o}: {b:.1f}"
                           for b, o in sorted((r[0], r[1].order) for r in polished))
        ar = {ch: k for ch, k in polish.ar_order.items() if k > 0}
        noise = ("; residuals whitened by AR noise models (" + ", ".join(f"{ch} order {k}" for ch, k in ar.items())
                 + ") shared by every order" if ar else "")
        offsets = " with their pre-step samples (offsets fitted)" if any(
            np.size((pre_step or {}).get(ch, ())) for ch in polish.channels) else ""
        choice += (f"; realisation polished by output-error least squares on {', '.join(polish.channels)}{offsets} "
                   f"(dead time {1e3 * polish.delay_s:.3g} ms){noise}, order {m} by the polished fits' BIC "
                   f"on one effective sample size per channel ({others})")
    return choice

def _mirrored(a_c: np.ndarray, c_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The realisation with its right-half-plane poles mirrored into the left (``B`` is refitted after)."""
    m = a_c.shape[0]
    p = np.linalg.eigvals(a_c)
    p = np.where(np.real(p) >= 0, -np.abs(np.real(p)) - 1e-6 * np.abs(p) - 1e-9 + 1j * np.imag(p), p)
    den = np.real(np.poly(p))
    a_n = np.zeros((m, m))
    a_n[:-1, 1:] = np.eye(m - 1)
    a_n[-1, :] = -den[1:][::-1]
    c_n = np.zeros((1, m))
    c_n[0, 0] = 1.0  # the zeros come from the refitted B: B·adj carries the numerator
    return a_n, c_n


@dataclass(frozen=True, slots=True)
class _Candidate:
    score: float
    coefficients: LaguerreCoefficients
    sv: np.ndarray
    floor: float
    above: int
    order: int
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    stable: bool


def _hankel_order_evidence(g: np.ndarray, cov: np.ndarray, settings: LaguerreSettings) -> tuple[np.ndarray, float]:
    """Singular values of the K×K Hankel matrix (K = max_order + 2 at most) and its noise floor.

    A fixed, small Hankel keeps the floor from growing with the number of terms (the noise
    matrix's norm grows like its size; the system's singular values do not).
    """
    k = min((g.size + 1) // 2, settings.max_order + 2)
    used = 2 * k - 1
    sv = laguerre_hankel_singular_values(g[:used])
    floor = laguerre_noise_floor(cov[:used, :used], draws=settings.floor_draws, quantile=settings.floor_quantile)
    return sv, floor


def _refit_input_gains(a_c: np.ndarray, c_c: np.ndarray, t: np.ndarray, y: np.ndarray, u: np.ndarray | None,
                       step_volts: float, delay: float, integrate: bool) -> tuple[np.ndarray, float]:
    """``B`` by least squares on the record with the realised poles and ``C`` kept.

    The output is linear in ``B``, so the realisation's poles decide and the data give the gains.
    """
    m = a_c.shape[0]
    a_s, b_s = a_c, np.eye(m)
    if integrate:
        a_s = np.block([[a_c, np.zeros((m, 1))], [c_c, np.zeros((1, 1))]])
        b_s = np.vstack([np.eye(m), np.zeros((1, m))])
        c_s = np.zeros((1, m + 1))
        c_s[0, -1] = 1.0
    else:
        c_s = c_c
    resp = _simulate(a_s, b_s, t, u, step_volts, delay)  # (n, states, inputs)
    phi = np.einsum("s,nsi->ni", c_s[0], resp)
    if not np.all(np.isfinite(phi)):
        # an unstable realisation kept for a fixed order: its response overflows over a long record
        # (numpy's least squares then failed with "SVD did not converge", LAPACK writing to stderr)
        raise IdentificationError("its realised poles are unstable: their response overflows over the record")
    coef, *_ = np.linalg.lstsq(phi, y, rcond=None)
    resid = y - phi @ coef
    return coef.reshape(-1, 1), float(resid @ resid)


def _simulate(a: np.ndarray, b: np.ndarray, t: np.ndarray, u: np.ndarray | None, step_volts: float,
              delay: float) -> np.ndarray:
    """State responses of ``ẋ = A x + B e_i·u`` for each input column ``i`` (exact for a held input)."""
    ns, ni = b.shape
    out = np.zeros((t.size, ns, ni))
    te = t - delay
    start = int(np.searchsorted(te, 0.0, side="left"))
    if start >= t.size:
        return out
    h = float(t[1] - t[0])

    def zoh(step: float) -> tuple[np.ndarray, np.ndarray]:
        return lti.zoh(a, b, step)

    f, g = zoh(h)
    if u is None:
        _, g0 = zoh(float(te[start]))
        out[start:] = held_states(f, g0 * step_volts, g * step_volts, None, t.size - start)
    else:
        ud = np.interp(te, t, u, left=0.0)
        out[start:] = held_states(f, np.zeros((ns, ni)), g, ud[start:], t.size - start)
    return out


# --- output-error polish of the low-order realisation ("a starting point") ----------------------------


