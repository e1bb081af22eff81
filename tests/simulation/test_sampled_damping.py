"""What sampling does to the loop's damping is measured and printed, not assumed.

``motorid simulate`` used to print, after every run, "a digital loop, a little less damped than
the continuous one the design's numbers describe" — also when the sampled loop kept the design's
poles (a 1 ms loop on a 20 rad/s design) and whatever the interval did.  Now the sampled loop's
eigenvalues are mapped back by ``ln(z)/dt`` and their least damping compared with the continuous
design's; the reference is python-control's ``c2d`` of the same model (an independent
discretisation).
"""

from __future__ import annotations

import json

import control
import numpy as np
import pytest
from clihelpers import motorid_ok

import motorid as mi
from motorid.control.design import design_model
from motorid.model import MotorModel, model_from_velocity_tf
from motorid.simulation.closed_loop import SampledDamping, least_damping


@pytest.fixture(scope="module")
def servo() -> MotorModel:
    """A position servo, 1/(s(0.05 s + 1)) per volt, with position and velocity measured."""
    return model_from_velocity_tf([20.0], [0.05, 1.0], with_position=True)


def _python_control_damping(model: MotorModel, design, dt: float) -> float:
    """Least damping of eig(Φ − ΓK) mapped back, Φ, Γ from python-control's zoh c2d."""
    mm = design_model(model, design)
    n = mm.A.shape[0]
    sysd = control.c2d(control.ss(mm.A, mm.B, np.eye(n), np.zeros((n, 1))), dt, method="zoh")
    z = np.linalg.eigvals(sysd.A - sysd.B @ np.asarray(design.K).reshape(1, -1))
    return least_damping(np.log(z) / dt)


def test_least_damping_of_known_poles():
    assert least_damping(np.array([-1.0, -2.0])) == 1.0
    wn, zeta = 10.0, 0.3
    pair = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
    assert least_damping(np.array([pair, np.conj(pair), -50.0])) == pytest.approx(zeta, abs=1e-12)
    assert least_damping(np.array([0.5 + 2j])) < 0  # unstable
    assert least_damping(np.array([-np.inf])) == 1.0  # a deadbeat z = 0 maps there


@pytest.mark.parametrize("dt", [0.001, 0.01, 0.03])
def test_the_sampled_damping_is_python_controls(servo, dt):
    des = mi.design(servo, damping=0.7, wn=30.0)
    sim = mi.simulate(servo, des, duration_s=1.0, dt_s=dt)
    sd = sim.sampled_damping
    assert sd is not None and sd.design == pytest.approx(0.7, abs=1e-9)
    assert sd.sampled == pytest.approx(_python_control_damping(servo, des, dt), abs=1e-9)
    if dt == 0.001:
        assert abs(sd.sampled - 0.7) <= SampledDamping.SAME and "keep the continuous design's" in sd.text()
    else:  # the held command's lag: measurably less damped, and it gets worse with the interval
        assert sd.sampled < 0.7 - SampledDamping.SAME and "less damped" in sd.text()
        assert f"least ζ {sd.sampled:.2g} against 0.7" in sd.text()


def test_a_zoh_observer_keeps_its_poles(servo):
    """Observer poles placed on the sampled motor map back exactly: only the controller's move."""
    des = mi.design(servo, damping=1.0, wn=20.0, observer_poles=[-100.0 + 80.0j, -100.0 - 80.0j])
    sim = mi.simulate(servo, des, duration_s=0.5, dt_s=0.001)
    assert sim.sampled_damping is not None
    observer_damping = 100.0 / abs(-100.0 + 80.0j)
    assert sim.sampled_damping.design == pytest.approx(observer_damping, abs=1e-12)
    assert sim.sampled_damping.sampled == pytest.approx(observer_damping, abs=1e-9)


def test_the_cli_prints_what_sampling_did(servo, tmp_path):
    model_file, design_file = tmp_path / "m.json", tmp_path / "d.json"
    model_file.write_text(json.dumps(servo.to_json()))
    motorid_ok("design", model_file, "--damping", "0.7", "--wn", "30", "--json", design_file)
    fine = motorid_ok("simulate", model_file, design_file).out
    assert "a little less damped" not in fine  # the old sentence, printed whatever the loop did
    assert "keep the continuous design's least damping, ζ 0.7" in fine
    coarse = motorid_ok("simulate", model_file, design_file, "--dt", "0.03", "--json", tmp_path / "s.json").out
    sim = json.loads((tmp_path / "s.json").read_text())
    printed = f"least ζ {sim['sampled_damping']['sampled']:.2g} against 0.7; a smaller --dt brings it closer"
    assert printed in coarse
    from jsonschema import validate

    from motorid.schemas import schema

    validate(sim, schema("simulation"))
