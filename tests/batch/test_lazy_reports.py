"""``motorid batch --reports lazy``: a page per experiment now, its full report on demand."""

from __future__ import annotations

import html
import json
import re
import shlex
from pathlib import Path

import pytest

from motorid.batch.lazy import render_command, report_stub


def _command_on_page(page: str) -> list[str]:
    text = re.search(r'<pre id="render-command">(.*?)</pre>', page, re.S).group(1)
    return shlex.split(html.unescape(text))


def test_the_stub_names_the_numbers_and_a_command_a_shell_reads_back():
    name = "class 1/o'brien; rm -rf ~ <b>"
    cmd = render_command(["motorid", "batch", "/data/my class", "--out", "/tmp/out"], name)
    # the shell gives back exactly the arguments: the name is one argument, never code
    assert shlex.split(cmd) == ["motorid", "batch", "/data/my class", "--out", "/tmp/out",
                                "--reports", "full", "--only", name]
    row = {"dc_gain": 2.5, "dc_gain_ci95": [2.4, 2.6], "time_constant": 0.0301, "time_constant_ci95": None,
           "order": 2, "method": "oe", "fit_percent": 97.25, "dc_gain_unit": "(rad/s)/V",
           "warnings": ["clipping <at> 10 V"]}
    page = report_stub(name, "warning", row, cmd)
    assert _command_on_page(page)[-1] == name
    assert "<b>" not in page and "&lt;at&gt;" in page  # everything from the data is escaped
    assert "2.5 [2.4, 2.6] (rad/s)/V" in page and "0.0301" in page and "97.2" in page
    # the way back to the summary climbs the name's two levels
    assert 'href="../../summary.html"' in page
    # a library call (no command line) still shows a complete command, with placeholders
    assert shlex.split(render_command(None, "s1"))[:5] == ["motorid", "batch", "ROOT", "--out", "OUT"]


@pytest.mark.slow
def test_lazy_batch_then_one_report_on_demand(class_root, run_cli, tmp_path):
    root, _ = class_root
    out = tmp_path / "lazy"
    res = run_cli("batch", root / "s00", root / "s01", root / "bad", "--out", out, "--reports", "lazy")
    assert res.code == 0, res.err
    summary = (out / "summary.html").read_text(encoding="utf-8")
    records = {n: json.loads((out / n / "result.json").read_text()) for n in ("s00", "s01")}
    for name, rec in records.items():
        # every good experiment's link leads to a page: its numbers and the command for its report
        assert f'href="./{name}/report.html"' in summary
        assert rec["report"] == "lazy" and rec["files"]["report"] == "report.html"
        page = (out / name / "report.html").read_text(encoding="utf-8")
        assert 'id="lazy-report"' in page and "<img" not in page
        assert f"{rec['row']['dc_gain']:.4g}" in page
        args = _command_on_page(page)
        assert args[:2] == ["motorid", "batch"] and args[-4:] == ["--reports", "full", "--only", name]
        assert str(out.resolve()) in args  # the batch folder named absolutely: the command runs from anywhere
    assert not (out / "bad" / "report.html").exists()  # a failure has no report, lazy or not

    # the teacher runs the command of s00: its report is rendered, the others are left as they are
    before = (out / "s01" / "report.html").read_bytes()
    res = run_cli(*_command_on_page((out / "s00" / "report.html").read_text(encoding="utf-8"))[1:])
    assert res.code == 0, res.err
    assert "1 computed" in res.out
    report = (out / "s00" / "report.html").read_text(encoding="utf-8")
    assert 'id="lazy-report"' not in report and "<img" in report and '<section id="summary">' in report
    assert json.loads((out / "s00" / "result.json").read_text())["report"] == "full"
    assert (out / "s01" / "report.html").read_bytes() == before
    # the model is the same as the lazy run's (same settings, same seed): only the report was added
    assert json.loads((out / "s00" / "result.json").read_text())["row"] == records["s00"]["row"]

    # a later lazy run computes nothing and keeps the rendered report
    res = run_cli("batch", root / "s00", root / "s01", root / "bad", "--out", out, "--reports", "lazy")
    assert res.code == 0, res.err
    assert "0 computed" in res.out or "(1 computed" in res.out  # the failed one is tried again
    assert 'id="lazy-report"' not in (out / "s00" / "report.html").read_text(encoding="utf-8")


def test_only_that_matches_nothing_is_an_option_error(class_root, run_cli, tmp_path):
    root, _ = class_root
    res = run_cli("batch", root / "s00", "--out", tmp_path / "o", "--no-report", "--only", "nobody*")
    assert res.code == 2 and "--only nobody*: no experiment matches" in res.err


def test_reports_option_is_checked(class_root, run_cli, tmp_path):
    root, _ = class_root
    res = run_cli("batch", root / "s00", "--out", tmp_path / "o", "--reports", "some")
    assert res.code == 2 and "--reports 'some'" in res.err


def test_summary_of_a_lazy_batch_is_that_of_a_full_one(class_root, tmp_path):
    """The stand-in pages change nothing else: same summary.csv as a batch without reports."""
    from motorid.batch import BatchSettings, run_batch

    root, _ = class_root
    lazy = run_batch([root / "s03"], tmp_path / "lazy", BatchSettings(lazy_reports=True))
    none = run_batch([root / "s03"], tmp_path / "none", BatchSettings(report=False))
    assert [r.dc_gain for r in lazy.rows] == [r.dc_gain for r in none.rows]
    assert lazy.rows[0].report == "run1/report.html" and none.rows[0].report == ""
    assert Path(tmp_path / "lazy" / "run1" / "report.html").stat().st_size < 10_000
