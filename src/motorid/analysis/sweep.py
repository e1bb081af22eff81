"""Sensitivity of the identified model to record length and sample interval.

Reproduces the paper's Tables 1–3 (Masoud 2019, section VI-A): the same captures identified
for every record length × sample interval, reporting the first-order ``k`` and ``τ`` of each
(``k/(s+p)`` with ``τ = 1/p``).  The captures are read once; conditioning (trimming,
reduction) and identification are repeated for each cell.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from motorid._threads import single_blas_thread
from motorid.capture import Capture
from motorid.conditioning.pipeline import condition_experiment
from motorid.errors import ConditioningError, MotorIdError
from motorid.identification.pipeline import IdentifySettings, identify_conditioned, with_conditioning

__all__ = ["PAPER_INTERVALS_S", "PAPER_LENGTHS_S", "SweepResult", "data_grid", "sensitivity_table"]

#: Record lengths of the paper's Tables 1–3.
PAPER_LENGTHS_S: tuple[float, ...] = (1.9, 2.4, 2.9)
#: Sample intervals of the paper's Tables 1–3.
PAPER_INTERVALS_S: tuple[float, ...] = (0.04, 0.06, 0.08, 0.10, 0.12)


@dataclass(frozen=True, slots=True)
class SweepResult:
    """k, τ and DC gain for each (sample interval, record length) cell.

    Arrays are indexed ``[interval, length]``; NaN where identification failed (the reason is
    in ``failures``).
    """

    lengths_s: tuple[float, ...]
    intervals_s: tuple[float, ...]
    k: np.ndarray
    tau_s: np.ndarray
    dc_gain: np.ndarray
    method: str
    failures: dict[str, str]

    def spread(self) -> dict[str, float]:
        """Half-range of k, τ and DC gain relative to their median (the paper's ±15%).

        Returns
        -------
        dict of str to float
            ``k``, ``tau`` and ``dc_gain``: half-range / |median| over the computed cells (NaN when
            none).
        """
        out = {}
        for name, arr in (("k", self.k), ("tau", self.tau_s), ("dc_gain", self.dc_gain)):
            a = arr[np.isfinite(arr)]
            out[name] = float((a.max() - a.min()) / 2 / abs(np.median(a))) if a.size else float("nan")
        return out

    def to_json(self) -> dict[str, Any]:
        """JSON object: axes, cells and spread.

        Returns
        -------
        dict
            JSON-able; failed cells as ``None``.
        """
        cells = []
        for i, dt in enumerate(self.intervals_s):
            for j, length in enumerate(self.lengths_s):
                cells.append({
                    "sample_interval": dt, "record_length": length,
                    "k": _num(self.k[i, j]), "time_constant": _num(self.tau_s[i, j]),
                    "dc_gain": _num(self.dc_gain[i, j]),
                })
        return {
            "schema": "motorid.analysis.sweep/1", "method": self.method,
            "record_lengths": list(self.lengths_s), "sample_intervals": list(self.intervals_s),
            "cells": cells, "spread": self.spread(), "failures": self.failures,
        }


#: Record lengths of the automatic grid, as fractions of the record after the step (the
#: paper's 1.9/2.4/2.9 s of a ~2.9 s record).
LENGTH_FRACTIONS: tuple[float, ...] = (0.65, 0.82, 1.0)
#: Sample intervals of the automatic grid, as multiples of the automatic interval (the
#: measured 63 % time / 5; the paper's 0.04–0.12 s around its 0.1 s).
INTERVAL_FACTORS: tuple[float, ...] = (0.4, 0.6, 0.8, 1.0, 1.2)


def data_grid(captures: Mapping[str, Capture], *, step_volts: float | None = None
              ) -> tuple[tuple[float, ...], tuple[float, ...], str]:
    """Record lengths and sample intervals of a sensitivity table, from the data.

    The paper's grid (1.9–2.9 s × 0.04–0.12 s) is about its 0.43 s motor and 2.9 s records: on
    a 16 ms motor recorded for 0.35 s no cell of it can be computed.  The same grid in the
    data's own time scales: lengths of 65, 82 and 100 % of the record after the step, intervals
    of 0.4–1.2 × the automatic one (the measured 63 % time / 5), never below the recording's.

    Parameters
    ----------
    captures : Mapping[str, Capture]
        Captures keyed by role.
    step_volts : float, optional
        For captures without an input channel.

    Returns
    -------
    (lengths_s, intervals_s, note)
        The axes and a sentence saying how they were chosen.
    """
    from motorid.conditioning.pipeline import ConditioningSettings

    cond = condition_experiment(captures, ConditioningSettings(), step_volts=step_volts)
    record = float(cond.full_time_s[-1])
    dt = float(cond.full_time_s[1] - cond.full_time_s[0])
    base = cond.sample_interval_s if np.isfinite(cond.sample_interval_s) else record / 25
    lengths = tuple(float(f"{record * f:.4g}") for f in LENGTH_FRACTIONS)
    intervals = tuple(sorted({float(f"{max(dt, base * f):.4g}") for f in INTERVAL_FACTORS}))
    note = (f"grid from the data: record lengths {', '.join(f'{x:g}' for x in lengths)} s (65–100 % of the "
            f"{record:.4g} s after the step), sample intervals {', '.join(f'{x:g}' for x in intervals)} s "
            f"(0.4–1.2 × the automatic {base:.4g} s); the paper's grid: --lengths paper --intervals paper")
    return lengths, intervals, note


def _num(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


@single_blas_thread
def sensitivity_table(
    captures: Mapping[str, Capture],
    *,
    lengths_s: Sequence[float] = PAPER_LENGTHS_S,
    intervals_s: Sequence[float] = PAPER_INTERVALS_S,
    settings: IdentifySettings | None = None,
    step_volts: float | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> SweepResult:
    """Identify the same captures for every record length × sample interval.

    Parameters
    ----------
    captures : Mapping[str, Capture]
        Captures keyed by role.
    lengths_s, intervals_s : sequence of float
        Table axes (defaults: the paper's).
    settings : IdentifySettings, optional
        Method and the rest; ``record_length_s`` and ``sample_interval_s`` are overridden.
        Default: ``IdentifySettings(method="pinv")``.
    step_volts : float, optional
        For captures without an input channel.
    progress : callable, optional
        Called as ``progress(done, total)`` after each cell (the CLI's progress bar).

    Returns
    -------
    SweepResult
        The table (cells that failed are NaN, their reasons in ``failures``).

    Raises
    ------
    ConditioningError
        When every cell failed: one line with the count and the first cell's reason.

    References
    ----------
    Masoud 2019, Tables 1–3.
    """
    if settings is None:
        settings = IdentifySettings(method="pinv")
    lengths = tuple(float(x) for x in lengths_s)
    intervals = tuple(float(x) for x in intervals_s)
    shape = (len(intervals), len(lengths))
    k = np.full(shape, np.nan)
    tau = np.full(shape, np.nan)
    dc = np.full(shape, np.nan)
    failures: dict[str, str] = {}
    total = shape[0] * shape[1]
    done = 0
    for i, dt in enumerate(intervals):
        for j, length in enumerate(lengths):
            s = with_conditioning(settings, record_length_s=length, sample_interval_s=dt, ratio=None)
            try:
                cond = condition_experiment(captures, s.conditioning, step_volts=step_volts)
                model = identify_conditioned(cond, s).model
                fo = model.first_order()
                k[i, j], tau[i, j], dc[i, j] = fo.k, fo.time_constant_s, fo.dc_gain
            except MotorIdError as exc:
                failures[f"{dt:g} s × {length:g} s"] = exc.message
            done += 1
            if progress is not None:
                progress(done, total)
    if failures and len(failures) == total:
        cell, why = next(iter(failures.items()))
        raise ConditioningError(
            f"every one of the {total} cells of the sweep failed (e.g. {cell}: {why}); "
            "check the captures, or choose --lengths/--intervals the records allow"
        )
    return SweepResult(lengths, intervals, k, tau, dc, settings.method, failures)
