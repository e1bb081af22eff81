"""The class summary: modified z-scores, outlier flags, CSV columns, the HTML page."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from motorid.batch import OUTLIER_Z, robust_z
from motorid.batch.page import summary_html
from motorid.batch.summary import SUMMARY_COLUMNS, summary_csv, summary_rows


def test_robust_z_is_the_modified_z_score_by_hand():
    x = [10.0, 11.0, 12.0, 13.0, 40.0]
    # median 12; |x − 12| = 2, 1, 0, 1, 28 → MAD 1 (above the 1 % floor 0.12)
    expected = [0.6745 * (v - 12.0) / 1.0 for v in x]
    np.testing.assert_allclose(robust_z(x), expected, rtol=1e-12)


def test_mad_floor_keeps_tiny_spreads_unflagged():
    x = [1.000, 1.001, 0.999, 1.000, 1.006]  # MAD 0.001 would give z = 4.0 for 0.6 %
    z = robust_z(x)
    # floor 1 % of the median: z = 0.6745 · 0.006 / 0.01
    assert z[-1] == pytest.approx(0.6745 * 0.006 / 0.01, rel=1e-9)
    assert robust_z([1.0, 1.0]).tolist() == [0.0, 0.0]


def _record(name, gain, tau, status="ok", error=""):
    row = {} if status == "failed" else {
        "dc_gain": gain, "dc_gain_ci95": [gain - 0.01, gain + 0.01], "time_constant": tau,
        "time_constant_ci95": None, "order": 2, "method": "oe", "fit_percent": 95.0, "velocity_nrmse": 0.01,
        "warnings": ["a warning, with a comma"] if status == "warning" else []}
    return {"experiment": name, "status": status, "error": error, "row": row,
            "files": {} if status == "failed" else {"report": "report.html"}}


def test_outliers_are_flagged_and_failures_kept_with_their_reason():
    gains = [0.90, 0.91, 0.89, 0.905, 0.895, 1.80]  # one student's doubled gain
    recs = [_record(f"s{i}", g, 0.43) for i, g in enumerate(gains)]
    recs.append(_record("broken", None, None, "failed", "ALL0001/F0001CH2.CSV:41: cannot read 'x' as a number"))
    recs[2] = _record("s2", 0.89, 0.43, "warning")
    rows = summary_rows(recs[::-1])  # any order in, sorted out
    assert [r.experiment for r in rows] == ["broken", "s0", "s1", "s2", "s3", "s4", "s5"]
    flagged = {r.experiment: r.outlier for r in rows if r.outlier}
    assert flagged == {"s5": "gain"}
    z5 = next(r.gain_z for r in rows if r.experiment == "s5")
    med = float(np.median(gains))
    mad = float(np.median(np.abs(np.array(gains) - med)))  # 0.0075, under the floor 1 % × 0.9025
    assert z5 == pytest.approx(0.6745 * (1.80 - med) / max(mad, 0.01 * med)) and z5 > OUTLIER_Z
    table = list(csv.DictReader(io.StringIO(summary_csv(rows))))
    assert tuple(table[0]) == SUMMARY_COLUMNS
    by = {t["experiment"]: t for t in table}
    assert by["broken"]["status"] == "failed" and by["broken"]["dc_gain"] == ""
    assert by["broken"]["error"].startswith("ALL0001/F0001CH2.CSV:41")
    assert by["s2"]["warnings"] == "a warning, with a comma" and by["s2"]["status"] == "warning"
    assert float(by["s5"]["dc_gain"]) == 1.8 and by["s5"]["report"] == "s5/report.html"
    page = summary_html(rows)
    assert 'href="./s5/report.html"' in page and "outlier: gain" in page
    assert "broken: ALL0001/F0001CH2.CSV:41: cannot read &#x27;x&#x27; as a number" in page
    assert "7 experiments: 5 ok, 1 with warnings, 1 failed" in page
    assert page.count('src="data:image/png;base64,') == 1
