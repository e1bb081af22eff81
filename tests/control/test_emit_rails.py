"""The emitted controller with actuator rails runs as ``simulate --saturation`` does.

Before, ``design --discrete TS --emit`` wrote the controller without rails: on the rig the command
saturates (an H-bridge at its supply, a PWM duty at 255), and the emitted code then wound its
integrator up and fed its observer the command it asked for instead of the one applied, while
``simulate --saturation`` showed the loop with conditional integration and an observer fed the
clamped command.  With ``--saturation U`` the emitted step clamps, holds and feeds as the
simulation does: run in closed loop on the motor behind a zero-order hold (python-control's
``c2d``, an independent discretisation) the emitted Python gives the simulation's commands to
1e-9, for a reduced-order observer, a full-order one and a PID, each with integral action; the
code without rails does not.
"""

from __future__ import annotations

import shutil
import subprocess

import control
import numpy as np
import pytest
from clihelpers import motorid_ok

from motorid.control import DesignSettings, design_controller, design_model
from motorid.control.pid import PidSettings, design_pid
from motorid.control.emit import discretise_design, discretise_pid, emit_c, emit_python
from motorid.errors import OptionError
from motorid.model import MotorModel
from motorid.simulation.closed_loop import ReferenceSignal, SimulationSettings, simulate_closed_loop

#: The HSLU rig's third-order model (as in test_sampled_observer; velocity in rpm per volt).
RIG = MotorModel(
    A=np.array([[-33.63196573398535, -349.4540810305391, -1043.969933855244], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
    B=np.array([[1.0], [0.0], [0.0]]), C=np.array([[0.0, 0.0, 256563.83061439937]]), D=np.zeros((1, 1)),
    states=("x1", "x2", "x3"), outputs=("velocity",), method="oe", units={"velocity": "rpm"})
TS, RAILS, LEVEL = 1e-3, 6.0, 2000.0


def _emitted_step(dc):
    """The emitted Python module's step function and its state."""
    space: dict = {}
    exec(compile(emit_python(dc), "<emitted>", "exec"), space)  # the code under test
    return space["motor_controller_step"], space["motor_controller_init"]()


def _closed_loop(model, design, dc, n):
    """The emitted step on the motor behind a zero-order hold (python-control c2d), from rest."""
    work = design_model(model, design) if not hasattr(design, "loop") else model
    motor = control.c2d(control.ss(work.A, work.B, np.eye(work.A.shape[0]), 0), TS)
    phi, gam = np.asarray(motor.A), np.asarray(motor.B)[:, 0]
    read = [list(work.outputs).index(name) for name in dc.inputs[1:]]
    rows = np.asarray(work.C)[read]
    step, x_ctl = _emitted_step(dc)
    x = np.zeros(work.A.shape[0])
    u = np.empty(n)
    for k in range(n):
        u[k] = step(x_ctl, LEVEL, *(rows @ x))
        x = phi @ x + gam * u[k]
    return u


def _simulated(design, **kw):
    return simulate_closed_loop(RIG, design, SimulationSettings(
        duration_s=0.6, dt_s=TS, reference=ReferenceSignal(level_v=LEVEL), saturation_v=RAILS, **kw))


@pytest.mark.parametrize("observer", ["reduced", "full"])
def test_state_feedback_with_an_observer_and_integral_action(observer):
    extra = {} if observer == "reduced" else {"observer_poles": (-200.0, -220.0, -240.0), "sensors": ("velocity",)}
    design = design_controller(RIG, DesignSettings(damping=1.0, wn=20.0, integral=True, output="velocity", **extra))
    sim = _simulated(design)
    assert np.max(np.abs(sim.control_raw_v)) > 2 * RAILS  # the rails bind, and the integrator is held
    dc = discretise_design(RIG, design, TS, rails=RAILS)
    assert dc.integrator is not None and np.any(dc.applied_column())
    u = _closed_loop(RIG, design, dc, sim.time_s.size)
    np.testing.assert_allclose(u, sim.control_v, rtol=1e-9, atol=1e-9 * RAILS)
    # without rails the emitted code asks for commands the actuator cannot give, and winds up
    loose = _closed_loop(RIG, design, discretise_design(RIG, design, TS), sim.time_s.size)
    assert np.max(np.abs(loose)) > 2 * RAILS


def test_a_pid_with_integral_action():
    pid = design_pid(RIG, PidSettings(loop="velocity"))
    sim = simulate_closed_loop(RIG, pid, SimulationSettings(duration_s=0.6, dt_s=TS,
                                                            reference=ReferenceSignal(level_v=LEVEL),
                                                            saturation_v=RAILS))
    assert np.max(np.abs(sim.control_raw_v)) > RAILS
    dc = discretise_pid(RIG, pid, TS, rails=RAILS)
    assert dc.integrator is not None and not np.any(dc.applied_column())
    u = _closed_loop(RIG, pid, dc, sim.time_s.size)
    np.testing.assert_allclose(u, sim.control_v, rtol=1e-9, atol=1e-9 * RAILS)


def test_rails_are_refused_where_they_cannot_be_kept():
    design = design_controller(RIG, DesignSettings(damping=1.0, wn=20.0))
    with pytest.raises(OptionError, match="zero-order-hold"):
        discretise_design(RIG, design, TS, "tustin", rails=RAILS)
    with pytest.raises(OptionError, match="> 0"):
        discretise_design(RIG, design, TS, rails=-1.0)


def test_the_cli_writes_the_rails_into_the_code_and_the_json(tmp_path):
    import json

    model_file = tmp_path / "m.json"
    model_file.write_text(json.dumps(RIG.to_json()))
    res = motorid_ok("design", model_file, "--damping", "1", "--wn", "20", "--integral", "--discrete", "0.001",
                     "--saturation", "6", "--emit", "c", "--emit-file", tmp_path / "ctl.c", "--json", tmp_path / "d.json")
    assert "its command clamped to ±6 V, the integrator held against the rails, the observer fed the clamped" in res.out
    code = (tmp_path / "ctl.c").read_text()
    assert "#define MOTOR_CONTROLLER_RAILS 6" in code and "const int hold" in code
    # how the volts reach an H-bridge (the sign its direction), said in the header
    assert "analogWrite(PWM_PIN, (int)(255.0 * fabs(u) / VS));  digitalWrite(DIR_PIN, u >= 0.0);" in code
    doc = json.loads((tmp_path / "d.json").read_text())
    assert doc["discrete"]["rails"] == 6.0 and doc["discrete"]["integrator"] is not None
    from jsonschema import validate

    from motorid.schemas import schema

    validate(doc, schema("design"))
    bad = motorid_ok.__globals__["run_motorid"]("design", model_file, "--damping", "1", "--wn", "20",
                                                "--saturation", "6")
    assert bad.code != 0 and "--saturation needs --discrete" in bad.err
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    subprocess.run([cc, "-std=c99", "-Wall", "-Werror", "-c", str(tmp_path / "ctl.c"), "-o", str(tmp_path / "ctl.o")],
                   check=True, capture_output=True, text=True)


def test_no_rails_leaves_the_code_as_it_was():
    design = design_controller(RIG, DesignSettings(damping=1.0, wn=20.0, integral=True))
    code = emit_c(discretise_design(RIG, design, TS))
    assert "RAILS" not in code and "const int hold" not in code and "u_raw" not in code
