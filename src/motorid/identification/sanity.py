"""The sanity gate every identified model passes before it is printed.

A model can be the optimum of its criterion and still be absurd: the paper's pinv at a 0.1 s
interval on a 15 ms motor returns an unstable pole; an output-error fit of the wrong
structure lets its AR noise model absorb the misfit and doubles τ.  None of that shows in
the fit's own numbers, so the model is checked against things it does not control:

1. stability (every pole of the velocity TF in the left half-plane);
2. the fit against a plain first-order-plus-dead-time step ``K·V·(1 − e^(−(t−θ)/τ))``
   fitted to the same samples (``scipy.optimize.curve_fit``): a model with more
   parameters that fits worse than that is wrong;
3. the read-offs a student makes by hand: the final level (DC gain) and the 63 % time
   of the measured response against the model's own step response;
4. the headline numbers inside their own intervals;
5. (output-error fits) the estimate with and without the AR whitening: when they disagree
   by more than their uncertainty the noise model has taken structure for noise;
6. the recorded input is a step: every method here models the response to one, so a
   closed-loop record (the controller's output on CH1) gives the model of a step that did
   not happen.

A failed check is a warning with its explanation; ``--strict`` turns it into exit 3.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize

from motorid.blockwise import sum_of_squares_about
from motorid.identification.classic import first_crossing
from motorid.identification.result import STOPPED_EARLY
from motorid.model.response import recorded_step_response
from motorid.model.simplify import nearest_zeros
from motorid.model.uncertainty import Uncertainty
from motorid.numfmt import sig

__all__ = ["TOLERANCES", "SanityCheck", "SanityReport", "demanded_zero_note", "first_order_baseline", "sanity_checks"]

#: Tolerances of the gate, each with its reason.
TOLERANCES: Mapping[str, float] = {
    # a model may fit up to this factor worse than the 3-parameter first-order baseline
    # (plus 0.5 % of the final level, for records where both fit to the noise) — never more
    "baseline_ratio": 1.5,
    "baseline_slack": 0.005,
    # DC gain vs the measured final level / step: a settled record shows its gain to well
    # under 5 % even with 8-bit codes and ripple
    "dc_gain_rel": 0.05,
    # model vs measured 63 % time: 15 % or two recorded samples, whichever is larger
    "t63_rel": 0.15,
    "t63_samples": 2.0,
    # whitened vs unwhitened estimate: apart by more than 4 combined standard errors and 5 %
    "white_sigmas": 4.0,
    "white_rel": 0.05,
    # an NRMSE above this is no model of the record at all
    "max_nrmse": 0.25,
    # RMS variation of the recorded input after its edge, relative to the step: 8-bit codes
    # and probe noise stay well under 1 %; a closed loop's control signal varies by 2–10 %
    "input_rms_rel": 0.02,
}


@dataclass(frozen=True, slots=True)
class SanityCheck:
    """One check: its name, whether it passed, and what it found (in words)."""

    name: str
    passed: bool
    detail: str


@dataclass(frozen=True, slots=True)
class SanityReport:
    """Every check of one model.

    Attributes
    ----------
    checks : tuple of SanityCheck
    """

    checks: tuple[SanityCheck, ...] = field(default=())

    @property
    def passed(self) -> bool:
        """True when every check passed."""
        return all(c.passed for c in self.checks)

    @property
    def failures(self) -> tuple[str, ...]:
        """The failed checks' explanations."""
        return tuple(c.detail for c in self.checks if not c.passed)

    def to_json(self) -> dict[str, object]:
        """``{"passed": bool, "checks": [{"name", "passed", "detail"}, ...]}``.

        Returns
        -------
        dict
            JSON-able.
        """
        return {"passed": self.passed,
                "checks": [{"name": c.name, "passed": c.passed, "detail": c.detail} for c in self.checks]}

    @classmethod
    def from_json(cls, data: object) -> SanityReport:
        """Read :meth:`to_json`'s object back (the model JSON's ``extras.sanity``).

        Parameters
        ----------
        data : object
            The decoded object; anything else than a mapping with a ``checks`` list reads as no
            checks.

        Returns
        -------
        SanityReport
        """
        checks = data.get("checks") if isinstance(data, Mapping) else None
        if not isinstance(checks, list):
            return cls()
        return cls(tuple(SanityCheck(str(c.get("name", "")), bool(c.get("passed")), str(c.get("detail", "")))
                         for c in checks if isinstance(c, Mapping)))


def first_order_baseline(time_s: np.ndarray, y: np.ndarray, step_volts: float) -> tuple[np.ndarray, dict[str, float]]:
    """Least-squares first order plus dead time fitted to a velocity step response.

    Parameters
    ----------
    time_s, y : ndarray
        Times from the step (≥ 0) and the response increment.
    step_volts : float
        Step level.

    Returns
    -------
    (ndarray, dict)
        The fitted response on ``time_s`` and its ``dc_gain``, ``time_constant``, ``delay``.
    """
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(y, dtype=float)
    n = v.size
    final = float(np.mean(v[-max(2, n // 10):]))
    span = float(t[-1] - t[0]) if n > 1 else 1.0
    z = v * np.sign(final) if final else v
    crossing = np.flatnonzero(z >= 0.632 * abs(final))
    tau0 = float(t[crossing[0]]) if crossing.size and t[crossing[0]] > 0 else 0.2 * span

    def f(tt: np.ndarray, k: float, tau: float, theta: float) -> np.ndarray:
        te = np.maximum(tt - theta, 0.0)
        return k * step_volts * -np.expm1(-te / tau)

    p0 = [final / step_volts if step_volts else 1.0, max(tau0, 1e-6), 0.0]
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            p, _ = scipy.optimize.curve_fit(f, t, v, p0=p0,
                                            bounds=([-np.inf, 1e-7, 0.0], [np.inf, 10 * span, 0.5 * span]),
                                            maxfev=2000)
    except (RuntimeError, ValueError):
        p = np.asarray(p0, dtype=float)
    return f(t, *p), {"dc_gain": float(p[0]), "time_constant": float(p[1]), "delay": float(p[2])}


def pole_unresolved(re_: float, lo: float, hi: float) -> bool:
    """Whether a pole with a 95 % interval ``[lo, hi]`` is not resolved by the data.

    Its interval reaches the imaginary axis, or is wider than the pole itself.  The gate's rule,
    which the structure choice applies too
    (:func:`motorid.identification.stages.unsupported_because`).

    Parameters
    ----------
    re_ : float
        The pole's real part (1/s).
    lo, hi : float
        Its 95 % interval (finite).

    Returns
    -------
    bool
    """
    return hi >= 0 or (hi - lo) / 2 > abs(re_)


def zero_undemanded(re_: float, lo: float) -> bool:
    """Whether a zero lies in the right half-plane without the data demanding it.

    A right-half-plane zero (an inverse response, not physical for a DC motor's velocity) is
    demanded only when its whole 95 % interval lies there; without an interval (``lo`` NaN)
    nothing demands it.

    Parameters
    ----------
    re_ : float
        The zero's real part (1/s).
    lo : float
        The lower end of its 95 % interval (NaN when there is none).

    Returns
    -------
    bool
    """
    return re_ > 0 and not lo > 0


def demanded_zero_note(re_: float, lo: float) -> str | None:
    """What a right-half-plane zero the data demand means for a DC motor, in one clause.

    A DC motor's velocity has no inverse response; a right-half-plane zero whose whole 95 %
    interval lies there stands for a lag that the structures with a dead time fit worse.  Its
    first-order Padé reading, ``e^(−sT) ≈ (1 − sT/2)/(1 + sT/2)``, gives the dead time it is
    worth, ``T = 2/z``; and it bounds a loop's crossover to below about ``z/2``.

    Parameters
    ----------
    re_ : float
        The zero's real part (1/s).
    lo : float
        The lower end of its 95 % interval (NaN when there is none).

    Returns
    -------
    str or None
        The clause; None for a zero in the left half-plane or one the data do not demand
        (:func:`zero_undemanded`: the sanity gate fails it and says so).
    """
    if re_ <= 0 or zero_undemanded(re_, lo):
        return None
    return (f"right half-plane, demanded by the data (its whole interval is there): an inverse response a DC "
            f"motor's velocity does not have; {_lag_reading(re_)}")


def _lag_reading(re_: float) -> str:
    """What a demanded right-half-plane zero at ``re_`` (1/s) is worth: a dead time, a crossover bound."""
    return (f"it stands for a lag the structures with a dead time fit worse, worth a dead time of about "
            f"2/z = {sig(2e3 / re_)} ms (first-order Padé), and it keeps a loop's crossover below about "
            f"z/2 = {sig(re_ / 2)} rad/s; check the sensor and its filter")


def _converged(model) -> list[SanityCheck]:  # MotorModel
    """A failed check when the model's own fit stopped before converging (none otherwise).

    Its headline and intervals are then those of where the solver stopped, not of an optimum;
    the usual cause is a pole and a zero that nearly cancel, a valley the solver crawls along.
    """
    stopped = next((w for w in model.warnings if w.startswith(STOPPED_EARLY)), None)
    if stopped is None:
        return []
    poles, zeros = np.asarray(model.poles()), np.asarray(model.zeros())
    pair = ""
    gaps, nearest = nearest_zeros(poles, zeros)
    if gaps.size and gaps.min() < 0.25:
        i = int(np.argmin(gaps))
        pair = (f"; its pole {sig(complex(poles[i]).real)} and zero {sig(complex(zeros[nearest[i]]).real)} nearly "
                "cancel, a pair the data hardly tell from none")
    why = _lower_first(stopped.split(": ", 1)[-1].rstrip("."))
    return [SanityCheck(
        "the fit converged", False,
        f"the fit of this structure stopped before converging ({why}): its "
        f"numbers are where the solver stopped, not an optimum{pair}; a structure with fewer poles or zeros "
        "(--order) may be what the data support")]


def _lower_first(text: str) -> str:
    return text[:1].lower() + text[1:]


def _resolved_roots(u: Uncertainty | None) -> list[SanityCheck]:
    """Every pole the data resolve (alone or as a pair); no right-half-plane zero they do not demand.

    A pole whose 95 % interval reaches the imaginary axis, or is wider than the pole itself, is not
    identified: the structure has a pole more than the record supports.  A right-half-plane zero
    (an inverse response) is not physical for a DC motor's velocity; it passes only when its whole
    interval lies in the right half-plane, i.e. the data demand it.
    """
    if u is None:
        return []
    paired = u.paired_poles()
    loose = []
    for i, item in enumerate(u.poles):
        re_ = float(np.real(item.value))
        if i in paired or item.ci95 is None:
            continue
        lo, hi = item.ci95
        if pole_unresolved(re_, lo, hi):
            loose.append(f"pole {i + 1} ({re_:.4g}, 95 % interval [{lo:.4g}, {hi:.4g}])")
    checks = [SanityCheck(
        "every pole resolved by the data", not loose,
        "each pole's 95 % interval is narrower than the pole and stays in the left half-plane"
        + (" (near-equal poles reported as a pair)" if paired else "") if not loose else
        f"the data do not resolve {', '.join(loose)}: its interval reaches the right half-plane or is wider "
        "than the pole — the structure has a pole more than the record supports (try --order with one pole "
        "fewer, or record longer / with less noise)")]
    for i, item in enumerate(u.zeros):
        re_ = float(np.real(item.value))
        if re_ <= 0:
            continue
        lo, hi = item.interval_or_nan()
        demanded = not zero_undemanded(re_, lo)
        checks.append(SanityCheck(
            "no unphysical right-half-plane zero", demanded,
            f"zero {i + 1} at {re_:+.4g} (95 % interval [{lo:.4g}, {hi:.4g}]) is in the right half-plane: an inverse "
            "response, which a DC motor's velocity does not have"
            + (f"; the data demand it (its whole interval is there): {_lag_reading(re_)}" if demanded else
               "; the data do not demand it (its interval reaches the left half-plane): a structure with fewer "
               "zeros describes the record as well (try --order, or --method oe with fewer zeros)")))
    return checks


def _t63(t: np.ndarray, y: np.ndarray, final: float) -> float:
    """63.2 % time of a response towards ``final`` (the classic read-off's crossing)."""
    return first_crossing(t, y, (1.0 - np.exp(-1.0)) * final)[0]


def _mean_square_about(u: np.ndarray, level: float) -> float:
    """``mean((u − level)²)`` in blocks: no temporary of the record's length (160 MB at 10 M samples)."""
    return sum_of_squares_about(u, level) / u.size


def sanity_checks(
    model,  # MotorModel
    time_s: np.ndarray,
    velocity: np.ndarray,
    step_volts: float,
    *,
    sample_interval_s: float,
    measured_t63_s: float | None = None,
    unwhitened: Mapping[str, float] | None = None,
    input_v: Mapping[str, np.ndarray] | None = None,
    velocity_window_s: float = 0.0,
    velocity_window_ends: np.ndarray | None = None,
) -> SanityReport:
    """Run the sanity gate on one model.

    Parameters
    ----------
    model : MotorModel
        The identified model (its ``velocity`` output; ``delay_s`` applied).
    time_s, velocity : ndarray
        The measured velocity step response at full rate, time 0 at the step.
    step_volts : float
        Step level.
    sample_interval_s : float
        Recorded sample interval (the 63 % time tolerance).
    measured_t63_s : float, optional
        The measured 63 % time (read off a smoothed record); computed from ``velocity``
        when omitted.
    unwhitened : Mapping, optional
        ``dc_gain``, ``time_constant`` (+ ``delay``) of the same structure fitted without
        the AR noise model, with ``dc_gain_std``/``time_constant_std`` of the whitened fit.
    input_v : Mapping[str, ndarray], optional
        Each capture's recorded input increment after its step (captures with an input
        channel only), keyed by file.
    velocity_window_s : float
        The window a counted velocity's samples are means over: the model's response is compared
        averaged the same way (:func:`~motorid.model.response.recorded_step_response`); 0 when sampled.
    velocity_window_ends : ndarray, optional
        Where each sample's window ends (a count kept over several lines: the line that logged it);
        default the samples' own times.

    Returns
    -------
    SanityReport
    """
    tol = TOLERANCES
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(velocity, dtype=float)
    keep = t >= 0
    t, v = t[keep], v[keep]
    checks: list[SanityCheck] = []
    poles = model.poles()
    unstable = poles[np.real(poles) >= 0]
    if unstable.size:
        where = ", ".join(f"{p.real:+.4g}" + (f"{p.imag:+.3g}j" if abs(p.imag) > 0 else "") for p in unstable)
        checks.append(SanityCheck("stable", False,
                                  f"UNSTABLE model: pole(s) at {where} — its step response grows without bound, "
                                  "which a motor that settles does not do; the method could not fit this record "
                                  "(too few samples per time constant, or the wrong state vector)"))
    else:
        checks.append(SanityCheck("stable", True, "every pole in the left half-plane"))
    final = float(np.mean(v[-max(2, v.size // 10):]))
    with np.errstate(over="ignore", invalid="ignore"):
        ends = None if velocity_window_ends is None else np.asarray(velocity_window_ends, dtype=float)[keep]
        yhat = np.asarray(recorded_step_response(model, t, step_volts, velocity_window_s=velocity_window_s,
                                                 velocity_window_ends=ends)["velocity"], dtype=float)
    finite = bool(np.all(np.isfinite(yhat)))
    err = float(np.sqrt(np.mean((v - yhat) ** 2)) / abs(final)) if finite and final else float("inf")
    base, bpar = first_order_baseline(t, v, step_volts)
    base_err = float(np.sqrt(np.mean((v - base) ** 2)) / abs(final)) if final else float("inf")
    limit = tol["baseline_ratio"] * base_err + tol["baseline_slack"]
    checks.append(SanityCheck(
        "better than a first-order baseline", err <= limit,
        f"fit NRMSE {100 * err:.3g}% against {100 * base_err:.3g}% of a plain first order plus dead time "
        f"(K {bpar['dc_gain']:.4g} {model.dc_gain_unit}, τ {bpar['time_constant']:.4g} s, θ {bpar['delay']:.3g} s) "
        "fitted to the same samples" + ("" if err <= limit else ": the model explains the record worse than three "
                          "parameters do — its structure or its data are wrong")))
    if err > tol["max_nrmse"]:
        checks.append(SanityCheck("fits the record", False,
                                  f"fit NRMSE {100 * err:.3g}%: the model does not reproduce the measured step "
                                  "response"))
    # the model's level over the same last 10 % of the record (its DC gain × step once the
    # record has settled; an unsettled record is compared where it ends, not at infinity)
    dc = model.dc_gain()
    gain_unit = model.dc_gain_unit
    tail = max(2, v.size // 10)
    end_model = float(np.mean(yhat[-tail:])) / step_volts if finite and step_volts else float("nan")
    dc_meas = final / step_volts if step_volts else float("nan")
    rel = abs(end_model - dc_meas) / abs(dc_meas) if dc_meas else float("inf")
    ok = bool(rel <= tol["dc_gain_rel"])
    checks.append(SanityCheck(
        "DC gain vs the final level", ok,
        f"DC gain {dc:.4g} {gain_unit}; the model's final level per {model.input_unit} of step {end_model:.4g} vs "
        f"{dc_meas:.4g} read off the record ({100 * rel:.2g}% apart"
        + (")" if ok else f", more than {100 * tol['dc_gain_rel']:g}%): the model's steady state is not the record's")))
    if finite and final:
        t63_meas = measured_t63_s if measured_t63_s is not None and np.isfinite(measured_t63_s) else _t63(t, v, final)
        model_final = dc * step_volts
        t63_model = _t63(t, yhat, model_final) if np.isfinite(model_final) and model_final else float("nan")
        slack = max(tol["t63_rel"] * t63_meas, tol["t63_samples"] * sample_interval_s)
        ok = bool(np.isfinite(t63_model) and abs(t63_model - t63_meas) <= slack)
        checks.append(SanityCheck(
            "63 % time vs the record", ok,
            f"63 % time of the model {t63_model:.4g} s vs {t63_meas:.4g} s read off the record"
            + ("" if ok else f" (apart by more than {slack:.3g} s): the model's speed of response is not the "
               "record's")))
    fo = model.first_order()
    u = model.uncertainty
    checks += _converged(model)
    checks += _resolved_roots(u)
    for key, label, value, unit in (("dc_gain", "DC gain", fo.dc_gain, gain_unit),
                                    ("time_constant", "τ", fo.time_constant_s, "s"),
                                    ("residence_time_s", "mean residence time", model.residence_time_s(), "s")):
        item = None if u is None else u.headline(key)
        if item is None:
            continue
        lo, hi = item.interval_or_nan()
        inside = bool(lo <= value <= hi)
        checks.append(SanityCheck(
            f"headline {label} inside its interval", inside,
            f"headline {label} {value:.5g} {unit} " + ("inside" if inside else "OUTSIDE") + f" its 95 % interval "
            f"[{lo:.5g}, {hi:.5g}] {unit}"))
    if unwhitened:
        for key, label, unit in (("dc_gain", "DC gain", gain_unit), ("time_constant", "τ + dead time", "s")):
            a = fo.dc_gain if key == "dc_gain" else fo.time_constant_s + model.delay_s
            b = float(unwhitened[key])
            sd = float(unwhitened.get(f"{key}_std", 0.0))
            apart = abs(a - b)
            ok = bool(apart <= max(tol["white_sigmas"] * sd, tol["white_rel"] * abs(a)))
            checks.append(SanityCheck(
                f"{label} with and without the noise model", ok,
                f"{label} {a:.4g} {unit} with the AR noise model, {b:.4g} {unit} without" + ("" if ok else
                 ": the noise model absorbed a misfit of the structure (try --order auto, or --delay when "
                 "the drive has a dead time)")))
    for source, u in (input_v or {}).items():
        u = np.asarray(u, dtype=float)
        if u.size < 5 or not step_volts:
            continue
        var = float(np.sqrt(_mean_square_about(u, step_volts)) / abs(step_volts))
        ok = bool(var <= tol["input_rms_rel"])
        checks.append(SanityCheck(
            "the input is a step", ok,
            f"the input recorded in {source} varies by {100 * var:.2g}% (RMS) of the {step_volts:.4g} "
            f"{model.input_unit} step "
            "after its edge"
            + ("" if ok else ": it is not a step (a closed-loop record, or a drive that sags), and every method here "
               "models the response to a step — this is the model of a step that did not happen; identify from an "
               "open-loop step, and score a model on this record with motorid validate")))
    return SanityReport(tuple(checks))
