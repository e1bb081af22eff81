"""A design's observer run every TS: placed on the motor as the sampled controller sees it.

The model is the output-error fit of the HSLU lab's open-loop rig log ``06_dc_step_5_15_00``
(three poles, its speed in rpm), written out so the test runs in a plain clone.  Only the
velocity is measured, so acceleration and jerk are estimated by a reduced-order observer
(poles −400 and −460 rad/s, four times the fastest closed-loop pole).  Sampled by holding the
measured velocity over each interval (python-control's ``c2d`` of the continuous observer, what
the simulation and the emitted code did), the estimate was biased by about ``L·TS/2`` times its
rate: at TS = 1 ms the acceleration came out 1.46 times too large and the loop rose in 0.845 s
where its design (poles −20, −20, −100) rises in 0.170 s.
"""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.control import DesignSettings, design_controller, design_model
from motorid.control.emit import discretise_design
from motorid.control.sampled import sampled_observer, sampled_reduced_observer
from motorid.model import MotorModel
from motorid.simulation.closed_loop import ReferenceSignal, SimulationSettings, simulate_closed_loop

#: The identified model (controllable canonical form; velocity in rpm per volt of the input).
RIG = MotorModel(
    A=np.array([[-33.63196573398535, -349.4540810305391, -1043.969933855244], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
    B=np.array([[1.0], [0.0], [0.0]]), C=np.array([[0.0, 0.0, 256563.83061439937]]), D=np.zeros((1, 1)),
    states=("x1", "x2", "x3"), outputs=("velocity",), method="oe", units={"velocity": "rpm"})
TS = 1e-3


@pytest.fixture(scope="module")
def design():
    return design_controller(RIG, DesignSettings(damping=1.0, wn=20.0))


def _continuous_step(design) -> dict:
    """python-control's step metrics of the continuous design (state feedback on the true states)."""
    work = design_model(RIG, design)
    a, b = np.asarray(work.A), np.asarray(work.B).reshape(-1, 1)
    c = np.asarray(work.C)[0:1]
    loop = control.ss(a - b @ design.K.reshape(1, -1), b * design.kr, c, 0)
    return control.step_info(loop * 500.0, SettlingTimeThreshold=0.02, RiseTimeLimits=(0.1, 0.9))


def test_the_estimate_of_an_unmeasured_derivative_is_exact_at_every_sample(design):
    assert design.reduced is not None and design.reduced.measured == ("velocity",)
    sim = simulate_closed_loop(RIG, design, SimulationSettings(duration_s=2.0, dt_s=TS,
                                                              reference=ReferenceSignal(level_v=500.0)))
    # from a motor at rest the sampled observer's error stays zero: e[k+1] = F e[k], e[0] = 0
    scale = np.max(np.abs(sim.states), axis=0)
    np.testing.assert_allclose(sim.estimates / scale, sim.states / scale, rtol=0, atol=1e-9)


def test_the_sampled_loop_keeps_to_its_design(design):
    sim = simulate_closed_loop(RIG, design, SimulationSettings(duration_s=2.0, dt_s=TS,
                                                              reference=ReferenceSignal(level_v=500.0)))
    want = _continuous_step(design)
    assert want["RiseTime"] == pytest.approx(0.170, abs=0.002)  # the design's promise
    # held command at TS·|p| = 0.1 of the fastest closed-loop pole: within a few per cent
    assert sim.metrics.rise_time_s == pytest.approx(want["RiseTime"], rel=0.03)
    assert sim.metrics.settling_time_s == pytest.approx(want["SettlingTime"], rel=0.03)


def test_the_emitted_controller_is_the_simulated_one(design):
    # the motor behind a zero-order hold and the --discrete controller give the simulation's commands
    sim = simulate_closed_loop(RIG, design, SimulationSettings(duration_s=0.5, dt_s=TS,
                                                              reference=ReferenceSignal(level_v=500.0)))
    dc = discretise_design(RIG, design, TS)
    work = design_model(RIG, design)
    motor = control.c2d(control.ss(work.A, work.B, np.eye(3)[[0]], 0, inputs=["u"], outputs=["velocity"]), TS)
    loop = control.interconnect([motor, dc.system], inplist=["r"], outlist=["u"], check_unused=False)
    n = sim.time_s.size
    u = np.ravel(control.forced_response(loop, T=sim.time_s, U=np.full(n, 500.0)).outputs)
    np.testing.assert_allclose(u, sim.control_v, rtol=1e-9, atol=1e-9 * np.max(np.abs(sim.control_v)))


def test_observer_poles_map_to_the_unit_circle(design):
    work = design_model(RIG, design)
    red = sampled_reduced_observer(work.A, work.B, design.reduced, tuple(design.states), TS)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(red.F).real),
                               np.sort(np.exp(design.reduced.poles.real * TS)), rtol=1e-9)
    full = design_controller(RIG, DesignSettings(damping=1.0, wn=20.0, output="velocity", sensors=("velocity",),
                                                 observer_poles=(-200.0, -220.0, -240.0)))
    work = design_model(RIG, full)
    c = np.asarray(work.C)[0:1]
    phi_o, _ = sampled_observer(work.A, work.B, c, np.array([-200.0, -220.0, -240.0]), TS)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(phi_o).real), np.exp(np.array([-240.0, -220.0, -200.0]) * TS),
                               rtol=1e-9)
