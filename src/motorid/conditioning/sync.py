"""Synchronisation of several captures of one experiment on their step edges.

The paper aligns the position, velocity and current captures by hand in Excel and trims them
to a common length (Masoud 2019, section V-1).  Each capture is a separate acquisition with
its own trigger offset, so the edges sit at different samples and, in general, at different
sub-sample phases.  ``method="index"`` does what the paper does (the samples from the edge
on, trimmed to the shortest); ``method="interp"`` puts all captures on one grid starting
exactly at the edge (linear interpolation, ``numpy.interp``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from motorid.blockwise import BLOCK
from motorid.conditioning.response import StepResponse
from motorid.errors import ConditioningError, OptionError

__all__ = ["SYNC_METHODS", "Synchronised", "blocked_interp", "grid_times", "level_throughout", "synchronise"]

#: Values of ``method`` (the command line's ``--sync``).
SYNC_METHODS: tuple[str, ...] = ("interp", "index")


@dataclass(frozen=True, slots=True)
class Synchronised:
    """Captures on one time grid from the step edge.

    Attributes
    ----------
    time_s : ndarray
        Common time from the step edge (starts at 0).
    input_v : ndarray
        Input increment (from the first response that has a measured input); a read-only
        broadcast of the step level when the input stays at it after the edge.
    outputs : dict[str, ndarray]
        Output increment of each response, keyed by role.
    sources : dict[str, str]
        File of each role.
    """

    time_s: np.ndarray
    input_v: np.ndarray
    outputs: dict[str, np.ndarray]
    sources: dict[str, str]


def synchronise(
    responses: Sequence[StepResponse],
    *,
    length_s: float | None = None,
    method: str = "interp",
) -> Synchronised:
    """Align step responses on their edges and trim them to a common length.

    Parameters
    ----------
    responses : sequence of StepResponse
        One per capture, with distinct roles.
    length_s : float, optional
        Record length after the edge to keep (the paper's 1.9/2.4/2.9 s); all that the
        shortest capture has when omitted.
    method : str
        ``"interp"`` (common grid from t = 0) or ``"index"`` (the paper's: samples from the
        edge on).

    Returns
    -------
    Synchronised
        The aligned signals.

    Raises
    ------
    ConditioningError, OptionError
        Duplicate roles, different sample intervals with ``method="index"``, or a record
        length longer than the captures hold.

    References
    ----------
    Masoud 2019, section V-1.
    """
    if not responses:
        raise OptionError("no captures to synchronise")
    roles = [r.role for r in responses]
    if len(set(roles)) != len(roles):
        raise OptionError(f"two captures given for the same role: {roles}")
    if method not in SYNC_METHODS:
        raise OptionError(f"unknown synchronisation method {method!r}; use interp or index")
    dt = min(r.sample_interval_s for r in responses)
    avail = min(float(r.time_s[-1]) for r in responses)
    if length_s is not None:
        if length_s > avail + 0.5 * dt:
            worst = min(responses, key=lambda r: r.time_s[-1])
            raise ConditioningError(
                f"record length {length_s:g} s is longer than the {avail:.4g} s after the step",
                file=worst.source,
            )
        avail = float(length_s)
    outputs: dict[str, np.ndarray] = {}
    if method == "index":
        dts = [r.sample_interval_s for r in responses]
        if max(dts) - min(dts) > 1e-6 * max(dts):
            raise ConditioningError("captures have different sample intervals: use method interp")
        n = int(np.floor(avail / dt + 1e-9)) + 1
        n = min([n] + [r.time_s.size - r.edge.index for r in responses])
        time = np.arange(n) * dt
        for r in responses:
            outputs[r.role] = r.output_v[r.edge.index : r.edge.index + n].copy()
        u = responses[0].input_v[responses[0].edge.index : responses[0].edge.index + n].copy()
    else:
        on_grid = _own_grid(responses, avail)
        if on_grid is not None:
            # logs sampled on one grid from their edges (the logged input changes at a stamp): their
            # own samples are the interpolation's values (to a millionth of a sample's change), as
            # read-only views instead of copies (80 MB fewer for a 10 M-row log's velocity)
            time, views = on_grid
            n = time.size
            outputs.update(views)
        else:
            n = int(np.floor(avail / dt + 1e-9)) + 1
            time = grid_times(n, dt)
            for r in responses:
                outputs[r.role] = blocked_interp(time, r.time_s, r.output_v)
        # the input is a step: after the edge it is its level (interpolating would smear
        # the edge sample); keep its recorded wiggles after the edge
        r0 = responses[0]
        level = r0.input_v[r0.edge.index]
        if level_throughout(time, r0.time_s, r0.input_v, float(level)):
            # a logged step that stays at its level: the interpolation is that level at every
            # sample (0·slope + level); a read-only view of the one number instead of an array of
            # the record's length (80 MB for a 10 M-sample log)
            u = np.broadcast_to(np.float64(level), (n,))
        else:
            u = np.interp(time, r0.time_s, r0.input_v)
            u[0] = level
    return Synchronised(time, u, outputs, {r.role: r.source for r in responses})


#: How far, in samples, a log's stamp may sit off the grid ``k·dt`` for its own sample to stand for
#: the interpolation onto it: a millionth of a sample moves a value by a millionth of a sample's change.
ON_GRID_TOL = 1e-6


def _own_grid(responses: Sequence[StepResponse], avail: float) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
    """The grid and each log's own samples on it, when every response is a log sampled on one grid from its edge.

    Only logs (``timing == "logged"``: a logged input's change fixes each edge at a stamp), whose
    records can be long; a scope's record keeps its interpolation.  The grid is ``k·dt`` with ``dt``
    the mean step of the first response's stamps from its edge to its end: the median of a long
    log's steps is off by their rounding, which ``k`` multiplies (2e-3 of a sample at the end of a
    10 M-row log).  ``None`` when a stamp from an edge on is further than :data:`ON_GRID_TOL` of a
    sample from the grid, or a record is shorter than the common length.
    """
    if any(r.timing != "logged" for r in responses):
        return None
    first = responses[0]
    i0 = first.edge.index
    t = first.time_s
    if t.size - i0 < 3:
        return None
    dt = float(t[-1] - t[i0]) / (t.size - 1 - i0)
    if not (np.isfinite(dt) and dt > 0):
        return None
    n = int(np.floor(avail / dt + 1e-9)) + 1
    views: dict[str, np.ndarray] = {}
    for r in responses:
        j0 = r.edge.index
        if r.time_s.size - j0 < n or not _stamps_on_grid(r.time_s[j0 : j0 + n], dt):
            return None
        view = r.output_v[j0 : j0 + n]
        view.flags.writeable = False
        views[r.role] = view
    return grid_times(n, dt), views


def _stamps_on_grid(stamps: np.ndarray, dt: float) -> bool:
    """Whether ``|stamps[k] − k·dt| ≤ ON_GRID_TOL·dt`` for every ``k`` (in blocks: no full-length temporary)."""
    tol = ON_GRID_TOL * dt
    for start in range(0, stamps.size, BLOCK):
        block = stamps[start : start + BLOCK]
        grid = np.arange(start, start + block.size, dtype=float)
        grid *= dt
        np.subtract(block, grid, out=grid)
        if not bool(np.all(np.abs(grid, out=grid) <= tol)):
            return False
    return True


def blocked_interp(x: np.ndarray, xp: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """``np.interp(x, xp, fp)``, the same bits, a block of ``x`` at a time.

    ``np.interp`` keeps an array of slopes as long as ``xp`` when ``xp`` is no longer than ``x``
    (80 MB beside the result for a 10 M-sample record); given a block of ``x`` and the nodes that
    bracket it, it computes each slope as it goes, by the same formula.  Each block's nodes run
    from the last one at or before its first sample to the first one after its last sample, so
    every sample has the bracket, and therefore the value, of the whole call (the right end's
    ``fp[-1]`` only at the record's end, as there).

    Parameters
    ----------
    x : ndarray
        Increasing sample times.
    xp, fp : ndarray
        The nodes, as for :func:`numpy.interp` (``xp`` increasing).

    Returns
    -------
    ndarray
        The interpolated values.
    """
    out = np.empty(x.size)
    for start in range(0, x.size, BLOCK):
        block = x[start : start + BLOCK]
        lo = max(int(np.searchsorted(xp, block[0], side="right")) - 1, 0)
        hi = min(int(np.searchsorted(xp, block[-1], side="right")) + 1, xp.size)
        out[start : start + block.size] = np.interp(block, xp[lo:hi], fp[lo:hi])
    return out


def grid_times(n: int, dt: float) -> np.ndarray:
    """``np.arange(n) * dt``, the same bits without the array of integers (one array, not two).

    Parameters
    ----------
    n : int
        Number of samples.
    dt : float
        Sample interval in s.

    Returns
    -------
    ndarray
        The grid ``k·dt``, ``k = 0 … n−1``.
    """
    # the integers below 2**53 are exact in float64: the products are those of the integer arange
    time = np.arange(n, dtype=float)
    time *= dt
    return time


def level_throughout(time: np.ndarray, xp: np.ndarray, fp: np.ndarray, level: float) -> bool:
    """Whether ``np.interp(time[1:], xp, fp)`` is ``level`` at every sample, bit for bit.

    True when every node ``np.interp`` reads for ``time[1:]`` (from the one at or before
    ``time[1]`` to the one after ``time[-1]``, or the right end) holds ``level``: each sample is then
    a node's value, the right end's, or ``0·(x − xp[j]) + level``, all ``level`` (checked in
    blocks: no full-length temporary).  A zero or non-finite level is left to ``np.interp``
    (``0·s + (−0.0)`` is ``+0.0``).

    Parameters
    ----------
    time : ndarray
        Increasing sample times, at least two.
    xp, fp : ndarray
        The nodes, as for :func:`numpy.interp` (``xp`` strictly increasing).
    level : float
        The value looked for.

    Returns
    -------
    bool
        Whether the interpolation after the first sample is ``level`` throughout.
    """
    if time.size < 2 or level == 0.0 or not np.isfinite(level):
        return False
    lo = int(np.searchsorted(xp, time[1], side="right")) - 1
    if lo < 0:
        return False  # samples left of the first node take fp[0] (np.interp's left)
    hi = min(int(np.searchsorted(xp, time[-1], side="right")) + 1, fp.size)
    return all(bool(np.all(fp[start : min(start + BLOCK, hi)] == level)) for start in range(lo, hi, BLOCK))
