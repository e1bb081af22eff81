"""``motorid batch`` end to end on a tiny class: failures isolated, Dask = one process, resume.

The class (conftest): four good experiments in four layouts and one with a corrupt
velocity file.  Runs without reports (the report is ``motorid report``'s, tested there),
except one that checks the links and the validation captures.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from motorid.batch import BatchSettings, run_batch

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow

#: The good experiments of the class (conftest.make_class); "bad" has a corrupt velocity file.
GOOD = ("s00", "s01", "s02", "s03/run1")
NO_REPORT = BatchSettings(report=False)


def _files(out: Path, name: str) -> set[str]:
    return {p.name for p in out.joinpath(*name.split("/")).iterdir()}


@pytest.fixture(scope="module")
def one_process(class_root, tmp_path_factory):
    """The class identified with ``--jobs 1`` (in this process)."""
    root, _ = class_root
    out = tmp_path_factory.mktemp("jobs1")
    return out, run_batch([root], out, NO_REPORT, jobs=1)


def test_a_corrupt_capture_fails_alone_with_its_reason(class_root, one_process):
    _, truth = class_root
    out, result = one_process
    assert sorted(truth) == sorted(GOOD)
    by = {r.experiment: r for r in result.rows}
    assert sorted(by) == sorted([*GOOD, "bad"])
    assert result.failed == ("bad",)
    # the reader's one line, the path relative to the experiment folder
    assert by["bad"].error.startswith("ALL0001/F0001CH2.CSV:41: ") and "\n" not in by["bad"].error
    assert "model.json" not in _files(out, "bad") and "result.json" in _files(out, "bad")
    for name in GOOD:
        r = by[name]
        assert r.status in ("ok", "warning") and "model.json" in _files(out, name)
        # against the trainer's truth (gain a 5.92 V step shows), not our own numbers: the
        # estimates' 95 % intervals are ±0.1 %; 1 % leaves room for the layouts' differences
        assert r.dc_gain == pytest.approx(truth[name], rel=0.01)
        assert r.time_constant == pytest.approx(0.43, rel=0.05)  # the paper's motor: τ ≈ 0.43 s
        model = json.loads(out.joinpath(*name.split("/"), "model.json").read_text(encoding="utf-8"))
        assert model["first_order"]["dc_gain"] == pytest.approx(r.dc_gain, rel=1e-9)
    roles = {name: json.loads(out.joinpath(*name.split("/"), "result.json").read_text())["roles"] for name in GOOD}
    assert roles["s00"] == {"position": "ALL0000", "velocity": "ALL0001", "current": "ALL0002",
                            "roles_from": "guessed"}
    assert roles["s02"]["roles_from"] == "manifest.csv"
    assert roles["s01"]["velocity"] == "F0001CH1.CSV+F0001CH2.CSV"
    assert roles["s03/run1"] == {"velocity": "log.csv", "roles_from": "guessed"}
    summary = (out / "summary.csv").read_text(encoding="utf-8").splitlines()
    assert summary[0].startswith("experiment,status,dc_gain,") and len(summary) == 6
    assert "bad: ALL0001/F0001CH2.CSV:41" in (out / "summary.html").read_text(encoding="utf-8")


def test_local_dask_cluster_gives_the_same_summary_byte_for_byte(class_root, one_process, tmp_path):
    distributed = pytest.importorskip("distributed")  # fallback only: the test extras install it
    root, _ = class_root
    out1, _ = one_process
    out = tmp_path / "dask"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        result = run_batch([root], out, NO_REPORT, scheduler=cluster.scheduler_address)
    assert len(result.computed) == 5
    for name in ("summary.csv", "summary.html"):
        assert (out / name).read_bytes() == (out1 / name).read_bytes(), name
    for name in GOOD:
        parts = name.split("/")
        assert out.joinpath(*parts, "model.json").read_bytes() == out1.joinpath(*parts, "model.json").read_bytes()
    log = json.loads((out / "batch-log.jsonl").read_text().splitlines()[-1])
    assert log["scheduler"] == cluster.scheduler_address


def _done(out: Path) -> set[str]:
    return {p.parent.relative_to(out).as_posix() for p in out.rglob("result.json")}


def test_killed_batch_resumes_with_only_the_rest(class_root, one_process, tmp_path):
    root, _ = class_root
    out1, _ = one_process
    out = tmp_path / "resumed"
    cmd = [sys.executable, "-m", "motorid", "batch", str(root), "--out", str(out), "--jobs", "1", "--no-report"]
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    try:
        deadline = time.monotonic() + 120
        while len(_done(out)) < 2:  # wait for a condition (two finished), not for a time
            assert proc.poll() is None, proc.stderr.read().decode()
            assert time.monotonic() < deadline, "no experiment finished in 120 s"
            time.sleep(0.02)
        proc.kill()
    finally:
        proc.kill()
        proc.wait()
    before = _done(out)
    assert 2 <= len(before) < 5, before  # killed halfway
    assert not (out / "summary.csv").exists()
    stored = {n: out.joinpath(*n.split("/"), "result.json").read_bytes() for n in before}
    rerun = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    log = json.loads((out / "batch-log.jsonl").read_text().splitlines()[-1])
    assert set(log["skipped"]) == before
    assert set(log["computed"]) == {*GOOD, "bad"} - before
    for n, data in stored.items():  # the finished ones were not touched
        assert out.joinpath(*n.split("/"), "result.json").read_bytes() == data
    # a resumed batch gives the summary of an uninterrupted one
    assert (out / "summary.csv").read_bytes() == (out1 / "summary.csv").read_bytes()
    # a changed capture is recomputed, alone (the same settings as the command line's defaults)
    f = root / "s00" / "ALL0002" / "F0002CH2.CSV"
    saved = f.read_bytes()
    try:
        f.write_bytes(saved.replace(b"\n", b"\r\n"))  # same numbers, other bytes
        again = run_batch([root], out, NO_REPORT, jobs=1)
    finally:
        f.write_bytes(saved)
    assert again.computed == ("s00",) and len(again.skipped) == 4


def test_cli_reports_links_validation_and_progress(class_root, run_cli, tmp_path):
    root, _ = class_root
    out = tmp_path / "one"
    res = run_cli("batch", root / "s02", root / "bad", "--out", out, "--validate", "--progress")
    assert res.code == 0, res.err
    assert "2 experiments: " in res.out and "1 failed" in res.out
    assert "failed bad: ALL0001/F0001CH2.CSV:41" in res.out
    assert "failed 1" in res.err and "2/2" in res.err  # the progress bar's last state
    page = (out / "summary.html").read_text(encoding="utf-8")
    assert 'href="./s02/report.html"' in page
    report = (out / "s02" / "report.html").read_text(encoding="utf-8")
    assert "ALL0003" in report  # the manifest's validation capture is in the report


def test_design_on_every_model(class_root, tmp_path):
    from motorid.control.design_io import read_design_json

    root, _ = class_root
    settings = BatchSettings(report=False, design={"damping": 0.7, "wn": 5.0})
    result = run_batch([root / "s00"], tmp_path, settings)
    (row,) = result.rows
    # the design adds no warning of its own; the model may carry one (its fit at the double pole)
    model_warnings = json.loads((tmp_path / "s00" / "model.json").read_text(encoding="utf-8"))["warnings"]
    assert row.status == ("warning" if model_warnings else "ok"), row
    assert set(row.warnings) <= set(model_warnings), row.warnings
    doc = read_design_json(tmp_path / "s00" / "design.json")
    # the closed-loop poles are the ones asked for: ζ = 0.7, ωn = 5 rad/s (independent of the gains)
    poles = sorted((complex(*p) if isinstance(p, list) else complex(p) for p in doc["closed_loop_poles"]),
                   key=lambda p: p.imag)
    dominant = [p for p in poles if abs(abs(p) - 5.0) < 1e-6]
    assert dominant and np.isclose(-dominant[0].real / abs(dominant[0]), 0.7)
