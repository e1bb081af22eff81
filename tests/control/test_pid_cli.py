"""``motorid design --pid`` and ``motorid simulate`` of its design on a first-order-plus-dead-time
model file and on the demo's identified model: the first and the emitted C through a fresh
process (``python -m motorid``, as a user runs it), the others in-process through the same entry
point (a fresh process costs a second or two each)."""

from __future__ import annotations

import json
import subprocess
import sys

import jsonschema
import numpy as np
import pytest
from clihelpers import run_motorid

from motorid.model.motor import model_from_velocity_tf
from motorid.schemas import schema


def _motorid(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "motorid", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


def _in_process(*args):
    """:func:`run_motorid` with the fields of a finished process (``returncode``, ``stdout``, ``stderr``)."""
    res = run_motorid(*args)
    return subprocess.CompletedProcess(["motorid", *map(str, args)], res.code, res.out, res.err)


@pytest.fixture()
def fopdt_file(tmp_path):
    m = model_from_velocity_tf([2.0], [0.5, 1.0], with_position=True, delay_s=0.1,
                               units={"velocity": "rpm", "position": "rev"})
    path = tmp_path / "fopdt.json"
    path.write_text(m.to_json_text())
    return path


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_pid_on_a_fopdt_model(fopdt_file, tmp_path):
    out = tmp_path / "pi.json"
    res = _motorid("design", fopdt_file, "--pid", "--json", out)
    assert res.returncode == 0, res.stderr
    # SIMC by hand: τc = max(θ, τ/4) = 0.125 s, Kc = τ/(k (τc + θ)) = 0.5/(2·0.225), τI = min(τ, 4 (τc + θ)) = 0.5
    kc = 0.5 / (2 * 0.225)
    assert f"kp = {kc:.4g} V per rpm" in res.stdout and f"ki = {kc / 0.5:.4g} V per (rpm·s)" in res.stdout
    for words in ("C(s) = ", "margins: gain margin", "phase margin", "dead time included", "closed-loop poles",
                  "overshoot", "settling time"):
        assert words in res.stdout, words
    doc = json.loads(out.read_text())
    jsonschema.Draft202012Validator(schema("design")).validate(doc)
    assert doc["pid"]["kp"] == pytest.approx(kc) and doc["pid"]["loop"] == "velocity" and doc["pid"]["rule"] == "simc"
    assert doc["pid"]["units"]["kp"] == "V per rpm" and doc["margins"]["dead_time_s"] == pytest.approx(0.1)
    assert all(re < 0 for re, _ in doc["closed_loop_poles"])
    sim = tmp_path / "sim.json"
    res = _motorid("simulate", fopdt_file, out, "--level", "100", "--saturation", "60", "--json", sim)
    assert res.returncode == 0, res.stderr
    data = json.loads(sim.read_text())
    assert data["anti_windup"] is True and data["metrics"]["overshoot_pct"] < 5
    assert abs(data["series"]["output"][-1] - 100) < 0.5


def test_pid_on_the_demo_model(demo_run, tmp_path):
    model = demo_run.folder / "model.json"
    out = tmp_path / "pd.json"
    res = _in_process("design", model, "--pid", "--pid-loop", "position", "--pid-integral", "--json", out)
    assert res.returncode == 0, res.stderr
    assert "PID on the position" in res.stdout and "half rule" in res.stdout and "margins: " in res.stdout
    doc = json.loads(out.read_text())
    jsonschema.Draft202012Validator(schema("design")).validate(doc)
    assert doc["pid"]["kind"] == "PID" and all(re < 0 for re, _ in doc["closed_loop_poles"])
    assert doc["margins"]["phase_deg"] > 30
    res = _in_process("simulate", model, out, "--duration", "4")
    assert res.returncode == 0, res.stderr
    assert "overshoot" in res.stdout and "diverged" not in res.stdout


def test_pid_with_a_pole_placement_option_is_refused_in_one_line(fopdt_file):
    res = _in_process("design", fopdt_file, "--pid", "--observer-poles", "-30,-40")
    assert res.returncode == 2
    line = res.stderr.strip()
    assert "\n" not in line and "--pid" in line and "--observer-poles" in line and "Traceback" not in line
    res = _in_process("design", fopdt_file, "--poles", "-3,-4", "--tau-c", "0.2")
    assert res.returncode == 2 and "--tau-c goes with --pid" in res.stderr


def test_placement_from_the_command_line(fopdt_file, tmp_path):
    out = tmp_path / "pl.json"
    res = _in_process("design", fopdt_file, "--pid", "--pid-rule", "placement", "--damping", "0.8", "--wn", "3",
                      "--json", out)
    assert res.returncode == 0, res.stderr
    pid = json.loads(out.read_text())["pid"]
    # τ s² + (1 + k kp) s + k ki = τ (s² + 2ζωn s + ωn²): kp = (2ζωnτ − 1)/k, ki = ωn² τ / k
    assert pid["kp"] == pytest.approx((2 * 0.8 * 3 * 0.5 - 1) / 2) and pid["ki"] == pytest.approx(9 * 0.5 / 2)
    assert np.isfinite(pid["tf_s"]) and pid["rule"] == "placement"


def test_the_declared_pid_options_are_flags_of_design_and_the_front_doors_keywords():
    import inspect

    import typer.main

    import motorid as mi
    from motorid import options
    from motorid.cli.app import app

    flags = {opt for p in typer.main.get_command(app).commands["design"].params for opt in (*p.opts, *p.secondary_opts)}
    assert {s.flag for s in options.DESIGN_PID} <= flags and "--pid" in flags
    params = inspect.signature(mi.design_pid).parameters
    assert [n for n, p in params.items() if p.kind is inspect.Parameter.KEYWORD_ONLY] == list(
        options.names(options.DESIGN_PID))


def test_the_front_door_is_the_library(fopdt_file):
    import motorid as mi
    from motorid.control.pid import PidSettings, design_pid

    model = mi.MotorModel.from_json(json.loads(fopdt_file.read_text()))
    got = mi.design_pid(model, loop="position", integral=True, tau_c=0.2)
    want = design_pid(model, PidSettings(loop="position", integral=True, tau_c_s=0.2))
    assert (got.kp, got.ki, got.kd, got.tf_s) == (want.kp, want.ki, want.kd, want.tf_s)
    with pytest.raises(mi.MotorIdError, match=r"^tau_c must be a finite number > 0"):
        mi.design_pid(model, tau_c=-1.0)
    sim = mi.simulate(model, got, duration_s=3.0, level_v=1.0)
    assert sim.metrics.overshoot_pct < 40


def test_a_pid_emitted_as_c_from_the_command_line_compiles(tmp_path):
    import json
    import shutil
    import subprocess
    import sys

    from motorid.model import model_from_velocity_tf

    cc = shutil.which("cc")
    if cc is None:
        pytest.skip("no C compiler (cc) on PATH")
    model = tmp_path / "m.json"
    model.write_text(json.dumps(model_from_velocity_tf([2.0], [0.5, 1.0], with_position=True, delay_s=0.05).to_json()))
    out = subprocess.run([sys.executable, "-m", "motorid", "design", str(model), "--pid", "--discrete", "0.005",
                          "--emit", "c", "--json", str(tmp_path / "d.json")], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    assert "discrete controller: TS = 0.005 s" in out.stderr  # the printout leaves stdout to the code
    (tmp_path / "pid.c").write_text(out.stdout)
    subprocess.run([cc, "-std=c99", "-Wall", "-Werror", "-c", str(tmp_path / "pid.c"), "-o", str(tmp_path / "pid.o")],
                   check=True)
    data = json.loads((tmp_path / "d.json").read_text())
    assert data["pid"]["kind"] == "PI" and data["discrete"]["inputs"] == ["r", "velocity"]
