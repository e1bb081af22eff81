"""End to end: several step levels → Hammerstein model → design → simulate → modes.

The chain runs on the model the code really produces (captures written as TDS files by the
virtual trainer, read back by the CLI), and the closed loop is checked against the trainer's
own nonlinear plant (amplifier dead-zone, Coulomb and static friction, rails).
"""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest

from motorid.control.design import Design, DesignSettings, design_controller
from motorid.io import write_tds_capture
from motorid.model import MotorModel
from motorid.simulation.closed_loop import ReferenceSignal, SimulationSettings, simulate_closed_loop
from motorid.simulation.modes import ModeCriteria, mode_map, servo_plants
from motorid.trainer.closed_loop import simulate_on_trainer
from motorid.trainer.multilevel import multilevel_experiment

POLES = "-4,-5,-30"
OBSERVER = "-40,-45,-50"


@pytest.fixture(scope="module")
def levels(tmp_path_factory):
    """Five levels × two repeats on the trainer with rails, as TDS folders ALL0000..ALL0009."""
    exp = multilevel_experiment("deadzone-rails", levels=(2.0, 4.0, 6.0, 8.0, 10.0), repeats=2, seed=7)
    out = tmp_path_factory.mktemp("levels")
    folders = []
    for i, c in enumerate(exp.captures):
        folder = out / f"ALL{i:04d}"
        write_tds_capture(folder, c.capture)
        folders.append(folder)
    return exp, folders


def _run(run_cli, *args):
    res = run_cli(*args)
    assert res.code == 0, res.err
    return res


def test_identify_several_levels_writes_a_hammerstein_model(levels, run_cli, tmp_path):
    exp, folders = levels
    m = tmp_path / "m.json"
    args = [a for f in folders for a in ("--velocity", f)]
    res = _run(run_cli, "identify", *args, "--json", m, "--report", tmp_path / "r.html")
    assert "dead-zone u0 =" in res.out and "saturated" in res.out
    doc = json.loads(m.read_text())
    nl = doc["static_nonlinearity"]
    assert abs(nl["dead_zone"]["value"] - exp.truth.dead_zone_v) < 0.05
    lo, hi = nl["dead_zone"]["ci95"]
    assert lo <= exp.truth.dead_zone_v <= hi
    assert nl["gain"]["value"] == pytest.approx(exp.truth.gain, rel=0.01)
    assert doc["first_order"]["dc_gain"] == pytest.approx(exp.truth.gain, rel=0.01)
    assert doc["first_order"]["time_constant"] == pytest.approx(exp.truth.time_constant_s, rel=0.03)
    assert nl["saturation"]["input_v"] == pytest.approx(exp.truth.saturation_input_v, abs=0.2)
    assert [lv["status"] for lv in nl["levels"]].count("saturated") == 2
    model = MotorModel.from_json(doc)
    assert model.static_nonlinearity is not None
    assert model.static_nonlinearity.dead_zone_v == pytest.approx(nl["dead_zone"]["value"])
    page = (tmp_path / "r.html").read_text()
    assert 'id="static"' in page and 'id="levels"' in page and "data:image/png;base64," in page


def test_experiment_folders_give_the_same_result(levels, run_cli, tmp_path):
    _, folders = levels
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    _run(run_cli, "identify", *[x for f in folders for x in ("--velocity", f)], "--json", a)
    _run(run_cli, "identify", *[x for f in folders for x in ("--experiment", f)], "--json", b)
    da, db = json.loads(a.read_text()), json.loads(b.read_text())
    assert da["static_nonlinearity"]["dead_zone"] == db["static_nonlinearity"]["dead_zone"]


def test_step_volts_list_must_match_the_captures(levels, run_cli):
    _, folders = levels
    res = run_cli("identify", "--velocity", folders[0], "--velocity", folders[2], "--step-volts", "2,4,6")
    assert res.code == 2 and "3 levels for 2 captures" in res.err


def _ess(text: str) -> float:
    return float(re.search(r"steady-state error (\S+) V", text).group(1))


def test_design_and_simulate_with_and_without_compensation_against_the_trainer(levels, run_cli, tmp_path):
    # the target: a position step with a dead-zone; the steady-state error with and
    # without compensation, on the identified model and on the trainer's nonlinear plant
    exp, folders = levels
    m, d = tmp_path / "m.json", tmp_path / "d.json"
    _run(run_cli, "identify", *[x for f in folders for x in ("--velocity", f)], "--json", m)
    res = _run(run_cli, "design", m, "--poles", POLES, "--observer-poles", OBSERVER, "--json", d)
    assert "dead-zone: u0 =" in res.out and "--compensate-dead-zone" in res.out
    design = Design.from_json(json.loads(d.read_text()))
    info = design.dead_zone_info()
    bound = info["steady_state_error_bound_v"]
    u0 = json.loads(m.read_text())["static_nonlinearity"]["dead_zone"]["value"]
    assert bound == pytest.approx(u0 / abs(design.K[design.states.index("position")]))
    common = ("--reference", "step", "--level", "1", "--duration", "4", "--saturation", "10")
    plain = _ess(_run(run_cli, "simulate", m, d, *common).out)
    comp = _ess(_run(run_cli, "simulate", m, d, *common, "--compensate-dead-zone").out)
    # the model: the loop stops inside the band without compensation, at the reference with it
    assert 0.2 * bound < abs(plain) <= 1.01 * bound
    assert abs(comp) < 0.05 * abs(plain)
    # the trainer's nonlinear plant (same dead-zone, plus static friction): same picture
    model = MotorModel.from_json(json.loads(m.read_text()))
    s = SimulationSettings(duration_s=4.0, dt_s=2e-3, reference=ReferenceSignal(kind="step", level_v=1.0),
                           saturation_v=10.0)
    tr_plain = simulate_on_trainer(model, design, s, config=exp.config).metrics.steady_state_error_v
    tr_comp = simulate_on_trainer(model, design, dataclasses.replace(s, dead_zone_compensation=True),
                                  config=exp.config).metrics.steady_state_error_v
    assert 0.2 * bound < abs(tr_plain) <= 1.2 * bound
    assert abs(tr_comp) < 0.2 * abs(tr_plain)


def test_compensation_needs_a_model_with_a_dead_zone(demo_run, run_cli, tmp_path):
    m = demo_run.folder / "model.json"
    d = tmp_path / "d.json"
    _run(run_cli, "design", m, "--damping", "1", "--wn", "5", "--observer-poles", "-40,-45,-50,-55",
         "--robust-samples", "0", "--json", d)
    res = run_cli("simulate", m, d, "--compensate-dead-zone")
    assert res.code == 2 and "static nonlinearity" in res.err


def test_the_dead_zone_changes_the_mode_map(levels):
    exp, _ = levels
    from motorid.identification.hammerstein import identify_levels

    model = identify_levels([c.capture for c in exp.captures]).model
    kp, kv = np.linspace(0.5, 20, 8), np.linspace(0, 3, 8)
    with_dz, _ = servo_plants(model)
    assert with_dz.dead_zone_v == pytest.approx(model.static_nonlinearity.dead_zone_v)
    without = dataclasses.replace(with_dz, dead_zone_v=0.0, dead_zone_negative_v=None)
    a = mode_map(with_dz, kp, kv, ModeCriteria(step_v=1.0)).labels
    b = mode_map(without, kp, kv, ModeCriteria(step_v=1.0)).labels
    assert np.any(a != b)


def test_linear_design_in_python_on_the_identified_model(levels):
    exp, _ = levels
    from motorid.identification.hammerstein import identify_levels

    model = identify_levels([c.capture for c in exp.captures]).model
    d = design_controller(model, DesignSettings(poles=(-4, -5, -30), observer_poles=(-40, -45, -50)))
    s = SimulationSettings(duration_s=4.0, dt_s=2e-3, reference=ReferenceSignal(kind="step", level_v=1.0))
    res = simulate_closed_loop(model, d, s)
    assert any("dead-zone" in w for w in res.warnings)
    assert d.to_json()["dead_zone"]["value"] == pytest.approx(model.static_nonlinearity.dead_zone_v)


def test_front_door_identify_levels(levels):
    import motorid as mi

    exp, folders = levels
    res = mi.identify_levels([str(f) for f in folders])
    assert abs(res.static.dead_zone_v - exp.truth.dead_zone_v) < 0.05
    assert res.model.static_nonlinearity is not None and res.shared_dynamics
    assert "identify_levels" in mi.__doc__


def test_real_hslu_logs_asked_for_several_levels_say_why_not(real_dir, run_cli):
    # the HSLU rig steps 5 V → 15 V (with and without a brake: one level) and its other logs are
    # closed-loop: each refusal is one line, exit 2
    csv = real_dir / "hslu-rtl-dcmotor" / "csv"
    res = run_cli("identify", "--velocity", csv / "06_dc_step_5_15_00.csv", "--velocity", csv / "06_dc_step_5_15_05.csv")
    assert res.code == 2 and res.err.count("\n") == 1 and "at least two step levels that move" in res.err
    res = run_cli("identify", "--velocity", csv / "06_dc_step_5_15_00.csv", "--velocity", csv / "09_dc_step_20_25_00.csv")
    assert res.code == 2 and res.err.count("\n") == 1 and "no step in the input channel" in res.err
