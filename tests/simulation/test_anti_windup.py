"""Integral action against the rails: the integrator held while the command is beyond a rail
(conditional integration), on by default with saturation; a loop swinging from rail to rail is
named as a limit cycle, with its cause."""

from __future__ import annotations

import json

import numpy as np
import pytest

import motorid as mi


@pytest.fixture(scope="module")
def model(demo_run):
    return mi.MotorModel.from_json(json.loads((demo_run.folder / "model.json").read_text()))


@pytest.fixture(scope="module")
def design(model):
    return mi.design(model, damping=1.0, wn=8.0, integral=True, robust_samples=0)


RUN = {"duration_s": 20.0, "level_v": 5.0, "saturation": 2.0}


def test_anti_windup_is_on_by_default_with_rails_and_lowers_overshoot_and_settling(model, design):
    held = mi.simulate(model, design, **RUN)
    wound = mi.simulate(model, design, **RUN, anti_windup=False)
    assert held.anti_windup and not wound.anti_windup
    assert held.metrics.overshoot_pct < wound.metrics.overshoot_pct
    settle = lambda r: r.metrics.settling_time_s if np.isfinite(r.metrics.settling_time_s) else np.inf  # noqa: E731
    assert settle(held) < settle(wound)
    # the integrator never ran away while held: its state stays within what the step needs
    assert np.max(np.abs(held.integrator)) < np.max(np.abs(wound.integrator))
    assert not any("limit-cycles" in w for w in held.warnings), held.warnings


def test_a_wound_up_loop_is_named_a_limit_cycle_with_its_cause(model, design):
    wound = mi.simulate(model, design, **RUN, anti_windup=False)
    cycle = [w for w in wound.warnings if "limit-cycles between the rails" in w]
    assert cycle and "integrator winds up" in cycle[0], wound.warnings
    # the series says the same: the command sits on both rails in the run's second half
    tail = wound.control_v[wound.control_v.size // 2:]
    assert tail.max() >= 2.0 - 1e-9 and tail.min() <= -2.0 + 1e-9


def test_without_rails_anti_windup_changes_nothing(model, design):
    a = mi.simulate(model, design, duration_s=3.0)
    b = mi.simulate(model, design, duration_s=3.0, anti_windup=True)
    np.testing.assert_array_equal(a.output_v, b.output_v)
    assert not a.anti_windup and b.anti_windup


def test_the_command_line_takes_the_switch(demo_run, run_cli, tmp_path):
    d = tmp_path / "d.json"
    assert run_cli("design", demo_run.folder / "model.json", "--damping", "1", "--wn", "8", "--integral",
                   "--robust-samples", "0", "--json", d).code == 0
    out = tmp_path / "s.json"
    res = run_cli("simulate", demo_run.folder / "model.json", d, "--saturation", "2", "--duration", "20",
                  "--no-anti-windup", "--json", out)
    assert res.code == 0, res.err
    data = json.loads(out.read_text())
    assert data["anti_windup"] is False and any("limit-cycles" in w for w in data["warnings"])
