"""A capture as a step response: time zero at the step edge, pre-step baseline removed."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from motorid.capture import ROLES, Capture
from motorid.conditioning.edge import StepEdge, ramp_onset, response_onset, step_edge
from motorid.conditioning.unwrap import unwrap_position
from motorid.errors import ConditioningError, OptionError, StepNotFoundError

__all__ = ["STEP_TIMINGS", "STEP_VOLTS_TOLERANCE", "StepResponse", "count_window_ends", "counting_lag", "may_count",
           "refresh_time", "refreshed", "split_at", "step_response", "window_ends"]

#: Where a response's step instant comes from (:attr:`StepResponse.timing`):
#: ``logged`` — a logged input column (a DAQ or Arduino log writes the command at the stamp it
#: applies it: the instant is exact); ``sampled`` — a scope channel sampling a physical step (the
#: edge lies between the last sample before it and the first at the new level: a sub-sample phase
#: that no fit can tell from a delay); ``onset`` — read off the response itself (no input channel);
#: ``given`` — ``--t0``.
STEP_TIMINGS: tuple[str, ...] = ("logged", "sampled", "onset", "given")

#: Capture formats whose input column is a logged command rather than a sampled voltage.
LOGGED_FORMATS: tuple[str, ...] = ("plain-csv", "xlsx")

#: Largest relative difference between a given ``step_volts`` and the step recorded on CH1.
STEP_VOLTS_TOLERANCE = 0.05

#: A log's input column that scatters around both of its levels by less than this fraction of the
#: step (and by more than nothing) is a measured voltage, not a command (:func:`measured_input`).
MEASURED_INPUT_SPREAD = 0.02


#: Units of a logged speed column that may be a count of encoder edges over each line (a volts
#: column is a tacho's, sampled).
COUNTED_SPEED_UNITS: tuple[str, ...] = ("rpm", "rad/s", "rev/s", "deg/s", "counts/s")


def is_log(capture: Capture) -> bool:
    """Whether a capture is a log (plain CSV or spreadsheet) rather than a scope's file.

    A scope's capture re-saved as ``.xlsx`` keeps its header (a record length): it stays a
    scope's.  A log's input column is a command held from its stamp unless it measured the
    voltage (:func:`measured_input`).

    Parameters
    ----------
    capture : Capture
        Any capture.

    Returns
    -------
    bool
    """
    return capture.format in LOGGED_FORMATS and capture.scope.record_length is None


def measured_input(input_v: np.ndarray | None, edge: StepEdge) -> bool:
    """Whether a log's input column measured the drive's voltage rather than logged a command.

    A command a loop writes (a PWM duty times the supply, a DAC code) holds the same value from
    one line to the next, so its step lies at the stamp of the first line with the new value.  A
    voltage an ADC, a DAQ or a scope channel measured (a PicoScope's CSV export) scatters around
    each level by its noise and quantisation, and its step lies somewhere in the interval before
    its first sample at the new level, as on a scope.  The test: more than one value on each side
    of the edge (an 8-bit channel on a level between two codes alternates between them), with a
    spread under :data:`MEASURED_INPUT_SPREAD` of the step (a closed loop's varying command, or a
    staircase's next level, is no such level).

    Parameters
    ----------
    input_v : ndarray or None
        The input column.
    edge : StepEdge
        Its step edge.

    Returns
    -------
    bool
    """
    if input_v is None or not edge.amplitude_v:
        return False
    before, after = input_v[: edge.index], input_v[edge.index :]

    def scatters(x: np.ndarray) -> bool:
        return x.size >= 3 and np.unique(x).size >= 2 and 0 < float(np.std(x)) < MEASURED_INPUT_SPREAD * abs(
            edge.amplitude_v)

    return scatters(before) and scatters(after)


@dataclass(frozen=True, slots=True)
class StepResponse:
    """One capture's step response.

    Attributes
    ----------
    source : str
        The capture's file.
    role : str
        ``position``, ``velocity`` or ``current``.
    time_s : ndarray
        Time from the step edge (negative before it).
    input_v : ndarray
        Input increment (CH1 minus its pre-step baseline); a clean step of ``step_volts``
        when the capture has no input channel.
    output_v : ndarray
        Output increment (unwrapped for a position, minus its pre-step baseline).
    step_volts : float
        Step amplitude.
    edge : StepEdge
        The edge on the file's own time axis.
    wraps : int
        Encoder wraps removed (position only).
    warnings : tuple of str
        What the user should know.
    wrap_count : ndarray of int or None
        Position: turns added to each sample by the unwrapping (``None`` without wraps).
    glitches : ndarray of int or None
        Position: indices of samples interpolated over wrap glitches.
    timing : str
        Where the step instant comes from, one of :data:`STEP_TIMINGS`.
    stamp_resolution_s : float
        For a logged step instant, the resolution its stamp was rounded to
        (:attr:`motorid.capture.Capture.stamp_resolution_s`); 0 when exact.
    sample_window_s : float
        The interval each output sample is the mean over (a counted speed,
        :attr:`motorid.capture.Capture.sample_window_s`); 0 for samples.
    rounded : bool
        Whether the output's steps are a reading rounded to its codes (an ADC's, a scope's), whose
        error follows the value; False for a speed in a counted-speed unit
        (:data:`COUNTED_SPEED_UNITS`), most often a difference of two encoder counts, whose errors
        telescope.
    count_step : float
        A velocity fitted as samples whose values come in whole steps (:attr:`motorid.capture.Capture.count_step`)
        and whose unit is a counted speed's or none: the column may count encoder edges over each
        line, so the motor may be quicker than its samples by half a line; 0 otherwise.
    count_hold : int
        Lines each of its values is kept for (:attr:`motorid.capture.Capture.count_hold`): counted
        over that many lines and held, the motor may be quicker by ``(2·hold − 1)/2`` lines.
    count_refresh_s : float
        A counted speed (``sample_window_s`` > 0) kept over ``count_hold`` lines: the time (from the
        step) of one line that logged a new count, whose window ends there; every ``count_hold``-th
        line from it does (:func:`window_ends`).  NaN otherwise.
    """

    source: str
    role: str
    time_s: np.ndarray
    input_v: np.ndarray
    output_v: np.ndarray
    step_volts: float
    edge: StepEdge
    wraps: int
    warnings: tuple[str, ...]
    wrap_count: np.ndarray | None = None
    glitches: np.ndarray | None = None
    timing: str = "onset"
    stamp_resolution_s: float = 0.0
    sample_window_s: float = 0.0
    rounded: bool = True
    count_step: float = 0.0
    count_hold: int = 1
    count_refresh_s: float = math.nan
    #: The sample interval, computed once: an identification asks for it over a hundred times
    #: (a median of the whole record's steps each time: 13 % of ``auto`` on the demo).
    _dt_cache: list[float] = field(default_factory=list, init=False, repr=False, compare=False)

    @property
    def count_held(self) -> bool:
        """Whether it is a counted speed whose counts are kept over several lines (:attr:`count_refresh_s` known)."""
        return self.sample_window_s > 0 and math.isfinite(self.count_refresh_s)

    @property
    def sample_interval_s(self) -> float:
        """Sample interval in seconds."""
        if not self._dt_cache:
            # the median reorders the steps it is given (no second copy of a long record's steps)
            self._dt_cache.append(float(np.median(np.diff(self.time_s), overwrite_input=True)))
        return self._dt_cache[0]


def step_timing(capture: Capture, edge: StepEdge) -> str:
    """Where a capture's step instant comes from, one of :data:`STEP_TIMINGS`.

    ``onset`` or ``given`` as the edge was found (the response's onset, ``--t0``); else ``logged``
    for a log's command (the step at the stamp of its first sample at the new level) and
    ``sampled`` for a scope's channel, or a log's measured voltage (:func:`measured_input`): the
    step somewhere in the interval before that sample.

    Parameters
    ----------
    capture : Capture
        The capture.
    edge : StepEdge
        Its step edge.

    Returns
    -------
    str
    """
    if edge.method in ("onset", "given"):
        return edge.method
    # a scope's channel is sampled; so is a log's measured voltage
    return "logged" if is_log(capture) and not measured_input(capture.input_v, edge) else "sampled"


def step_response(
    capture: Capture,
    role: str,
    *,
    step_volts: float | None = None,
    t0_s: float | None = None,
    encoder_span_v: float | None = None,
) -> StepResponse:
    """Turn a capture into a step response.

    Parameters
    ----------
    capture : Capture
        The capture (CH1 = step input when present).
    role : str
        What the output channel measures.
    step_volts : float, optional
        The step level, required when the capture has no input channel.
    t0_s : float, optional
        Step instant on the file's time axis (overrides detection).
    encoder_span_v : float, optional
        Volts per turn of the position sensor (estimated from the data when omitted).

    Returns
    -------
    StepResponse
        Time from the edge, increments of input and output.

    Raises
    ------
    ConditioningError, StepNotFoundError
        Unknown role, no step, or no step level for a capture without input channel.
    """
    if role not in ROLES:
        raise ConditioningError(f"unknown role {role!r}; use one of {', '.join(ROLES)}", file=capture.source)
    warnings: list[str] = list(capture.warnings)
    y = capture.output_v
    wraps = 0
    wrap_count = glitches = None
    if role == "position":
        unwrapped = unwrap_position(y, span_v=encoder_span_v, file=capture.source)
        y = unwrapped.position_v
        wraps = unwrapped.wraps
        wrap_count = unwrapped.wrap_count
        glitches = unwrapped.glitch_indices if unwrapped.glitch_indices.size else None
        warnings.extend(unwrapped.warnings)
    t = capture.time_s
    if capture.input_v is not None:
        edge = step_edge(t, capture.input_v, file=capture.source)
        amp = edge.amplitude_v if step_volts is None else float(step_volts)
        if abs(amp - edge.amplitude_v) > STEP_VOLTS_TOLERANCE * abs(edge.amplitude_v):
            # a given level that contradicts the recorded step (a sign slip, a 10x probe
            # setting) would scale every gain silently
            raise OptionError(f"--step-volts (step_volts) {amp:g} contradicts the {edge.amplitude_v:.4g} V step "
                              "on its CH1: leave it out (CH1 gives the step) or check the probe setting",
                              file=capture.source)
    else:
        if step_volts is None:
            raise StepNotFoundError(
                "no input channel: give the step level with --step-volts", file=capture.source
            )
        amp = float(step_volts)
        # nothing in the data can check this level (a response is a good response to *some*
        # step): say that every gain rests on it
        warnings.append(f"no input channel: the step level is the {amp:g} V given by --step-volts, not a recorded "
                        "one; every gain scales with 1/step")
        edge = response_onset(t, y, file=capture.source)
        if role == "position" and t0_s is None:
            # a ramp: the line through its rise meets the baseline a time constant late
            edge = ramp_onset(t, y, edge)
    if t0_s is not None:
        idx = int(np.searchsorted(t, t0_s))
        dt_rec = float(t[1] - t[0])
        if idx == 0 and t0_s >= t[0] - 0.5 * dt_rec:
            # a log that starts at the step: its first sample is the baseline
            warnings.append(f"--t0 {t0_s:g} s is the record's first sample: no samples before the step, the "
                            "baseline is the first sample")
            idx = 1 if t0_s > t[0] else 0
        elif not 0 <= idx < t.size or (idx == 0 and t0_s < t[0]):
            raise ConditioningError(f"--t0 {t0_s:g} s is outside the record ({t[0]:g} to {t[-1]:g} s)",
                                    file=capture.source)
        edge = StepEdge(idx, float(t0_s), edge.baseline_v, edge.level_v, edge.amplitude_v, edge.noise_v, "given")
    timing = step_timing(capture, edge)
    k = max(1, edge.index)
    if k < 5:
        warnings.append(f"only {k} samples before the step: baseline uncertain")
    base_y = float(np.mean(y[:k]))
    if capture.input_v is not None:
        u = _minus(capture.input_v, float(np.mean(capture.input_v[:k])))
    else:
        u = np.where(t >= edge.time_s, amp, 0.0)
    time = _minus(t, edge.time_s)
    output = _minus(y, base_y)
    refresh = (refresh_time(time, output, capture.count_hold) if capture.sample_window_s > 0 and capture.count_hold > 1
               else math.nan)
    if capture.sample_window_s > 0 and capture.count_hold > 1 and not math.isfinite(refresh):
        dt = float(np.median(np.diff(t)))
        warnings.append(f"each count is kept for {capture.count_hold} lines, but the lines that logged them cannot be "
                        "placed (uneven stamps, or no change in the record): fitted as means over "
                        f"{1e3 * capture.sample_window_s:.4g} ms ending at every line, so the motor may be up to "
                        f"{1e3 * (capture.count_hold - 1) * dt:.3g} ms quicker than this model")
    return StepResponse(
        source=capture.source,
        role=role,
        time_s=time,
        input_v=u,
        output_v=output,
        step_volts=float(amp),
        edge=edge,
        wraps=wraps,
        warnings=tuple(warnings),
        wrap_count=wrap_count,
        glitches=glitches,
        timing=timing,
        stamp_resolution_s=capture.stamp_resolution_s if timing == "logged" else 0.0,
        sample_window_s=capture.sample_window_s,
        rounded=not (role == "velocity" and capture.output_info.units in COUNTED_SPEED_UNITS),
        count_step=capture.count_step if may_count(capture, role) else 0.0,
        count_hold=capture.count_hold,
        count_refresh_s=refresh,
    )


def refresh_time(time_s: np.ndarray, values: np.ndarray, hold: int) -> float:
    """The stamp of a line that logged a new count, for a count kept over ``hold`` lines (NaN if none shows).

    A firmware that counts over ``hold`` loops and logs every loop changes its value only on the
    lines it counts anew: their commonest index modulo ``hold`` is the count's phase.  On an even
    grid only (jittered stamps have no fixed phase in time).

    Parameters
    ----------
    time_s, values : ndarray
        The record.
    hold : int
        Lines each count is kept for (> 1).

    Returns
    -------
    float
    """
    t = np.asarray(time_s, dtype=float)
    changes = np.flatnonzero(np.diff(np.asarray(values, dtype=float)) != 0) + 1
    if hold < 2 or changes.size == 0 or t.size < 2:
        return math.nan
    steps = np.diff(t)
    dt = float(np.median(steps))
    if not dt > 0 or float(np.max(np.abs(steps - dt))) > 1e-6 * dt:
        return math.nan
    phase = int(np.argmax(np.bincount(changes % hold, minlength=hold)))
    return float(t[phase])


def window_ends(r: StepResponse, time_s: np.ndarray) -> np.ndarray:
    """Where the count of a counted speed's sample at each of ``time_s`` ends (its own stamp, unless held).

    A count kept over several lines (:attr:`StepResponse.count_refresh_s`) ends at the last line
    that logged it: ``refresh + ⌊(t − refresh)/T⌋·T`` with ``T`` the count's window.

    Parameters
    ----------
    r : StepResponse
        The velocity's response.
    time_s : ndarray
        Times on its axis (from the step).

    Returns
    -------
    ndarray
        ``time_s`` itself when not held.
    """
    t = np.asarray(time_s, dtype=float)
    return count_window_ends(t, r.count_refresh_s, r.sample_window_s) if r.count_held else t


def count_window_ends(time_s: np.ndarray, refresh_s: float, window_s: float) -> np.ndarray:
    """``refresh + ⌊(t − refresh)/T⌋·T``: the last line at or before each time that logged a count.

    Parameters
    ----------
    time_s : ndarray
        Times.
    refresh_s : float
        One line that logged a count (:func:`refresh_time`).
    window_s : float
        The count's window ``T``, the lines between two counts.

    Returns
    -------
    ndarray
    """
    t = np.asarray(time_s, dtype=float)
    return refresh_s + np.floor((t - refresh_s) / window_s + 1e-6) * window_s


def refreshed(r: StepResponse) -> np.ndarray | None:
    """The samples of a held counted speed on the lines that logged a new count (None when not held).

    The other lines repeat them: fitted, they would count each value ``count_hold`` times.

    Parameters
    ----------
    r : StepResponse

    Returns
    -------
    ndarray of bool or None
    """
    if not r.count_held:
        return None
    return np.abs(window_ends(r, r.time_s) - r.time_s) <= 1e-6 * r.sample_interval_s


def may_count(capture: Capture, role: str) -> bool:
    """Whether a capture's output, fitted as samples, may be a speed counted over each line.

    A velocity (or a column whose role is not known yet) in a counted speed's unit or none, whose
    values come in whole steps (:attr:`~motorid.capture.Capture.count_step`), not already read as
    counted; a volts column is a tacho's, sampled.

    Parameters
    ----------
    capture : Capture
        Any capture.
    role : str
        Its role (``unknown`` before one is given).

    Returns
    -------
    bool
    """
    return (capture.count_step > 0 and role in ("velocity", "unknown") and capture.sample_window_s == 0
            and capture.output_info.units in ("", *COUNTED_SPEED_UNITS))


def counting_lag(r: StepResponse) -> float:
    """How much quicker the motor is than a speed fitted as samples if that speed counts (s; 0 if it cannot).

    A count over ``hold`` lines (kept for that many) lags by half its window and half its hold:
    ``(2·hold − 1)/2`` lines; over each line, half a line.

    Parameters
    ----------
    r : StepResponse
        A response whose ``count_step`` says whether it may count.

    Returns
    -------
    float
    """
    return 0.5 * (2 * r.count_hold - 1) * r.sample_interval_s if r.count_step > 0 else 0.0


def split_at(time_s: np.ndarray, values: np.ndarray, t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``(values[time_s < t0], values[time_s >= t0])`` as views, for times that never decrease.

    A response's times are a strictly increasing capture minus its edge time, so the samples before
    an instant are a prefix and the rest a tail: the same values as the masks, without the masks and
    their copies of the record's length (90 MB each for a 10 M-sample log).

    Parameters
    ----------
    time_s : ndarray
        Non-decreasing times, s.
    values : ndarray
        Samples on ``time_s``.
    t0 : float
        The instant (0: the step).

    Returns
    -------
    (ndarray, ndarray)
        The samples before ``t0`` and those at or after it (views of ``values``).
    """
    k = int(np.searchsorted(time_s, t0, side="left"))
    return values[:k], values[k:]


def _minus(a: np.ndarray, b: float) -> np.ndarray:
    """``a − b``; ``a`` itself when ``b`` is zero and ``a`` read-only (``x − 0.0`` is ``x``, bit for bit).

    A log whose step is at ``t = 0`` or whose input rests at 0 V before it shares the capture's
    read-only column instead of holding an 80 MB copy of it (a 10 M-row log).
    """
    # (+0.0 only: x − (−0.0) turns −0.0 into +0.0)
    if b == 0.0 and math.copysign(1.0, b) > 0 and isinstance(a, np.ndarray) and a.dtype == np.float64 \
            and not a.flags.writeable:
        return a
    return a - b
