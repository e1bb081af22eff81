"""A PID in the closed-loop simulation: the sampled linear loop against python-control's
``forced_response`` of the continuous closed loop, and anti-windup by conditional integration."""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.control.pid import PidSettings, design_pid
from motorid.model.motor import model_from_velocity_tf
from motorid.simulation.closed_loop import ReferenceSignal, SimulationSettings, simulate_closed_loop


def _model(delay_s):
    return model_from_velocity_tf([2.0], np.polymul([0.5, 1.0], [0.05, 1.0]), with_position=True, delay_s=delay_s,
                                  units={"velocity": "rpm", "position": "rev"})


def _continuous(model, p, t, level):
    """r → y of the continuous loop built here: y = G (C_r r − C_y y), the dead time by Padé (order 10)."""
    g = model.velocity_tf if p.loop == "velocity" else model.position_tf
    g = control.tf(g.num[0][0], g.den[0][0])
    if model.delay_s > 0:
        g = g * control.tf(*control.pade(model.delay_s, 10))
    s = control.tf("s")
    c_r = p.kp + (p.ki / s if p.ki else 0 * s)
    c_y = c_r + (p.kd * s / (p.tf_s * s + 1) if p.kd else 0 * s)
    closed = control.feedback(g, c_y) * c_r
    return control.forced_response(closed, T=t, U=np.full(t.size, level)).outputs


@pytest.mark.parametrize("delay_s", [0.0, 0.05])
@pytest.mark.parametrize("settings", [PidSettings(), PidSettings(loop="position"),
                                      PidSettings(loop="position", integral=True)], ids=["PI", "PD", "PID"])
def test_the_sampled_loop_is_the_continuous_closed_loop(delay_s, settings):
    model = _model(delay_s)
    p = design_pid(model, settings)
    sim = simulate_closed_loop(model, p, SimulationSettings(duration_s=6.0, dt_s=1e-4,
                                                            reference=ReferenceSignal(level_v=10.0)))
    want = _continuous(model, p, sim.time_s, 10.0)
    # tolerance: the controller samples y every 0.1 ms and holds u (about half a sample of extra lag),
    # and the dead time's Padé approximant rings for a few ms around t = θ: 0.5 % of the step
    assert np.max(np.abs(sim.output_v - want)) < 0.005 * 10.0
    assert abs(sim.output_v[-1] - 10.0) < 0.1  # 1 %: integral action, or the motor's own integrator
    m = sim.metrics
    assert np.isfinite(m.settling_time_s) and m.overshoot_pct < 25
    info = control.step_info(want / 10.0, T=sim.time_s, yfinal=1.0, SettlingTimeThreshold=0.02)
    assert m.overshoot_pct == pytest.approx(info["Overshoot"], abs=0.5)


def test_anti_windup_holds_the_integrator_on_the_rails():
    model = _model(0.05)
    p = design_pid(model, PidSettings())
    base = dict(duration_s=4.0, reference=ReferenceSignal(level_v=5.0), saturation_v=3.0)
    held = simulate_closed_loop(model, p, SimulationSettings(**base))
    wound = simulate_closed_loop(model, p, SimulationSettings(**base, anti_windup=False))
    assert held.anti_windup and not wound.anti_windup
    assert np.max(np.abs(held.control_v)) == pytest.approx(3.0)
    # the wound-up integrator overshoots further and holds a larger integral at the peak
    assert held.metrics.overshoot_pct < wound.metrics.overshoot_pct
    assert np.max(held.integrator) < np.max(wound.integrator)
    assert any("saturated" in w for w in held.warnings)


def test_a_pid_runs_on_the_virtual_trainer():
    from motorid.control.params import MotorParams, model_from_params
    from motorid.trainer.closed_loop import simulate_on_trainer

    # the lab report's motor (the trainer's lab-report preset) and a position PD on it
    model = model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))
    p = design_pid(model, PidSettings(loop="position"))
    res = simulate_on_trainer(model, p, SimulationSettings(duration_s=3.0, dt_s=2e-3, saturation_v=10.0,
                                                           reference=ReferenceSignal(level_v=2.0)))
    assert not any("diverged" in w for w in res.warnings)
    assert abs(res.output_v[-1] - 2.0) < 0.1  # the trainer's friction and dead-zone leave a small error
