"""``motorid demo`` writes TDS files that ``motorid inspect`` reads back as generated."""

import json

import pytest


@pytest.fixture(scope="module")
def demo_dir(demo_run):
    return demo_run.folder


def test_demo_writes_the_scope_layout(demo_dir):
    for i in range(6):
        folder = demo_dir / f"ALL{i:04d}"
        assert (folder / f"F{i:04d}CH1.CSV").is_file() and (folder / f"F{i:04d}CH2.CSV").is_file()
    truth = json.loads((demo_dir / "truth.json").read_text())
    assert truth["schema"] == "motorid.trainer-truth/1"
    assert set(truth["captures"]) >= {"position", "velocity", "current"}


def test_inspect_reads_back_step_time_amplitude_and_wraps(demo_dir, run_cli):
    truth = json.loads((demo_dir / "truth.json").read_text())["captures"]
    names = ("position", "velocity", "current")
    res = run_cli("inspect", "--json", *(demo_dir / truth[n]["folder"] for n in names))
    assert res.code == 0, res.err
    got = json.loads(res.out)
    for name, item in zip(names, got, strict=False):
        true = truth[name]
        assert item["format"] == "tds2000-csv"
        assert item["role"] == name, item["role_reason"]
        # brief: step time within one sample, amplitude within 1% of what was generated
        assert abs(item["step"]["time"] - true["step_time"]) <= item["sample_interval"] * 1.0001
        assert item["step"]["volts"] == pytest.approx(true["step_volts"], rel=0.01)
        assert item["wraps"] == true["wraps"]
    assert truth["position"]["wraps"] >= 1  # the paper preset turns the output shaft


@pytest.mark.slow
def test_demo_refuses_to_overwrite_without_force(demo_dir, run_cli):
    f = demo_dir / "ALL0001" / "F0001CH2.CSV"
    before = f.read_bytes()
    res = run_cli("demo", "--out", demo_dir, "--seed", "9")
    assert res.code == 2
    assert "--force" in res.err and str(demo_dir) in res.err and len(res.err.strip().splitlines()) == 1
    assert f.read_bytes() == before
    res = run_cli("demo", "--out", demo_dir, "--seed", "9", "--force")
    assert res.code == 0, res.err
    assert f.read_bytes() != before
