"""A class's folders are named by students: the summary never runs what a name says."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest

from motorid.batch.page import summary_html
from motorid.batch.summary import SummaryRow, summary_csv


def _row(name: str, **kw) -> SummaryRow:
    base = dict(experiment=name, status="ok", dc_gain=0.9, dc_gain_ci=(0.89, 0.91), time_constant=0.43,
                time_constant_ci=(0.42, 0.44), order=2, method="oe", fit_percent=95.0, velocity_nrmse=0.01,
                gain_z=0.0, tau_z=0.0, outlier="", warnings=(), error="", report=f"{name}/report.html")
    return SummaryRow(**(base | kw))


def test_a_folder_named_like_a_formula_is_text_in_summary_csv():
    rows = [_row('=HYPERLINK("http://evil.example","x")'), _row("+cmd"), _row("@sum"), _row("-2+3"),
            _row("alice", warnings=("=1+1 looks odd",))]
    got = list(csv.DictReader(io.StringIO(summary_csv(rows))))
    for r in got:
        for key in ("experiment", "warnings", "report", "error"):
            assert not r[key].startswith(("=", "+", "-", "@")), (key, r[key])
    assert got[0]["experiment"] == """'=HYPERLINK("http://evil.example","x")"""
    assert got[4]["experiment"] == "alice" and got[4]["warnings"] == "'=1+1 looks odd"
    assert float(got[0]["dc_gain"]) == 0.9  # numbers stay numbers


def test_a_folder_named_like_a_url_scheme_links_to_its_own_report():
    page = summary_html([_row("javascript:alert(1)"), _row("data:text/html,x"), _row("bob")])
    assert 'href="javascript:' not in page and 'href="data:' not in page
    assert 'href="./javascript%3Aalert%281%29/report.html"' in page
    assert 'href="./bob/report.html"' in page


def _class(tmp_path, demo_run, names=("alice", "bob")):
    root = tmp_path / "class"
    for name in names:
        (root / name).mkdir(parents=True)
        (root / name / "ALL0001").symlink_to(demo_run.folder / "ALL0001", target_is_directory=True)
    return root


def test_links_to_itself_its_parent_or_outside_are_not_followed(tmp_path, demo_run):
    from motorid.batch.discover import discover_experiments

    root = _class(tmp_path, demo_run)
    (root / "alice" / "self").symlink_to(".", target_is_directory=True)
    (root / "alice" / "up").symlink_to("..", target_is_directory=True)
    (root / "bob" / "away").symlink_to(demo_run.folder, target_is_directory=True)  # out of the class
    names = [s.name for s in discover_experiments([root])]
    assert names == ["alice", "bob"]


def test_an_experiment_named_like_the_batchs_own_files_is_one_line(tmp_path, demo_run, run_cli):
    root = _class(tmp_path, demo_run, names=("alice", "summary.csv"))
    res = run_cli("batch", root, "--out", tmp_path / "out", "--jobs", "1")
    assert res.code == 2 and "rename that folder" in res.err and len(res.err.strip().splitlines()) == 1


def test_out_inside_a_symlink_loop_is_one_line(tmp_path, demo_run, run_cli):
    root = _class(tmp_path, demo_run, names=("alice",))
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    res = run_cli("batch", root, "--out", tmp_path / "a" / "out", "--jobs", "1")
    assert res.code == 2, res.err
    assert "internal error" not in res.err and len(res.err.strip().splitlines()) == 1


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_a_file_beyond_every_reader_is_refused_without_being_hashed(tmp_path, demo_run, run_cli, monkeypatch):
    import builtins

    from motorid.batch.discover import discover_experiments
    from motorid.io._common import MAX_TEXT_BYTES

    root = _class(tmp_path, demo_run, names=("alice",))
    (root / "bob").mkdir()
    huge = root / "bob" / "huge.csv"
    with open(huge, "wb") as fh:  # sparse: no disk is used
        fh.truncate(MAX_TEXT_BYTES + 1)
    spec = next(s for s in discover_experiments([root]) if s.name == "bob")
    real_open = builtins.open

    def no_reading_of_huge(file, *args, **kwargs):  # 512 MiB read and hashed would take seconds
        assert Path(file) != huge, "the file beyond every reader was opened to be hashed"
        return real_open(file, *args, **kwargs)

    with monkeypatch.context() as m:
        m.setattr(builtins, "open", no_reading_of_huge)
        first = spec.content_hash({})
    with open(huge, "r+b") as fh:  # its size and time stand in for its content: a change shows
        fh.truncate(MAX_TEXT_BYTES + 2)
    assert spec.content_hash({}) != first
    res = run_cli("batch", root, "--out", tmp_path / "out", "--jobs", "1")
    rows = {r["experiment"]: r for r in csv.DictReader((tmp_path / "out" / "summary.csv").open())}
    assert rows["alice"]["status"] == "ok" and rows["bob"]["status"] == "failed", res.err
    assert "MiB" in rows["bob"]["error"] or "too large" in rows["bob"]["error"], rows["bob"]["error"]
