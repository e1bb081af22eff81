"""Guess what a capture measured (position, velocity, current) from its signal.

Used by ``motorid inspect`` and to check the ``--position/--velocity/--current`` flags.
Criteria, in order: the file's own label (column name) wins; a sawtooth with wraps is a
position; after the step, a signal that keeps growing at a steady (not slowing) rate is a
position (integrator), one that peaks well above its final value and falls back is an
armature current, one that rises and settles is a velocity.

:func:`role_conflict` is the check behind the command line's ``--position/--velocity/
--current`` flags: it names the role a capture *confidently* looks like when that is not the
role it was given as (a guess of ``unknown``, or a guess that is not confident, never
conflicts).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from motorid.capture import Capture
from motorid.conditioning.edge import response_onset, step_edge
from motorid.conditioning.unwrap import unwrap_position
from motorid.errors import MotorIdError

__all__ = ["RoleGuess", "classify_response", "guess_role", "role_conflict"]

#: A response whose final level is below this fraction of its peak is an armature current.
CURRENT_FINAL_OF_PEAK = 1.0 / 1.5
#: A rise is a velocity's (concave from its onset on) when, counted from its 10 % crossing
#: (so that a dead time does not count), it reaches 50 % of its final level within this
#: fraction of the time it takes to reach 90 %: first order 0.27, a double pole 0.34; a
#: position that ramps at a constant rate to a stop 0.5, one that starts as a parabola more.
VELOCITY_T50_OF_T90 = 0.42
#: A position keeps rising at the end at no less than this fraction of its rate just before.
POSITION_RATE_KEPT = 0.8


@dataclass(frozen=True, slots=True)
class RoleGuess:
    """A guessed role and the reason, in words a user can check.

    Attributes
    ----------
    role : str
        ``position``, ``velocity``, ``current`` or ``unknown``.
    reason : str
        Why, in words a user can check against the trace.
    confident : bool
        Whether the evidence is strong enough to refuse a capture given as another role
        (:func:`role_conflict`).
    """

    role: str
    reason: str
    confident: bool = True


def classify_response(y: np.ndarray) -> RoleGuess:
    """Classify the part of a step response after the step (baseline already removed).

    Parameters
    ----------
    y : ndarray
        Response samples from the step onwards, pre-step baseline subtracted.

    Returns
    -------
    RoleGuess
        ``position`` (still rising at the end, not slowing down), ``current`` (peak > 1.5 ×
        final), ``velocity`` (rises and settles; confident when the rise is concave from the
        step on, see :data:`VELOCITY_T50_OF_T90`) or ``unknown``.
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    if n < 10 or not np.all(np.isfinite(y)):
        return RoleGuess("unknown", "too few samples after the step", confident=False)
    peak = float(np.max(np.abs(y)))
    if peak == 0:
        return RoleGuess("unknown", "flat after the step", confident=False)
    sgn = np.sign(y[np.argmax(np.abs(y))])
    z = y * sgn / peak
    final = float(np.mean(z[-max(2, n // 10):]))
    q = n // 4
    x = np.arange(q)
    slope_last = float(np.polyfit(x, z[-q:], 1)[0]) * n  # change per record, in peaks
    slope_prev = float(np.polyfit(x, z[-2 * q : -q], 1)[0]) * n
    # an integrator's rate never falls (its derivative, the velocity, rises and settles); a
    # velocity that is still settling at the end of a short record slows down
    if final > 0.9 and slope_last > 0.3 and slope_last >= POSITION_RATE_KEPT * slope_prev:
        return RoleGuess("position", "keeps rising at a steady rate after the step (integrates velocity)")
    if final < CURRENT_FINAL_OF_PEAK:
        # a final level near zero (or past it) has no meaningful ratio: "1000000000.0×" said nothing
        how = (f"peaks at {1 / final:.1f}× its final value and falls back" if final >= 0.01
               else f"peaks and falls back to {100 * final:.2g} % of its peak" if final >= 0
               else f"peaks and falls back past its pre-step level (to {100 * final:.2g} % of its peak)")
        return RoleGuess("current", how)
    if abs(slope_last) < 0.1:
        i10, i50, i90 = (int(np.argmax(z >= f * final)) for f in (0.1, 0.5, 0.9))
        concave = i90 > i10 and (i50 - i10) <= VELOCITY_T50_OF_T90 * (i90 - i10)
        return RoleGuess(
            "velocity",
            f"rises after the step and settles to a constant level, reaching 10/50/90 % of it "
            f"{i10}/{i50}/{i90} samples after the step",
            confident=concave,
        )
    return RoleGuess("unknown", "neither settles nor rises steadily", confident=False)


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
        return RoleGuess("unknown", "no step found to judge the response by", confident=False)
    base = float(np.mean(y[: max(1, edge.index)]))
    return classify_response(y[edge.index :] - base)


def _label_role(capture: Capture) -> str | None:
    """The role the output channel's own label (column header) names, if any."""
    from motorid.io._table import role_from_name  # io reads the labels; imported late (layering)

    return role_from_name(capture.output_info.name or "")


def role_conflict(capture: Capture, declared: str) -> RoleGuess | None:
    """The role a capture confidently looks like, when it is not the role it was given as.

    The capture's ``role_hint`` is ignored (the readers set it from the user's flag); the
    output channel's own label (a plain-CSV or spreadsheet column header such as
    ``position_raw``) is evidence, then the signal (:func:`guess_role`).

    Parameters
    ----------
    capture : Capture
        The capture as read.
    declared : str
        The role the user gave it (``position``, ``velocity`` or ``current``).

    Returns
    -------
    RoleGuess or None
        ``None`` when the capture may well be ``declared`` (including every ``unknown`` or
        not confident guess); else the role it looks like and why.
    """
    label = _label_role(capture)
    if label is not None:
        if label == declared:
            return None
        return RoleGuess(label, f"its column is named {capture.output_info.name!r}")
    guess = guess_role(replace(capture, role_hint=None))
    if guess.role in ("unknown", declared) or not guess.confident:
        return None
    return guess
