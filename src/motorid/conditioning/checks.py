"""Signal-level checks of step responses before identification.

A file can be perfectly readable and still unable to give a motor model: the motor did not
turn (stalled, brake on, power off, wrong channel saved), the trace ran off the scope screen
(clipped at the 8-bit rails), or the output jumps to its final level within one sample (no
dynamics at this sample rate, or CH1 saved as CH2).  Identification would then return a model
that looks plausible and is wrong, so these are refused (or, where the data can still be
used, warned about) here, before any method runs.

What the data cannot tell: a wrong ``--step-volts`` on a capture without an input channel
scales the model's gain by the same factor and leaves every signal-level check unchanged (the
response is a perfectly good response to *some* step).  Only a CH1 step (checked against
``--step-volts`` by the command line) or a known motor gain can catch it, so each such
capture carries a warning that its gains rest on the level given.
"""

from __future__ import annotations

from collections.abc import Mapping

from dataclasses import replace

import numpy as np

from motorid.blockwise import BLOCK, max_abs
from motorid.capture import Capture, ChannelInfo
from motorid.conditioning.response import StepResponse, split_at
from motorid.errors import ConditioningError

__all__ = [
    "BACK_TO_REST",
    "SCREEN_HALF_DIVISIONS",
    "VOLTS_PER_DIV",
    "check_step_responses",
    "clipping",
    "falls_back_to_rest",
    "fitting_volts_per_div",
    "no_dynamics",
    "stalled_response",
]

#: The TDS1000/2000 screen spans ±5.12 divisions around its centre (8-bit codes −128…127 at
#: 25 codes per division).
SCREEN_HALF_DIVISIONS = 5.12
#: Volts/div settings of the TDS1000/2000 (1-2-5 sequence, ×1 probe; scaled by the probe).
VOLTS_PER_DIV: tuple[float, ...] = (2e-3, 5e-3, 1e-2, 2e-2, 5e-2, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0)
#: Samples at the extreme, as a fraction of the post-step record, that make a trace clipped.
CLIP_FRACTION = 0.05
#: Rails are the codes within this many LSB of ±128 (the existing reader check uses 3).
RAIL_TOLERANCE_LSB = 3.0


def _abs_percentile(y: np.ndarray, level: float, q: float) -> float:
    """``np.percentile(|y − level|, q)`` holding one array of ``y``'s length, not three (partitioned in place)."""
    d = np.subtract(y, level)
    np.abs(d, out=d)
    return float(np.percentile(d, q, overwrite_input=True))


def _near(y: np.ndarray, value: float, tol: float) -> np.ndarray:
    """``|y − value| ≤ tol``, built a block at a time (the boolean result is the only array of ``y``'s length)."""
    out = np.empty(y.size, dtype=bool)
    for start in range(0, y.size, BLOCK):
        d = y[start : start + BLOCK] - value
        np.less_equal(np.abs(d, out=d), tol, out=out[start : start + BLOCK])
    return out


def _peak_change(y: np.ndarray, base: float) -> float:
    """``c[argmax |c|]`` of ``c = y − base`` without ``c``: the larger change of the maximum and the minimum.

    On a tie the first of them in the record, as ``argmax`` finds it.
    """
    hi, lo = float(y.max()) - base, float(y.min()) - base
    if abs(hi) != abs(lo):
        return hi if abs(hi) > abs(lo) else lo
    return hi if int(np.argmax(y)) <= int(np.argmin(y)) else lo


def _quantum(values: np.ndarray, info: ChannelInfo | None) -> float:
    """The recording's quantisation step: the 8-bit LSB when the scale is known."""
    if info is not None and info.lsb is not None and np.isfinite(info.lsb) and info.lsb > 0:
        return float(info.lsb)
    return 0.0


def stalled_response(resp: StepResponse, quantum: float = 0.0) -> str | None:
    """Why the output does not move after the step, or ``None`` when it does.

    The output after the step must leave the band of its own pre-step variation: its 95th
    percentile distance from the pre-step level must exceed twice the pre-step 99th
    percentile (plus 1.5 quantisation steps).  A constant trace, noise only, or a signal that
    does the same before and after the step (a sine saved as a step) does not.

    Parameters
    ----------
    resp : StepResponse
        The synchronised step response (time 0 at the step).
    quantum : float
        The recording's quantisation step in volts (0 when unknown).

    Returns
    -------
    str or None
        The reason, or ``None`` when the output moves.
    """
    y = np.asarray(resp.output_v, dtype=float)
    pre, post = split_at(np.asarray(resp.time_s, dtype=float), y)
    if post.size < 2:
        return None
    level = float(np.median(pre)) if pre.size else float(post[0])
    dev_pre = float(np.percentile(np.abs(pre - level), 99)) if pre.size >= 10 else 0.0
    dev_post = _abs_percentile(post, level, 95)
    scale = max(max_abs(y), 1e-300)
    band = 2.0 * dev_pre + 1.5 * quantum + 1e-9 * scale
    if dev_post > band:
        return None
    if dev_pre == 0.0 and quantum == 0.0:
        return "its output stays constant after the step"
    return (f"after the step its output stays within the pre-step variation (±{max(dev_pre, quantum):.3g} V "
            f"around the baseline)")


def fitting_volts_per_div(scale: float, probe: float | None = None) -> float:
    """The next scope setting above ``scale`` that shows half as much again of the trace.

    Parameters
    ----------
    scale : float
        The volts/div the trace was recorded at (at the probe).
    probe : float, optional
        Probe attenuation; the settings are multiplied by it.

    Returns
    -------
    float
        The volts/div to record at.
    """
    factor = probe if probe is not None and np.isfinite(probe) and probe > 0 else 1.0
    need = 1.5 * scale
    for s in VOLTS_PER_DIV:
        if s * factor >= need * (1 - 1e-9):
            return s * factor
    return VOLTS_PER_DIV[-1] * factor


def clipping(capture: Capture, resp: StepResponse) -> tuple[str, bool] | None:
    """Whether the response is flat at an extreme value (clipped).

    Parameters
    ----------
    capture : Capture
        The capture as read (raw output samples and channel metadata).
    resp : StepResponse
        The synchronised step response (time 0 at the step).

    Returns
    -------
    (str, bool) or None
        The description and whether it is certain (at the scope's 8-bit rails, read from the
        channel's volts/div and offset) or only likely (a long run at exactly the extreme
        value entered steeply, without metadata); ``None`` when not clipped.
    """
    raw = np.asarray(capture.output_v, dtype=float)
    t = np.asarray(capture.time_s, dtype=float)
    pre, post = split_at(t, raw, resp.edge.time_s)
    if post.size < 20:
        return None
    info = capture.output_info
    lsb = _quantum(raw, info)
    tol = 0.01 * lsb if lsb > 0 else 1e-9 * max(max_abs(post), 1e-300)
    for extreme, sign in ((float(post.max()), 1.0), (float(post.min()), -1.0)):
        at = _near(post, extreme, tol)
        n_at = int(np.count_nonzero(at))
        if n_at < max(10, CLIP_FRACTION * post.size):
            continue
        edge = "top" if sign > 0 else "bottom"
        pct = 100.0 * n_at / post.size
        if lsb > 0 and info.vertical_scale is not None:  # (lsb > 0 only with a known scale)
            yzero = info.yzero or 0.0
            offset = info.vertical_offset or 0.0
            for centre in {yzero - offset, yzero + offset}:
                rail = centre + sign * (127 if sign > 0 else 128) * lsb
                if abs(extreme - rail) <= RAIL_TOLERANCE_LSB * lsb:
                    scale = float(info.vertical_scale)
                    fit = fitting_volts_per_div(scale, info.probe_atten)
                    return (f"the {resp.role} capture is clipped: flat at the screen's {edge} edge "
                            f"({extreme:.4g} V at {scale:g} V/div) on {pct:.0f}% of the record after the step; "
                            f"record again at {fit:g} V/div or more (or move the trace with the vertical "
                            "position)", True)
        # no rail known: a long run at exactly the extreme, entered while still moving fast
        run = _longest_run(at)
        if run < max(20, 0.10 * post.size):
            continue
        start = int(np.argmax(at))
        span = extreme - float(np.median(pre)) if pre.size else np.nan
        if not np.isfinite(span) or span == 0 or start == 0:
            continue
        if _steep_entry(t[pre.size :], post, start, extreme, span):
            return (f"the {resp.role} capture looks clipped: it sits at exactly {extreme:.4g} V (its {edge} "
                    f"value) on {pct:.0f}% of the record after the step and reached it without slowing down "
                    "(a response settles gradually); if the scope screen or an amplifier limited it, record "
                    "again with a larger volts/div", False)
    return None


def _steep_entry(tp: np.ndarray, post: np.ndarray, start: int, extreme: float, span: float) -> bool:
    """Whether the trace entered its flat run still moving fast.

    The rise up to the run is cut in tenths of the span; a natural response settles, so its
    last tenth takes many times longer than its fastest tenth, while a clipped one is cut off
    mid-rise: its last tenth takes at most three times the fastest (a first order clipped
    below about 70 % of its final value).
    """
    frac = (post[:start + 1] - (extreme - span)) / span  # 0 at the baseline, 1 at the extreme
    crossings = []
    for k in range(1, 10):
        idx = np.nonzero(frac >= k / 10)[0]
        if idx.size == 0:
            return False
        crossings.append(tp[idx[0]])
    crossings.append(tp[start])
    bands = np.diff(crossings)
    dt = float(np.median(np.diff(tp)))
    fastest = max(float(np.min(bands[:-1])), dt)
    return bool(bands[-1] <= 3.0 * fastest)


def _longest_run(mask: np.ndarray) -> int:
    if not mask.any():
        return 0
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, ends = np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]
    return int((ends - starts).max())


def no_dynamics(resp: StepResponse, quantum: float = 0.0) -> str | None:
    """A velocity or position that is at its final level one sample after the step.

    Such a trace has no dynamics to identify at this sample rate (the time base is far too
    slow for the motor) or is not a motor response at all (the step itself saved as CH2).

    Parameters
    ----------
    resp : StepResponse
        The synchronised step response (time 0 at the step).
    quantum : float
        The recording's quantisation step in volts (0 when unknown).

    Returns
    -------
    str or None
        Why the trace has no dynamics, or ``None`` when it has.
    """
    if resp.role not in ("velocity", "position"):
        return None  # the armature current may legitimately jump within a sample
    pre, post = split_at(np.asarray(resp.time_s, dtype=float), np.asarray(resp.output_v, dtype=float))
    if post.size < 10:
        return None
    base = float(np.median(pre)) if pre.size else 0.0
    final = float(np.median(post[-max(post.size // 5, 1):])) - base
    noise = float(np.percentile(np.abs(pre - base), 99)) if pre.size >= 10 else 0.0
    if abs(final) <= max(4.0 * noise, 2.0 * quantum, 1e-12):
        return None
    second = float(post[min(1, post.size - 1)]) - base
    if second / final < 0.9:
        return None  # (most responses: no array of the record's length for the rest)
    rel = (post - base) / final
    if float(np.max(rel)) <= 1.1 and float(np.min(rel[1:])) >= 0.9:
        dt = resp.sample_interval_s
        return (f"the {resp.role} capture jumps to its final level within one sample ({dt:.3g} s) of the step "
                "and stays there: no dynamics to identify at this sample rate; use a faster time base "
                "(s/div), or check that CH2 is the motor's response and not the step itself")
    return None


#: A velocity whose last tenth is within this fraction of its peak change from its pre-step level
#: has fallen back to rest.
BACK_TO_REST = 0.2


def falls_back_to_rest(resp: StepResponse, record_length_s: float | None = None) -> str | None:
    """A velocity that rises after the step and falls back to its pre-step level before the record ends.

    The motor stopped (an end stop, a brake, the drive switched off): a step model of the whole
    record is wrong, its first part is a step response.

    Parameters
    ----------
    resp : StepResponse
        A velocity step response.
    record_length_s : float, optional
        The seconds after the step the identification keeps (``--record-length``).

    Returns
    -------
    str or None
        The warning (with the ``--record-length`` that keeps the step part), or None.
    """
    t, y = resp.time_s, resp.output_v
    if record_length_s is not None:
        # (increasing times: the kept part is a prefix, a view)
        keep = int(np.searchsorted(t, record_length_s, side="right"))
        t, y = t[:keep], y[:keep]
        resp = replace(resp, time_s=t, output_v=y, input_v=np.asarray(resp.input_v)[: t.size])
    pre, post = split_at(t, y)
    if pre.size < 2 or post.size < 20:
        return None
    base = float(np.median(pre))
    peak = _peak_change(post, base)
    n_tail = max(2, post.size // 10)
    tail = post[-n_tail:] - base
    if peak == 0 or abs(float(np.median(tail))) > BACK_TO_REST * abs(peak):
        return None
    u = np.asarray(resp.input_v, dtype=float)
    if u.size == y.size and abs(float(np.median(u[-n_tail:]) - np.median(u[: pre.size]))) < 0.5 * abs(resp.step_volts):
        return None  # the input went back too (a pulse): the motor did what it was told
    ta, ya = t[pre.size :], post - base
    i_peak = int(np.argmax(np.abs(ya)))
    falling = np.flatnonzero(np.abs(ya[i_peak:]) < 0.5 * abs(peak))
    t_stop = float(ta[i_peak + falling[0]]) if falling.size else float(ta[-1])
    return (f"the velocity falls back to its pre-step level {t_stop:.3g} s after the step (the motor stopped: an "
            f"end stop, a brake or the drive switched off); a step model of the whole record is wrong: keep the "
            f"step part with --record-length {0.9 * t_stop:.3g}")


def check_step_responses(captures: Mapping[str, Capture], responses: Mapping[str, StepResponse], *,
                         record_length_s: float | None = None) -> list[str]:
    """Refuse responses that cannot give a model; return warnings about doubtful ones.

    Parameters
    ----------
    captures : Mapping[str, Capture]
        The captures keyed by role.
    responses : Mapping[str, StepResponse]
        Their step responses (same keys).
    record_length_s : float, optional
        The seconds after the step the identification keeps.

    Returns
    -------
    list of str
        Warnings, each naming the file.

    Raises
    ------
    ConditioningError
        A response that does not move after the step, a velocity/position clipped at the
        scope's rails, or one that jumps to its final level within one sample.
    """
    warnings: list[str] = []
    for role, resp in responses.items():
        cap = captures[role]
        q = _quantum(cap.output_v, cap.output_info)
        why = stalled_response(resp, q)
        if why is not None and role == "current" and "constant" not in why:
            # brush noise and PWM ripple can hide a small current change: warn, the velocity
            # or position decides whether the motor moved
            warnings.append(f"{resp.source}: the current capture barely moves after the step: {why}")
        elif why is not None:
            raise ConditioningError(
                f"the {role} capture does not move after the step at {resp.edge.time_s + 0.0:.6g} s: {why}; check that "
                "the motor turned (power, brake, wiring) and that the right channel was saved",
                file=resp.source)
        clip = clipping(cap, resp)
        if clip is not None:
            text, certain = clip
            if certain and role in ("velocity", "position"):
                raise ConditioningError(f"{text}; a clipped {role} gives a wrong gain and time constant",
                                        file=resp.source)
            warnings.append(f"{resp.source}: {text}")
        jump = no_dynamics(resp, q)
        if jump is not None:
            raise ConditioningError(jump, file=resp.source)
        stop = falls_back_to_rest(resp, record_length_s) if role == "velocity" else None
        if stop is not None:
            warnings.append(f"{resp.source}: {stop}")
    return warnings
