"""Designs read the sensors the rig has; what no sensor measures is estimated, never differentiated."""

from __future__ import annotations

import json

import control
import numpy as np
import pytest
from clihelpers import motorid_ok

import motorid as mi
from motorid.control.design import Design, design_model, output_row
from motorid.errors import OptionError


@pytest.fixture(scope="module")
def demo_model(demo_run):
    return mi.MotorModel.from_json(json.loads((demo_run.folder / "model.json").read_text()))


def test_the_default_design_reads_the_identified_channels_and_estimates_the_acceleration(demo_model):
    des = mi.design(demo_model, damping=1.0, wn=8.0, robust_samples=0)
    assert des.sensors == ("position", "velocity", "current")
    assert des.reduced is not None and des.reduced.estimated == ("acceleration",)
    # the observer's error obeys ė = F e: F = A_uu − L A_mu, its poles those reported
    work = design_model(demo_model, des)
    mi_, ui = des.reduced.split(des.states)
    f = work.A[np.ix_(ui, ui)] - des.reduced.L @ work.A[np.ix_(mi_, ui)]
    np.testing.assert_allclose(np.linalg.eigvals(f), des.reduced.poles, rtol=1e-9)
    # separation: the loop's poles are the controller's and the observer's
    want = np.sort_complex(np.concatenate([des.closed_loop_poles, des.reduced.poles]))
    np.testing.assert_allclose(np.sort_complex(des.output_feedback_poles), want, rtol=1e-6, atol=1e-6)
    data = des.to_json()
    assert data["sensors"] == ["position", "velocity", "current"]
    assert data["reduced_observer"]["estimated"] == ["acceleration"]
    back = Design.from_json(json.loads(des.to_json_text()))
    np.testing.assert_array_equal(back.reduced.L, des.reduced.L)


def test_a_position_sensor_alone_gets_a_third_order_observer(demo_model):
    des = mi.design(demo_model, damping=1.0, wn=8.0, sensors=["position"], robust_samples=0)
    assert des.reduced.measured == ("position",)
    assert des.reduced.estimated == ("velocity", "current", "acceleration")
    assert des.reduced.poles.size == 3 and np.all(des.reduced.poles.real < 0)
    given = mi.design(demo_model, damping=1.0, wn=8.0, sensors=["position"], observer_poles=[-60, -70, -80],
                      robust_samples=0)
    np.testing.assert_allclose(np.sort(given.reduced.poles.real), [-80, -70, -60], rtol=1e-8)


def test_the_simulated_loop_from_rest_is_the_state_feedback_loop(demo_model):
    # the estimate starts exact (the motor at rest) and its error obeys ė = F e: the response to a
    # step is the one of state feedback on the true states, computed here by python-control
    des = mi.design(demo_model, damping=1.0, wn=8.0, robust_samples=0)
    sim = mi.simulate(demo_model, des, duration_s=2.0, level_v=1.0)
    work = design_model(demo_model, des)
    a, b = work.A, work.B.reshape(-1, 1)
    c = output_row(work, des.output)[1].reshape(1, -1)
    closed = control.ss(a - b @ des.K.reshape(1, -1), b * des.kr, c, 0.0)
    _, y = control.step_response(closed, T=sim.time_s)
    np.testing.assert_allclose(sim.output_v, np.ravel(y), atol=0.01 * float(np.max(np.abs(y))))
    assert sim.metrics.overshoot_pct < 1.0


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"sensors": ["acceleration"]}, "derivatives are estimated"),
    ({"sensors": ["position", "position"]}, "distinct"),
    ({"sensors": ["velocity"], "integral": True, "ki": 1.0}, "add it to (--)?sensors"),
    ({"sensors": ["position"], "observer_poles": [-50, -60]}, "one per state the sensors do not measure"),
])
def test_bad_sensor_choices_are_one_line_refusals(demo_model, kwargs, match):
    with pytest.raises(OptionError, match=match):
        mi.design(demo_model, damping=1.0, wn=8.0, robust_samples=0, **kwargs)


def test_a_model_without_a_current_channel_has_no_current_sensor():
    from motorid.model import model_from_velocity_tf

    model = model_from_velocity_tf([20.0], [1.0, 12.0, 20.0], with_position=True, step_volts=5.0, method="oe")
    des = mi.design(model, damping=1.0, wn=4.0, robust_samples=0)
    assert des.sensors == ("position", "velocity") and des.reduced.estimated == ("acceleration",)
    with pytest.raises(OptionError, match="has no current"):
        mi.design(model, damping=1.0, wn=4.0, sensors=["position", "current"], robust_samples=0)


def test_the_command_line_prints_the_sensors_the_observer_the_margins_and_the_robust_fraction(demo_run, tmp_path):
    text = motorid_ok("design", demo_run.folder / "model.json", "--damping", "1", "--wn", "8",
                      "--json", tmp_path / "d.json").out
    assert "sensors: position, velocity, current; acceleration estimated by a reduced-order observer" in text
    assert "(on its estimate)" in text
    assert "margins: gain margin" in text
    assert "robust: stable for 100 % of 2000 plausible motors" in text
    data = json.loads((tmp_path / "d.json").read_text())
    assert data["robust"]["samples"] == 2000 and data["robust"]["stable_fraction"] == 1.0
    sim = motorid_ok("simulate", demo_run.folder / "model.json", tmp_path / "d.json")
    assert "diverged" not in sim.out + sim.err


def test_the_rig_logs_model_gets_a_design_on_its_tacho_with_margins_and_the_robust_fraction(tmp_path):
    """The L298N rig's rpm log (a velocity-only model with a dead time) as a user runs it (in-process
    through the real entry point; ``tests/control/test_pid_cli.py`` runs design and simulate in a
    fresh process)."""
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("l298n-rpm", tmp_path / "rig", seed=0)
    model = tmp_path / "m.json"
    motorid_ok("identify", *rec.cli_args, "--json", model)
    out = motorid_ok("design", model, "--damping", "1", "--wn", "8", "--integral", "--json", tmp_path / "d.json").out
    assert "sensors: velocity" in out and "acceleration" not in out
    assert "margins: gain margin" in out and "dead time included" in out
    assert "robust: stable for 100 % of 2000 plausible motors" in out
    assert "per rpm of the tacho" in out
    sim = motorid_ok("simulate", model, tmp_path / "d.json", "--level", "500")
    assert "overshoot" in sim.out and "diverged" not in sim.out + sim.err
