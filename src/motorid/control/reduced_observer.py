"""Reduced-order observer: estimate only what the rig does not measure (Luenberger 1964; Gopinath 1971).

The design's states are measurable coordinates (position, velocity, current, acceleration…,
:mod:`.coordinates`).  The sensors measure some of them, ``z_m``; the rest, ``z_u`` (an
acceleration, a jerk: derivatives no rig measures), are estimated from the measured ones and
the command, never by differentiating a measured signal::

    ẇ = F w + G z_m + H u,    ẑ_u = w + L z_m,
    F = A_uu − L A_mu,   G = F L + A_um − L A_mm,   H = B_u − L B_m,

so that the error ``e = z_u − ẑ_u`` obeys ``ė = F e`` whatever the motor does.  The controller
is ``u = −K_m z_m − K_u ẑ_u + kr r`` (or ``− ki z``); the closed loop's poles are the
state-feedback poles and ``eig(F)`` (separation, checked on the full matrix).  ``L`` is placed
on the dual pair ``(A_uuᵀ, A_muᵀ)`` with python-control (:func:`~motorid.control.feedback.place_gains`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from motorid.control.feedback import UNCONTROLLABLE_TOL, ControlDesignError, pbh_margins, place_gains
from motorid.errors import OptionError

__all__ = ["OBSERVER_SPEED", "ReducedObserver", "command_rows", "default_poles", "placed_observer", "reduced_loop",
           "reduced_loop_matrix", "reduced_observer"]

#: Default observer poles: this many times the fastest closed-loop pole's real part, spread
#: by 15 % each (distinct, so the multi-sensor placement is well posed).  Fast enough that the
#: estimate settles before the controller acts on it, slow enough not to amplify sensor noise
#: far beyond the loop's bandwidth (the usual 2–6× rule; Franklin, Powell & Emami-Naeini, §7.7).
OBSERVER_SPEED = 4.0


@dataclass(frozen=True, slots=True)
class ReducedObserver:
    """``ẇ = F w + G z_m + H u``, ``ẑ_u = w + L z_m``.

    Attributes
    ----------
    measured : tuple of str
        The measured states ``z_m`` (the sensors), in the design's state order.
    estimated : tuple of str
        The estimated states ``z_u``.
    L : ndarray, shape (n_u, n_m)
    F : ndarray, shape (n_u, n_u)
    G : ndarray, shape (n_u, n_m)
    H : ndarray, shape (n_u, 1)
    poles : ndarray
        ``eig(F)``.
    """

    measured: tuple[str, ...]
    estimated: tuple[str, ...]
    L: np.ndarray
    F: np.ndarray
    G: np.ndarray
    H: np.ndarray
    poles: np.ndarray

    def to_json(self) -> dict[str, Any]:
        """The design JSON's ``reduced_observer`` object.

        Returns
        -------
        dict
            ``measured``, ``estimated``, ``L``, ``F``, ``G``, ``H`` (row lists), ``poles`` as
            ``[re, im]`` pairs.
        """
        def rows(m: np.ndarray) -> list[list[float]]:
            return [[float(v) for v in row] for row in np.atleast_2d(m)]

        return {"measured": list(self.measured), "estimated": list(self.estimated), "L": rows(self.L),
                "F": rows(self.F), "G": rows(self.G), "H": rows(self.H),
                "poles": [[float(p.real), float(p.imag)] for p in self.poles]}

    @classmethod
    def from_json(cls, data: Any, states: tuple[str, ...]) -> ReducedObserver:
        """Rebuild from :meth:`to_json`, checked against the design's ``states``.

        Parameters
        ----------
        data : Mapping
            The ``reduced_observer`` object.
        states : tuple of str
            The design's states.

        Returns
        -------
        ReducedObserver

        Raises
        ------
        ValueError
            On a malformed entry (named).
        """
        if not isinstance(data, dict):
            raise ValueError("reduced_observer must be an object")
        measured = tuple(data.get("measured") or ())
        estimated = tuple(data.get("estimated") or ())
        if not estimated or sorted((*measured, *estimated)) != sorted(states) or \
                not all(isinstance(s, str) for s in (*measured, *estimated)):
            raise ValueError("reduced_observer: measured and estimated must split the design's states")
        nm, nu = len(measured), len(estimated)

        def matrix(key: str, shape: tuple[int, int]) -> np.ndarray:
            try:
                m = np.array(data.get(key), dtype=float).reshape(shape)
            except (TypeError, ValueError):
                raise ValueError(f"reduced_observer.{key} must be a {shape[0]}×{shape[1]} matrix") from None
            if not np.all(np.isfinite(m)):
                raise ValueError(f"reduced_observer.{key} must hold finite numbers")
            return m

        f = matrix("F", (nu, nu))
        return cls(measured, estimated, matrix("L", (nu, nm)), f, matrix("G", (nu, nm)), matrix("H", (nu, 1)),
                   np.linalg.eigvals(f))

    def split(self, states: tuple[str, ...]) -> tuple[list[int], list[int]]:
        """Indices of the measured and the estimated states in ``states``.

        Parameters
        ----------
        states : tuple of str
            The design's states.

        Returns
        -------
        (list of int, list of int)
            Where the measured and the estimated states sit.
        """
        return [states.index(s) for s in self.measured], [states.index(s) for s in self.estimated]


def default_poles(controller_poles: np.ndarray, count: int, speed: float = OBSERVER_SPEED) -> np.ndarray:
    """``count`` real observer poles ``speed`` times faster than the controller's fastest.

    Parameters
    ----------
    controller_poles : ndarray
        The closed loop's (state feedback's) poles.
    count : int
        How many states are estimated.
    speed : float
        The factor (default :data:`OBSERVER_SPEED`).

    Returns
    -------
    ndarray
        Distinct negative real poles.
    """
    fastest = max(float(np.max(np.abs(np.asarray(controller_poles).real), initial=0.0)), 1.0)
    return -speed * fastest * (1.0 + 0.15 * np.arange(count))


def reduced_observer(a: np.ndarray, b: np.ndarray, states: tuple[str, ...], measured: tuple[str, ...],
                     poles: np.ndarray) -> ReducedObserver:
    """Place a reduced-order observer of the states not in ``measured``.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix in the design's coordinates.
    b : ndarray, shape (n, 1)
        Input column.
    states : tuple of str
        The design's state names (``a``'s order).
    measured : tuple of str
        The states the sensors measure (a subset of ``states``).
    poles : ndarray
        One pole per estimated state (stable; complex ones in conjugate pairs).

    Returns
    -------
    ReducedObserver

    Raises
    ------
    OptionError
        Wrong number of poles, or an unstable one.
    ControlDesignError
        The estimated states cannot be seen from the measured ones (``(A_uu, A_mu)`` not
        observable), or the placement fails.
    """
    ui = [i for i, s in enumerate(states) if s not in measured]
    p = np.asarray(poles, dtype=complex)
    if p.size != len(ui):
        raise OptionError(f"a reduced-order observer of {', '.join(states[i] for i in ui)} needs {len(ui)} "
                          f"pole(s), got {p.size}")
    if np.any(p.real >= 0):
        raise OptionError(f"observer poles must be stable (negative real part), got {list(p)}")
    return placed_observer(a, b, states, measured, p)


def placed_observer(a: np.ndarray, b: np.ndarray, states: tuple[str, ...], measured: tuple[str, ...],
                    poles: np.ndarray) -> ReducedObserver:
    """The reduced-order observer with ``eig(F) = poles``, continuous or sampled alike.

    The same algebra holds for ``ż = A z + B u`` and for the sampled ``z[k+1] = Φ z[k] + Γ u[k]``
    (``F = Φ_uu − L Φ_mu``, …, the estimate's error then ``e[k+1] = F e[k]``): given ``(Φ, Γ)``
    and poles inside the unit circle, this is the observer of a controller that runs every sample
    (:func:`motorid.control.sampled.sampled_reduced_observer`).

    Parameters
    ----------
    a, b : ndarray
        ``(A, B)``, or ``(Φ, Γ)``.
    states, measured : tuple of str
        As :func:`reduced_observer`.
    poles : ndarray
        One per estimated state (not checked here).

    Returns
    -------
    ReducedObserver

    Raises
    ------
    ControlDesignError
        As :func:`reduced_observer`.
    """
    mi = [i for i, s in enumerate(states) if s in measured]
    ui = [i for i, s in enumerate(states) if s not in measured]
    p = np.asarray(poles, dtype=complex)
    a, b = np.asarray(a, float), np.asarray(b, float).reshape(-1, 1)
    a_mm, a_mu, a_um, a_uu = a[np.ix_(mi, mi)], a[np.ix_(mi, ui)], a[np.ix_(ui, mi)], a[np.ix_(ui, ui)]
    # (A_uu, A_mu) observable ⇔ (A_uuᵀ, A_muᵀ) controllable: the scale-free PBH test of the design
    margins, _ = pbh_margins(a_uu.T, a_mu.T)
    if np.any(margins < UNCONTROLLABLE_TOL):
        raise ControlDesignError(f"{', '.join(states[i] for i in ui)} cannot be estimated from "
                                 f"{', '.join(states[i] for i in mi)}: measure another channel")
    # only the directions of z_m's derivative that see z_u carry information: place on a full-rank
    # basis of them (a position sensor's derivative is the measured velocity: no column of its own)
    u_svd, sv, _ = np.linalg.svd(a_mu, full_matrices=False)
    rank = int(np.sum(sv > 1e-12 * max(float(sv[0]), 1e-300))) if sv.size else 0
    basis = u_svd[:, :rank]
    gain = place_gains(a_uu.T, (basis.T @ a_mu).T, p).T @ basis.T
    f = a_uu - gain @ a_mu
    g = f @ gain + a_um - gain @ a_mm
    h = b[ui] - gain @ b[mi]
    return ReducedObserver(tuple(states[i] for i in mi), tuple(states[i] for i in ui), gain, f, g, h,
                           np.linalg.eigvals(f))


def command_rows(k: np.ndarray, ki: float | None, obs: ReducedObserver, states: tuple[str, ...]
                 ) -> tuple[np.ndarray, np.ndarray, float | None]:
    """The command ``u = Kz·z_m + Kw·w (− ki·z_int)`` as rows on the measured states and on ``w``.

    ``u = −K_m z_m − K_u (w + L z_m)``: ``Kz = −(K_m + K_u L)``, ``Kw = −K_u``.

    Parameters
    ----------
    k : ndarray
        The gain row on the design's states.
    ki : float or None
        Integral gain (returned as it is).
    obs : ReducedObserver
    states : tuple of str
        The design's states.

    Returns
    -------
    (ndarray, ndarray, float or None)
        ``Kz`` (1, n_m), ``Kw`` (1, n_u) and ``ki``.
    """
    mi, ui = obs.split(states)
    k = np.asarray(k, float).ravel()
    k_m, k_u = k[mi].reshape(1, -1), k[ui].reshape(1, -1)
    return -(k_m + k_u @ obs.L), -k_u, ki


def reduced_loop(a: np.ndarray, b: np.ndarray, c: np.ndarray, k: np.ndarray, ki: float | None,
                 obs: ReducedObserver, states: tuple[str, ...], sel: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)`` of the loop broken at the motor's input: ``L = −u/v``, states ``[x, w(, z)]`` (``r = 0``).

    The motor is driven by ``v``; the observer is fed the controller's own command ``u`` and the
    measured states; the integrator reads ``y = c x``.

    Parameters
    ----------
    a, b, c : ndarray
        The motor; ``c`` the integrator's output row.
    k : ndarray
        The gain row on the design's states.
    ki : float or None
        Integral gain.
    obs : ReducedObserver
    states : tuple of str
        The design's states.
    sel : ndarray, optional
        Rows giving the measured states from ``x`` (default: ``x`` is in the design's
        coordinates, the unit rows of the measured states).

    Returns
    -------
    (ndarray, ndarray, ndarray)
        ``A``, ``B`` (column), ``C`` (row; minus the command).
    """
    n = a.shape[0]
    mi, _ = obs.split(states)
    nu = obs.F.shape[0]
    kz, kw, _ = command_rows(k, ki, obs, states)
    sel = np.eye(n)[mi] if sel is None else sel
    size = n + nu + (1 if ki is not None else 0)
    f = np.zeros((1, size))  # u as a row on [x, w, z]
    f[:, :n] = kz @ sel
    f[:, n:n + nu] = kw
    if ki is not None:
        f[0, -1] = -ki
    big = np.zeros((size, size))
    big[:n, :n] = a
    big[n:n + nu, :] = obs.H @ f
    big[n:n + nu, :n] += obs.G @ sel
    big[n:n + nu, n:n + nu] += obs.F
    if ki is not None:
        big[-1, :n] = np.asarray(c, float).ravel()
    col = np.zeros((size, 1))
    col[:n] = np.asarray(b, float).reshape(n, 1)
    return big, col, -f


def reduced_loop_matrix(a: np.ndarray, b: np.ndarray, c: np.ndarray, k: np.ndarray, ki: float | None,
                        obs: ReducedObserver, states: tuple[str, ...]) -> np.ndarray:
    """System matrix of plant + reduced observer + feedback, states ``[x, w(, z)]`` (``r = 0``).

    Its eigenvalues are the state-feedback poles and ``eig(F)`` (separation).

    Parameters
    ----------
    a, b, c : ndarray
        The model in the design's coordinates; ``c`` the integrator's output row.
    k : ndarray
        The gain row on the design's states.
    ki : float or None
        Integral gain.
    obs : ReducedObserver
    states : tuple of str
        The design's states.

    Returns
    -------
    ndarray
        Shape (n + n_u (+ 1)) squared.
    """
    big, col, minus_f = reduced_loop(a, b, c, k, ki, obs, states)
    return big - col @ minus_f
