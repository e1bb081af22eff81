"""One log with several steps (a staircase, a pulse) cut into step experiments.

A rig's log often holds a whole test: the input stepped 0 → 2 → 4 → 6 → 8 V, a few seconds per
level, or up and back down.  Every stage after this one models the response to one step, so the
log is cut at its input's steps: each segment runs from the middle of the plateau before its
step (the pre-step samples give its baseline) to the end of its own plateau, and is an ordinary
step capture from a settled level (or from rest).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from itertools import pairwise

import numpy as np

from motorid.blockwise import BLOCK
from motorid.capture import Capture
from motorid.conditioning.edge import MIN_POST_STEP_SAMPLES, noise_level

__all__ = ["MIN_STEP_FRACTION", "StepSegment", "cut_segment", "find_steps"]

#: A change of the input smaller than this fraction of its range is not a step (a logged command's
#: dither, a PWM duty rounding).
MIN_STEP_FRACTION = 0.05
#: A plateau shorter than this many samples is an edge's ramp, not a level.
MIN_PLATEAU_SAMPLES = 5
#: On a plateau the input stays within this fraction of its nearest step of the level, but for at most
#: :data:`MAX_OFF_LEVEL` of its samples (its first two, an edge's last, are not counted).
MAX_LEVEL_SPREAD, MAX_OFF_LEVEL = 0.25, 0.01
#: The output has settled on a plateau when its last tenth and the tenth before differ by less
#: than this fraction of the step's change of the output.
SETTLED_REL = 0.02


@dataclass(frozen=True, slots=True)
class StepSegment:
    """One step of a multi-step log.

    Attributes
    ----------
    index : int
        1-based, in time order (``--segment N``).
    time_s : float
        Time of the first sample at the new level, on the log's own axis.
    edge : int
        Its sample index.
    start, stop : int
        The samples of the cut, ``[start, stop)``: from the middle of the previous plateau to the
        end of this one.
    from_v, to_v : float
        The input's level before and after (medians of the plateaus).
    settled : bool
        Whether the output settled before the next step (see :data:`SETTLED_REL`): a segment that
        did not is still identified, but its final level is not its steady state.
    unit : str
        The input's unit (the log's: ``V``, or ``pwm``/``%`` for a logged PWM command).
    """

    index: int
    time_s: float
    edge: int
    start: int
    stop: int
    from_v: float
    to_v: float
    settled: bool
    unit: str = "V"

    def describe(self) -> str:
        """One line for the printout.

        Returns
        -------
        str
            ``segment N: step at T s, A → B V`` (and whether the output settled).
        """
        return (f"segment {self.index}: step at {self.time_s:.6g} s, {self.from_v:.4g} → {self.to_v:.4g} {self.unit}"
                + ("" if self.settled else " (the output had not settled before the next step)"))


def find_steps(capture: Capture) -> tuple[StepSegment, ...]:
    """The steps of a capture's recorded input, and where to cut the log for each.

    Parameters
    ----------
    capture : Capture
        A capture with an input channel (without one: no steps are found).

    Returns
    -------
    tuple of StepSegment
        In time order; empty or one step for an ordinary step capture.
    """
    if capture.input_v is None or capture.input_v.size < 3 * MIN_PLATEAU_SAMPLES:
        return ()
    u = np.asarray(capture.input_v, dtype=float)
    span = float(np.ptp(u))
    if span == 0:
        return ()
    # the noise first (its temporaries gone), then the jumps in place: one array of the log's length
    # at a time, not three (240 MB on a 10 M-row log)
    threshold = max(MIN_STEP_FRACTION * span, 8.0 * noise_level(u))
    jump = np.diff(u)
    np.abs(jump, out=jump)
    changes = np.flatnonzero(jump > threshold) + 1  # first sample at the new level
    del jump
    # a change spread over a few samples (a slewing driver) is one step: keep its last sample
    edges = [int(k) for i, k in enumerate(changes) if i + 1 == len(changes) or changes[i + 1] - k > 1]
    if not edges:
        return ()
    bounds = [0, *edges, u.size]
    plateaus = list(pairwise(bounds))
    if any(b - a < MIN_PLATEAU_SAMPLES for a, b in plateaus):
        return ()  # not a staircase of levels: a ramp, a sine, a noisy command
    if any(b - a < MIN_POST_STEP_SAMPLES for a, b in plateaus[1:]):
        # a level held for less than a step needs after it (a controller's brief rail): no staircase
        # whose steps can be identified, and the step path says what the record is
        return ()
    levels = [float(np.median(u[a:b])) for a, b in plateaus]
    jumps = np.abs(np.diff(levels))
    for i, (a, b) in enumerate(plateaus):
        # a level the input wanders off (a controller's output leaving its rail and settling) is no
        # plateau: the log is a closed-loop record, which the step path names as such
        near = float(min(jumps[max(i - 1, 0):i + 1]))
        off = _count_off(u[a + 2:b], levels[i], MAX_LEVEL_SPREAD * near)
        if off > MAX_OFF_LEVEL * (b - a):
            return ()
    unit = getattr(capture.input_info, "units", "") or "V"
    y = np.asarray(capture.output_v, dtype=float)
    out: list[StepSegment] = []
    for i, k in enumerate(edges):
        (a, _), (_, stop) = plateaus[i], plateaus[i + 1]
        start = (a + k) // 2 if i > 0 else 0
        tail = max(2, (stop - k) // 10)
        last, before = float(np.mean(y[stop - tail:stop])), float(np.mean(y[stop - 2 * tail:stop - tail]))
        change = last - float(np.mean(y[max(start, k - tail):k]))
        settled = abs(last - before) <= SETTLED_REL * abs(change) if change else True
        out.append(StepSegment(i + 1, float(capture.time_s[k]), k, start, stop, levels[i], levels[i + 1],
                               bool(settled), unit))
    return tuple(out)


def _count_off(u: np.ndarray, level: float, limit: float) -> int:
    """``count_nonzero(|u − level| > limit)`` in blocks: no temporaries of the log's length."""
    off = 0
    for start in range(0, u.size, BLOCK):
        d = u[start : start + BLOCK] - level
        np.abs(d, out=d)
        off += int(np.count_nonzero(d > limit))
    return off


def cut_segment(capture: Capture, segment: StepSegment) -> Capture:
    """The part of a log that holds one of its steps, as a capture of its own.

    Parameters
    ----------
    capture : Capture
        The whole log.
    segment : StepSegment
        One of :func:`find_steps`'s answers for it.

    Returns
    -------
    Capture
        Same source, format and channels, samples ``[start, stop)``, a note naming the segment.
    """
    sl = slice(segment.start, segment.stop)
    return replace(
        capture,
        time_s=capture.time_s[sl],
        output_v=capture.output_v[sl],
        input_v=None if capture.input_v is None else capture.input_v[sl],
        extra={k: v[sl] for k, v in capture.extra.items()},
        warnings=(*capture.warnings, f"{segment.describe()} of a log with several steps"),
    )
