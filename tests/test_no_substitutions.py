"""Nothing swapped behind the user's back: each front end says what it used, or refuses.

- ``validate`` on a closed-loop log: the input it drives the model with is the one recorded,
  and the printout says it is not a step (it used to be labelled "step").
- ``simulate --plant trainer`` with a model of another motor: refused in one line (it ran the
  trainer's own motor and printed rise time ``nan``).
- ``batch`` on a rig log with a position column: the same model as ``identify --velocity FILE``
  (it used to fit the position column too: 4 states against 3), the unused column noted.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

REAL = Path(__file__).resolve().parents[2] / "shared" / "real" / "hslu-rtl-dcmotor" / "csv"
need_real = pytest.mark.skipif(not REAL.is_dir(), reason="../shared/real is not beside this clone")


def _rig_log(path: Path) -> Path:
    """A 100 Hz log in the HSLU layout: voltage 5 → 15 V, speed in rpm, a wrapping position column."""
    rng = np.random.default_rng(0)
    t = np.arange(-100, 400) * 0.01
    te = np.clip(t - 0.03, 0, None)
    speed = 245.5 * 5 + 2455 * (1 - (0.12 * np.exp(-te / 0.12) - 0.03 * np.exp(-te / 0.03)) / 0.09)
    speed = np.where(t >= 0.03, speed, 245.5 * 5) + rng.normal(0, 1.0, t.size)
    pos = np.mod(np.cumsum(speed) * 0.01 / 60 * 7.22, 230.16)
    u = np.where(t >= 0, 15.0, 5.0)
    rows = "\n".join(f"{a:.2f},{b:.1f},{c:.3f},{d:.3f}" for a, b, c, d in zip(t, u, speed, pos, strict=True))
    path.write_text("time_s,motor_voltage_V,speed_rpm,position_raw\n" + rows + "\n")
    return path


def test_batch_and_identify_give_the_same_model_for_one_log(tmp_path, run_cli):
    folder = tmp_path / "class" / "s1"
    folder.mkdir(parents=True)
    log = _rig_log(folder / "run.csv")
    out = tmp_path / "m.json"
    res = run_cli("identify", "--velocity", str(log), "--json", str(out))
    assert res.code == 0, res.err
    cli = json.loads(out.read_text())
    assert any("also holds a position column, not used" in n for n in cli["extras"]["conditioning"])
    res = run_cli("batch", str(tmp_path / "class"), "--out", str(tmp_path / "b"), "--no-report")
    assert res.code == 0, res.err
    import csv

    row = next(csv.DictReader((tmp_path / "b" / "summary.csv").open()))
    assert float(row["dc_gain"]) == pytest.approx(cli["first_order"]["dc_gain"], rel=1e-9)
    assert int(row["order"]) == len(cli["poles"])


def test_simulate_on_the_trainer_refuses_a_model_of_another_motor(tmp_path, run_cli):
    log = _rig_log(tmp_path / "rig.csv")
    model, design = tmp_path / "m.json", tmp_path / "d.json"
    assert run_cli("identify", "--velocity", str(log), "--json", str(model)).code == 0
    assert run_cli("design", str(model), "--damping", "0.9", "--wn", "8", "--robust-samples", "0",
                   "--json", str(design)).code == 0
    res = run_cli("simulate", str(model), str(design), "--plant", "trainer")
    assert res.code == 2 and "not of the virtual trainer's motor" in res.err and "--plant linear" in res.err
    assert len(res.err.strip().splitlines()) == 1
    assert run_cli("simulate", str(model), str(design), "--plant", "linear").code == 0


@need_real
def test_validate_says_a_closed_loop_input_is_not_a_step(tmp_path, run_cli):
    model = tmp_path / "m.json"
    assert run_cli("identify", "--velocity", str(REAL / "06_dc_step_5_15_00.csv"), "--json", str(model)).code == 0
    local = tmp_path / "closed.csv"
    shutil.copy(REAL / "12_dc_step_20_25_00.csv", local)
    res = run_cli("validate", str(model), str(local), "--json")
    assert res.code == 0, res.err
    (doc,) = json.loads(res.out)
    assert doc["input"] == "recorded (not a step)"
    assert any("not a step (a closed-loop record)" in w for w in doc["warnings"])
    open_loop = json.loads(run_cli("validate", str(model), str(REAL / "06_dc_step_5_15_05.csv"), "--json").out)
    assert open_loop[0]["input"] == "step"
