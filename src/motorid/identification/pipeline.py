"""``motorid identify``: captures → conditioning → one of the paper's methods → a MotorModel.

This module only chains the stages (io → conditioning → identify → model) and picks among
methods; the signal processing lives in :mod:`motorid.conditioning`, the estimators in
:mod:`motorid.identification`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Protocol

import numpy as np

from motorid._threads import single_blas_thread
from motorid.blockwise import line_slope
from motorid.capture import ROLES, Capture
from motorid.conditioning.denoise import fft_denoise
from motorid.conditioning.derivative import derivative, savgol_derivative
from motorid.conditioning.pipeline import ConditionedExperiment, ConditioningSettings, condition_experiment
from motorid.conditioning.response import split_at
from motorid.errors import OptionError
from motorid.identification.classic import classic_first_order
from motorid.identification.markov import MarkovSettings, markov_identify
from motorid.identification.method_options import MethodOptions, OutputErrorOptions
from motorid.identification.pinv import PinvSettings, pinv_identify
from motorid.identification.result import STOPPED_EARLY, IdentificationError
from motorid.identification.sanity import SanityReport, sanity_checks
from motorid.identification.metrics import bic, step_fit
from motorid.model import MotorModel, step_nrmse
from motorid.model.response import recorded_step_response
from motorid.model.simplify import nearest_zeros
from motorid.numfmt import complex_text

__all__ = ["METHODS", "REFINERS", "Identification", "IdentifySettings", "Refiner", "identify_conditioned",
           "identify_experiment"]

#: Methods of ``--method``.  ``auto``: the paper's methods → output-error refinement →
#: order selection → uncertainty; ``paper-auto``: the best of the paper's methods alone.
METHODS: tuple[str, ...] = ("auto", "pinv", "markov", "classic", "oe", "srivc", "paper-auto")
#: The paper's own methods (Masoud 2019 §III–IV, lab report §1.1).
PAPER_METHODS: tuple[str, ...] = ("pinv", "markov", "classic")
#: Bases of the Markov method (``--markov-basis``): Laguerre (default) or the paper's Taylor.
MARKOV_BASES: tuple[str, ...] = ("laguerre", "taylor")


@dataclass(frozen=True, slots=True)
class IdentifySettings:
    """Everything that decides how a model is obtained (defaults: the paper's).

    Attributes
    ----------
    method : str
        One of :data:`METHODS`.
    order : str or int
        ``"auto"`` or 1–3: the number of states (= order of the velocity TF).  For
        ``pinv`` it chooses the state vector: 1 → [θ̇]; 2 → [θ, θ̇] (or [θ̇, Ia] without a
        position capture); 3 → [θ, θ̇, Ia] (the paper's extended state).
    conditioning : ConditioningSettings
        Sample reduction, record length, synchronisation.
    derivative : str
        Differentiation formula for pinv (paper: ``five_point``, eq. 17).
    structure : str
        pinv: ``free`` (all coefficients unknown) or ``known`` (θ̇ row known).
    markov_params : int or None
        Markov parameters ``Lm`` (paper: 11); ``None`` chooses among 5, 7, 11.
    markov_window_s : float or None
        Markov window ``Tε``; ``None`` chooses between ½ and 1 dominant time constant.
        Automatic choices are made by the fit of the resulting model to the whole record.
    delay : bool or None
        ``oe``/``auto``: ``True`` fits a pure delay (dead time of the drive, a late trigger)
        in every structure, ``False`` none; ``None`` (default) tries it when the data stay
        in their noise band for a few samples after the step and lets BIC decide.
    markov_basis : str
        ``laguerre`` (default): generalised Markov parameters on a Laguerre basis
        (:mod:`motorid.identification.laguerre`; ``markov_params`` sets the number of terms,
        ``markov_window_s`` the part of the record fitted); ``taylor``: the paper's
        procedure exactly (:mod:`motorid.identification.markov`).
    method_options : MethodOptions
        The estimators' own settings (Laguerre, SRIVC, output-error fit), for Python callers:
        :class:`~motorid.identification.method_options.MethodOptions`.
    """

    def __post_init__(self) -> None:
        # settings validate themselves, naming the Python parameter
        from motorid.conditioning.derivative import DERIVATIVE_METHODS
        from motorid.identification.pinv import PINV_STRUCTURES

        if self.markov_basis not in MARKOV_BASES:
            raise OptionError(f"--markov-basis must be one of {', '.join(MARKOV_BASES)}, not {self.markov_basis!r}")
        if self.method not in METHODS:
            raise OptionError(f"method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if isinstance(self.order, bool) or self.order not in ("auto", 1, 2, 3):
            raise OptionError(f"order must be 'auto', 1, 2 or 3, got {self.order!r}")
        if self.derivative not in DERIVATIVE_METHODS:
            raise OptionError(f"derivative must be one of {', '.join(DERIVATIVE_METHODS)}, got {self.derivative!r}")
        if self.structure not in PINV_STRUCTURES:
            raise OptionError(f"structure must be one of {', '.join(PINV_STRUCTURES)}, got {self.structure!r}")
        mp = self.markov_params
        if mp is not None and (isinstance(mp, bool) or not isinstance(mp, (int, np.integer)) or mp < 3):
            raise OptionError(f"markov_params must be None or a whole number >= 3, got {mp!r}")
        mw = self.markov_window_s
        if mw is not None and not (isinstance(mw, (int, float)) and np.isfinite(mw) and mw > 0):
            raise OptionError(f"markov_window_s must be None or a positive number of seconds, got {mw!r}")
        if self.delay is not None and not isinstance(self.delay, (bool, np.bool_)):
            raise OptionError(f"delay must be None, True or False, got {self.delay!r}")
        if not isinstance(self.conditioning, ConditioningSettings):
            raise OptionError(f"conditioning must be a ConditioningSettings, got {type(self.conditioning).__name__}")
        if not isinstance(self.method_options, MethodOptions):
            raise OptionError(f"method_options must be a MethodOptions, got {type(self.method_options).__name__}")
        lag = self.method_options.laguerre
        if lag is not None and mp is not None and lag.n_terms is not None and lag.n_terms != mp:
            raise OptionError(f"markov_params={mp} and method_options.laguerre.n_terms={lag.n_terms} disagree: "
                              "give one")
        if lag is not None and self.order != "auto" and lag.order != "auto" and int(lag.order) != int(self.order):
            raise OptionError(f"order={self.order} and method_options.laguerre.order={lag.order} disagree: give one")

    method: str = "auto"
    order: str | int = "auto"
    conditioning: ConditioningSettings = field(default_factory=ConditioningSettings)
    derivative: str = "five_point"
    structure: str = "free"
    markov_params: int | None = None
    markov_window_s: float | None = None
    delay: bool | None = None
    markov_basis: str = "laguerre"
    method_options: MethodOptions = field(default_factory=MethodOptions)


@dataclass(frozen=True, slots=True)
class Identification:
    """The chosen model and how it was chosen.

    Attributes
    ----------
    model : MotorModel
        The identified model, ``fit.velocity_nrmse`` filled in.
    conditioned : ConditionedExperiment
        The conditioned data it was identified from.
    candidates : dict[str, MotorModel]
        Every method tried (``auto``) with its model.
    failures : dict[str, str]
        Methods that could not run, with the reason.
    reason : str
        Why this model was chosen.
    sanity : SanityReport
        The sanity gate's checks of ``model`` (:mod:`motorid.identification.sanity`); its
        failures are also in ``model.warnings``.
    """

    model: MotorModel
    conditioned: ConditionedExperiment
    candidates: dict[str, MotorModel]
    failures: dict[str, str]
    reason: str
    sanity: SanityReport = field(default_factory=SanityReport)


def _velocity(cond: ConditionedExperiment, full: bool) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Velocity step response (full rate or reduced), derived from position if needed."""
    t = cond.full_time_s if full else cond.time_s
    outs = cond.full_outputs if full else cond.outputs
    if "velocity" in outs:
        return t, outs["velocity"], []
    dt = float(t[1] - t[0])
    # a 7-sample derivative of an 8-bit position is its quantisation steps: at full rate, smooth
    # over the reduced interval (position-only experiments failed the sanity gate)
    window = max(7, 2 * (cond.ratio // 2) + 1) if full else 7
    v = savgol_derivative(outs["position"], dt, window=window, polyorder=2)
    return t, v, ["no velocity capture: velocity is the derivative of the position (the position's unit per second)"]


def _settled_warning(t: np.ndarray, v: np.ndarray) -> list[str]:
    n = v.size
    tail = v[-max(3, n // 5):]
    final = float(np.mean(v[-max(2, n // 10):]))
    if final == 0:
        return []
    tt = t[-tail.size:]
    drift = line_slope(tt, tail) * (t[-1] - tt[0])
    # a drift is only real when it stands out of the ripple: the slope of ten block means
    # (ripple and noise average out in each) against its own standard error — a low-speed
    # step whose ripple never goes away is not told to record longer
    blocks = min(10, tail.size // 2)
    if blocks >= 4:
        cut = tail.size // blocks * blocks
        bt = tt[:cut].reshape(blocks, -1).mean(axis=1)
        bv = tail[:cut].reshape(blocks, -1).mean(axis=1)
        _, cov = np.polyfit(bt, bv, 1, cov=True)
        se = float(np.sqrt(max(cov[0, 0], 0.0))) * (t[-1] - tt[0])
        if abs(drift) <= 3.0 * se:
            return []
    if abs(drift) > 0.02 * abs(final):
        return [f"the velocity has not settled: it still changes by {100 * abs(drift / final):.1f}% over the last "
                "fifth of the record; record longer for a trustworthy gain"]
    return []


def _pinv(cond: ConditionedExperiment, s: IdentifySettings) -> MotorModel:
    have = set(cond.outputs)
    if "velocity" not in have:
        raise IdentificationError("pinv needs a velocity capture (--velocity)")
    if s.order == "auto":
        # every state vector the captures allow; keep the one whose step response fits the
        # measured velocity best (the extended state needs a current that starts from zero
        # on the reduced grid, which a fast armature rarely gives at 100 ms)
        best: MotorModel | None = None
        tried = []
        why: list[str] = []
        for order in (1, 2, 3):
            try:
                m = _with_fit(_pinv(cond, replace(s, order=order)), cond)
            except (IdentificationError, OptionError) as exc:
                why.append(f"order {order}: {exc.message}")
                continue
            tried.append(f"order {order} {100 * m.fit['velocity_nrmse']:.2f}%")
            if best is None or m.fit["velocity_nrmse"] < best.fit["velocity_nrmse"]:
                best = m
        if best is None:  # e.g. a velocity that falls back to zero (an end stop, the supply switched off)
            raise IdentificationError("pinv found no model of any order: " + "; ".join(why))
        return best.replace(extras={**dict(best.extras), "pinv_orders": "; ".join(tried)})
    return _pinv_states(cond, s)


def _pinv_states(cond: ConditionedExperiment, s: IdentifySettings) -> MotorModel:
    have = set(cond.outputs)
    order = int(s.order)
    if order == 1:
        states = ["velocity"]
    elif order == 2:
        states = ["position", "velocity"] if "position" in have else ["velocity", "current"]
    else:
        states = ["position", "velocity", "current"]
    missing = [r for r in states if r not in have]
    if missing:
        raise IdentificationError(
            f"pinv of order {order} needs the {', '.join(missing)} capture(s) (--{missing[0]})"
        )
    dt = cond.sample_interval_s
    x = np.vstack([cond.outputs[r] for r in states])
    needed = len(states) + 1 + 4
    if x.shape[1] < needed:
        raise IdentificationError(
            f"only {x.shape[1]} samples after reduction; pinv of order {len(states)} needs at "
            f"least {needed}: use a shorter --sample-interval or a longer --record-length"
        )
    x_dot = np.vstack([derivative(row, dt, s.derivative) for row in x])
    kind = {
        ("position", "velocity"): "reduced",
        ("position", "velocity", "current"): "extended",
        ("velocity",): "velocity",
        ("velocity", "current"): "velocity_current",
    }[tuple(states)]
    pset = PinvSettings(states=kind, structure=s.structure)
    # drop the samples the finite-difference stencil could not reach (NaN); pinv itself
    # then drops the paper's first and last two
    ok = np.all(np.isfinite(x_dot), axis=0)
    first, last = int(np.argmax(ok)), int(ok.size - np.argmax(ok[::-1]))
    sl = slice(max(0, first - 2), min(ok.size, last + 2))
    x_dot = np.where(np.isfinite(x_dot), x_dot, 0.0)
    res = pinv_identify(x[:, sl], x_dot[:, sl], cond.input_v[sl], pset)
    model = res.to_model(step_volts=cond.step_volts, sample_interval_s=dt)
    return model.replace(states=tuple(states), outputs=tuple(states))


#: Most samples the Laguerre least squares takes (an evenly sub-sampled record beyond).
LAGUERRE_SAMPLES = 5000
#: Most samples the sanity gate looks at (an evenly sub-sampled record beyond).
SANITY_SAMPLES = 20000
#: Methods whose Markov stage polishes each order's realisation by least squares:
#: ``markov`` (it is the answer) and ``paper-auto``; ``auto``/``oe``/``srivc`` refine by their own
#: output-error fit, so their Markov stage is the unpolished Laguerre–Hankel estimate (0.6 s less).
MARKOV_POLISHED_FOR = ("markov", "paper-auto")
#: Stages reported to a progress callback: conditioning, paper methods, refinement, sanity checks.
PROGRESS_STEPS = 4


def _dynamic_part(cond: ConditionedExperiment, max_samples: int, time_s: np.ndarray, *arrays: np.ndarray,
                  length_s: float | None = None) -> tuple[np.ndarray, ...]:
    """The part of a full-rate record the dynamics need, evenly thinned.

    As long as the output-error fit's (:func:`motorid.identification.stages.fit_record_length`), or
    ``length_s``, evenly thinned to at most ``max_samples`` samples; ``arrays`` share ``time_s``'s
    grid.
    """
    from motorid.identification.stages import fit_record_length

    length = fit_record_length(cond) if length_s is None else length_s
    keep = np.ones(time_s.size, dtype=bool) if length is None else time_s <= length * (1 + 1e-9)
    step = max(1, int(np.ceil(np.count_nonzero(keep) / max_samples)))
    return tuple(a[keep][::step] for a in (time_s, *arrays))


def _markov_laguerre(cond: ConditionedExperiment, s: IdentifySettings) -> MotorModel:
    """Generalised Markov parameters on a Laguerre basis.

    a, N and the dead time from the measured response time, by BIC; the order from the Hankel
    singular values above the coefficients' noise floor; the recorded input channel drives the
    regressors; each order's realisation is polished by output-error least squares on the same
    samples, with the current capture sharing the poles, and the order is the polished fits' BIC.
    """
    from motorid.identification.laguerre import LaguerreSettings, laguerre_identify
    from motorid.identification.stages import _sampled_phase

    t = cond.full_time_s
    output = "velocity" if "velocity" in cond.full_outputs else "position"
    # the current (poles shared) joins the polish of the realisation; a position beside a velocity does not: its
    # errors follow the motion (wrap span error, undithered 8-bit codes) and buy a spurious slow pole pair
    others = [ch for ch in ("current",) if ch in cond.full_outputs and ch != output]
    y = cond.full_outputs[output]
    u = cond.full_input_v
    # a 3000 s log took 40 s of SVDs of 300 000-row regressors
    t, y, u, *rest = _dynamic_part(cond, LAGUERRE_SAMPLES, t, y, u, *(cond.full_outputs[ch] for ch in others),
                                   length_s=s.markov_window_s)
    # each capture's samples before its step (its baseline was their mean), thinned as the record was: they pin
    # the channel's offset in the polish
    pre_step = {ch: r.output_v[r.time_s < 0][::max(1, round(float(t[1] - t[0]) / r.sample_interval_s))]
                for ch in (output, *others) if (r := cond.responses.get(ch)) is not None}
    given = s.method_options.laguerre or LaguerreSettings()
    # identify's own parameters set the terms and the order; the method whether the realisation is polished
    lset = replace(given, n_terms=s.markov_params if s.markov_params is not None else given.n_terms,
                   polish=given.polish and s.method in MARKOV_POLISHED_FOR,
                   order=given.order if s.order == "auto" else int(s.order))
    res = laguerre_identify(t, y, cond.step_volts, lset, input_v=u, output=output,
                            response_time_s=cond.response_time_s, dead_time_s=cond.dead_time_s,
                            extra_outputs=dict(zip(others, rest, strict=True)), pre_step=pre_step,
                            phase_s=_sampled_phase(cond.responses[output]))
    notes = [] if output == "velocity" else [
        "no velocity capture: the Laguerre expansion is of the position channel's derivative "
        "(the position's unit per second), fitted to the position itself"]
    model = res.to_model()
    model = model.replace(warnings=tuple(model.warnings) + tuple(notes), sample_interval_s=float(t[1] - t[0]),
                          # first_order() cancels only pairs slower than the record: the intervals' models the same
                          settings={**dict(model.settings), "record_length_s": float(cond.full_time_s[-1])})
    if res.polish is None:
        return model
    # a step instant read off the response (no input channel) holds any dead time already: the polish's
    # delay is that read-off's error, the channel's shift (as the output-error fit has it), not the motor's
    onset = cond.responses[res.polish.channels[0]].timing == "onset"
    shifted = onset and model.delay_s > 0
    if shifted:
        choice = str(model.extras.get("markov_choice", ""))
        model = model.replace(delay_s=0.0, extras={**dict(model.extras), "markov_choice": choice + (
            f"; the polish's dead time ({1e3 * model.delay_s:.3g} ms) is the error of the step instant read off the "
            f"response: the {res.polish.channels[0]}'s shift, not in τ or the residence time")})
    return model.replace(uncertainty=_polish_uncertainty(cond, model, res.polish, onset_shift=shifted))


def _polish_uncertainty(cond: ConditionedExperiment, model: MotorModel, polish: Any, *,
                        onset_shift: bool = False) -> Any:
    """The Markov polish's intervals, with the step level's and the step instant's errors the fit does not see.

    A read-off onset's error fitted as a delay is the primary channel's shift (``onset_shift``), and
    the intervals hold what the readings cannot tell apart (a read-off onset's lag, a counted speed's:
    :func:`~motorid.identification.stages.reading_allowances`), as the output-error fit's do.
    """
    from motorid.identification.laguerre_uncertainty import polish_uncertainty
    from motorid.identification.stages import (instant_std, output_level_rel_std, reading_allowances,
                                                step_instant, step_level_std)

    timing = {role: step_instant(r) for role, r in cond.responses.items() if role in polish.channels}
    u = polish_uncertainty(
        model, polish, step_rel_std=float(np.hypot(step_level_std(cond) / cond.step_volts, output_level_rel_std(cond))),
        instant_std=instant_std(cond.responses[polish.channels[0]]), timing=timing,
        kinds={role: r.timing for role, r in cond.responses.items() if role in polish.channels},
        shift_bound_s=float(model.sample_interval_s or np.inf), onset_shift=onset_shift)
    return reading_allowances(u, cond)


#: Most Markov parameters (or Laguerre terms) asked for: each needs several samples, and the
#: regressors and the Hankel matrix grow with their square (100 000 asked for 75 GiB).
MAX_MARKOV_PARAMS = 200


#: Samples after the step a Laguerre window (``--markov-window``) must hold.
MIN_WINDOW_SAMPLES = 20


def _markov(cond: ConditionedExperiment, s: IdentifySettings) -> MotorModel:
    if s.markov_params is not None:
        n = int(np.count_nonzero(cond.full_time_s >= 0))
        limit = max(3, min(n // 4, MAX_MARKOV_PARAMS))
        if s.markov_params > limit:
            raise OptionError(f"--markov-params {s.markov_params}: at most {limit} for this record ({n} samples after "
                              f"the step, at least 4 per parameter, and no more than {MAX_MARKOV_PARAMS})")
    if s.markov_basis == "laguerre":
        if s.markov_window_s is not None:
            after = cond.full_time_s[cond.full_time_s >= 0]
            dt = float(after[1] - after[0]) if after.size > 1 else float("nan")
            n = int(np.count_nonzero(after <= s.markov_window_s * (1 + 1e-9)))
            if n < MIN_WINDOW_SAMPLES:
                raise OptionError(f"--markov-window {s.markov_window_s:g} s holds {n} sample(s) after the step "
                                  f"(Δt {dt:.3g} s; at least {MIN_WINDOW_SAMPLES} are needed): give at least "
                                  f"{MIN_WINDOW_SAMPLES * dt:.3g} s")
        return _markov_laguerre(cond, s)
    t, v_meas, notes = _velocity(cond, full=True)
    dt = float(t[1] - t[0])
    # the k-th Markov parameter amplifies noise like k!: take the 8-bit quantisation noise and
    # ripple out first with the paper's own FFT denoiser (its band edge found from the data)
    v = fft_denoise(v_meas, dt).values
    tau = classic_first_order(t, v, cond.step_volts).time_constant_s
    if not np.isfinite(tau) or tau <= 0:
        tau = 0.2 * float(t[-1])
    # The paper leaves Lm and Tε to the student.  The truncated Taylor series behind the
    # Markov parameters only converges on windows short against the time constant, and
    # noise grows like k! in the k-th parameter: choose both by the fit of the resulting
    # model to the whole measured step response (unless the user fixed them).
    params = [s.markov_params] if s.markov_params is not None else [5, 7, 11]
    windows = [s.markov_window_s] if s.markov_window_s is not None else [f * tau for f in (0.5, 1.0)]
    best: tuple[float, MotorModel] | None = None
    errors: list[str] = []
    for n_params in params:
        for window in windows:
            window = float(np.clip(window, (n_params + 2) * dt, t[-1]))
            mset = MarkovSettings(
                n_params=n_params, window_s=window, order=s.order if s.order == "auto" else int(s.order),
            )
            try:
                res = markov_identify(t, v, cond.step_volts, mset)
            except (IdentificationError, OptionError) as exc:
                errors.append(exc.message)
                continue
            model = res.to_model()
            score = step_nrmse(model, t, v_meas, channel="velocity", step_volts=cond.step_volts)
            if best is None or score < best[0]:
                extras = {
                    **dict(model.extras),
                    "markov_choice": f"Lm = {n_params}, Tε = {window:.4g} s "
                    f"(velocity NRMSE {100 * score:.2f}%, best of {len(params) * len(windows)})",
                    "hankel_singular_values_scaled": [float(x) for x in res.sv_scaled],
                    "hankel_singular_values_raw": [float(x) for x in res.sv_raw],
                    "hankel_noise_floor": float(res.sv_noise_floor),
                }
                best = (score, model.replace(extras=extras))
    if best is None:
        raise IdentificationError("Markov method failed for every window: " + (errors[0] if errors else "no data"))
    model = best[1]
    return model.replace(warnings=tuple(model.warnings) + tuple(notes), sample_interval_s=dt)


def _classic(cond: ConditionedExperiment, s: IdentifySettings) -> MotorModel:
    if s.order not in ("auto", 1, "1"):
        raise OptionError(f"the classic method gives a first-order model only, not order {s.order}")
    t, v, notes = _velocity(cond, full=True)
    res = classic_first_order(t, v, cond.step_volts)
    model = res.to_model()
    return model.replace(warnings=tuple(model.warnings) + tuple(notes), sample_interval_s=float(t[1] - t[0]))


_RUNNERS: dict[str, Callable[[ConditionedExperiment, IdentifySettings], MotorModel]] = {
    "pinv": _pinv,
    "markov": _markov,
    "classic": _classic,
}


def _with_fit(model: MotorModel, cond: ConditionedExperiment) -> MotorModel:
    """The model with its fit on the full-rate record.

    NRMSE (docs/formats.md: RMS error over the measured steady-state change) of velocity and position,
    and MATLAB compare's fit % of every channel it predicts, all from one step response with the
    model's dead time applied.
    """
    t, v, _ = _velocity(cond, full=True)
    if "record_length_s" not in model.settings:
        # first_order() cancels only pole-zero pairs slower than the record (model/simplify.py)
        model = model.replace(settings={**dict(model.settings), "record_length_s": float(t[-1])})
    measured = {"velocity": v, **{k: y for k, y in cond.full_outputs.items() if k != "velocity"}}
    channels = ["velocity"] + (["position"] if "position" in cond.full_outputs and "position" in model.outputs else [])

    def simulate(block: slice) -> dict[str, np.ndarray]:
        with np.errstate(over="ignore", invalid="ignore"):
            return recorded_step_response(model, t[block], cond.step_volts, velocity_window_s=cond.velocity_window_s,
                                          velocity_window_ends=cond.velocity_window_ends(t[block]))

    # the residuals a block at a time (step_fit): a 10 M-sample record's fit holds no array of its length
    errors, fits = step_fit(measured, simulate, channels)
    fit = dict(model.fit)
    for channel, value in errors.items():
        fit[f"{channel}_nrmse"] = value
    for channel, value in fits.items():
        fit[f"{channel}_fit_percent"] = float(value)
    return model.replace(fit=fit)


def _paper_stage(
    cond: ConditionedExperiment, settings: IdentifySettings, names: list[str]
) -> tuple[dict[str, MotorModel], dict[str, str]]:
    candidates: dict[str, MotorModel] = {}
    failures: dict[str, str] = {}
    for name in names:
        try:
            m = _RUNNERS[name](cond, settings)
        except (IdentificationError, OptionError) as exc:
            # a Markov option the user gave and the data cannot take is refused, not dropped
            asked = name == "markov" and (settings.markov_params is not None or settings.markov_window_s is not None)
            if len(names) == 1 or (asked and isinstance(exc, OptionError)):
                raise
            failures[name] = exc.message
            continue
        candidates[name] = _with_fit(m, cond)
    if not candidates:
        raise IdentificationError(
            "no method could identify a model: " + "; ".join(f"{k}: {v}" for k, v in failures.items()))
    return candidates, failures


def _summary(name: str, m: MotorModel) -> dict[str, Any]:
    fo = m.first_order()
    return {"method": name, "order": m.order, "dc_gain": fo.dc_gain, "time_constant": fo.time_constant_s,
            "velocity_nrmse": m.fit.get("velocity_nrmse")}


def _unwhitened(cond: ConditionedExperiment, sel: Any, oe: OutputErrorOptions) -> dict[str, float] | None:
    """The chosen structure refitted without the AR noise model (for the sanity gate)."""
    from motorid.identification.stages import oe_stage

    try:
        # compared with the headline within their standard errors: the search's tolerance is plenty
        res, m = oe_stage(cond, sel.model, sel.structure, delay=sel.delay, noise=sel.noise, white=True,
                          tolerance=oe.search_tolerance, max_nfev=oe.max_nfev)
    except (IdentificationError, OptionError):
        return None
    fo = m.first_order()
    u = sel.result.std
    return {"dc_gain": fo.dc_gain, "time_constant": fo.time_constant_s + m.delay_s,
            "dc_gain_std": float(np.hypot(u.get("dc_gain", 0.0), res.std.get("dc_gain", 0.0))),
            "time_constant_std": float(np.hypot(
                np.hypot(u.get("time_constant", 0.0), u.get("delay", 0.0)),
                np.hypot(res.std.get("time_constant", 0.0), res.std.get("delay", 0.0))))}


def _refine(cond: ConditionedExperiment, settings: IdentifySettings, init: MotorModel, init_name: str,
            stages: list[dict[str, Any]]) -> tuple[MotorModel, str, dict[str, float] | None, bool]:
    """Output-error refinement with order selection (``oe`` and ``auto``), SRIVC as a second opinion."""
    from motorid.identification.srivc import SrivcSettings
    from motorid.identification.stages import select_order, srivc_stage

    orders = (1, 2, 3) if settings.order == "auto" else (int(settings.order),)
    oe = settings.method_options.oe
    sel = select_order(cond, init, orders, delay=settings.delay, options=oe)
    model = _with_fit(sel.model, cond)
    unwhitened = _unwhitened(cond, sel, oe)
    stages.append({"stage": "output-error", "initialised_from": init_name, "structures": sel.table,
                   "chosen": {"poles": sel.structure[0], "zeros": sel.structure[1], "delay": sel.delay},
                   "runner_up": (None if sel.runner_up is None
                                 else {"poles": sel.runner_up[0], "zeros": sel.runner_up[1]}),
                   "evidence": sel.evidence, **_summary("oe", model)})
    # cross-check with the time-scaled Hankel singular values of the Markov method
    markov = next((st for st in stages if st.get("method") == "markov"), None)
    if markov is not None:
        stages.append({"stage": "order cross-check", "markov_order": markov["order"],
                       "oe_order": sel.structure[0],
                       "agree": markov["order"] == sel.structure[0]})
    sr: MotorModel | None = None
    if settings.method == "auto":
        try:
            # a second opinion beside the chosen model, shown to four digits: stopped at the order
            # search's tolerance, not the srivc method's own (its linear convergence took 18–30
            # iterations on third-order records); settings the user gave are used as given
            given = settings.method_options.srivc or SrivcSettings(tol=oe.search_tolerance)
            sr = _with_fit(srivc_stage(cond, init, sel.structure, max_samples=500, settings=given), cond)
            stages.append({"stage": "srivc (second opinion)", **_summary("srivc", sr)})
        except (IdentificationError, OptionError) as exc:
            stages.append({"stage": "srivc (second opinion)", "failed": exc.message})
    reason = (f"output-error fit initialised from {init_name}; {sel.evidence}")
    worse = _worse_than_a_stage(model, stages, sel)
    edge = _at_the_edge(sel, model, sr)
    extra = tuple(w for w in (worse, *edge) if w)
    if extra:
        model = model.replace(warnings=(*model.warnings, *extra))
    return model, reason, unwhitened, bool(edge)


def _at_the_edge(sel: Any, model: MotorModel, srivc: MotorModel | None) -> list[str]:
    """One sentence per pair of the chosen fit's poles held at their double pole (damping 1).

    The output-error fit's poles are real: a pair the data would make complex is held at the
    double pole, the nearest it can reach, and its damping of 1 there is not a measurement (two
    close real poles land there too, so the sentence does not say which).  SRIVC's second
    opinion fits complex poles; what it found is quoted.
    """
    from motorid.identification.stages import pairs_at_the_edge

    pairs = pairs_at_the_edge(sel.result)
    if not pairs:
        return []
    opinion = ""
    if srivc is not None:
        pair = _complex_pair(srivc)
        opinion = ("; the srivc second opinion, whose poles may be complex, found real ones too" if pair is None else
                   f"; the srivc second opinion, whose poles may be complex, has {pair} and τ "
                   f"{srivc.first_order().time_constant_s:.4g} s against {model.first_order().time_constant_s:.4g} s "
                   "here")
    poles = sel.result.poles
    return [f"poles {i + 1} and {i + 2} ({complex_text(poles[i])}, {complex_text(poles[i + 1])}) sit at their double "
            "pole, the edge of the output-error fit: its poles are real (damping at least 1), so if the data want a "
            "complex pair (damping below 1) it cannot follow them, and the damping of 1 here is that edge, not a "
            "measurement" + opinion + "; compare with --method markov, whose output-error polish fits complex poles "
            "with intervals" for i in pairs]


def _no_dead_time_warning(cond: ConditionedExperiment, settings: IdentifySettings, model: MotorModel) -> list[str]:
    """A warning when the data show a dead time the chosen model cannot have.

    The paper's pinv, its Taylor-Markov method and the classic read-off model none: fitted from
    the step instant, their poles take up the dead time, and the residence time comes out short.
    The output-error fits and the Laguerre-Markov method try one and keep it when BIC says so
    (their choice text says what was tried): no warning for them.
    """
    from motorid.identification.stages import dead_time_shows

    never = model.method in ("pinv", "classic") or (model.method == "markov" and settings.markov_basis == "taylor")
    if not never or model.delay_s > 0 or not dead_time_shows(cond):
        return []
    return [f"the response stays in its noise band for {1e3 * cond.dead_time_s:.3g} ms after the step (a dead time), "
            f"and this {model.method} model has none: its poles take it up, so τ and the residence time may be "
            "short by up to that much — --method auto, oe or markov fit the dead time"]


def _worse_than_a_stage(model: MotorModel, stages: list[dict[str, Any]], sel: Any) -> str | None:
    """One sentence when the chosen model's velocity NRMSE is worse than one of its own stages'.

    The output-error fit minimises the residuals weighted by each channel's noise, whitened by
    its AR model when the noise is coloured, over every capture, with the pre-step samples; the
    NRMSE is the raw velocity residual alone.  A stage that fitted the velocity only, unweighted,
    can have the smaller NRMSE and still be the worse model of all the data — say which it is.
    """
    own = model.fit.get("velocity_nrmse")
    if own is None or not np.isfinite(own):
        return None
    better = [(st.get("method"), st["velocity_nrmse"]) for st in stages
              if isinstance(st.get("velocity_nrmse"), float) and np.isfinite(st["velocity_nrmse"])
              and st["velocity_nrmse"] < own * 0.98 and st.get("stage") != "output-error"]
    if not better:
        return None
    name, value = min(better, key=lambda x: x[1])
    why = []
    if sel.noise is not None and any(o > 0 for o in sel.noise.ar_order.values()):
        why.append("it whitens the coloured noise by an AR model (its criterion is the innovations, not the raw "
                   "residual the NRMSE measures)")
    if len(sel.result.residuals) > 1:
        why.append(f"it fits all {len(sel.result.residuals)} captures at once, weighted by their noise")
    why.append("it is chosen by BIC, which charges each parameter")
    return (f"the chosen model's velocity NRMSE {100 * own:.3g} % is above the {name} stage's "
            f"{100 * value:.3g} % because " + "; ".join(why) + ": the smaller raw residual of a stage is not a better "
            "model of the data")


@single_blas_thread
def identify_conditioned(
    cond: ConditionedExperiment, settings: IdentifySettings = IdentifySettings(),
    progress: Callable[..., None] | None = None, *, units: Mapping[str, str] | None = None,
) -> Identification:
    """Identify a model from conditioned data (see :func:`identify_experiment`).

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.
    settings : IdentifySettings
        Method and options (the conditioning part is already applied).
    progress : callable, optional
        ``progress(done, total, label)`` before each stage (the CLI draws a bar with it).
    units : Mapping, optional
        The data's units by channel (``input`` for the command): the chosen model carries them,
        and the sanity gate's messages speak them.

    Returns
    -------
    Identification
        The chosen model, the candidates and why.
    """
    if settings.method not in METHODS:
        raise OptionError(f"unknown method {settings.method!r}; use one of {', '.join(METHODS)}")
    if settings.order not in ("auto", 1, 2, 3):
        raise OptionError(f"--order must be auto, 1, 2 or 3, not {settings.order!r}")
    report = progress or (lambda *args: None)
    t, v, notes = _velocity(cond, full=True)
    extra_warn = list(cond.warnings) + notes + _settled_warning(t, v)
    report(1, PROGRESS_STEPS, "paper methods")
    start = _initialise(cond, settings)
    extra_warn += [f"the paper's {k} method did not run: {v}" for k, v in start.failures.items()]
    model, reason, unwhitened = start.model, start.reason, None
    refine = REFINERS.get(settings.method)
    if settings.method not in PAPER_METHODS:
        report(2, PROGRESS_STEPS, "output-error fits, order selection, SRIVC check")
    if refine is not None:
        step = refine(cond, settings, start)
        model, reason, unwhitened = step.model, step.reason, step.unwhitened
        start.candidates[step.name] = model
    report(3, PROGRESS_STEPS, "sanity checks")
    if units:
        model = model.replace(units=dict(units))
    model, sanity = _gated(cond, settings, model, reason, unwhitened, start.stages, extra_warn, t, v)
    report(PROGRESS_STEPS, PROGRESS_STEPS, "done")
    return Identification(model, cond, start.candidates, start.failures, reason, sanity)


@dataclass
class _Start:
    """The paper's methods run on the data: their models, the best one and why (the start of a refinement)."""

    candidates: dict[str, MotorModel]
    failures: dict[str, str]
    best: str
    model: MotorModel
    reason: str
    stages: list[dict[str, Any]]


@dataclass(frozen=True)
class _Refined:
    """What a refinement gives: its model, why, its name among the candidates, the unwhitened σ."""

    name: str
    model: MotorModel
    reason: str
    unwhitened: dict[str, float] | None = None


class Refiner(Protocol):
    """A refinement of the paper's best model: ``(conditioned, settings, start) -> refined``."""

    def __call__(self, cond: ConditionedExperiment, settings: IdentifySettings, start: _Start) -> _Refined:
        """Refine ``start.model`` on ``cond`` (appending its stages to ``start.stages``).

        Parameters
        ----------
        cond : ConditionedExperiment
            The conditioned captures.
        settings : IdentifySettings
            The options.
        start : _Start
            The paper's methods' results.

        Returns
        -------
        _Refined
            The refined model, why, its candidate name.
        """
        ...


def _initialise(cond: ConditionedExperiment, settings: IdentifySettings) -> _Start:
    """The paper's methods: the one asked for, or all three ranked by their velocity NRMSE."""
    stages: list[dict[str, Any]] = []
    if settings.method in PAPER_METHODS:
        candidates, failures = _paper_stage(cond, settings, [settings.method])
        best = settings.method
        return _Start(candidates, failures, best, candidates[best], f"method {best} as asked", stages)
    # the paper's methods first: the initial model (and the answer of paper-auto)
    init_settings = settings if settings.method == "paper-auto" else replace(settings, order="auto")
    candidates, failures = _paper_stage(cond, init_settings, list(PAPER_METHODS))
    # a stable model before an unstable one whatever their NRMSE: over a record a slowly growing pole
    # (pinv's velocity at +0.0006 1/s beside −1.8, a position fed back) fits as well, and the gate rejects it
    unstable = {k: bool(np.any(np.real(m.poles()) >= 0)) for k, m in candidates.items()}
    ranked = sorted(candidates, key=lambda k: (unstable[k], candidates[k].fit.get("velocity_nrmse", np.inf)))
    for k in ranked:
        stages.append({"stage": "paper method", **_summary(k, candidates[k])})
    scores = ", ".join(f"{k} {100 * candidates[k].fit['velocity_nrmse']:.2f}%" + (" unstable" if unstable[k] else "")
                       for k in ranked)
    best = ranked[0]
    reason = ("smallest velocity step-response NRMSE among the paper's methods"
              + (" whose models are stable" if any(unstable.values()) else "") + f" ({scores})")
    if failures:
        reason += "; not run: " + "; ".join(f"{k} ({v})" for k, v in failures.items())
    return _Start(candidates, failures, best, candidates[best], reason, stages)


def _srivc_refined(cond: ConditionedExperiment, settings: IdentifySettings, start: _Start) -> _Refined:
    """SRIVC from the paper's best model, each structure of the asked orders, BIC on the step response."""
    from motorid.identification.stages import STRUCTURES, srivc_stage

    orders = (1, 2, 3) if settings.order == "auto" else (int(settings.order),)
    tried: list[tuple[float, MotorModel, tuple[int, int]]] = []
    why: list[str] = []  # each structure's refusal, said when none was fitted
    n = cond.full_time_s.size
    for order in orders:
        for structure in STRUCTURES[order]:
            try:
                m = _with_fit(srivc_stage(cond, start.model, structure, settings=settings.method_options.srivc), cond)
            except (IdentificationError, OptionError) as exc:
                why.append(exc.message)
                continue
            if np.any(np.real(m.poles()) >= 0) or not np.isfinite(m.fit["velocity_nrmse"]):
                continue
            # BIC on the velocity step response (its normalisation cancels between structures)
            score = bic({"velocity": n}, {"velocity": m.fit["velocity_nrmse"] ** 2}, sum(structure) + 1)
            tried.append((score, m, structure))
    if not tried:
        reasons = "; ".join(dict.fromkeys(why))
        raise IdentificationError("SRIVC found no stable model at the requested order(s)" + (f": {reasons}" if reasons
                                                                                             else ""))
    tried.sort(key=lambda x: x[0])
    model = tried[0][1]
    start.stages.append({"stage": "srivc", **_summary("srivc", model)})
    st = tried[0][2]
    return _Refined("srivc", model, f"SRIVC initialised from {start.best}; {st[0]} pole(s), {st[1]} zero(s) by BIC "
                                    f"among {len(tried)} stable fits")


def _oe_refined(cond: ConditionedExperiment, settings: IdentifySettings, start: _Start) -> _Refined:
    """The output-error fit, its order selection and noise model, from the paper's best model.

    With ``auto``, a fit that holds a pair of poles at their double pole (the edge of its real
    poles) is set beside the Markov method's polished model, whose poles may be complex: when
    that one fits the velocity clearly better, it is the answer (:func:`_complex_pair_instead`).
    """
    model, reason, unwhitened, at_edge = _refine(cond, settings, start.model, start.best, start.stages)
    if settings.method == "auto" and at_edge:
        alt = _complex_pair_instead(cond, settings, model, start.stages)
        if alt is not None:
            start.candidates["oe"] = model
            polished, why = alt
            return _Refined("markov", polished, f"{reason}; {why}", None)
    return _Refined("oe", model, reason, unwhitened)


#: The Markov method's polished model replaces an output-error fit held at the edge of its real
#: poles when its velocity NRMSE is below this fraction of the fit's.
COMPLEX_PAIR_NRMSE_RATIO = 0.8


def _complex_pair_instead(cond: ConditionedExperiment, settings: IdentifySettings, model: MotorModel,
                          stages: list[dict[str, Any]]) -> tuple[MotorModel, str] | None:
    """The Markov method's polished model and why, when it should replace an output-error fit at its edge.

    Called for a fit that holds a pair of poles at their double pole
    (:func:`~motorid.identification.stages.pairs_at_the_edge`).  The output-error fit's poles are
    real, so there its structure may be wrong, and its own criterion cannot say so: it has no
    complex pair to try.  The Markov method polishes its realisation by output error on
    polynomial coefficients, whose poles may be complex (with the options given, the order among
    them).  Its model replaces the fit when it has a complex pair and its velocity NRMSE is below
    :data:`COMPLEX_PAIR_NRMSE_RATIO` of the fit's: the same samples, the same measure.  Two real
    poles that merely sit close, on a record that cannot tell them from a pair, fit no better as a
    pair and do not pass that margin.  On a trainer motor with a complex pair (damping 0.81) the
    fit's NRMSE was 3.8 % against 0.9 %, and its τ 17 % off.
    """
    try:
        polished = _with_fit(_markov_laguerre(cond, replace(settings, method="markov")), cond)
    except (IdentificationError, OptionError):
        return None
    own, alt = model.fit.get("velocity_nrmse"), polished.fit.get("velocity_nrmse")
    pair = _complex_pair(polished, uncancelled=True)
    stages.append({"stage": "markov, polished (complex poles allowed)", **_summary("markov", polished)})
    if pair is None or own is None or alt is None or not (np.isfinite(alt) and alt < COMPLEX_PAIR_NRMSE_RATIO * own):
        return None
    why = (f"the output-error fit held a pair of poles at their double pole, the edge of its real poles, and the "
           f"Markov method's polished model, whose poles may be complex, fits the velocity with NRMSE "
           f"{100 * alt:.3g} % against its {100 * own:.3g} % with {pair}: that model is the answer")
    return polished.replace(warnings=(*polished.warnings, f"auto: {why}")), why


#: A complex pole and a zero closer than this fraction of the pole's magnitude cancel: the pair is
#: a resonance its own anti-resonance undoes, not the motor's dynamics.
PAIR_CANCEL_REL = 0.2


def _complex_pair(model: MotorModel, *, uncancelled: bool = False) -> str | None:
    """A model's first complex pair as text, ``-2.233 ± 1.598j (damping 0.81)``; None when its poles are real.

    ``uncancelled``: only a pair no zero of the model nearly cancels (:data:`PAIR_CANCEL_REL`).  On
    a Raspberry Pi log of rpm (the clock-stamps rig preset, seed 0) the Markov method's polish put a
    pair at −14.75 ± 86.92j beside zeros at −9.217 ± 89.05j, a lightly damped resonance and its
    anti-resonance in a first-order gearmotor: it fitted the counted rpm's ripple, not the motor.
    """
    poles = np.asarray(model.poles())
    gaps, _ = nearest_zeros(poles, np.asarray(model.zeros()))
    for p, gap in zip(poles, gaps, strict=True):
        if np.imag(p) > 0 and not (uncancelled and gap < PAIR_CANCEL_REL):
            return f"{complex_text(p, pair=True)} (damping {-np.real(p) / abs(p):.3g})"
    return None


#: The refinement of each method that is not one of the paper's own (``paper-auto`` has none).
REFINERS: dict[str, Refiner] = {"srivc": _srivc_refined, "oe": _oe_refined, "auto": _oe_refined}


def _gated(cond: ConditionedExperiment, settings: IdentifySettings, model: MotorModel, reason: str,
           unwhitened: dict[str, float] | None, stages: list[dict[str, Any]], extra_warn: list[str],
           t: np.ndarray, v: np.ndarray) -> tuple[MotorModel, Any]:
    """The chosen model with its settings, the sanity gate's verdict and every warning."""
    settings_doc = dict(model.settings)
    settings_doc.update(
        conditioning=asdict(settings.conditioning), derivative=settings.derivative,
        reduction_ratio=cond.ratio, sources=dict(cond.sources), record_length_s=float(t[-1]),
        sample_interval_chosen_s=cond.sample_interval_s,
    )
    model = model.replace(settings=settings_doc, step_volts=cond.step_volts)
    recorded = {r.source: split_at(r.time_s, r.input_v)[1] for r in cond.responses.values() if r.edge.method != "onset"}
    # its first-order baseline is a nonlinear fit: 9 s on a 10-million-sample log
    t_gate, v_gate = _dynamic_part(cond, SANITY_SAMPLES, t, v)
    sanity = sanity_checks(model, t_gate, v_gate, cond.step_volts,
                           sample_interval_s=float(t[1] - t[0]), unwhitened=unwhitened, input_v=recorded,
                           velocity_window_s=cond.velocity_window_s,
                           velocity_window_ends=cond.velocity_window_ends(t_gate))
    gate = tuple(f"SANITY CHECK FAILED — {f}" for f in sanity.failures)
    # a fit that stopped early is a failed check of the gate, whose line says it with what it means
    model = model.replace(warnings=tuple(w for w in model.warnings if not w.startswith(STOPPED_EARLY)))
    extra_warn = extra_warn + _no_dead_time_warning(cond, settings, model)
    if np.isfinite(model.dc_gain()) and model.dc_gain() < 0:
        # legitimate (a tacho wired the other way round), but a student should know it
        extra_warn.append(f"negative DC gain ({model.dc_gain():.4g}): the measured channel moves against the "
                          "input — a sensor wired with the other polarity, or a negative step; the model keeps "
                          "the sign, so a controller designed on it has the matching sign")
    model = model.replace(
        warnings=tuple(dict.fromkeys(gate + tuple(model.warnings) + tuple(extra_warn))),
        extras={**dict(model.extras), "choice": reason, "conditioning": list(cond.notes),
                "sanity": sanity.to_json(), "response_time_s": cond.response_time_s,
                "apparent_dead_time_s": cond.dead_time_s},
        stages=tuple(stages),
    )
    return model, sanity


@single_blas_thread
def identify_experiment(
    captures: Mapping[str, Capture],
    settings: IdentifySettings = IdentifySettings(),
    *,
    step_volts: float | None = None,
    t0_s: float | None = None,
    progress: Callable[..., None] | None = None,
    units: Mapping[str, str] | None = None,
) -> Identification:
    """Identify a motor model from the captures of one step experiment.

    Parameters
    ----------
    captures : Mapping[str, Capture]
        Captures keyed by role; ``velocity`` or ``position`` is required.
    settings : IdentifySettings
        Method, order, conditioning.
    step_volts, t0_s : float, optional
        For captures without an input channel.
    progress : callable, optional
        ``progress(done, total, label)`` before each stage (conditioning, paper methods,
        refinement, sanity checks); the CLI's progress bar.
    units : Mapping, optional
        Declared units by channel (``--units``), over what the captures' columns say.

    Returns
    -------
    Identification
        The model with its fit, and the alternatives considered.

    Raises
    ------
    OptionError, IdentificationError, ConditioningError
        Bad options, unusable data; messages name the file and what would fix it.
    """
    if "velocity" not in captures and "position" not in captures:
        raise OptionError("give at least --velocity or --position")
    if progress is not None:
        progress(0, PROGRESS_STEPS, "conditioning")
    cond = condition_experiment(captures, settings.conditioning, step_volts=step_volts, t0_s=t0_s)
    from motorid.model.units import units_of, with_velocity_of_position

    # the data's units (a plain-CSV log in rpm: the gain reads rpm/V), the declared ones over them
    data_units = with_velocity_of_position({**units_of(captures), **(units or {})}, captures)
    unnamed = _units_not_given(captures, units or {})
    if unnamed:
        cond = replace(cond, notes=(*cond.notes, unnamed))
    return identify_conditioned(cond, settings, progress, units=data_units)


def _units_not_given(captures: Mapping[str, Capture], declared: Mapping[str, str]) -> str | None:
    """A note naming the measured columns whose unit neither their file nor ``--units`` gives.

    A scope's CSV says its volts; a log's column named ``speed`` says nothing, and its values are
    then labelled with the default, volts: the note says so, and how to give the unit.
    """
    roles = [role for role, cap in captures.items()
             if role in ROLES and role not in declared and not cap.output_info.units]
    if not roles:
        return None
    cols = ", ".join(f"{captures[r].output_info.name!r} ({r})" for r in roles)
    example = " ".join(f"--units {r}=…" for r in roles)
    return (f"no unit given for {cols} (neither the column's name nor --units): labelled V, the default; "
            f"if the values are not volts, give their unit ({example}, e.g. rad/s, rpm, deg, counts)")


def with_conditioning(settings: IdentifySettings, **changes: Any) -> IdentifySettings:
    """A copy of ``settings`` with conditioning fields changed (used by the sweep)."""
    return replace(settings, conditioning=replace(settings.conditioning, **changes))
