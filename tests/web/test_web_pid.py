"""POST /api/simulate runs a PID design JSON (motorid design --pid --json) as the front door does."""

from __future__ import annotations

import numpy as np
import pytest

import motorid as mi
from motorid.control.pid import PidSettings, design_pid


def test_api_simulate_runs_a_pid_design(client, demo_run):
    model_json = demo_run.result.identification.model.to_json()
    model = mi.MotorModel.from_json(model_json)
    pid = design_pid(model, PidSettings())
    res = client.post("/api/simulate", json={"model": model_json, "design": pid.to_json(), "duration_s": 2.0,
                                             "saturation": 10.0, "level_v": 3.0})
    assert res.status_code == 200, res.text
    sim = mi.simulate(model, pid, duration_s=2.0, saturation=10.0, level_v=3.0)
    body = res.json()
    assert body["metrics"]["overshoot_pct"] == pytest.approx(sim.metrics.overshoot_pct, rel=1e-9, abs=1e-12)
    np.testing.assert_allclose(body["series"]["output"], sim.output_v, rtol=1e-9, atol=1e-12)
    assert body["anti_windup"] is True


def test_api_design_with_pid_is_the_front_door(client, demo_run):
    model_json = demo_run.result.identification.model.to_json()
    res = client.post("/api/design", json={"model": model_json, "pid": True, "loop": "position", "tau_c": 0.2})
    assert res.status_code == 200, res.text
    want = mi.design_pid(mi.MotorModel.from_json(model_json), loop="position", tau_c=0.2)
    got = res.json()
    assert got["schema"] == "motorid.design/1" and got["pid"]["kp"] == pytest.approx(want.kp, rel=1e-12)
    assert got["pid"]["kd"] == pytest.approx(want.kd, rel=1e-12)
    res = client.post("/api/design", json={"model": model_json, "pid": True, "poles": [-3, -4]})
    assert res.status_code == 422 and "pid and poles" in res.text
