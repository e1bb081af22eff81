"""Guess what a capture measured (position, velocity, current) from its signal.

Used by ``motorid inspect`` and to check the ``--position/--velocity/--current`` flags.
Criteria, in order: the file's own label (column name) wins; a sawtooth with wraps is a
position; after the step, a signal that keeps growing at a steady rate is a position
(integrator), one that peaks well above its final value and falls back is an armature
current, one that rises and settles is a velocity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.capture import Capture
from motorid.conditioning.edge import response_onset, step_edge
from motorid.conditioning.unwrap import unwrap_position
from motorid.errors import MotorIdError

__all__ = ["RoleGuess", "guess_role", "classify_response"]


@dataclass(frozen=True, slots=True)
class RoleGuess:
    """A guessed role and the reason, in words a user can check."""

    role: str
    reason: str


def classify_response(y: np.ndarray) -> RoleGuess:
    """Classify the part of a step response after the step (baseline already removed).

    Parameters
    ----------
    y : ndarray
        Response samples from the step onwards, pre-step baseline subtracted.

    Returns
    -------
    RoleGuess
        ``position`` (still rising steadily at the end), ``current`` (peak > 1.5 × final),
        ``velocity`` (rises and settles) or ``unknown``.
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    if n < 10:
        return RoleGuess("unknown", "too few samples after the step")
    peak = float(np.max(np.abs(y)))
    if peak == 0:
        return RoleGuess("unknown", "flat after the step")
    sgn = np.sign(y[np.argmax(np.abs(y))])
    z = y * sgn / peak
    final = float(np.mean(z[-max(2, n // 10):]))
    q = n // 4
    last = z[-q:]
    slope_last = float(np.polyfit(np.arange(q), last, 1)[0]) * n  # change per record, in peaks
    if final > 0.9 and slope_last > 0.3:
        return RoleGuess("position", "keeps rising at a steady rate after the step (integrates velocity)")
    if final < 1.0 / 1.5:
        return RoleGuess("current", f"peaks at {1 / max(final, 1e-9):.1f}× its final value and falls back")
    if abs(slope_last) < 0.1:
        return RoleGuess("velocity", "rises after the step and settles to a constant level")
    return RoleGuess("unknown", "neither settles nor rises steadily")


def guess_role(capture: Capture) -> RoleGuess:
    """Guess the role of a capture's output channel.

    Parameters
    ----------
    capture : Capture
        Any capture.

    Returns
    -------
    RoleGuess
        One of ``position``, ``velocity``, ``current``, ``unknown``, with the reason.
    """
    if capture.role_hint is not None:
        return RoleGuess(capture.role_hint, "named by the file (column or channel label)")
    y = capture.output_v
    try:
        unwrapped = unwrap_position(y, file=capture.source)
    except MotorIdError:
        unwrapped = None
    if unwrapped is not None and unwrapped.wraps > 0:
        return RoleGuess("position", f"sawtooth with {unwrapped.wraps} wrap(s) of {unwrapped.span_v:.3g} V")
    try:
        if capture.input_v is not None:
            edge = step_edge(capture.time_s, capture.input_v, file=capture.source)
        else:
            edge = response_onset(capture.time_s, y, file=capture.source)
    except MotorIdError:
        return RoleGuess("unknown", "no step found to judge the response by")
    base = float(np.mean(y[: max(1, edge.index)]))
    return classify_response(y[edge.index :] - base)
