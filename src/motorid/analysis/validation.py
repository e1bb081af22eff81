"""Validation of a model on any recorded input (paper section VI-B, Figs. 36–38).

The model is driven by the input actually recorded on CH1 (sine, triangle, square, a step…)
— or, for a capture without an input channel, by a step of ``step_volts`` at ``t0_s`` (the
onset found from the response when not given) — and its output compared with CH2 over the
whole record.  Nothing is skipped silently: the record rarely starts at rest and the sensor
rarely reads 0 V at rest, so the initial state ``x0`` and an output offset ``c`` are
estimated with the score, by linear least squares (the output is linear in both):

    y(t) ≈ ŷ_forced(t) + C·e^{At}·x0 + c

and reported.  A position channel is unwrapped (:func:`motorid.conditioning.unwrap.unwrap_position`);
a step capture is scored as ``identify`` scores it: on the increments from the pre-step
baseline, NRMSE over the steady-state change (:mod:`motorid.identification.metrics`).  The model's fitted
dead time (``delay_s``) delays the input.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from motorid._threads import single_blas_thread
from motorid.capture import Capture
from motorid.conditioning.edge import step_edge
from motorid.conditioning.response import count_window_ends, is_log, refresh_time, step_response
from motorid.conditioning.unwrap import unwrap_position
from motorid.errors import CaptureDataError, OptionError, StepNotFoundError
from motorid.identification.metrics import fit_percent, nrmse
from motorid.identification.sanity import TOLERANCES
from motorid.model import CHANNELS, MotorModel
from motorid.model.forced import linear_hold_response, zero_hold_delayed
from motorid.model.units import channel_unit

__all__ = ["ValidationResult", "check_channel", "check_options", "model_delay_s", "validate_capture"]

#: Fewest scored samples a validation needs.
MIN_SCORED = 10


@dataclass(frozen=True, slots=True)
class ValidationResult:
    """A model's prediction of one capture.

    Attributes
    ----------
    source : str
        The capture.
    channel : str
        The model output compared (``velocity``, ``position`` or ``current``).
    time_s, input_v, measured_v, simulated_v : ndarray
        The scored part of the record: time on the file's own axis [s], the input that drove
        the model [V] (before the model's delay), the measured channel [V] (unwrapped; for a
        step, the increment from the pre-step baseline) and the model's output [V] with the
        estimated initial state and offset.
    nrmse : float
        RMS(measured − simulated) / measured change of the response (:func:`motorid.identification.metrics.nrmse`
        with ``nrmse_reference``).
    fit_percent : float
        MATLAB ``compare``'s ``100·(1 − ‖y − ŷ‖/‖y − ȳ‖)``.
    warmup_s : float
        Simulated but not scored, from the start of the record (0 unless asked for).
    nrmse_reference : str
        ``"final"`` (a step: steady-state change) or ``"span"`` (other inputs: P99 − P1).
    input_kind : str
        ``"step"`` (a step on CH1), ``"built step"`` (no input channel: ``step_volts`` at
        ``step_time_s``) or ``"recorded"`` (any other CH1 signal).
    step_time_s : float or None
        The step instant on the file's time axis (steps only).
    state_names : tuple of str
        Names of the entries of ``initial_state``.
    initial_state : tuple of float
        Least-squares initial state at the first sample (NaN for states the channel cannot
        see, and everywhere when not estimated).
    offset_v : float
        Least-squares output offset [V] (0 when not estimated or not separable from the
        initial state).
    delay_s : float
        Dead time applied to the input [s] (the model's fitted ``delay_s``, 0 without one).
    wraps : int
        Encoder wraps removed from a position channel.
    notes : tuple of str
        What was estimated or assumed, in words.
    warnings : tuple of str
        What the user should check.
    """

    source: str
    channel: str
    time_s: np.ndarray
    input_v: np.ndarray
    measured_v: np.ndarray
    simulated_v: np.ndarray
    nrmse: float
    fit_percent: float
    warmup_s: float
    nrmse_reference: str = "span"
    input_kind: str = "recorded"
    step_time_s: float | None = None
    state_names: tuple[str, ...] = ()
    initial_state: tuple[float, ...] = ()
    offset_v: float = 0.0
    delay_s: float = 0.0
    wraps: int = 0
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()

    def to_dataframe(self) -> Any:
        """The scored time series as a pandas DataFrame (pandas is optional).

        Returns
        -------
        pandas.DataFrame
            Indexed by time on the file's axis (s): ``input`` (V), ``measured`` and ``simulated``
            (the channel's recorded volts), units in ``attrs["units"]``.
        """
        from motorid.frames import to_dataframe

        return to_dataframe({"time": self.time_s, "input": self.input_v, "measured": self.measured_v,
                             "simulated": self.simulated_v}, {"input": "V", "measured": "V", "simulated": "V"})

    def to_dict(self) -> dict[str, Any]:
        """The scalar results as a JSON-able dict (non-finite numbers as ``None``).

        Returns
        -------
        dict
            JSON-able scalars and notes.
        """

        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {
            "file": self.source,
            "channel": self.channel,
            "nrmse": num(self.nrmse),
            "fit_percent": num(self.fit_percent),
            "warmup_s": self.warmup_s,
            "nrmse_reference": self.nrmse_reference,
            "input": self.input_kind,
            "step_time_s": self.step_time_s,
            "initial_state": {k: num(v) for k, v in zip(self.state_names, self.initial_state, strict=False)},
            "offset_v": num(self.offset_v),
            "delay_s": self.delay_s,
            "wraps": self.wraps,
            "notes": list(self.notes),
            "warnings": list(self.warnings),
        }


def model_delay_s(model: MotorModel) -> float:
    """The dead time a model was fitted with (its ``delay_s``), 0 without one.

    A model JSON written before the model carried its own ``delay_s`` has it only in
    ``extras["delay_s"]`` (the output-error fit's): read there when the model has none.

    Parameters
    ----------
    model : MotorModel
        An identified model.

    Returns
    -------
    float
        The dead time in s (0.0 without one).
    """
    if model.delay_s > 0:
        return float(model.delay_s)
    d = model.extras.get("delay_s")
    try:
        d = float(d) if d is not None else 0.0
    except (TypeError, ValueError):
        return 0.0
    return d if math.isfinite(d) and d > 0 else 0.0


def _channel_system(model: MotorModel, channel: str) -> tuple[tuple[np.ndarray, ...], tuple[str, ...]]:
    """``(A, B, C, D)`` from the input to the channel, in the model's own state coordinates."""
    if channel in model.outputs:
        i = model.outputs.index(channel)
        return (model.A, model.B, model.C[i:i + 1], model.D[i:i + 1]), model.states
    # position of a model without a position row: the integral of the velocity channel
    n = model.order
    iv = model.outputs.index("velocity")
    a = np.zeros((n + 1, n + 1))
    a[:n, :n] = model.A
    a[n, :n] = model.C[iv]
    b = np.vstack([model.B, model.D[iv:iv + 1]])
    c = np.zeros((1, n + 1))
    c[0, n] = 1.0
    return (a, b, c, np.zeros((1, 1))), (*model.states, "position (integral)")


#: An input that varies by more than this (RMS, relative to its edge) after its edge is not a step:
#: the identification's sanity gate's figure (8-bit codes and probe noise stay well under 1 %, a
#: closed loop's control signal varies by 2–10 %).
INPUT_RMS_REL = TOLERANCES["input_rms_rel"]


def _is_step(capture: Capture) -> bool:
    if capture.input_v is None:
        return False
    try:
        step_edge(capture.time_s, capture.input_v, file=capture.source)
    except StepNotFoundError:
        return False
    return True


def check_options(channel: str, warmup_s: float) -> None:
    """Check the validation's options that need neither the model nor a capture.

    :func:`motorid.validate` calls it before it reads any file.

    Parameters
    ----------
    channel : str
        The model output the capture measured.
    warmup_s : float
        Seconds simulated but not scored.

    Raises
    ------
    OptionError
        An unknown channel, or a negative or non-finite warm-up.
    """
    if channel not in CHANNELS:
        raise OptionError(f"--channel {channel!r} is not a model output: use one of {', '.join(CHANNELS)}")
    if not (math.isfinite(warmup_s) and warmup_s >= 0):
        raise OptionError(f"--warmup must be a non-negative number of seconds, got {warmup_s!r}")


def check_channel(model: MotorModel, channel: str) -> None:
    """Check that ``model`` predicts ``channel`` (a position always: it integrates the velocity).

    Parameters
    ----------
    model : MotorModel
        The model to validate.
    channel : str
        The model output the capture measured.

    Raises
    ------
    OptionError
        The model has no such output.
    """
    if channel not in model.outputs and channel != "position":
        raise OptionError(f"the model has no {channel!r} output (it has {', '.join(model.outputs)}): "
                          "choose another --channel")


def _checked_delay(model: MotorModel, channel: str, warmup_s: float, delay_s: float | None) -> float:
    """The dead time the model is driven with, after checking the channel and the warm-up."""
    check_options(channel, warmup_s)
    check_channel(model, channel)
    try:
        delay = model_delay_s(model) if delay_s is None else float(delay_s)
    except (TypeError, ValueError):
        raise OptionError(f"delay must be a number of seconds, got {delay_s!r}") from None
    if not (math.isfinite(delay) and delay >= 0):
        raise OptionError(f"delay must be a non-negative number of seconds, got {delay_s!r}")
    return delay


@dataclass(frozen=True, slots=True)
class _Drive:
    """What the model is driven with and scored against, and how that was read off the capture."""

    u: np.ndarray
    y: np.ndarray
    wraps: int
    reference: Literal["final", "span"]
    kind: str
    step_time: float | None
    #: The input holds each value from its stamp (a logged command), not linear between samples.
    held: bool = False


def _step_drive(capture: Capture, channel: str, step_volts: float | None, t0_s: float | None,
                encoder_span_v: float | None, notes: list[str], warnings: list[str]) -> _Drive:
    """A step response: the increments from the pre-step baseline, the input as recorded or built."""
    if capture.input_v is None and step_volts is None:
        raise StepNotFoundError(
            "no input channel (CH1) to drive the model with: give the step level with --step-volts",
            file=capture.source,
        )
    if capture.input_v is not None and step_volts is not None:
        warnings.append("--step-volts ignored: the capture's CH1 gives the input")
    sr = step_response(capture, channel, step_volts=step_volts, t0_s=t0_s, encoder_span_v=encoder_span_v)
    warnings.extend(sr.warnings)
    u, y = np.asarray(sr.input_v, float), np.asarray(sr.output_v, float)
    step_time = float(sr.edge.time_s)
    kind = "built step" if capture.input_v is None else "step"
    how = {"given": "given (--t0)", "onset": "the response's onset", "change-point": "CH1's edge"}
    after = u[sr.time_s >= 0]
    varies = float(np.sqrt(np.mean((after - sr.step_volts) ** 2)) / abs(sr.step_volts)) if after.size else 0.0
    if capture.input_v is not None and varies > INPUT_RMS_REL:
        # a closed loop's control signal has an edge too: the model is driven by it as recorded
        kind = "recorded (not a step)"
        warnings.append(f"the input recorded in {capture.source} varies by {100 * varies:.2g} % (RMS) of its "
                        f"{sr.step_volts:.4g} V edge after it: not a step (a closed-loop record); the model is "
                        "driven by the input as recorded, and the NRMSE is over the change from the "
                        "pre-edge baseline")
    notes.append(f"step input: {kind} of {sr.step_volts:.4g} V at {step_time + 0.0:.6g} s "
                 f"(from {how.get(sr.edge.method, sr.edge.method)}); the model is driven by the input "
                 f"{'as recorded' if capture.input_v is not None else 'built from --step-volts'}; scored on the "
                 "increments from the pre-step baseline")
    # a current returns towards 0 after the step: its change is its span, not its end
    return _Drive(u, y, sr.wraps, "span" if channel == "current" else "final", kind, step_time,
                  held=sr.timing == "logged" and capture.input_v is not None)


def _recorded_drive(capture: Capture, channel: str, step_volts: float | None, t0_s: float | None,
                    encoder_span_v: float | None, notes: list[str], warnings: list[str]) -> _Drive:
    """Any other input (sine, triangle, square, a log): CH1 as recorded, the output as recorded."""
    if step_volts is not None:
        warnings.append("--step-volts ignored: the capture's CH1 gives the input")
    if t0_s is not None:
        warnings.append("--t0 ignored: the input on CH1 is not a step")
    warnings.extend(capture.warnings)
    u = np.asarray(capture.input_v, float)
    y = np.asarray(capture.output_v, float)
    wraps = 0
    if channel == "position":
        un = unwrap_position(y, span_v=encoder_span_v, file=capture.source)
        y, wraps = un.position_v, un.wraps
        warnings.extend(un.warnings)
    notes.append("input: CH1 as recorded")
    return _Drive(u, y, wraps, "span", "recorded", None,
                  held=is_log(capture))


def _responses(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, h: float, u: np.ndarray,
               delay: float, n_free: int, *, held: bool, window: bool,
               ends: tuple[np.ndarray, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The model's forced response to ``u`` on a grid ``h`` apart and its free responses to unit states.

    ``held``: each input sample holds from its stamp to the next (a logged command: the step at
    the stamp that logged it, as the identification places it), the dead time ``delay`` exact
    (:func:`~motorid.model.forced.zero_hold_delayed`); else the input is linear between samples
    (a sampled voltage: a sampled step's edge in the interval before its first sample), ``u``
    delayed already and ``delay`` unused.

    ``window``: the output's means over each interval ``(t_{k−1}, t_k]`` (a speed counted over
    each interval), from the realisation with an integrator of the output appended,
    ``İ = C x + D u``: ``(I[k] − I[k−1])/h``; the free responses likewise (the integrator's own
    start cancels).  The first sample, which has no interval before it, is the model's sample.
    ``ends = (index, lines)``: a count over ``lines`` intervals kept until the next, each sample's
    mean over the window that ends at the line ``index`` that logged it,
    ``(I[index] − I[index − lines])/(lines·h)`` (the model's sample where that window starts
    before the record).
    """
    n = a.shape[0]
    rows = [(a, b, c, d)]
    if window:
        aa = np.zeros((n + 1, n + 1))
        aa[:n, :n], aa[n, :n] = a, np.ravel(c)
        cc = np.zeros((1, n + 1))
        cc[0, n] = 1.0
        rows.append((aa, np.vstack([np.reshape(b, (n, 1)), np.reshape(d, (1, 1))]), cc, np.zeros((1, 1))))
    out = []
    for a_, b_, c_, d_ in rows:
        m = a_.shape[0]
        initial = np.eye(m)[:, :n_free] if n_free else None
        if held:
            forced = zero_hold_delayed(a_, b_, np.reshape(c_, (1, m)), np.ravel(d_), h, u, delay)[:, 0]
            _, free = linear_hold_response(a_, b_, c_, d_, h, np.zeros(u.size), initial)
        else:
            forced, free = linear_hold_response(a_, b_, c_, d_, h, u, initial)
        out.append((forced, free))
    if not window:
        return out[0]
    (sampled, free_sampled), (integral, free_integral) = out
    if ends is not None:
        index, lines = ends
        full = index >= lines  # the lines before the first one that logged a count have no window here
        index = np.maximum(index, 0)
        lo = np.where(full, index - lines, 0)

        def held_means(x: np.ndarray, at: np.ndarray) -> np.ndarray:
            mask = full if x.ndim == 1 else full[:, None]
            return np.where(mask, (x[index] - x[lo]) / (lines * h), at[index])

        return (held_means(integral, sampled),
                held_means(free_integral, free_sampled) if n_free else free_sampled)
    means = np.r_[sampled[:1], np.diff(integral) / h]
    return means, (np.vstack([free_sampled[:1], np.diff(free_integral, axis=0) / h]) if n_free else free_sampled)


@single_blas_thread
def validate_capture(
    model: MotorModel,
    capture: Capture,
    *,
    channel: str = "velocity",
    step_volts: float | None = None,
    t0_s: float | None = None,
    warmup_s: float = 0.0,
    delay_s: float | None = None,
    estimate_initial_state: bool = True,
    estimate_offset: bool = True,
    encoder_span_v: float | None = None,
) -> ValidationResult:
    """Drive ``model`` with the capture's input and score its output against the record.

    Parameters
    ----------
    model : MotorModel
        Any identified model.
    capture : Capture
        A capture; without an input channel it must be a step response and ``step_volts``
        is needed.
    channel : str
        The model output that CH2 measured (``velocity``, ``position`` or ``current``).
    step_volts : float, optional
        Step level for a capture without an input channel [V] (ignored, with a warning,
        when CH1 is present).
    t0_s : float, optional
        Step instant on the file's time axis [s]; found from CH1's edge, or from the
        response's onset without CH1, when omitted.
    warmup_s : float
        Simulate but do not score the first ``warmup_s`` seconds of the record (default 0:
        the initial state is estimated instead).
    delay_s : float, optional
        Dead time of the input [s]; the model's fitted ``delay_s`` when omitted.
    estimate_initial_state, estimate_offset : bool
        Fit the initial state / a constant output offset by least squares (default on).
    encoder_span_v : float, optional
        Volts per turn of a position sensor (estimated from the wraps when omitted).

    Returns
    -------
    ValidationResult
        The scores and everything estimated on the way.

    Raises
    ------
    OptionError
        An unknown channel, a model without that output, a bad warm-up or delay.
    StepNotFoundError
        A capture without input channel and no ``step_volts``, or without a step response.
    CaptureDataError
        A record too short to score.

    References
    ----------
    Masoud 2019, section VI-B (validation on sine, triangle and square inputs); MathWorks
    ``compare`` (fit % and the estimated initial condition).
    """
    delay = _checked_delay(model, channel, warmup_s, delay_s)
    notes: list[str] = []
    warnings: list[str] = []
    if capture.input_v is None or _is_step(capture):
        drive = _step_drive(capture, channel, step_volts, t0_s, encoder_span_v, notes, warnings)
    else:
        drive = _recorded_drive(capture, channel, step_volts, t0_s, encoder_span_v, notes, warnings)
    t_file = capture.time_s
    u, y, wraps, reference, kind, step_time = (drive.u, drive.y, drive.wraps, drive.reference, drive.kind,
                                               drive.step_time)
    if wraps:
        notes.append(f"position unwrapped: {wraps} encoder wrap(s) removed")
    t = t_file - t_file[0]
    (a, b, c, d), names = _channel_system(model, channel)
    # the model runs on an evenly spaced grid: a logger's jittered time stamps are simulated on the
    # even grid of the same span and read back at the samples
    dt = np.diff(t)
    even = bool(np.allclose(dt, t[-1] / (t.size - 1), rtol=1e-6, atol=0.0))
    grid = t if even else np.linspace(0.0, t[-1], t.size)

    def on_samples(values: np.ndarray) -> np.ndarray:
        values = np.asarray(values, float).ravel()
        return values if even else np.interp(t, grid, values)

    if not even:
        notes.append("uneven time stamps: simulated on an even grid and interpolated")
    # a logged command holds from its stamp (where the identification puts a logged step)
    held = drive.held and even
    # otherwise the model's dead time delays the input, linear between samples
    u_model = np.interp(t - delay, t, u, left=u[0]) if delay > 0 and not held else u
    u_grid = u_model if even else np.interp(grid, t, u_model)
    n = a.shape[0]
    h = float(grid[1] - grid[0])
    window = capture.sample_window_s if channel == "velocity" else 0.0
    lines = capture.count_hold
    refresh = refresh_time(t, y, lines) if window > 0 and even and lines > 1 else math.nan
    counted = window > 0 and even and abs(window - lines * h) <= 1e-6 * h and (lines == 1 or math.isfinite(refresh))
    ends = None
    if counted and lines > 1:
        # a count kept over several lines: its window ends at the line that logged it
        ends = (np.rint((count_window_ends(t, refresh, window) - float(t[0])) / h).astype(np.intp), lines)
    forced_grid, free = _responses(a, b, c, d, h, u_grid, delay, n if estimate_initial_state else 0, held=held,
                                   window=counted, ends=ends)
    if delay > 0:
        notes.append(f"input delayed by the model's dead time {delay:.4g} s")
    if held:
        notes.append("the logged input holds each value from its stamp to the next (the step at the stamp that "
                     "logged it)")
    if counted:
        why = (" (its values times their stamped intervals are whole counts: read as counted)"
               if capture.count_over_stamps else "")
        kept = f", each count kept for {lines} lines (its window ends at the line that logged it)" if lines > 1 else ""
        notes.append(f"the velocity is counted over each {1e3 * window:.4g} ms interval{why}{kept}: the model's mean "
                     "over each interval is scored")
    elif window > 0:
        warnings.append(f"the velocity is counted over {1e3 * window:.4g} ms, not over this record's "
                        f"{1e3 * h:.4g} ms grid: the model's samples are scored, which lead such means by "
                        f"about {0.5e3 * window:.3g} ms")
    forced = on_samples(forced_grid)
    scored = t >= warmup_s - 1e-12 * max(1.0, t[-1])
    if int(scored.sum()) < MIN_SCORED:
        raise CaptureDataError(
            f"record of {t[-1]:.3g} s leaves fewer than {MIN_SCORED} samples after the {warmup_s:g} s "
            "warm-up: use a shorter --warmup",
            file=capture.source,
        )
    if warmup_s > 0:
        notes.append(f"first {warmup_s:g} s simulated but not scored (--warmup)")
    cols = [on_samples(free[:, i]) for i in range(free.shape[1])]
    x0_hat = np.full(n, np.nan)
    offset = 0.0
    yhat = forced.copy()
    if np.all(np.isfinite(forced)) and (cols or estimate_offset):
        basis = np.column_stack(cols) if cols else np.zeros((t.size, 0))
        use_offset = estimate_offset
        if use_offset and cols:
            # an integrating channel's initial position already is a constant: the offset
            # cannot be told from it
            q, *_ = np.linalg.lstsq(basis[scored], np.ones(int(scored.sum())), rcond=None)
            if np.linalg.norm(basis[scored] @ q - 1.0) < 1e-6 * math.sqrt(scored.sum()):
                use_offset = False
                notes.append("output offset not separable from the initial position: taken into the initial state")
        design = np.column_stack([basis, np.ones(t.size)]) if use_offset else basis
        if np.all(np.isfinite(design)):
            scale = np.linalg.norm(design[scored], axis=0)
            seen = scale > 1e-12 * max(float(scale.max(initial=0.0)), 1e-300)
            a = design[scored][:, seen] / scale[seen]
            coef_s, *_ = np.linalg.lstsq(a, y[scored] - forced[scored], rcond=1e-10)
            coef = np.zeros(design.shape[1])
            coef[seen] = coef_s / scale[seen]
            yhat = forced + design @ coef
            if cols:
                x0_hat = np.where(seen[:n], coef[:n], np.nan)
                notes.append("initial state estimated by least squares over the scored record"
                             + ("" if np.all(seen[:n]) else " (states the channel cannot see: null)"))
            if use_offset:
                offset = float(coef[n if cols else 0])
                notes.append(f"output offset estimated: {offset:+.4g} {channel_unit(model.units, channel)}")
        else:
            warnings.append("the model's free response overflows (unstable model): initial state not estimated")
    elif not np.all(np.isfinite(forced)):
        warnings.append("the model's response overflows (unstable model)")
    ym, yh = y[scored], yhat[scored]
    score = nrmse(ym, yh, reference=reference) if np.ptp(ym) > 0 else float("inf")
    fit = fit_percent(ym, yh) if np.ptp(ym) > 0 else float("-inf")
    return ValidationResult(
        source=capture.source,
        channel=channel,
        time_s=t_file[scored],
        input_v=u[scored],
        measured_v=ym,
        simulated_v=yh,
        nrmse=score,
        fit_percent=fit,
        warmup_s=float(warmup_s),
        nrmse_reference=reference,
        input_kind=kind,
        step_time_s=step_time,
        state_names=tuple(names),
        initial_state=tuple(float(v) for v in x0_hat),
        offset_v=offset,
        delay_s=delay,
        wraps=int(wraps),
        notes=tuple(notes),
        warnings=tuple(dict.fromkeys(warnings)),
    )
