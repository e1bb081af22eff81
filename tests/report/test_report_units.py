"""The report speaks the data's units — the HSLU speed log (plain CSV, speed in rpm)
gives a page whose gain reads rpm/V and whose velocity axes are in rpm."""

from __future__ import annotations

import re

import pytest

from motorid.report import figures

LOG = "hslu-rtl-dcmotor/csv/06_dc_step_5_15_00.csv"


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_report_of_a_log_in_rpm_says_rpm(real_dir, run_cli, tmp_path, monkeypatch):
    kept = []
    real_png = figures.png
    monkeypatch.setattr(figures, "png", lambda fig: kept.append(fig) or real_png(fig))
    page = tmp_path / "r.html"
    res = run_cli("report", "--velocity", real_dir / LOG, "--out", page)
    assert res.code == 0, res.err
    html = page.read_text(encoding="utf-8")
    summary = html[html.index('<section id="summary">'):html.index('<section id="captures">')]
    gain = re.search(r"<td class=l>dc gain</td><td>([-0-9.]+) rpm/V</td>", summary)
    assert gain is not None, summary[:2000]
    # the authors' own first-order fit is about 245.5 rpm/V (../shared/real/README.md)
    assert 230 < float(gain.group(1)) < 260
    # the text, not the embedded figures' base64 (where any four characters may appear)
    assert "V/V" not in re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", summary)
    labels = {ax.get_ylabel() for fig in kept for ax in fig.axes}
    assert "velocity (rpm)" in labels and "residual (rpm)" in labels
    assert not any(lab.startswith("velocity (V") for lab in labels), labels
