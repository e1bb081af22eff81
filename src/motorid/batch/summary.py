"""The class summary: one row per experiment, robust z-scores of gain and τ, ``summary.csv``.

Outliers are flagged with the modified z-score of Iglewicz & Hoaglin (1993),
``z = 0.6745 (x − median) / MAD``, ``|z| > 3.5``: the median and the median absolute
deviation are not pulled by the outliers themselves, as a mean and a standard deviation
are (one student's 10× gain would hide itself).  ``scipy.stats.median_abs_deviation`` gives
the MAD, floored at 1 % of the median (:data:`MAD_FLOOR_REL`) so that a class measured
very consistently does not flag differences of a fraction of a percent.  No timings go
into the summary: it is the same, byte for byte, whichever engine ran the batch (the
workers' times are in each ``result.json`` and ``batch-log.jsonl``).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["MAD_FLOOR_REL", "OUTLIER_Z", "SUMMARY_COLUMNS", "SummaryRow", "robust_z", "summary_csv", "summary_rows"]

#: |modified z| above which a gain or τ is flagged (Iglewicz & Hoaglin's recommendation).
OUTLIER_Z = 3.5
#: The MAD is floored at this fraction of the median: a class of one motor model measured
#: well has a MAD of a few 0.1 %, and a 0.5 % difference would score |z| > 3.5; with the floor a
#: flagged value lies at least 3.5/0.6745 × 1 % ≈ 5 % from the class median.
MAD_FLOOR_REL = 0.01
#: Columns of ``summary.csv``, in order.
SUMMARY_COLUMNS: tuple[str, ...] = (
    "experiment", "status", "dc_gain", "dc_gain_ci_low", "dc_gain_ci_high", "time_constant",
    "time_constant_ci_low", "time_constant_ci_high", "order", "method", "fit_percent", "velocity_nrmse",
    "gain_z", "tau_z", "outlier", "warnings", "error", "report", "dc_gain_unit",
)


@dataclass(frozen=True, slots=True)
class SummaryRow:
    """One experiment in the class summary.

    Attributes
    ----------
    experiment : str
        Its folder relative to its root.
    status : str
        ``ok``, ``warning`` or ``failed``.
    dc_gain, time_constant : float or None
        DC gain [:attr:`dc_gain_unit`] and dominant time constant [s].
    dc_gain_ci, time_constant_ci : tuple of float or None
        Their 95 % intervals.
    order : int or None
        Poles of the velocity TF.
    method : str
        The method of the chosen model.
    fit_percent, velocity_nrmse : float or None
        Fit of the velocity (else position) channel [%]; velocity NRMSE (fraction).
    gain_z, tau_z : float or None
        Modified z-scores in the class.
    outlier : str
        ``gain``, ``tau``, ``gain+tau`` or empty.
    warnings : tuple of str
        The identification's warnings.
    error : str
        Why it failed (one line).
    report : str
        The report's path relative to the batch folder (empty without one).
    dc_gain_unit : str
        The gain's unit (``V/V`` for scope volts, ``rpm/V`` for a log in rpm): gains in
        different units are scored, summarised and plotted apart.
    """

    experiment: str
    status: str
    dc_gain: float | None
    dc_gain_ci: tuple[float, float] | None
    time_constant: float | None
    time_constant_ci: tuple[float, float] | None
    order: int | None
    method: str
    fit_percent: float | None
    velocity_nrmse: float | None
    gain_z: float | None
    tau_z: float | None
    outlier: str
    warnings: tuple[str, ...]
    error: str
    report: str
    dc_gain_unit: str = "V/V"


def robust_z(values: Sequence[float], *, floor_rel: float = MAD_FLOOR_REL) -> np.ndarray:
    """Modified z-scores ``0.6745 (x − median) / MAD`` (Iglewicz & Hoaglin 1993).

    Parameters
    ----------
    values : sequence of float
        The class's values (finite).
    floor_rel : float
        The MAD is taken as at least this fraction of ``|median|`` (see :data:`MAD_FLOOR_REL`).

    Returns
    -------
    ndarray
        One score per value; zeros for fewer than three values or no spread at all.
    """
    from scipy.stats import median_abs_deviation

    x = np.asarray(values, dtype=float)
    if x.size < 3:
        return np.zeros(x.size)
    med = float(np.median(x))
    scale = max(float(median_abs_deviation(x, scale=1.0)), floor_rel * abs(med))
    return np.zeros(x.size) if scale == 0 else 0.6745 * (x - med) / scale


def _opt(x: Any) -> float | None:
    return None if x is None else float(x)


def summary_rows(records: Sequence[Mapping[str, Any]]) -> list[SummaryRow]:
    """The summary rows of the stored records, sorted by experiment, with their z-scores.

    Parameters
    ----------
    records : sequence of Mapping
        The ``result.json`` records (:func:`motorid.batch.store.write_outcome`).

    Returns
    -------
    list of SummaryRow
        Failed experiments keep ``None`` values and their error.
    """
    recs = sorted(records, key=lambda r: r["experiment"])
    ok = [i for i, r in enumerate(recs) if r["status"] != "failed"]
    tz = robust_z([recs[i]["row"]["time_constant"] for i in ok])
    # a gain in rpm/V and one in V/V are not one distribution: each unit is scored on its own
    gain_z: dict[int, float] = {}
    for unit in sorted({_gain_unit(recs[i]) for i in ok}):
        group = [i for i in ok if _gain_unit(recs[i]) == unit]
        gain_z.update(zip(group, map(float, robust_z([recs[i]["row"]["dc_gain"] for i in group])), strict=True))
    zs = {i: (gain_z[i], float(t)) for i, t in zip(ok, tz, strict=True)}
    rows = []
    for i, r in enumerate(recs):
        v = r.get("row", {})
        g, t = zs.get(i, (None, None))
        flags = [name for name, z in (("gain", g), ("tau", t)) if z is not None and abs(z) > OUTLIER_Z]
        gci, tci = v.get("dc_gain_ci95"), v.get("time_constant_ci95")
        rows.append(SummaryRow(
            experiment=r["experiment"], status=r["status"],
            dc_gain=_opt(v.get("dc_gain")), dc_gain_ci=None if gci is None else (float(gci[0]), float(gci[1])),
            time_constant=_opt(v.get("time_constant")),
            time_constant_ci=None if tci is None else (float(tci[0]), float(tci[1])),
            order=v.get("order"), method=v.get("method", ""), fit_percent=_opt(v.get("fit_percent")),
            velocity_nrmse=_opt(v.get("velocity_nrmse")), gain_z=g, tau_z=t, outlier="+".join(flags),
            warnings=tuple(v.get("warnings", ())), error=r.get("error", ""),
            report=f"{r['experiment']}/{r['files']['report']}" if "report" in r.get("files", {}) else "",
            dc_gain_unit=_gain_unit(r),
        ))
    return rows


def _gain_unit(record: Mapping[str, Any]) -> str:
    return str(record.get("row", {}).get("dc_gain_unit") or "V/V")


def _num(x: float | None, digits: int = 10) -> str:
    if x is None or not math.isfinite(x):
        return "" if x is None else str(x)
    return f"{x:.{digits}g}"


#: A cell starting with one of these is run as a formula by a spreadsheet (OWASP, CSV injection).
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def _text(cell: str) -> str:
    """A text cell as a spreadsheet shows it, never runs it: a leading ``'`` before a formula start."""
    return "'" + cell if cell.startswith(FORMULA_STARTS) else cell


def summary_csv(rows: Sequence[SummaryRow]) -> str:
    """``summary.csv``: :data:`SUMMARY_COLUMNS`, numbers to 10 significant digits.

    Parameters
    ----------
    rows : sequence of SummaryRow
        From :func:`summary_rows`.

    Returns
    -------
    str
        The CSV text (warnings joined with `` | ``); text cells that a spreadsheet would run as a
        formula (a student's folder named ``=HYPERLINK(…)``) start with ``'``.
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(SUMMARY_COLUMNS)
    for r in rows:
        gci = r.dc_gain_ci or (None, None)
        tci = r.time_constant_ci or (None, None)
        w.writerow([
            _text(r.experiment), r.status, _num(r.dc_gain), _num(gci[0]), _num(gci[1]), _num(r.time_constant),
            _num(tci[0]), _num(tci[1]), "" if r.order is None else r.order, r.method, _num(r.fit_percent),
            _num(r.velocity_nrmse), _num(r.gain_z, 4), _num(r.tau_z, 4), r.outlier, _text(" | ".join(r.warnings)),
            _text(r.error), _text(r.report), r.dc_gain_unit,
        ])
    return buf.getvalue()
