"""The conditioning pipeline: captures → synchronised, reduced step responses.

Order as in the paper (Masoud 2019, section V): step responses (edge, baseline, unwrapping)
→ synchronisation → optional denoising of the current → sample reduction.  Differentiation
is left to the identification method that needs it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from motorid.capture import ROLES, Capture
from motorid.conditioning.checks import check_step_responses
from motorid.conditioning.denoise import fft_denoise
from motorid.conditioning.resample import ratio_for_interval, sample_reduction
from motorid.conditioning.response import (COUNTED_SPEED_UNITS, StepResponse, counting_lag, is_log, step_response,
                                          window_ends)
from motorid.conditioning.sync import synchronise
from motorid.conditioning.timescale import ResponseTimes, auto_reduction_ratio, response_times
from motorid.errors import ConditioningError, OptionError

__all__ = ["ConditionedExperiment", "ConditioningSettings", "condition_experiment"]


@dataclass(frozen=True, slots=True)
class ConditioningSettings:
    """How captures are conditioned (defaults: the paper's).

    Attributes
    ----------
    sample_interval_s : float, "auto" or None
        Target sample interval after reduction: ``"auto"`` (default) chooses it from the
        measured response (:func:`~motorid.conditioning.timescale.auto_reduction_ratio`,
        about five samples per 63 % time); a number fixes it (the paper's 0.1 s);
        ``None`` keeps the recording's.
    ratio : int or None
        Reduction ratio; overrides ``sample_interval_s``.
    reduction : str
        ``subsample`` (the paper's), ``block_mean`` or ``fir``.
    record_length_s : float or None
        Length kept after the step (the paper's 1.9/2.4/2.9 s); all when ``None``.
    sync : str
        ``interp`` or ``index`` (see :func:`synchronise`).
    denoise_current : bool
        FFT-denoise the armature current before reduction.
    step_tolerance : float
        Relative difference of step levels above which captures are refused as not of the
        same experiment.
    """

    sample_interval_s: float | str | None = "auto"
    ratio: int | None = None
    reduction: str = "subsample"
    record_length_s: float | None = None
    sync: str = "interp"
    denoise_current: bool = True
    step_tolerance: float = 0.03

    def __post_init__(self) -> None:
        # settings validate themselves: a wrong value fails here, naming the
        # parameter, not deep inside the pipeline
        import math

        from motorid.conditioning.resample import REDUCTION_METHODS
        from motorid.conditioning.sync import SYNC_METHODS

        si = self.sample_interval_s
        if not (si is None or si == "auto" or (isinstance(si, (int, float)) and not isinstance(si, bool)
                                                and math.isfinite(si) and si > 0)):
            raise OptionError(f"sample_interval_s must be 'auto', None or a positive number of seconds, got {si!r}")
        if self.ratio is not None and not (isinstance(self.ratio, (int, np.integer)) and self.ratio >= 1):
            raise OptionError(f"ratio must be a whole number >= 1, got {self.ratio!r}")
        if self.reduction not in REDUCTION_METHODS:
            raise OptionError(f"reduction must be one of {', '.join(REDUCTION_METHODS)}, got {self.reduction!r}")
        rl = self.record_length_s
        if rl is not None and not (isinstance(rl, (int, float)) and math.isfinite(rl) and rl > 0):
            raise OptionError(f"record_length_s must be None or a positive number of seconds, got {rl!r}")
        if self.sync not in SYNC_METHODS:
            raise OptionError(f"sync must be one of {', '.join(SYNC_METHODS)}, got {self.sync!r}")
        if not (isinstance(self.step_tolerance, (int, float)) and 0 < self.step_tolerance < 1):
            raise OptionError(f"step_tolerance must be between 0 and 1, got {self.step_tolerance!r}")


@dataclass(frozen=True, slots=True)
class ConditionedExperiment:
    """Synchronised step responses of one experiment, full rate and reduced.

    Attributes
    ----------
    time_s, input_v : ndarray
        Reduced grid from the step edge and the input increment on it.
    outputs : dict[str, ndarray]
        Reduced output increments keyed by role.
    full_time_s, full_input_v : ndarray
        The same before reduction (the input a read-only view of the step level when a logged
        step stays at it: :func:`~motorid.conditioning.sync.synchronise`).
    full_outputs : dict[str, ndarray]
        Output increments before reduction (current not denoised).
    step_volts : float
        Step level (mean over the captures).
    sources : dict[str, str]
        File of each role.
    responses : dict[str, StepResponse]
        The individual step responses (on each file's own grid).
    settings : ConditioningSettings
        How it was done.
    ratio : int
        Reduction ratio used.
    warnings : tuple of str
        Everything the user should know.
    response_time_s : float
        63 % time of the velocity (or the position's slope) read off the data (NaN if not
        found): the time scale behind every automatic choice.
    dead_time_s : float
        Apparent dead time read off the same response (0 when it moves at once).
    notes : tuple of str
        The automatic choices made, in words.
    """

    time_s: np.ndarray
    input_v: np.ndarray
    outputs: dict[str, np.ndarray]
    full_time_s: np.ndarray
    full_input_v: np.ndarray
    full_outputs: dict[str, np.ndarray]
    step_volts: float
    sources: dict[str, str]
    responses: dict[str, StepResponse]
    settings: ConditioningSettings
    ratio: int
    warnings: tuple[str, ...] = field(default=())
    response_time_s: float = float("nan")
    dead_time_s: float = 0.0
    notes: tuple[str, ...] = field(default=())

    @property
    def sample_interval_s(self) -> float:
        """Sample interval after reduction."""
        return float(self.time_s[1] - self.time_s[0]) if self.time_s.size > 1 else float("nan")

    @property
    def velocity_window_s(self) -> float:
        """The window each sample of a counted velocity capture is the mean over (0: sampled, or none)."""
        r = self.responses.get("velocity")
        return r.sample_window_s if r is not None else 0.0

    def velocity_window_ends(self, time_s: np.ndarray) -> np.ndarray:
        """Where the counted velocity's window ends for its samples at ``time_s``: their own stamps, unless held.

        A count kept over several lines ends at the last line that logged it
        (:func:`~motorid.conditioning.response.window_ends`).

        Parameters
        ----------
        time_s : ndarray
            Times from the step.

        Returns
        -------
        ndarray
        """
        r = self.responses.get("velocity")
        return np.asarray(time_s, dtype=float) if r is None else window_ends(r, time_s)


def condition_experiment(
    captures: Mapping[str, Capture],
    settings: ConditioningSettings = ConditioningSettings(),
    *,
    step_volts: float | None = None,
    t0_s: float | None = None,
) -> ConditionedExperiment:
    """Condition the captures of one step experiment.

    Parameters
    ----------
    captures : Mapping[str, Capture]
        Captures keyed by role (``position``, ``velocity``, ``current``).
    settings : ConditioningSettings
        Reduction, record length, synchronisation.
    step_volts : float, optional
        Step level for captures without an input channel.
    t0_s : float, optional
        Step instant on the files' time axis (for captures without an input channel).

    Returns
    -------
    ConditionedExperiment
        Synchronised, reduced step responses.

    Raises
    ------
    ConditioningError
        Captures of different step levels (naming both files and levels), or too little
        record after the step.
    """
    if not captures:
        raise OptionError("give at least one capture (--velocity or --position)")
    responses = {
        role: step_response(cap, role, step_volts=step_volts, t0_s=t0_s) for role, cap in captures.items()
    }
    notes: list[str] = []
    if t0_s is None:
        responses, shared = _shared_onsets(captures, responses, step_volts)
        notes.extend(shared)
    for role, cap in captures.items():
        if is_log(cap) and responses[role].timing == "sampled":
            notes.append(f"{cap.source}: its input column scatters around its levels, a measured voltage rather "
                         "than a logged command: its step lies in the sample interval before the first sample at "
                         "the new level (taken at the interval's middle, ±dt/√12 in the intervals), as on a scope; "
                         "--t0 gives the instant if it is known")
        # a log with more measured columns than the role it was given: say what is left out
        unused = [r for r in ROLES if r in cap.extra and r not in captures]
        if unused:
            notes.append(f"{cap.source} also holds a {' and a '.join(unused)} column, not used: give the file as "
                         + " and ".join(f"--{r}" for r in unused) + " too to fit it")
        if (role == "velocity" and cap.sample_window_s == 0 and responses[role].timing == "logged"
                and (cap.output_info.units in COUNTED_SPEED_UNITS or responses[role].count_step > 0)):
            # the default takes the column for samples; a count's half interval is then in the model's timing
            notes.append(_sampled_speed_note(cap, responses[role]))
        if cap.sample_window_s > 0:
            why = (f"its values times their stamped intervals are whole counts of {cap.count_step:.4g}"
                   f"{' ' + cap.output_info.units if cap.output_info.units else ''} over the median interval, so it "
                   "counts over each interval its clock measured" if cap.count_over_stamps else
                   "counted over each interval, --counted-velocity")
            held = responses[role].count_hold if responses[role].count_held else 1
            lag = 0.5 * cap.sample_window_s + 0.5 * (held - 1) * cap.sample_interval_s
            where = (f"before the line that logged it (each count kept for {held} lines, every {held}th line "
                     "fitted)") if held > 1 else "before it"
            notes.append(f"{cap.source}: each sample is the mean speed over the {1e3 * cap.sample_window_s:.4g} ms "
                         f"{where} ({why}): the output-error fit (methods "
                         "auto, oe) models it so, and its dead time and time constants are the motor's, without the "
                         f"counting's lag of about {1e3 * lag:.3g} ms, which the other methods "
                         "take for dead time")
    warnings: list[str] = []
    for r in responses.values():
        warnings.extend(f"{r.source}: {w}" for w in r.warnings)
    # stalled, clipped, no dynamics, back to rest (within the record the user keeps)
    warnings.extend(check_step_responses(captures, responses, record_length_s=settings.record_length_s))
    items = list(responses.values())
    for a in items:
        for b in items:
            if a is b or abs(a.step_volts) < abs(b.step_volts):
                continue
            if abs(a.step_volts - b.step_volts) > settings.step_tolerance * max(abs(a.step_volts), 1e-12):
                raise ConditioningError(
                    f"captures of different step levels: {a.source} has {a.step_volts:.4g} V, "
                    f"{b.source} has {b.step_volts:.4g} V; record all captures with the same step"
                )
    synced = synchronise(items, length_s=settings.record_length_s, method=settings.sync)
    dt = float(synced.time_s[1] - synced.time_s[0])
    times = _response_times(responses, synced.time_s, synced.outputs)
    if settings.ratio is not None:
        ratio = int(settings.ratio)
    elif settings.sample_interval_s == "auto":
        ratio, why = auto_reduction_ratio(dt, float(synced.time_s[-1]), times.t63_s)
        notes.append(why)
    elif settings.sample_interval_s is not None:
        ratio = ratio_for_interval(dt, float(settings.sample_interval_s))
    else:
        ratio = 1
    outs = dict(synced.outputs)
    if settings.denoise_current and "current" in outs:
        outs["current"] = fft_denoise(outs["current"], dt).values
    roles = list(outs)
    rows = [synced.input_v] + [outs[r] for r in roles]
    if settings.reduction == "subsample" and ratio > 1:
        # the paper's reduction is a selection: each channel reduced on its own and the reduced ones
        # stacked, the same array as reducing the stack without a stack of the full-rate channels
        # (160 MB for a 10 M-sample velocity record)
        parts = [sample_reduction(synced.time_s, row, ratio, settings.reduction) for row in rows]
        red = replace(parts[0], values=np.vstack([p.values for p in parts]))
    else:
        red = sample_reduction(synced.time_s, np.vstack(rows), ratio, settings.reduction)
    if red.time_s.size < 6:
        raise ConditioningError(
            f"only {red.time_s.size} samples left after reduction by {ratio}, at least 6 are "
            "needed: use a shorter --sample-interval or a longer record"
        )
    return ConditionedExperiment(
        time_s=red.time_s,
        input_v=red.values[0],
        outputs={r: red.values[i + 1] for i, r in enumerate(roles)},
        full_time_s=synced.time_s,
        full_input_v=synced.input_v,
        full_outputs=dict(synced.outputs),
        step_volts=float(np.mean([r.step_volts for r in items])),
        sources=synced.sources,
        responses=responses,
        settings=settings,
        ratio=ratio,
        warnings=tuple(warnings),
        response_time_s=times.t63_s,
        dead_time_s=times.dead_time_s if np.isfinite(times.dead_time_s) else 0.0,
        notes=tuple(notes),
    )


def _sampled_speed_note(cap: Capture, r: StepResponse) -> str:
    """What fitting a logged speed as samples leaves in the model if it counts, and what its values show."""
    window = 1e3 * cap.sample_interval_s
    unit = cap.output_info.units
    lag = 1e3 * counting_lag(r)
    head = f"{cap.source}: the speed{f' ({unit})' if unit else ''} is fitted as sampled at each stamp; "
    steps = f"its values come in whole steps of {r.count_step:.4g}{' ' + unit if unit else ''}"
    if r.count_step > 0 and r.count_hold > 1:
        return (head + f"{steps}, each kept for {r.count_hold} lines: if that is a count of encoder edges over "
                f"{r.count_hold} lines ({r.count_hold * window:.4g} ms) held until the next, the motor is about "
                f"{lag:.3g} ms quicker than this model, so the timing intervals reach {lag:.3g} ms lower "
                "(--counted-velocity fits it so)")
    counts = (f"; {steps} (one encoder edge over a line, or an ADC's code: the two look alike), so the timing "
              f"intervals reach {lag:.3g} ms lower" if r.count_step > 0 else "")
    return (head + "if the log counts encoder edges over each line (as Arduino sketches print it), each value is "
            f"the mean over the {window:.4g} ms before it, the motor is about {0.5 * window:.3g} ms quicker than "
            f"this model{counts}, and --counted-velocity fits it so")


def _response_times(responses: Mapping[str, StepResponse], time_s: np.ndarray, outputs: Mapping[str, np.ndarray]
) -> ResponseTimes:
    """Time scales of the experiment: of the velocity, else of the position's slope."""
    from motorid.conditioning.derivative import derivative

    if "velocity" in outputs:
        y, role = outputs["velocity"], "velocity"
    else:
        dt = float(time_s[1] - time_s[0])
        y, role = derivative(outputs["position"], dt, "savgol"), "position"
    r = responses[role]
    pre = r.output_v[r.time_s < 0] if role == "velocity" else None
    return response_times(time_s, y, pre=pre)


def _shared_onsets(
    captures: Mapping[str, Capture], responses: dict[str, StepResponse], step_volts: float | None
) -> tuple[dict[str, StepResponse], list[str]]:
    """One step instant for the captures of one acquisition that have no input channel.

    Two channels of one scope acquisition (tacho and current shunt) saw the same step, but
    each one's onset read-off is late by its own lags: the armature current moves first
    (its rise starts with the full slope ``V/La``) while the tacho starts with zero slope,
    so its tangent meets the baseline a few lags late (1.4–2.1 ms, τ
    4–9 % short).  Captures on the same time axis therefore share the earliest onset.
    """
    groups: list[list[str]] = []
    for role, cap in captures.items():
        if cap.input_v is not None or responses[role].edge.method != "onset":
            continue
        for g in groups:
            other = captures[g[0]].time_s
            if other.shape == cap.time_s.shape and np.array_equal(other, cap.time_s):
                g.append(role)
                break
        else:
            groups.append([role])
    notes: list[str] = []
    out = dict(responses)
    for g in groups:
        if len(g) < 2:
            continue
        first = min(g, key=lambda r: responses[r].edge.time_s)
        t0 = responses[first].edge.time_s
        for role in g:
            if role == first:
                continue
            late = responses[role].edge.time_s - t0
            # still an onset read off a response (its shift is fitted, shared with the group's)
            out[role] = replace(step_response(captures[role], role, step_volts=step_volts, t0_s=t0), timing="onset")
            notes.append(f"one step instant for the {' and '.join(g)} captures (one acquisition): the "
                         f"{first}'s onset at {t0:.6g} s; the {role}'s own read-off was {1e3 * late:.3g} ms later")
    return out, notes
