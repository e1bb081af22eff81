"""Intervals of the Markov method's polished model (:mod:`.laguerre_refine`).

The polish is an output-error least-squares fit: its Gauss–Newton covariance
(:attr:`~motorid.identification.laguerre_refine.LaguerrePolish.covariance`) carried by the delta
method to what the model reports — DC gain, τ, residence time, 63 % time, poles, zeros, dead time
and each other capture's shift — so that every parameter the fit adjusts is printed and written
with its interval, as the output-error method's are.  The derivatives are central differences of
the model itself, rebuilt from each perturbed parameter vector: the value at the fit is the
model's own headline, whatever it cancels or trims.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from motorid.identification.laguerre_refine import LaguerrePolish, _PolishModel
from motorid.model import MotorModel, model_from_velocity_tf
from motorid.model.uncertainty import ChannelTiming, JointCovariance, ParameterEstimate, Uncertainty

__all__ = ["polish_uncertainty", "polished_tf", "unresolved_poles"]

#: Relative step of the central differences, in standard errors of the parameter moved.
STEP_STD = 1e-3

#: The primary channel's shift when its step instant was read off its response, in its ``timing`` note.
ONSET_SHIFT = ("the step instant read off the response, moved by the fitted shift: the onset's error, not a "
               "dead time of the motor (with no input channel a dead time is in the onset)")
#: A shift the data do not resolve within its bound, in the channel's ``timing`` note.
UNRESOLVED_SHIFT = "not resolved by the data within its bound of one grid step (its interval is the bound)"

#: How the intervals are obtained, in the JSON's ``uncertainty.method``.
METHOD = ("Gauss-Newton covariance of the Markov method's output-error polish (delta method), "
          "95% = ±1.96 std")


def polished_tf(polish: LaguerrePolish, params: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Velocity ``num, den`` and dead time of a parameter vector of ``polish``'s structure.

    The numerator's coefficients below 1e-12 of its largest are dropped, as
    :meth:`~motorid.identification.laguerre.LaguerreResult.to_model` drops them.

    Parameters
    ----------
    polish : LaguerrePolish
        The fit whose structure (order, channels) ``params`` follows.
    params : ndarray
        A parameter vector (``polish.params`` or a perturbation of it).

    Returns
    -------
    tuple
        ``num``, ``den`` (monic, highest power first) and the dead time in seconds.
    """
    q = _PolishModel(polish.den.size - 1, polish.channels, polish.n_zeros).unpack(np.asarray(params, dtype=float))
    num = np.asarray(q["n"], dtype=float)[::-1]
    big = float(np.max(np.abs(num))) if num.size else 0.0
    num = np.trim_zeros(np.where(np.abs(num) < 1e-12 * big, 0.0, num), "f")
    return (num if num.size else np.zeros(1)), np.r_[1.0, np.asarray(q["d"], dtype=float)[::-1]], float(q["delay"])


def _moving(polish: LaguerrePolish) -> int | None:
    """How many leading parameters enter the velocity TF (denominator, numerator, dead time).

    ``None`` when the fit's covariance is not known (a singular Fisher information) or not finite.
    """
    cov = polish.covariance
    if cov is None or cov.shape != (polish.params.size, polish.params.size) or not np.all(np.isfinite(cov)):
        return None
    return _PolishModel(polish.den.size - 1, polish.channels, polish.n_zeros).delay_index + 1


def _central_steps(params: np.ndarray, cov: np.ndarray,
                   moving: int) -> Iterator[tuple[int, np.ndarray, np.ndarray, float]]:
    """``(i, params + h·e_i, params − h·e_i, 2h)`` for each of the first ``moving`` parameters.

    ``h`` is :data:`STEP_STD` of the parameter's standard error (a relative 1e-9 where that is 0).
    """
    for i in range(moving):
        h = STEP_STD * float(np.sqrt(cov[i, i])) or 1e-9 * max(abs(float(params[i])), 1.0)
        up, down = params.copy(), params.copy()
        up[i] += h
        down[i] -= h
        yield i, up, down, 2.0 * h


def unresolved_poles(polish: LaguerrePolish) -> list[int]:
    """Indices (slowest first) of the poles of ``polish`` that the data do not resolve.

    Each pole's real part with its delta-method interval, as :func:`polish_uncertainty` gives it
    (central differences of the denominator's roots), judged by the sanity gate's rule
    (:func:`motorid.identification.sanity.pole_unresolved`).  Without a covariance nothing can be
    judged, and no pole is listed.

    Parameters
    ----------
    polish : LaguerrePolish
        A polished fit.

    Returns
    -------
    list of int
    """
    from motorid.identification.sanity import pole_unresolved

    moving, cov = _moving(polish), polish.covariance
    if moving is None or cov is None:
        return []

    def roots(x: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            return _slowest_first(np.roots(polished_tf(polish, x)[1]))

    base = roots(polish.params)
    grad = np.zeros((base.size, moving))
    for i, up, down, span in _central_steps(polish.params, cov, moving):
        a, b = _matched(base, roots(up)), _matched(base, roots(down))
        grad[:, i] = np.nan if a is None or b is None else np.real(a - b) / span
    sub = cov[:moving, :moving]
    out = []
    for k, p in enumerate(base):
        std = float(np.sqrt(max(float(grad[k] @ sub @ grad[k]), 0.0)))
        if np.isfinite(std) and pole_unresolved(float(np.real(p)), float(np.real(p)) - 1.96 * std,
                                                float(np.real(p)) + 1.96 * std):
            out.append(k)
    return out


def _slowest_first(roots: np.ndarray) -> np.ndarray:
    """Roots by the size of their real part, then their imaginary part (as the output-error method lists them)."""
    roots = np.asarray(roots, dtype=complex)
    return roots[np.lexsort((np.imag(roots), np.abs(np.real(roots))))]


def _matched(base: np.ndarray, moved: np.ndarray) -> np.ndarray | None:
    """``moved`` reordered so each entry is the one nearest ``base``'s (None if their counts differ)."""
    if moved.size != base.size:
        return None
    left = list(moved)
    out = []
    for b in base:
        j = int(np.argmin([abs(b - c) for c in left]))
        out.append(left.pop(j))
    return np.asarray(out, dtype=complex)


def _quantities(m: MotorModel) -> dict[str, Any]:
    fo = m.first_order()
    return {"dc_gain": m.dc_gain(), "time_constant": fo.time_constant_s, "residence_time_s": m.residence_time_s(),
            "t63_s": m.t63_s(), "delay": m.delay_s,
            "poles": _slowest_first(m.poles()), "zeros": _slowest_first(m.zeros())}


def polish_uncertainty(
    model: MotorModel,
    polish: LaguerrePolish,
    *,
    step_rel_std: float = 0.0,
    instant_std: float = 0.0,
    timing: Mapping[str, tuple[str, float]] | None = None,
    shift_bound_s: float = float("inf"),
    kinds: Mapping[str, str] | None = None,
    onset_shift: bool = False,
) -> Uncertainty | None:
    """The typed uncertainty of a model the Markov method's polish fitted.

    Parameters
    ----------
    model : MotorModel
        The model made from ``polish`` (its settings decide what :meth:`MotorModel.first_order`
        cancels; each perturbed model is made with them).
    polish : LaguerrePolish
        The polished fit, with its covariance.
    step_rel_std : float
        Relative error of the measured step level and of the velocity's recorded change (in
        quadrature): every gain scales with it (as in the output-error method).
    instant_std : float
        Standard error of the step instant the time axis starts at (a scope's sampled edge:
        ``dt/√12``): it moves the dead time one for one.
    timing : Mapping, optional
        Per channel: the step instant in words and on the file's time axis; the channels the
        polish gave a shift get it with its interval.
    shift_bound_s : float
        The polish's bound on a shift (``±`` one grid step): an interval that reaches past it on
        either side is reported as the bound, with no standard error (the data do not resolve the
        shift within it).
    kinds : Mapping, optional
        Per channel: the kind of its step instant (``logged``, ``sampled``, ``onset``, ``given``:
        :attr:`~motorid.model.uncertainty.ChannelTiming.kind`).
    onset_shift : bool
        The primary channel's step instant was read off its response (no input channel): the
        polish's dead time is that read-off's error, a shift of the channel (its ``timing``, with
        its interval), not a delay of the motor.  Every quantity is then the model's without it
        (``model`` has none), and the joint covariance leaves it out.

    Returns
    -------
    Uncertainty or None
        ``None`` when the fit's covariance is not known (a singular Fisher information).
    """
    # the denominator, the numerator and the dead time: nothing else enters the velocity TF
    moving, cov = _moving(polish), polish.covariance
    if moving is None or cov is None:
        return None
    base = _quantities(model)

    def rebuilt(x: np.ndarray) -> dict[str, Any]:
        num, den, delay = polished_tf(polish, x)
        delay = 0.0 if onset_shift else max(delay, 0.0)
        with np.errstate(all="ignore"):
            return _quantities(model_from_velocity_tf(num, den, settings=model.settings, delay_s=delay))

    grads: dict[str, np.ndarray] = {}
    for i, up, down, span in _central_steps(polish.params, cov, moving):
        _gradient_columns(grads, base, rebuilt(up), rebuilt(down), span, i, moving)
    sub = cov[:moving, :moving]

    def std_of(key: str, extra: float = 0.0) -> float:
        g = grads.get(key)
        var = float(g @ sub @ g) if g is not None and np.all(np.isfinite(g)) else float("nan")
        return float(np.sqrt(max(var, 0.0) + extra))

    def estimate(value: float | complex, std: float) -> ParameterEstimate:
        centre = float(np.real(value))
        ok = np.isfinite(std) and np.isfinite(centre)
        return ParameterEstimate(value, std, (centre - 1.96 * std, centre + 1.96 * std) if ok else None)

    dc = float(base["dc_gain"])
    gain_extra = (dc * step_rel_std) ** 2 if np.isfinite(dc) else 0.0
    timing_extra = instant_std**2
    timing_of = _shift_timing(polish, cov, timing or {}, shift_bound_s, kinds or {})
    delay: ParameterEstimate | None = _at_least_zero(estimate(float(base["delay"]), std_of("delay", timing_extra)))
    joint = _joint(polish, cov, moving)
    if onset_shift and polish.channels and polish.channels[0] in timing_of:
        # the dead time the polish fitted is the read-off onset's error: the primary channel's shift
        k = moving - 1  # (the delay is the last parameter that moves the velocity TF)
        value, std = float(polish.params[k]), float(np.sqrt(max(float(cov[k, k]), 0.0)))
        primary = polish.channels[0]
        # (cut at 0 as a dead time's interval is: the polish's bound)
        shift = _at_least_zero(ParameterEstimate(value, std, (value - 1.96 * std, value + 1.96 * std)))
        timing_of[primary] = replace(timing_of[primary], shift=shift, note=ONSET_SHIFT)
        delay = None
        joint = JointCovariance(joint.parameters[:-1], joint.values[:-1], joint.covariance[:-1, :-1])
    return Uncertainty(
        dc_gain=estimate(dc, std_of("dc_gain", gain_extra)),
        time_constant=estimate(float(base["time_constant"]), std_of("time_constant")),
        residence_time_s=estimate(float(base["residence_time_s"]), std_of("residence_time_s", timing_extra)),
        t63_s=estimate(float(base["t63_s"]), std_of("t63_s", timing_extra)),
        poles=tuple(estimate(complex(p), std_of(f"pole_{k}")) for k, p in enumerate(base["poles"])),
        zeros=tuple(estimate(complex(z), std_of(f"zero_{k}")) for k, z in enumerate(base["zeros"])),
        delay=delay,
        method=METHOD,
        joint=joint,
        timing=timing_of,
    )


def _joint(polish: LaguerrePolish, cov: np.ndarray, moving: int) -> JointCovariance:
    """The velocity TF's coefficients and dead time with their covariance (``uncertainty.joint``).

    ``den_i`` are the monic denominator's coefficients of ``sⁱ``, ``num_j`` the numerator's of ``sʲ``
    (lowest powers first, as the polish fits them), then ``delay``: what a robustness check
    samples plausible motors from (complex poles included, which time constants cannot hold).
    """
    m = polish.den.size - 1
    names = (*(f"den_{i}" for i in range(m)), *(f"num_{j}" for j in range(moving - m - 1)), "delay")
    return JointCovariance(names, np.asarray(polish.params[:moving], dtype=float), cov[:moving, :moving])


def _at_least_zero(item: ParameterEstimate) -> ParameterEstimate:
    """A dead time's interval cut at 0, the fit's bound (its standard error as the fit gives it)."""
    if item.ci95 is None or item.ci95[0] >= 0.0:
        return item
    return ParameterEstimate(item.value, item.stderr, (0.0, max(item.ci95[1], 0.0)))


def _gradient_columns(grads: dict[str, np.ndarray], base: Mapping[str, Any], up: Mapping[str, Any],
                      down: Mapping[str, Any], span: float, i: int, size: int) -> None:
    """Column ``i`` of every quantity's gradient; a root that vanishes or appears under the step: NaN."""
    def put(key: str, value: float) -> None:
        grads.setdefault(key, np.zeros(size))[i] = value

    for key in ("dc_gain", "time_constant", "residence_time_s", "t63_s", "delay"):
        put(key, (float(up[key]) - float(down[key])) / span)
    for kind, label in (("poles", "pole"), ("zeros", "zero")):
        a, b = _matched(base[kind], up[kind]), _matched(base[kind], down[kind])
        for k in range(base[kind].size):
            put(f"{label}_{k}", float("nan") if a is None or b is None else float(np.real(a[k] - b[k])) / span)


def _shift_timing(polish: LaguerrePolish, cov: np.ndarray, timing: Mapping[str, tuple[str, float]],
                  bound: float, kinds: Mapping[str, str]) -> dict[str, ChannelTiming]:
    """Each channel's step instant; the other captures' fitted shifts against the primary's, with intervals."""
    out: dict[str, ChannelTiming] = {}
    n_shifts = len(polish.channels) - 1
    first = polish.params.size - n_shifts
    for k, role in enumerate(polish.channels):
        if role not in timing:
            continue
        words, edge = timing[role]
        shift: ParameterEstimate | None = None
        note = "the primary channel: the others' shifts are against its step instant" if k == 0 and n_shifts else None
        if k > 0:
            value = float(polish.params[first + k - 1])
            std = float(np.sqrt(max(float(cov[first + k - 1, first + k - 1]), 0.0)))
            shift = ParameterEstimate(value, std, (value - 1.96 * std, value + 1.96 * std))
            if not (-bound < value - 1.96 * std and value + 1.96 * std < bound):
                # its own numerator takes up a shift this small: the data leave it anywhere in the bound
                shift = ParameterEstimate(value, float("nan"), (-bound, bound))
                note = UNRESOLVED_SHIFT
        out[role] = ChannelTiming(words, float(edge), shift, note, kind=kinds.get(role))
    return out
