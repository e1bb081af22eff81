"""Closed-loop simulation against python-control and the report's qualitative results."""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.control import DesignSettings, MotorParams, design_controller, model_from_params
from motorid.errors import OptionError
from motorid.simulation.closed_loop import (
    ReferenceSignal,
    SimulationSettings,
    plot_simulation,
    simulate_closed_loop,
)


@pytest.fixture(scope="module")
def model():
    return model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))


@pytest.fixture(scope="module")
def sf(model):
    return design_controller(model, DesignSettings(damping=1.0, k2=8.5))


def test_linear_step_matches_python_control(model, sf):
    s = SimulationSettings(duration_s=3.0, dt_s=1e-3, x0=(2.0, 0.0), reference=ReferenceSignal(level_v=5.0))
    res = simulate_closed_loop(model, sf, s)
    k = sf.K.reshape(1, 2)
    cl = control.ss(model.A - model.B @ k, model.B * sf.kr, [[1, 0]], 0)
    ref = control.forced_response(cl, res.time_s, np.full(res.time_s.size, 5.0), X0=[2.0, 0.0])
    # the sampled controller (1 ms ZOH) vs the continuous loop with poles at −7.9: ~0.4 % of the step
    np.testing.assert_allclose(res.output_v, np.asarray(ref.outputs), atol=0.015)
    m = res.metrics
    assert m.overshoot_pct < 0.1  # critically damped: no overshoot (report §2.2.1)
    # double pole at −ω: the error (1 + ωt)e^(−ωt) falls below 2 % at ωt = 5.834
    omega = -float(sf.closed_loop_poles[0].real)
    assert m.settling_time_s == pytest.approx(5.834 / omega, abs=2e-3)
    assert abs(m.steady_state_error_v) < 1e-6


def test_saturation_bounds_control(model, sf):
    res = simulate_closed_loop(model, sf, SimulationSettings(duration_s=2.0, x0=(2.0, 0.0), saturation_v=10.0))
    assert res.metrics.peak_control_v <= 10.0 + 1e-12
    assert np.max(np.abs(res.control_raw_v)) > 10.0 and res.warnings


def test_brake_error_and_integral_rejection(model, sf):
    d_v = 1.0
    s = SimulationSettings(duration_s=8.0, dt_s=2e-3, x0=(2.0, 0.0), disturbance_v=d_v)
    res = simulate_closed_loop(model, sf, s)
    # static feedback: k1 (r − x1) = d at rest → e_ss = d/k1 (report §2.2.2: an error remains)
    assert res.metrics.steady_state_error_v == pytest.approx(d_v / sf.K[0], rel=1e-3)
    di = design_controller(model, DesignSettings(damping=1.0, k2=8.5, integral=True, ki=5.0))
    res_i = simulate_closed_loop(model, di, SimulationSettings(duration_s=40.0, dt_s=5e-3, x0=(2.0, 0.0),
                                                             z0=-2.0, disturbance_v=d_v))
    assert abs(res_i.metrics.steady_state_error_v) < 1e-3  # report §3: integral action removes it


def test_sinusoid_tracking_worse_at_higher_frequency(model, sf):
    # report §2.2.3: 5 + 2 sin ωt followed well at ω = π/8, with a visible lag at ω = π/2
    errs = []
    for w in (np.pi / 2, np.pi / 8):
        ref = ReferenceSignal(kind="sine", level_v=5.0, amplitude_v=2.0, frequency_hz=w / (2 * np.pi))
        res = simulate_closed_loop(model, sf, SimulationSettings(duration_s=16.0, dt_s=4e-3, x0=(5.0, 0.0),
                                                                 reference=ref))
        errs.append(res.metrics.tracking_rms_v)
    assert errs[0] > 3 * errs[1]


def test_observer_estimate_converges(model):
    d = design_controller(model, DesignSettings(damping=1.0, k2=8.5, observer_poles=(-80, -10)))
    res = simulate_closed_loop(model, d, SimulationSettings(duration_s=3.0, x0=(2.0, 0.0), xhat0=(0.0, 0.0)))
    err = np.abs(res.estimates - res.states)
    # e(t) decays with the observer poles (slowest −10: e^(−30) after 3 s)
    assert err[0].max() > 1.0 and err[-1].max() < 1e-6
    assert abs(res.metrics.steady_state_error_v) < 1e-4


def test_trainer_plant_close_to_model(model, sf):
    s = SimulationSettings(duration_s=0.8, dt_s=4e-3, x0=(2.0, 0.0), saturation_v=10.0, plant="trainer")
    from motorid.trainer.closed_loop import simulate_on_trainer

    res = simulate_on_trainer(model, sf, s)
    lin = simulate_closed_loop(model, sf, SimulationSettings(duration_s=0.8, dt_s=4e-3, x0=(2.0, 0.0),
                                                             saturation_v=10.0))
    # the lab-report trainer is built from the same km, kT, Tm but has a 2 ms electrical pole,
    # friction and a dead-zone: the output should follow the model to within ~0.1 V of a 3 V move
    assert np.max(np.abs(res.output_v - lin.output_v)) < 0.15


def test_trainer_plant_must_be_passed_in(model, sf):
    # simulate does not import the trainer: a trainer run without its loop is refused, by name
    s = SimulationSettings(duration_s=0.1, dt_s=4e-3, x0=(2.0, 0.0), plant="trainer")
    with pytest.raises(OptionError, match="simulate_on_trainer"):
        simulate_closed_loop(model, sf, s)


def test_outputs_and_plot(model, sf, tmp_path):
    res = simulate_closed_loop(model, sf, SimulationSettings(duration_s=0.5, x0=(2.0, 0.0)))
    text = res.to_csv_text()
    assert text.splitlines()[0].startswith("time,reference,output,u,u_raw,position,velocity")
    assert res.to_json()["metrics"]["peak_control_v"] > 0
    png = tmp_path / "s.png"
    plot_simulation(res, png)
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_bad_settings(model, sf):
    with pytest.raises(OptionError):
        SimulationSettings(dt_s=-1)
    with pytest.raises(OptionError):
        ReferenceSignal(kind="ramp")
    with pytest.raises(OptionError, match="--x0"):
        simulate_closed_loop(model, sf, SimulationSettings(duration_s=1.0, x0=(1.0,)))
