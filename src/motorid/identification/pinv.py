"""Pseudo-inverse state-space identification (Masoud 2019, §III, eqs. 10–14).

With the state ``x`` = [θ, θ̇] (reduced) or [θ, θ̇, Ia] (extended) and its derivative
sampled on a common grid, ``ẋ = A x + B u`` holds at every sample; stacking the samples
gives a linear least-squares problem for the rows of ``[A B]`` (eq. 13), solved with the
Moore–Penrose pseudo-inverse (eq. 14).  The caller conditions the data (sample reduction,
unwrapping, the eq. 17 derivative); this module only solves the regression.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from motorid.errors import OptionError
from motorid.identification.result import IdentificationError, equilibrated_condition

__all__ = ["COND_WARN", "PINV_STRUCTURES", "PinvResult", "PinvSettings", "pinv_identify"]

#: Values of ``PinvSettings.structure`` (the command line's ``--structure``).
PINV_STRUCTURES: tuple[str, ...] = ("free", "known")

#: Condition number (column-equilibrated regressor) above which the result warns.
COND_WARN = 1e8
#: |x(0)| above this fraction of the state's range triggers a warning (eq. 14 assumes x(0)=0).
INITIAL_STATE_WARN = 0.05

_STATES = {
    "reduced": ("position", "velocity"),
    "extended": ("position", "velocity", "current"),
    # without a position capture (a tacho-only or tacho + current-shunt set-up)
    "velocity": ("velocity",),
    "velocity_current": ("velocity", "current"),
}


@dataclass(frozen=True, slots=True)
class PinvSettings:
    """Settings of the pseudo-inverse method (defaults: the paper's).

    Parameters
    ----------
    states : {"reduced", "extended", "velocity", "velocity_current"}
        ``[θ, θ̇]`` (paper §V-4, eq. 38) or ``[θ, θ̇, Ia]`` (eq. 46); without a position
        capture ``[θ̇]`` or ``[θ̇, Ia]``.
    structure : {"free", "known"}
        ``free``: every entry of ``A`` and ``B`` is unknown (eq. 13 as printed);
        ``known``: the θ row is fixed to ``ẋ₁ = x₂`` (first row of ``A`` = [0 1 0…],
        ``B[0] = 0``) as the paper suggests, and only the other rows are fitted.
    drop_edges : int
        Samples dropped at each end (the eq. 17 derivative is invalid within two samples of
        the record's ends; the paper discards them, §V-3).
    """

    states: str = "reduced"
    structure: str = "free"
    drop_edges: int = 2

    def __post_init__(self) -> None:
        if self.states not in _STATES:
            raise OptionError(f"states must be one of {', '.join(_STATES)}, got {self.states!r}")
        if self.structure == "known" and _STATES[self.states][:2] != ("position", "velocity"):
            raise OptionError("the known structure (θ row of A) needs the position and velocity states")
        if self.structure not in PINV_STRUCTURES:
            raise OptionError(f"structure must be 'free' or 'known', got {self.structure!r}")
        if not isinstance(self.drop_edges, (int, np.integer)) or self.drop_edges < 0:
            raise OptionError(f"drop_edges must be an integer >= 0, got {self.drop_edges!r}")

    @property
    def state_names(self) -> tuple[str, ...]:
        """Names of the states, in order."""
        return _STATES[self.states]


@dataclass(frozen=True, slots=True)
class PinvResult:
    """Outcome of :func:`pinv_identify`.

    Attributes
    ----------
    A, B : ndarray
        Identified matrices, shapes (n, n) and (n, 1).
    states : tuple of str
        State names.
    residual_rms : ndarray
        RMS of ``ẋ − (A x + B u)`` per state row, in the units of ``ẋ``.
    relative_residual : ndarray
        ``residual_rms`` divided by the RMS of each ``ẋ`` row.
    condition : float
        Condition number of the column-equilibrated regressor ``[Xᵀ U]``.
    rank : int
        Numerical rank of that regressor.
    n_samples : int
        Samples used after dropping the edges.
    settings : PinvSettings
    warnings : tuple of str
    """

    A: np.ndarray
    B: np.ndarray
    states: tuple[str, ...]
    residual_rms: np.ndarray
    relative_residual: np.ndarray
    condition: float
    rank: int
    n_samples: int
    settings: PinvSettings
    warnings: tuple[str, ...]

    def to_model(self, *, step_volts: float | None = None, sample_interval_s: float | None = None) -> Any:
        """The result as a :class:`motorid.model.MotorModel`, every state an output.

        ``C = I`` (rows named after the states), ``D = 0``: the paper's ``C = [0 1 0]`` is
        the velocity row (eq. 38) and ``C = [1 0 0]`` the position row (eq. 40).

        Parameters
        ----------
        step_volts : float, optional
            Step level recorded in the model.
        sample_interval_s : float, optional
            Sample interval the fit used, recorded in the model.

        Returns
        -------
        MotorModel
            The model.
        """
        from motorid.model import MotorModel

        n = len(self.states)
        return MotorModel(
            A=self.A, B=self.B, C=np.eye(n), D=np.zeros((n, 1)), states=self.states,
            outputs=self.states, step_volts=step_volts, method="pinv",
            settings=asdict(self.settings), sample_interval_s=sample_interval_s,
            warnings=self.warnings,
        )


def pinv_identify(x: Any, x_dot: Any, u: Any, settings: PinvSettings | None = None) -> PinvResult:
    """Fit ``ẋ = A x + B u`` to sampled states by least squares (pseudo-inverse).

    Parameters
    ----------
    x : array_like, shape (n, N)
        States on a common grid, rows in the order of ``settings.state_names``, starting
        from zero (the paper's zero initial conditions).
    x_dot : array_like, shape (n, N)
        Their time derivatives (e.g. the eq. 17 five-point formula), per second.
    u : array_like, shape (N,)
        Input in volts (the step level after the edge).
    settings : PinvSettings, optional
        Defaults to the paper's.

    Returns
    -------
    PinvResult

    Raises
    ------
    OptionError
        On arrays whose shapes do not match the settings.
    IdentificationError
        When fewer samples remain after dropping the edges than unknowns per row.

    Notes
    -----
    ``numpy.linalg.lstsq`` (SVD) is used instead of forming ``pinv(Q)·Z``: it computes the
    same minimum-norm solution with better accuracy.  Each row of ``[A B]`` is an
    independent problem with the same regressor ``[Xᵀ U]``, so the paper's block system
    (eq. 10) reduces to one call with a matrix right-hand side.  Ill-conditioning is never
    silent: a condition number above ``COND_WARN`` or a rank deficit goes into ``warnings``.

    References
    ----------
    Masoud 2019, eqs. 10–14 and §V-3/V-4.
    """
    settings = PinvSettings() if settings is None else settings
    names = settings.state_names
    n = len(names)
    xs = np.atleast_2d(np.asarray(x, dtype=float))
    xd = np.atleast_2d(np.asarray(x_dot, dtype=float))
    uu = np.asarray(u, dtype=float).ravel()
    if xs.shape[0] != n or xd.shape != xs.shape or uu.size != xs.shape[1]:
        raise OptionError(
            f"pinv with {settings.states} states needs x and x_dot of shape ({n}, N) and u of length N; "
            f"got {xs.shape}, {xd.shape} and {uu.size}")
    if not (np.all(np.isfinite(xs)) and np.all(np.isfinite(xd)) and np.all(np.isfinite(uu))):
        raise OptionError("pinv data contain NaN or infinity")
    warnings: list[str] = []
    span = np.ptp(xs, axis=1)
    far = [names[i] for i in range(n) if span[i] > 0 and abs(xs[i, 0]) > INITIAL_STATE_WARN * span[i]]
    if far:
        warnings.append(f"initial state not zero for {', '.join(far)}; the paper's method assumes "
                        "x(0) = 0 (shift the record to the step edge)")
    e = settings.drop_edges
    total = xs.shape[1]
    keep = slice(e, total - e) if e > 0 else slice(None)
    xs, xd, uu = xs[:, keep], xd[:, keep], uu[keep]
    n_samples = xs.shape[1]
    unknowns = n + 1
    if n_samples < unknowns:
        raise IdentificationError(
            f"pinv with {settings.states} states needs at least {unknowns + 2 * e} samples "
            f"({unknowns} after dropping {e} at each end), got {total}; use a shorter sample "
            "interval or a longer record")
    q = np.column_stack([xs.T, uu])  # regressor [Xᵀ U], eq. 13
    a = np.zeros((n, n))
    b = np.zeros((n, 1))
    if settings.structure == "known":
        # θ row known a priori: dθ/dt = θ̇, i.e. A[0] = [0 1 0…], B[0] = 0.
        a[0, 1] = 1.0
        rows = list(range(1, n))
    else:
        rows = list(range(n))
    norms = np.linalg.norm(q, axis=0)
    norms[norms == 0] = 1.0
    sol, _, rank, _ = np.linalg.lstsq(q / norms, xd[rows].T, rcond=None)
    sol = sol / norms[:, None]
    a[rows] = sol[:n].T
    b[rows, 0] = sol[n]
    cond = equilibrated_condition(q)
    if rank < unknowns:
        warnings.append(f"pinv regressor is rank deficient (rank {rank} of {unknowns}, condition number "
                        f"{cond:.3g}); the model is not determined by these data")
    elif cond > COND_WARN:
        warnings.append(f"pinv regressor is ill-conditioned (condition number {cond:.3g}); "
                        "the model may be unreliable")
    resid = xd - (a @ xs + b * uu)
    res_rms = np.sqrt(np.mean(resid**2, axis=1))
    xd_rms = np.sqrt(np.mean(xd**2, axis=1))
    rel = np.divide(res_rms, xd_rms, out=np.full(n, np.nan), where=xd_rms > 0)
    return PinvResult(
        A=a, B=b, states=names, residual_rms=res_rms, relative_residual=rel,
        condition=cond, rank=int(rank), n_samples=n_samples, settings=settings,
        warnings=tuple(warnings),
    )
