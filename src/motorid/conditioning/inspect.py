"""What ``motorid inspect`` says about a capture: format, timing, step, role, encoder wraps.

This module only combines the readers (:mod:`motorid.io`) with the conditioning steps
(:mod:`motorid.conditioning`); it holds no signal processing of its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from motorid._threads import single_blas_thread
from motorid.capture import Capture
from motorid.conditioning.edge import StepEdge, response_onset, step_edge
from motorid.conditioning.response import may_count, step_timing
from motorid.conditioning.role import guess_role
from motorid.conditioning.unwrap import unwrap_position
from motorid.errors import MotorIdError, StepNotFoundError

__all__ = ["CaptureSummary", "describe_capture"]


@dataclass(frozen=True, slots=True)
class CaptureSummary:
    """The facts ``motorid inspect`` reports for one capture (docs/formats.md, Inspect JSON).

    Attributes
    ----------
    file : str
        The file or folder the capture came from.
    format : str
        ``tds2000-csv``, ``xlsx`` or ``plain-csv``.
    sample_interval_s : float
        Sample interval in seconds.
    n_samples : int
        Number of samples.
    step : StepEdge or None
        The step found (on the file's own time axis), ``None`` if there is none.
    step_volts : float or None
        Step amplitude in volts: from the input channel, or ``--step-volts`` when the capture
        has no input channel (``None`` if unknown).
    role, role_reason : str
        Guessed role (``position``, ``velocity``, ``current`` or ``unknown``) and why.
    wraps : int
        Encoder wraps found in the output channel (0 unless the role is ``position``).
    warnings : tuple of str
        Everything a user should know (clipping, no step, no input channel, …).
    timing : str or None
        Where ``identify`` puts the step instant (:func:`~motorid.conditioning.response.step_timing`):
        ``logged`` (at the stamp of a log's command), ``sampled`` (in the interval before the
        first sample at the new level: a scope's channel, a log's measured voltage) or ``onset``
        (read off the response); ``None`` without a step.
    count_step, count_hold, count_over_stamps : float, int, bool
        A log's output column in whole encoder counts (:attr:`motorid.capture.Capture.count_step`
        and the rest): the step, the lines each value is kept for, whether the counts are over each
        line's own stamped interval; ``count_step`` 0 for none.
    """

    file: str
    format: str
    sample_interval_s: float
    n_samples: int
    step: StepEdge | None
    step_volts: float | None
    role: str
    role_reason: str
    wraps: int
    warnings: tuple[str, ...]
    timing: str | None = None
    count_step: float = 0.0
    count_hold: int = 1
    count_over_stamps: bool = False

    def to_json(self) -> dict[str, Any]:
        """The docs/formats.md ``inspect --json`` object (extra keys are additions).

        Returns
        -------
        dict
            JSON-able.
        """
        step = None
        if self.step is not None:
            step = {
                "time": self.step.time_s,
                "volts": self.step_volts,
                "index": self.step.index,
                "baseline": self.step.baseline_v,
                "method": self.step.method,
                **({"timing": self.timing} if self.timing is not None else {}),
            }
        return {
            "file": self.file,
            "format": self.format,
            "sample_interval": self.sample_interval_s,
            "n_samples": self.n_samples,
            "step": step,
            "role": self.role,
            "role_reason": self.role_reason,
            "wraps": self.wraps,
            "warnings": list(self.warnings),
            **({"counts": {"step": self.count_step, "hold": self.count_hold, "over_stamps": self.count_over_stamps}}
               if self.count_step > 0 else {}),
        }

    def counts_line(self) -> str | None:
        """What the output's whole counts mean for ``identify``, one line; ``None`` when it has none.

        Returns
        -------
        str or None
        """
        if self.count_step <= 0:
            return None
        step = f"{self.count_step:.4g}"
        if self.count_over_stamps:
            return (f"its values times their stamped intervals are whole counts ({step} over the median interval): "
                    "a count of encoder edges over each interval its clock measured; identify fits it so")
        held = f", each kept for {self.count_hold} lines" if self.count_hold > 1 else ""
        return (f"its values come in whole steps of {step}{held}: a count of encoder edges over each line may give "
                "that, or an ADC's codes; identify fits it as samples with timing intervals that hold the counted "
                "reading too (--counted-velocity if it counts)")


def _find_step(capture: Capture, step_volts: float | None) -> tuple[StepEdge | None, float | None, list[str]]:
    warnings: list[str] = []
    try:
        if capture.input_v is not None:
            edge = step_edge(capture.time_s, capture.input_v, file=capture.source)
            return edge, edge.amplitude_v, warnings
        if step_volts is not None:
            edge = response_onset(capture.time_s, capture.output_v, file=capture.source)
            return edge, float(step_volts), warnings
        # A lone channel: it may be the step input itself (CH1 saved alone).
        try:
            edge = step_edge(capture.time_s, capture.output_v, file=capture.source)
            warnings.append("no input channel: the single channel is read as the step itself")
            return edge, edge.amplitude_v, warnings
        except StepNotFoundError:
            edge = response_onset(capture.time_s, capture.output_v, file=capture.source)
            warnings.append("no input channel: step instant from the response onset; "
                            "step volts unknown (give --step-volts)")
            return edge, None, warnings
    except StepNotFoundError as exc:
        warnings.append(f"no step: {exc.message}")
        return None, None, warnings


@single_blas_thread
def describe_capture(capture: Capture, *, step_volts: float | None = None) -> CaptureSummary:
    """Describe one capture for ``motorid inspect``.

    Parameters
    ----------
    capture : Capture
        A capture from any reader.
    step_volts : float, optional
        The step level, for captures without an input channel (``--step-volts``).

    Returns
    -------
    CaptureSummary
        Format, timing, step, role (with the reason) and encoder wraps.  A capture with no
        step is described too: ``step`` is ``None`` and a warning says so.
    """
    edge, volts, warnings = _find_step(capture, step_volts)
    guess = guess_role(capture)
    wraps = 0
    if guess.role == "position":
        try:
            unwrapped = unwrap_position(capture.output_v, file=capture.source)
        except MotorIdError as exc:
            warnings.append(f"position not unwrapped: {exc.message}")
        else:
            wraps = unwrapped.wraps
            warnings.extend(unwrapped.warnings)
    counted = capture.count_over_stamps and guess.role in ("velocity", "unknown")
    return CaptureSummary(
        file=capture.source,
        format=capture.format,
        sample_interval_s=capture.sample_interval_s,
        n_samples=capture.n_samples,
        step=edge,
        step_volts=volts,
        role=guess.role,
        role_reason=guess.reason,
        wraps=wraps,
        warnings=tuple(capture.warnings) + tuple(warnings),
        timing=None if edge is None else step_timing(capture, edge),
        # (what identify makes of them: a velocity's, in a counted speed's unit or none)
        count_step=capture.count_step if counted or may_count(capture, guess.role) else 0.0,
        count_hold=capture.count_hold,
        count_over_stamps=counted,
    )
