"""SRIVC: the simplified refined instrumental-variable method for continuous-time models.

Young's SRIVC (Young & Jakeman 1980; Garnier & Young, the CONTSID toolbox's ``srivc``) fits
``A(s) y = B(s) u`` with an output-error noise model: at each iteration the data are
prefiltered by ``1/Â(s)`` (which also gives their time derivatives without numerical
differentiation), and the regression is solved with instruments built from the noise-free
output of the current model.  It is close to statistically efficient for white output noise
and needs no nonlinear optimiser — an independent second opinion to the output-error fit.
No Python library implements it, hence this module; the filtering is ``scipy.signal.lsim``'s
linear-interpolation discretisation run through a compiled recursive filter
(:func:`motorid.model.forced.linear_hold_filtered`, the project's one module of forced responses).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from motorid.identification.method_options import positive_int, tolerance
from motorid.identification.result import IdentificationError
from motorid.model import lti
from motorid.model.forced import linear_hold_filtered

__all__ = ["SrivcResult", "SrivcSettings", "srivc_fit"]


@dataclass(frozen=True, slots=True)
class SrivcSettings:
    """Structure and stopping rule.

    Attributes
    ----------
    n_poles, n_zeros : int
        Degrees of ``A`` (monic) and ``B``.
    max_iter : int
        Most iterations.
    tol : float
        Relative change of the parameters that stops the iteration.
    step_in_stderr : float
        The iteration also stops when every parameter moved by less than this fraction of its
        standard error: a poorly determined fast pair (±25 % on the paper's motor) otherwise
        oscillates towards ``tol`` for 15–30 iterations while the DC gain and τ stay put to 1e-6.
    """

    n_poles: int = 2
    n_zeros: int = 0
    max_iter: int = 30
    tol: float = 1e-8
    step_in_stderr: float = 1e-3

    def __post_init__(self) -> None:
        # the stopping rule is checked where it is declared (the structure by the fit, which
        # names the structure it cannot make)
        positive_int("srivc.max_iter", self.max_iter)
        tolerance("srivc.tol", self.tol)
        tolerance("srivc.step_in_stderr", self.step_in_stderr)


@dataclass(frozen=True, slots=True)
class SrivcResult:
    """An SRIVC estimate.

    Attributes
    ----------
    num, den : ndarray
        ``B(s)`` and monic ``A(s)``, highest power first.
    dc_gain, time_constant_s : float
        ``B(0)/A(0)`` and the mean residence time.
    poles, zeros : ndarray
    iterations : int
    converged : bool
    cov : ndarray
        Covariance of ``[a_1..a_n, b_0..b_m]``.
    warnings : tuple of str
    """

    num: np.ndarray
    den: np.ndarray
    dc_gain: float
    time_constant_s: float
    poles: np.ndarray
    zeros: np.ndarray
    iterations: int
    converged: bool
    cov: np.ndarray
    warnings: tuple[str, ...] = field(default=())


def _filtered_derivatives(den: np.ndarray, t: np.ndarray, x: np.ndarray, k: int) -> np.ndarray:
    """Rows i = 0..k: ``s^i/A(s)`` applied to x (zero initial state), A monic of degree n ≥ k."""
    return _filtered_many(den, t, [x], k)[0]


def _filtered_many(den: np.ndarray, t: np.ndarray, signals: list[np.ndarray], k: int) -> list[np.ndarray]:
    """:func:`_filtered_derivatives` of several signals, one discretisation and one filter run per row for all."""
    n = den.size - 1
    a = np.zeros((n, n))
    a[:-1, 1:] = np.eye(n - 1)
    a[-1, :] = -den[1:][::-1]
    b = np.zeros((n, 1))
    b[-1, 0] = 1.0
    c = np.vstack([np.eye(n), -den[1:][::-1]])
    d = np.zeros((n + 1, 1))
    d[-1, 0] = 1.0
    return linear_hold_filtered(a, b, c[: k + 1], d[: k + 1], t, np.vstack(signals))


def _lsim(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, t: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Rows of ``y = C x + D u`` for ``ẋ = A x + B u`` from rest, ``u`` linear between samples.

    The same discretisation as ``scipy.signal.lsim`` (``interp=True``), whose Python loop over
    the samples costs 34 ms for 2500 samples of a third order (every SRIVC iteration runs it
    several times): :func:`motorid.model.forced.linear_hold_filtered`, about 8× faster and equal
    to ``lsim`` to about 1e-10 of the signal.
    """
    return linear_hold_filtered(a, b, c, d, t, np.asarray(u, dtype=float)[None, :])[0]


def _simulate(num: np.ndarray, den: np.ndarray, t: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Output of ``num/den`` (proper) to ``u`` from rest: ``scipy.signal.lsim`` through :func:`_lsim`."""
    a, b, c, d = lti.tf2ss(num, den)
    return _lsim(a, b, c, d, t, u)[0]


def _relative(theta: np.ndarray, before: np.ndarray) -> np.ndarray:
    """The step from ``before`` to ``theta``, each parameter's relative to its size before."""
    return (theta - before) / np.maximum(np.abs(before), 1e-300)


def srivc_fit(time_s: np.ndarray, u: np.ndarray, y: np.ndarray, settings: SrivcSettings = SrivcSettings(),
              *, init_den: np.ndarray) -> SrivcResult:
    """Estimate ``B(s)/A(s)`` from input ``u`` and output ``y`` (uniformly sampled, from rest).

    Parameters
    ----------
    time_s, u, y : ndarray
        Time grid (from the step), input and output increments.
    settings : SrivcSettings
        Structure.
    init_den : ndarray
        A first denominator (e.g. from the paper's pinv), degree ``n_poles``.

    Returns
    -------
    SrivcResult

    Raises
    ------
    IdentificationError
        Impossible structure, too few samples, or a singular IV system.
    """
    n, m = settings.n_poles, settings.n_zeros
    if n < 1 or m < 0 or m >= n:
        raise IdentificationError(f"SRIVC needs 0 ≤ zeros < poles, got {n} poles and {m} zeros")
    t = np.asarray(time_s, dtype=float)
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.size < 4 * (n + m + 1):
        raise IdentificationError(f"only {t.size} samples for SRIVC of order {n}")
    den = np.asarray(init_den, dtype=float)
    den = den / den[0]
    if den.size != n + 1:
        den = np.poly(np.resize(np.roots(den), n)) if den.size > 1 else np.poly(-np.ones(n))
    theta_old = None
    last_step: np.ndarray | None = None
    was_stable = False
    converged = False
    warnings: list[str] = []
    num = np.zeros(m + 1)
    p_mat = np.eye(n + m + 1)
    iterations = 0
    for _ in range(settings.max_iter):
        iterations += 1
        if np.any(np.real(np.roots(den)) >= 0):
            # the prefilter must be stable: reflect unstable roots (standard SRIVC practice)
            r = np.roots(den)
            r = np.where(np.real(r) >= 0, -np.abs(np.real(r)) - 1e-6 + 1j * np.imag(r), r)
            den = np.real(np.poly(r))
        # first pass: plain (refined least-squares) prefiltered regression
        x_hat = y if theta_old is None else _simulate(num, den, t, u)
        with np.errstate(over="ignore", invalid="ignore"):  # (an unstable estimate overflows)
            sigma2 = float(np.mean((y - x_hat) ** 2)) if theta_old is not None else np.inf
        yf, uf, xf = _filtered_many(den, t, [y, u, x_hat], n)
        uf = uf[: m + 1]
        phi = np.vstack([-yf[n - 1 :: -1][:n], uf[::-1]])  # [−y^(n−1)..−y, u^(m)..u]
        zeta = np.vstack([-xf[n - 1 :: -1][:n], uf[::-1]])
        target = yf[n]
        scale = np.maximum(np.sqrt(np.mean(zeta**2, axis=1)), 1e-300)
        lhs = (zeta / scale[:, None]) @ (phi / scale[:, None]).T
        rhs = (zeta / scale[:, None]) @ target
        try:
            th_s = np.linalg.solve(lhs, rhs)
        except np.linalg.LinAlgError:
            raise IdentificationError("SRIVC instrumental-variable system is singular: try a lower order") from None
        theta = th_s / scale
        if last_step is not None and theta_old is not None and float(np.dot(_relative(theta, theta_old),
                                                                            last_step)) < 0:
            # the iteration swings back and forth (a poorly determined fast pair: the map's slowest
            # mode near −1 took 15–30 iterations to settle on the paper's motor); the mean of the two
            # iterates has the same fixed point and damps that mode
            theta = 0.5 * (theta + theta_old)
        den = np.r_[1.0, theta[:n]]
        num = theta[n:]
        p_mat = np.linalg.pinv((zeta / scale[:, None]) @ (zeta / scale[:, None]).T) / np.outer(scale, scale)
        stable = bool(np.all(np.real(np.roots(den)) < 0))
        if theta_old is not None:
            step = np.abs(theta - theta_old)
            # the previous estimate's residuals scale the instruments' covariance: a step far inside
            # the standard errors moves nothing the data can tell
            # (only between stable estimates: an unstable one's residuals, which scale the errors, are its
            # divergence, not the noise)
            stderr = (np.sqrt(sigma2 * np.maximum(np.diag(p_mat), 0.0)) if stable and was_stable
                      else np.zeros(step.size))
            if (np.linalg.norm(step) <= settings.tol * np.linalg.norm(theta)
                    or (np.all(np.isfinite(stderr)) and np.all(step <= settings.step_in_stderr * stderr))):
                converged = True
                break
            last_step = _relative(theta, theta_old)
        theta_old = theta
        was_stable = stable
    with np.errstate(over="ignore", invalid="ignore"):  # an unstable estimate overflows
        x_hat = _simulate(num, den, t, u)
        sigma2 = float(np.mean((y - x_hat) ** 2))
    cov = sigma2 * p_mat
    poles = np.roots(den)
    zeros = np.roots(num) if num.size > 1 else np.array([], dtype=complex)
    dc = float(num[-1] / den[-1]) if den[-1] != 0 else float("nan")
    tau = float(np.real(np.sum(-1.0 / poles) - (np.sum(-1.0 / zeros) if zeros.size else 0.0)))
    if np.any(np.real(poles) >= 0):
        warnings.append("SRIVC model is unstable")
    return SrivcResult(num, den, dc, tau, poles, zeros, iterations, converged, cov, tuple(warnings))
