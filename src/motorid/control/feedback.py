"""State feedback ``u = −K x + kr r`` by pole placement (Tsiolakis 2022, §2).

The gains come from python-control (``place`` for distinct poles, ``acker`` when a pole is
repeated, which ``place`` refuses with one input); this module adds the ways the report and
the textbook specify the poles and the checks that turn bad specifications into one-line
:class:`~motorid.errors.OptionError` messages.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import control
import numpy as np
import scipy.linalg

from motorid.errors import ControlDesignError, OptionError

__all__ = [
    "POLE_RATIO_MAX",
    "UNCONTROLLABLE_TOL",
    "ControlDesignError",
    "check_controllable",
    "check_gains",
    "check_pole_range",
    "check_poles",
    "k1_for_damping",
    "parse_poles",
    "pbh_margins",
    "place_gains",
    "poles_from_damping",
    "poles_from_specs",
    "reference_gain",
]


# ControlDesignError lives in motorid.errors with every other user-facing error


def parse_poles(text: str, option: str = "--poles") -> np.ndarray:
    """Parse ``"-3+2j,-3-2j"`` (or ``-5,-6``) into a complex array.

    Parameters
    ----------
    text : str
        Comma-separated real or complex numbers.
    option : str
        The option the text came from, named in the error (default ``--poles``).

    Returns
    -------
    ndarray
        The poles, complex dtype.

    Raises
    ------
    OptionError
        On text that is not a comma-separated list of numbers.
    """
    items = [s.strip().replace(" ", "").replace("i", "j") for s in str(text).split(",") if s.strip()]
    if not items:
        raise OptionError(f"{option} needs a comma-separated list of poles, e.g. -3+2j,-3-2j")
    try:
        return np.array([complex(s) for s in items])
    except ValueError:
        raise OptionError(f"{option}: cannot read {text!r} as poles; write them like -3+2j,-3-2j") from None


def check_poles(poles: Sequence[complex] | np.ndarray, n: int, what: str = "closed-loop",
                option: str = "--poles", *, require_stable: bool = False) -> np.ndarray:
    """Validate a pole set: count, finiteness, conjugate pairs, stability.

    Parameters
    ----------
    poles : sequence of complex
    n : int
        How many poles are needed (the number of states to place).
    what : str
        Named in messages (``closed-loop``, ``observer``).
    option : str
        The option the poles came from, named in messages.
    require_stable : bool
        Refuse poles with a non-negative real part (observers).

    Returns
    -------
    ndarray of complex

    Raises
    ------
    OptionError
        Wrong count, NaN/inf, a complex pole without its conjugate, or an unstable pole when
        ``require_stable``.
    """
    p = np.asarray(poles, dtype=complex).ravel()
    if p.size != n:
        raise OptionError(f"{option}: {p.size} {what} poles given, the system needs exactly {n}")
    if not np.all(np.isfinite(p)):
        raise OptionError(f"{option}: {what} poles must be finite numbers")
    scale = max(1.0, float(np.max(np.abs(p))))
    rest = list(p[np.abs(p.imag) > 1e-9 * scale])
    while rest:
        z = rest.pop(0)
        j = int(np.argmin([abs(w - np.conj(z)) for w in rest])) if rest else -1
        if j < 0 or abs(rest[j] - np.conj(z)) > 1e-6 * scale:
            raise OptionError(f"{option}: complex {what} pole {z:.6g} has no conjugate; add {np.conj(z):.6g}")
        rest.pop(j)
    if require_stable and np.any(p.real >= 0):
        bad = p[p.real >= 0][0]
        raise OptionError(f"{option}: {what} pole {bad:.6g} is not in the left half-plane; "
                          f"an observer needs poles with negative real parts")
    return p


def check_gains(values: Sequence[float] | np.ndarray, option: str) -> np.ndarray:
    """Return gains as a float array, or raise OptionError for NaN/inf.

    Parameters
    ----------
    values : sequence of float or ndarray
        The gains as given.
    option : str
        The option they came from, named in the error.

    Returns
    -------
    ndarray
        The gains as floats.
    """
    try:
        g = np.asarray(values, dtype=float).ravel()
    except (TypeError, ValueError):
        raise OptionError(f"{option}: gains must be numbers") from None
    if not np.all(np.isfinite(g)):
        raise OptionError(f"{option}: gains must be finite, got {list(g)}")
    return g


#: Relative distance to uncontrollability below which a pair ``(A, B)`` is refused: the
#: smallest singular value of ``[λI − A, B]`` over the eigenvalues ``λ`` (PBH test), on the
#: balanced realisation with ``B`` scaled to the norm of ``A``, divided by that norm.  Exact
#: round-off would be ~1e-15; an eigenvalue of a double (Jordan) block is computed only to
#: ~√eps ≈ 1.5e-8 relative, so the threshold sits above that.  A model this close to losing
#: a mode would need gains ~1e7 times its scale to move it.
UNCONTROLLABLE_TOL = 1e-7
#: Poles (closed-loop or observer) farther from the origin than this many times the model's
#: fastest open-loop pole (at least 1 rad/s) are refused as absurd: the gains would be of the
#: order of that ratio to the power of the number of states and no amplifier or sensor
#: bandwidth could realise them.
POLE_RATIO_MAX = 1e4


def pbh_margins(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scale-free PBH measure of controllability of ``(A, B)``, one value per eigenvalue.

    The realisation is balanced (``scipy.linalg.matrix_balance``, a diagonal similarity) and
    the input columns scaled to the norm of ``A``; then for every eigenvalue ``λ`` the
    smallest singular value of ``[λI − A, B]`` relative to ``‖A‖`` is taken (0 for a mode the
    input cannot reach).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    b : ndarray, shape (n, 1)
        Input column ``B``.

    Returns
    -------
    (ndarray, ndarray)
        The margins and the eigenvalues they belong to.
    """
    a = np.asarray(a, dtype=float)
    n = a.shape[0]
    b = np.asarray(b, dtype=float).reshape(n, -1)
    ab, (scale, _) = scipy.linalg.matrix_balance(a, permute=False, separate=True)
    bb = b / scale[:, None]
    lams = np.linalg.eigvals(ab)
    na = float(np.linalg.norm(ab, 2))
    nb = float(np.linalg.norm(bb, 2))
    if nb == 0.0:
        return np.zeros(n), lams
    norm = na if na > 0 else nb
    bb = bb * (norm / nb)
    margins = np.array([float(np.linalg.svd(np.hstack([lam * np.eye(n) - ab, bb]), compute_uv=False)[-1]) / norm
                        for lam in lams])
    return margins, lams


def check_controllable(a: np.ndarray, b: np.ndarray, what: str = "model") -> None:
    """Raise ControlDesignError when ``(A, B)`` is not controllable.

    Scale-free: the PBH test of :func:`pbh_margins` on the balanced realisation against
    :data:`UNCONTROLLABLE_TOL` (the rank of the raw ``[B AB …]`` depends on the units of the
    states and wrongly refused identified models whose states differ in scale by 10⁴).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    b : ndarray, shape (n, 1)
        Input column ``B``.
    what : str
        What the pair is, named in the error (default ``model``).

    References
    ----------
    Tsiolakis 2022, eq. 30 (rank of the controllability matrix; PBH is the equivalent test).
    """
    n = a.shape[0]
    margins, lams = pbh_margins(a, b)
    lost = margins < UNCONTROLLABLE_TOL
    if np.any(lost):
        rank = n - int(np.sum(lost))
        lam = complex(lams[int(np.argmin(margins))])
        raise ControlDesignError(
            f"the {what} is not controllable (rank of [B AB ...] is {rank} < {n} states; mode at "
            f"{lam.real:.4g}{lam.imag:+.4g}j): the input cannot move every state, so its poles cannot all be placed"
        )


def check_pole_range(poles: np.ndarray, a: np.ndarray, what: str = "closed-loop", option: str = "--poles") -> None:
    """Refuse poles more than :data:`POLE_RATIO_MAX` × the model's fastest pole from the origin.

    Parameters
    ----------
    poles : ndarray
        The poles asked for.
    a : ndarray, shape (n, n)
        State matrix ``A``.
    what : str
        Which poles they are, named in the error (default ``closed-loop``).
    option : str
        The option they came from (default ``--poles``).

    Raises
    ------
    OptionError
        Naming the option, the pole and the largest sensible magnitude.
    """
    p = np.asarray(poles, dtype=complex).ravel()
    ref = max(1.0, float(np.max(np.abs(np.linalg.eigvals(a)))) if a.size else 1.0)
    limit = POLE_RATIO_MAX * ref
    big = p[np.abs(p) > limit]
    if big.size:
        raise OptionError(f"{option}: {what} pole {big[0]:.4g} is absurdly far from the model's dynamics "
                          f"(fastest open-loop pole {ref:.4g} rad/s); keep poles within {limit:.3g} rad/s")


def place_gains(a: np.ndarray, b: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """Gain row ``K`` with ``eig(A − B K) = poles``.

    ``control.place`` (Tits–Yang, robust) for distinct poles; ``control.acker`` when a pole is
    repeated (critical damping), which ``place`` cannot assign with one input.  Both run on the
    balanced realisation (``scipy.linalg.matrix_balance``) so states of very different scales
    (position volts next to acceleration volts per second) do not spoil the placement.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    b : ndarray, shape (n, 1) or (n, m)
        Input column ``B`` (``m`` columns: an observer placed on several outputs' dual).
    poles : ndarray
        The ``n`` closed-loop poles (complex ones in conjugate pairs).

    Returns
    -------
    ndarray, shape (1, n) or (m, n)
        The gain row ``K``.

    Raises
    ------
    ControlDesignError
        When the placement fails numerically.
    """
    p = np.asarray(poles, dtype=complex)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float).reshape(a.shape[0], -1)
    ab, (scale, _) = scipy.linalg.matrix_balance(a, permute=False, separate=True)
    bb = b / scale[:, None]
    pmax = max(1.0, float(np.max(np.abs(p)))) if p.size else 1.0
    repeated = any(abs(p[i] - p[j]) < 1e-6 * pmax for i in range(p.size) for j in range(i + 1, p.size))
    try:
        with np.errstate(all="ignore"):
            kb = control.acker(ab, bb, p) if repeated else control.place(ab, bb, p)
    except (ValueError, np.linalg.LinAlgError, ArithmeticError) as exc:
        raise ControlDesignError(f"pole placement failed for poles {list(np.round(p, 6))} ({exc}); "
                                 "choose other poles") from None
    # x = diag(scale) x_b, so K x = K_b x_b gives K = K_b diag(scale)⁻¹
    k = np.real(np.asarray(kb, dtype=float).reshape(b.shape[1], -1)) / scale[None, :]
    return k


def poles_from_damping(zeta: float, wn: float, n: int) -> tuple[np.ndarray, list[str]]:
    """Dominant pair of ``s² + 2ζωn s + ωn²`` plus, for ``n > 2``, fast real poles.

    Parameters
    ----------
    zeta : float
        Damping ratio ζ (> 0).
    wn : float
        Natural frequency ωn in rad/s (> 0).
    n : int
        Number of poles to return.

    Returns
    -------
    (ndarray, list of str)
        The poles and warnings (extra poles placed at 5, 6, … × ζωn).
    """
    if not (math.isfinite(zeta) and zeta > 0):
        raise OptionError(f"--damping must be > 0, got {zeta!r}")
    if not (math.isfinite(wn) and wn > 0):
        raise OptionError(f"--wn must be > 0, got {wn!r}")
    pair: list[complex]
    if zeta >= 1.0:
        r = wn * math.sqrt(zeta * zeta - 1.0)
        pair = [-zeta * wn + r, -zeta * wn - r]
    else:
        d = wn * math.sqrt(1.0 - zeta * zeta)
        pair = [complex(-zeta * wn, d), complex(-zeta * wn, -d)]
    warnings: list[str] = []
    extra = [-(5.0 + i) * zeta * wn for i in range(max(0, n - 2))]
    if extra:
        warnings.append(f"{n} states: the poles beyond the dominant pair are placed at "
                        + ", ".join(f"{e:.4g}" for e in extra))
    return np.array((pair + extra)[:n], dtype=complex), warnings


def poles_from_specs(settling_time_s: float, overshoot_pct: float, n: int) -> tuple[np.ndarray, list[str]]:
    """Dominant pair from a 2 % settling time and a percent overshoot.

    ``ζ = −ln(OS)/√(π² + ln² OS)`` (``ζ = 1`` for no overshoot) and ``ωn = 4/(ζ Ts)``.

    Parameters
    ----------
    settling_time_s : float
        2 % settling time Ts in s (> 0).
    overshoot_pct : float
        Percent overshoot OS, in [0, 100).
    n : int
        Number of poles to return.

    Returns
    -------
    (ndarray, list of str)
        The poles and warnings, as :func:`poles_from_damping`.
    """
    if not (math.isfinite(settling_time_s) and settling_time_s > 0):
        raise OptionError(f"--settling-time must be > 0 s, got {settling_time_s!r}")
    if not (math.isfinite(overshoot_pct) and 0 <= overshoot_pct < 100):
        raise OptionError(f"--overshoot must be a percentage in [0, 100), got {overshoot_pct!r}")
    if overshoot_pct == 0:
        zeta = 1.0
    else:
        lo = math.log(overshoot_pct / 100.0)
        zeta = -lo / math.sqrt(math.pi ** 2 + lo * lo)
    return poles_from_damping(zeta, 4.0 / (zeta * settling_time_s), n)


def k1_for_damping(a: np.ndarray, b: np.ndarray, k2: float, zeta: float) -> tuple[float, float]:
    """The report's design: given ``k2`` and ``ζ``, the ``k1`` that gives that damping.

    For two states the closed-loop polynomial ``s² + P1 s + P2`` is affine in ``(k1, k2)``; with
    ``k2`` fixed, ``P1² = 4ζ² P2`` (eq. 36 for ζ = 1) is solved for ``k1`` (a linear equation
    for the report's model, where ``P1`` does not depend on ``k1``, eqs. 33–34; a quadratic in
    general, whose stabilising root is taken).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    b : ndarray, shape (n, 1)
        Input column ``B``.
    k2 : float
        The given velocity gain.
    zeta : float
        The damping ratio ζ asked for.

    Returns
    -------
    (float, float)
        ``k1`` and the resulting ``ωn``.

    Raises
    ------
    ControlDesignError
        For a model that does not have exactly two states, or when no real ``k1`` gives a
        stable loop with this damping (e.g. ``k2`` below the Routh bound, eq. 46).

    References
    ----------
    Tsiolakis 2022, eqs. 32–36.
    """
    from motorid.control.routh import affine_char_poly

    if a.shape[0] != 2:
        raise ControlDesignError(f"--k2 with --damping needs a 2-state model (the report's); this one has "
                                 f"{a.shape[0]} states: use --poles or --damping with --wn")
    if not (math.isfinite(zeta) and zeta > 0):
        raise OptionError(f"--damping must be > 0, got {zeta!r}")
    if not math.isfinite(k2):
        raise OptionError(f"--k2 must be finite, got {k2!r}")
    poly = affine_char_poly(a, b, ("k1", "k2"))
    # P1 = α1 + β1 k1, P2 = α0 + β0 k1 with k2 fixed
    al1 = poly.const[0] + poly.coef[0, 1] * k2
    be1 = poly.coef[0, 0]
    al0 = poly.const[1] + poly.coef[1, 1] * k2
    be0 = poly.coef[1, 0]
    z2 = 4.0 * zeta * zeta
    # (α1 + β1 k)² − 4ζ²(α0 + β0 k) = 0
    roots = np.roots([be1 * be1, 2 * al1 * be1 - z2 * be0, al1 * al1 - z2 * al0])
    good = [float(r.real) for r in np.atleast_1d(roots) if abs(r.imag) < 1e-9 * max(1.0, abs(r))
            and al1 + be1 * r.real > 0 and al0 + be0 * r.real > 0]
    if not good:
        raise ControlDesignError(
            f"no k1 gives a stable loop with damping {zeta:g} for k2 = {k2:g}; "
            "raise k2 above the Routh bound printed by 'motorid design'"
        )
    k1 = min(good, key=abs)
    return k1, math.sqrt(al0 + be0 * k1)


def reference_gain(a: np.ndarray, b: np.ndarray, c: np.ndarray, k: np.ndarray) -> float:
    """``kr = −1 / (C (A − B K)⁻¹ B)`` for zero steady-state error to a step.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix ``A``.
    b : ndarray, shape (n, 1)
        Input column ``B``.
    c : ndarray, shape (1, n)
        Output row ``C`` of the measured channel.
    k : ndarray, shape (1, n)
        The state-feedback gain row.

    Returns
    -------
    float
        The reference gain ``kr``.

    Raises
    ------
    ControlDesignError
        When the closed loop has a zero DC gain or a pole at the origin.

    References
    ----------
    Tsiolakis 2022, eq. 37 (``kr = k1`` for the report's model, eq. 39).
    """
    acl = a - b @ k
    try:
        dc = float((c @ np.linalg.solve(acl, b))[0, 0])
    except np.linalg.LinAlgError:
        raise ControlDesignError("the closed loop has a pole at s = 0, so no reference gain kr gives "
                                 "zero steady-state error; move that pole") from None
    if dc == 0.0 or not math.isfinite(dc):
        raise ControlDesignError("the closed loop has zero DC gain to the output; kr is undefined")
    return -1.0 / dc
