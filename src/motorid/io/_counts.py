"""Whether a logged speed comes in whole encoder counts: the step its values are multiples of.

Private to :mod:`motorid.io`.  A speed an Arduino sketch or a Raspberry Pi loop prints from the
encoder edges counted since the last line is ``n · c / T``: whole counts ``n`` of one edge's
angle ``c`` over the interval ``T``.  Its values are then multiples of one step ``c / T`` (a sketch
that divides by its nominal loop time), or its values times their stamped intervals are
multiples of ``c`` (a loop that divides by the clock's own interval, which jitters).  This is
read off the raw column, before jittered stamps are resampled (which would blur it), and kept on
the capture (:attr:`motorid.capture.Capture.count_step`).

A sampled tacho read through an ADC and printed in rpm also comes in steps at a steady rate,
so the step says that the column *may* count, not that it does: the identification widens its
timing intervals by what counting would change, and ``--counted-velocity`` says that it does.

numpy and scipy have no approximate greatest common divisor of real numbers, hence this module.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["COUNT_MAX_DIVISOR", "COUNT_MIN_LEVELS", "COUNT_MIN_VALUES", "COUNT_SHARE", "CountLattice",
           "count_hold", "count_lattice", "print_resolution"]

#: The share of the non-zero values that must lie within the print's rounding of a multiple of the step.
COUNT_SHARE = 0.99
#: Non-zero values needed before a step is looked for.
COUNT_MIN_VALUES = 20
#: Distinct multiples the values must take (a speed that rises through its counts, not two levels).
COUNT_MIN_LEVELS = 5
#: The step is looked for as the smallest non-zero value divided by 1 … this (the fewest counts seen:
#: a Raspberry Pi loop at 20 ms printed 44 counts or more once the motor moved).
COUNT_MAX_DIVISOR = 250
#: Each candidate step is screened on this many non-zero values before all are checked.
COUNT_SCREEN = 200
#: The step must be at least this many times the print's rounding (not the printed decimals' own grid): a
#: value off the counts then lands within one rounding of a multiple by chance at most once in five, and
#: 99 % of 20 or more values never do.
COUNT_MIN_RESOLUTIONS = 10
#: The most counts one value may hold: a step finer than the largest value over this is not looked for
#: (an encoder line with a million edges is none a log prints; and the counts' squares stay finite).
COUNT_MAX_COUNTS = 1e6
#: Runs of one value a held speed needs, and the share of them whose length is a multiple of the hold.
HOLD_MIN_RUNS, HOLD_SHARE = 10, 0.8
#: At most this many rows are looked at (pairs of consecutive lines spread over a longer log).
COUNT_ROWS = 100_000


def print_resolution(values: np.ndarray, max_decimals: int = 9) -> float:
    """The decimal resolution a column was printed with (0.1 for ``%.1f``), 0 when finer than ``1e-max_decimals``.

    Parameters
    ----------
    values : ndarray
        The column's finite values.
    max_decimals : int
        The most decimals looked for.

    Returns
    -------
    float
    """
    v = np.asarray(values, dtype=float)
    for k in range(max_decimals + 1):
        s = v * 10.0**k
        if np.all(np.abs(s - np.rint(s)) <= 1e-9 + 1e-12 * np.abs(s)):
            return 10.0 ** -k
    return 0.0


def _refined(q: float, b: np.ndarray) -> float:
    """The step ``q`` fitted to the ascending values ``b`` (least squares on their counts), from the smallest up.

    A step taken from the smallest value carries that value's rounding, which grows with the
    count: the counts are taken on the values up to twice the last bound at a time, each time
    with the step the smaller ones fitted.
    """
    bound = 4.0 * q
    while True:
        part = b[: int(np.searchsorted(b, bound, side="right"))]
        k = np.rint(part / q)
        if np.any(k > 0):
            q = float(np.sum(k * part) / np.sum(k * k))
        if part.size == b.size:
            return q
        bound *= 2.0


def _lattice(a: np.ndarray, tol: np.ndarray) -> float:
    """The largest step every value of ``a`` (apart from zero) is a whole multiple of, within ``tol``; 0 for none."""
    nz = np.abs(a) > tol
    if int(np.count_nonzero(nz)) < COUNT_MIN_VALUES:
        return 0.0
    b, t = np.abs(a[nz]), tol[nz]
    order = np.argsort(b)
    b, t = b[order], t[order]
    floor = max(COUNT_MIN_RESOLUTIONS * float(np.median(t)), float(b[-1]) / COUNT_MAX_COUNTS)
    # screened on an even spread of the values (their smallest and largest among them) before all are checked
    pick = np.unique(np.linspace(0, b.size - 1, min(COUNT_SCREEN, b.size)).astype(int))
    few, few_t = b[pick], t[pick]
    for m in range(1, COUNT_MAX_DIVISOR + 1):
        q = float(b[0]) / m
        if q <= floor:
            break
        q = _refined(q, few)
        if np.mean(np.abs(few - np.rint(few / q) * q) <= few_t + 1e-12 * few) < COUNT_SHARE:
            continue
        q = _refined(q, b)
        k = np.rint(b / q)
        near = np.abs(b - k * q) <= t + 1e-12 * b
        if np.mean(near) >= COUNT_SHARE and np.unique(k[near]).size >= COUNT_MIN_LEVELS:
            return q
    return 0.0


class CountLattice(NamedTuple):
    """What :func:`count_lattice` reads off a speed column.

    Attributes
    ----------
    step : float
        The step its values come in (one count over the median interval), 0 for none.
    over_stamps : bool
        The counts are over each line's own stamped interval (its values on no grid).
    hold : int
        Lines each value is kept for (a firmware that counts over several lines and logs every
        line): 1 when it changes from line to line.
    """

    step: float
    over_stamps: bool
    hold: int


def count_hold(values: np.ndarray) -> int:
    """Lines a moving speed's value is kept for: the commonest run of one value, if most runs are its multiples.

    A firmware that counts encoder edges over five loops and logs every loop prints each count
    five times (runs of 5, or 10 when two counts agree); a speed counted every line has runs of 1.

    Parameters
    ----------
    values : ndarray
        The column, consecutive lines.

    Returns
    -------
    int
        At least 1.
    """
    v = np.asarray(values, dtype=float)
    if v.size < 2:
        return 1
    starts = np.r_[0, np.flatnonzero(np.diff(v) != 0) + 1]
    lengths = np.diff(np.r_[starts, v.size])
    runs = lengths[v[starts] != 0][1:-1]  # while it moves; the first and last runs are cut by the record
    if runs.size < HOLD_MIN_RUNS:
        return 1
    kinds, counts = np.unique(runs, return_counts=True)
    mode = int(kinds[np.argmax(counts)])
    return mode if mode >= 2 and float(np.mean(runs % mode == 0)) >= HOLD_SHARE else 1


def count_lattice(time_s: np.ndarray, values: np.ndarray) -> CountLattice:
    """The step a logged speed's values come in when it counts encoder edges over each line, and on what.

    Parameters
    ----------
    time_s : ndarray
        The log's stamps (s), as logged (before any resampling).
    values : ndarray
        The speed column, as logged.

    Returns
    -------
    CountLattice
        ``step``, the step in the column's unit: one count over the median interval (the values are whole
        multiples of it, or their products with their stamped intervals are whole multiples of it
        times the median interval); 0 when neither holds for :data:`COUNT_SHARE` of the non-zero
        values, with at least :data:`COUNT_MIN_LEVELS` multiples, a step of at least
        :data:`COUNT_MIN_RESOLUTIONS` times the print's rounding, and no more than
        :data:`COUNT_MAX_DIVISOR` counts in the smallest non-zero value.
        ``over_stamps``: the values themselves are on no grid, their products with their jittered
        stamped intervals are: each value is a count over the interval its own clock measured, which
        no sampled reading is (an ADC's codes are a grid of the values). ``hold``: the lines each
        value is kept for (:func:`count_hold`, on the lines from the first moving one), 1 without a step.
    """
    t_all = np.asarray(time_s, dtype=float)
    v_all = np.asarray(values, dtype=float)
    none = CountLattice(0.0, False, 1)
    if t_all.size < COUNT_MIN_VALUES + 1:
        return none
    if t_all.size <= COUNT_ROWS:
        t, v = t_all, v_all
        t0, t1, v1 = t[:-1], t[1:], v[1:]
    else:
        # a long log: pairs of consecutive lines spread over all of it (the motion may start late)
        first = np.unique(np.linspace(0, t_all.size - 2, COUNT_ROWS // 2).astype(int))
        t0, t1, v1 = t_all[first], t_all[first + 1], v_all[first + 1]
        t, v = np.r_[t0, t1], np.r_[v_all[first], v1]
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(t))):
        return none
    rv, rt = print_resolution(v), print_resolution(t)
    # a printed value is within half its resolution of the count's: one resolution leaves room for the
    # fitted step's error
    step = _lattice(v, np.full(v.size, rv))
    if step > 0:
        return CountLattice(step, False, _hold_from_motion(v_all))
    dt = t1 - t0
    if np.any(dt <= 0):
        return none
    # a loop that divides its count by its own stamped interval: the value times that interval counts
    per_line = _lattice(v1 * dt, rv * dt + 2.0 * rt * np.abs(v1))
    return CountLattice(per_line / float(np.median(dt)), True, 1) if per_line > 0 else none


def _hold_from_motion(v: np.ndarray) -> int:
    """:func:`count_hold` on at most :data:`COUNT_ROWS` consecutive lines from the first that moves."""
    moving = np.flatnonzero(v != 0)
    return 1 if moving.size == 0 else count_hold(v[int(moving[0]) : int(moving[0]) + COUNT_ROWS])
