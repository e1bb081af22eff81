"""The controller as a system, discretised and emitted as C, Python and MATLAB difference equations.

The closed loop of :func:`controller_system` with the motor is built here with python-control's
``interconnect`` (not with the module's own plant helper) and must have the design's poles; the
emitted code is compiled (C) or executed (Python, MATLAB read as Python) and must reproduce
python-control's response of the discretised controller to 1e-9.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import control
import numpy as np
import pytest

from motorid.control import DesignSettings, MotorParams, design_controller, design_model, model_from_params
from motorid.control.controller import controller_system, signal_unit
from motorid.control.design import output_row
from motorid.control.emit import (
    METHODS,
    DiscreteController,
    discretise,
    discretise_design,
    emit,
    emit_c,
    emit_matlab,
    emit_python,
)
from motorid.errors import OptionError
from motorid.model import MotorModel

#: The lab report's motor (position and velocity, scope volts).
REPORT = MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55)

#: A motor like the demo's (tests/control/test_coordinates.py): velocity
#: (228 s + 5088)/((s + 2.31)(s + 36.2)(s + 67.3)), a position integrator and a current channel,
#: in a companion realisation the design re-expresses in measured coordinates.
VEL_NUM = [228.235, 5088.27]
VEL_DEN = np.poly([-2.31, -36.16, -67.29])
CUR_NUM = [44.89, 1027.97, 1135.73]


def _demo_like_model() -> MotorModel:
    sys_v = control.tf2ss(control.tf(VEL_NUM, VEL_DEN))
    a3, b3, cv = (np.asarray(x, dtype=float) for x in (sys_v.A, sys_v.B, sys_v.C))
    s_pts = [1j, 3.0 + 0j, 10j]
    g = np.array([np.linalg.solve(s * np.eye(3) - a3, b3[:, 0]) for s in s_pts])
    h = np.array([np.polyval(CUR_NUM, s) / np.polyval(VEL_DEN, s) for s in s_pts])
    ci = np.linalg.solve(g, h).real
    a = np.zeros((4, 4))
    a[0, 1:] = cv[0]
    a[1:, 1:] = a3
    b = np.vstack([[[0.0]], b3])
    c = np.vstack([np.r_[1.0, 0, 0, 0], np.r_[0.0, cv[0]], np.r_[0.0, ci]])
    return MotorModel(A=a, B=b, C=c, D=np.zeros((3, 1)), states=("position", "x1", "x2", "x3"),
                      outputs=("position", "velocity", "current"), method="test", units={"velocity": "rpm"})


REPORT_MODEL = model_from_params(REPORT)
DEMO_MODEL = _demo_like_model()

#: (model, settings): plain state feedback, integral action, an observer, both, on both motors.
CASES = {
    "feedback": (REPORT_MODEL, DesignSettings(poles=(-6.0, -9.0))),
    "integral": (REPORT_MODEL, DesignSettings(poles=(-4.0, -5.0, -7.0), integral=True)),
    "observer": (REPORT_MODEL, DesignSettings(poles=(-6.0, -9.0), observer_poles=(-50.0, -40.0))),
    "integral+observer": (REPORT_MODEL, DesignSettings(poles=(-4.0, -5.0, -7.0), integral=True,
                                                       observer_poles=(-50.0, -40.0))),
    "demo-feedback": (DEMO_MODEL, DesignSettings(poles=(-8.0, -10.0, -40.0, -70.0))),
    "demo-integral+observer": (DEMO_MODEL, DesignSettings(poles=(-5.0, -8.0, -10.0, -40.0, -70.0), integral=True,
                                                          observer_poles=(-100.0, -120.0, -140.0, -160.0))),
}


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    model, settings = CASES[request.param]
    return model, design_controller(model, settings)


def _plant(model, design):
    """The motor in the design's coordinates, its outputs named as the controller's inputs."""
    work = design_model(model, design)
    n = work.A.shape[0]
    if design.reduced is not None:  # the sensors read the measured states
        idx = [list(design.states).index(x) for x in design.reduced.measured]
        return control.ss(work.A, work.B, np.eye(n)[idx], np.zeros((len(idx), 1)), inputs=["u"],
                          outputs=list(design.reduced.measured))
    if design.L is not None:
        return control.ss(work.A, work.B, work.C, work.D, inputs=["u"], outputs=list(work.outputs))
    return control.ss(work.A, work.B, np.eye(n), np.zeros((n, 1)), inputs=["u"], outputs=list(design.states))


def test_the_controller_closes_the_designs_loop(case):
    model, design = case
    k = controller_system(model, design)
    assert k.input_labels[0] == "r" and k.output_labels == ["u"]
    if design.reduced is not None:
        assert k.input_labels[1:] == list(design.reduced.measured)
        assert k.state_labels[: len(design.reduced.estimated)] == [f"w_{s}" for s in design.reduced.estimated]
    elif design.L is None:
        assert k.input_labels[1:] == list(design.states)
    else:
        assert k.input_labels[1:] == [design.output]
        assert k.state_labels[: len(design.states)] == [f"x̂_{s}" for s in design.states]
    assert ("z" in k.state_labels) == (design.ki is not None)
    loop = control.interconnect([_plant(model, design), k], inplist=["r"], outlist=["u"], check_unused=False)
    want = design.output_feedback_poles if design.output_feedback_poles is not None else design.closed_loop_poles
    # characteristic polynomials: a repeated pole's eigenvalues split by √eps, its polynomial does not
    got_poly, want_poly = np.poly(np.linalg.eigvals(loop.A)).real, np.poly(want).real
    np.testing.assert_allclose(got_poly, want_poly, rtol=1e-8, atol=1e-8 * np.max(np.abs(want_poly)))


def test_unit_gain_at_dc_without_integral_action():
    """kr makes the state-feedback loop's output follow the reference (eq. 37): the controller's own DC gain agrees."""
    model, design = REPORT_MODEL, design_controller(REPORT_MODEL, CASES["observer"][1])
    loop = control.interconnect([_plant(model, design), controller_system(model, design)], inplist=["r"],
                                outlist=["position"], check_unused=False)
    assert float(np.real(loop.dcgain())) == pytest.approx(1.0, rel=1e-9)


def test_signal_units_follow_the_model():
    assert signal_unit("velocity", {"velocity": "rpm"}) == "rpm"
    assert signal_unit("acceleration", {"velocity": "rpm"}) == "rpm/s"
    assert signal_unit("r", {"velocity": "rpm"}, output="velocity") == "rpm"
    assert signal_unit("u", {}) == "V" and signal_unit("x1") == ""


def _inputs(dc: DiscreteController, n: int = 300) -> np.ndarray:
    """A step in r and a sine in every measured signal, one row per sample."""
    k = np.arange(n)
    cols = [np.where(k >= 5, 1.0, 0.0)]
    for j in range(1, len(dc.inputs)):
        cols.append(0.8 * np.sin(0.07 * (j + 1) * k + 0.3 * j) + 0.1 * j)
    return np.column_stack(cols)


def _reference(dc: DiscreteController, w: np.ndarray) -> np.ndarray:
    """python-control's response of the discretised controller (zero initial state)."""
    t = np.arange(w.shape[0]) * dc.ts_s
    return np.ravel(control.forced_response(dc.system, T=t, U=w.T).outputs)


@pytest.mark.parametrize("method", ["zoh", "tustin"])
def test_discretise_is_python_controls_c2d(case, method):
    model, design = case
    if method == "zoh" and (design.L is not None or design.reduced is not None):
        pytest.skip("zoh places an observer on the sampled motor: test_a_zoh_observer_is_placed_on_the_sampled_motor")
    dc = discretise_design(model, design, 0.002, method)
    ref = control.c2d(controller_system(model, design), 0.002, method="bilinear" if method == "tustin" else method)
    for got, want in ((dc.Ad, ref.A), (dc.Bd, ref.B), (dc.Cd, ref.C), (dc.Dd, ref.D)):
        np.testing.assert_array_equal(got, np.asarray(want, dtype=float).reshape(got.shape))
    assert dc.system.dt == 0.002 and dc.method == method
    w = _inputs(dc)
    np.testing.assert_allclose(dc.difference(w)[:, 0], _reference(dc, w), rtol=0, atol=1e-9)


def test_a_zoh_observer_is_placed_on_the_sampled_motor(case):
    # independently: the motor behind a zero-order hold (python-control's c2d), closed with the
    # sampled controller, has the sampled state feedback's poles (the command held, the estimate
    # exact) and the observer's poles mapped by z = e^{p·TS}: the separation of a sampled observer
    model, design = case
    if design.L is None and design.reduced is None:
        pytest.skip("no observer: zoh is python-control's c2d (above)")
    ts = 0.002
    dc = discretise_design(model, design, ts, "zoh")
    assert dc.method == "zoh" and "observer placed on the motor" in dc.description()
    motor = control.c2d(_plant(model, design), ts, method="zoh")
    loop = control.interconnect([motor, dc.system], inplist=["r"], outlist=["u"], check_unused=False)
    got = np.sort_complex(np.linalg.eigvals(np.asarray(loop.A, dtype=float)))
    work = design_model(model, design)
    phi = np.asarray(control.c2d(control.ss(work.A, work.B, np.eye(work.A.shape[0]), 0), ts).A)
    gam = np.asarray(control.c2d(control.ss(work.A, work.B, np.eye(work.A.shape[0]), 0), ts).B)
    k = design.K.reshape(1, -1)
    if design.ki is None:
        feedback = phi - gam @ k
    else:
        c = np.asarray(output_row(work, design.output)[1], dtype=float).reshape(1, -1)
        feedback = np.block([[phi - gam @ k, -gam * design.ki], [ts * c, np.ones((1, 1))]])
    observer = design.reduced.poles if design.reduced is not None else design.observer_poles
    want = np.sort_complex(np.r_[np.linalg.eigvals(feedback), np.exp(np.asarray(observer, dtype=complex) * ts)])
    np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-9)


CC = shutil.which("cc")

MAIN_C = r"""
#include <stdio.h>
#include "controller.c"

int main(void)
{
    motor_controller_state s;
    double in[%(n)d];
    motor_controller_init(&s);
    for (;;) {
        for (int i = 0; i < %(n)d; ++i)
            if (scanf("%%lf", &in[i]) != 1)
                return 0;
        printf("%%.17g\n", motor_controller_step(&s, %(args)s));
    }
}
"""


def _run_c(dc: DiscreteController, w: np.ndarray, tmp_path) -> np.ndarray:
    """The emitted C compiled with a small main() and fed ``w`` row by row: its ``u`` per row."""
    (tmp_path / "controller.c").write_text(emit_c(dc, source="a test"))
    n = len(dc.inputs)
    (tmp_path / "main.c").write_text(MAIN_C % {"n": n, "args": ", ".join(f"in[{i}]" for i in range(n))})
    exe = tmp_path / "ctl"
    subprocess.run([CC, "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2", "-o", str(exe),
                    str(tmp_path / "main.c")], check=True, capture_output=True, cwd=tmp_path)
    stdin = "\n".join(" ".join(format(v, ".17g") for v in row) for row in w) + "\n"
    run = subprocess.run([str(exe)], input=stdin, capture_output=True, text=True, check=True)
    return np.array([float(v) for v in run.stdout.split()])


@pytest.mark.skipif(CC is None, reason="no C compiler (cc) on PATH")
@pytest.mark.parametrize("method", ["zoh", "tustin"])
def test_the_emitted_c_computes_the_discretised_controller(case, method, tmp_path):
    model, design = case
    dc = discretise_design(model, design, 0.002, method)
    w = _inputs(dc)
    u = _run_c(dc, w, tmp_path)
    assert u.shape == (w.shape[0],)
    assert np.max(np.abs(u - _reference(dc, w))) <= 1e-9


def _run_python(code: str, w: np.ndarray) -> np.ndarray:
    ns: dict = {}
    exec(compile(code, "<emitted>", "exec"), ns)
    x = ns["motor_controller_init"]()
    return np.array([ns["motor_controller_step"](x, *row) for row in w])


def test_the_emitted_python_computes_the_discretised_controller(case):
    model, design = case
    dc = discretise_design(model, design, 0.002, "zoh")
    w = _inputs(dc)
    assert np.max(np.abs(_run_python(emit_python(dc), w) - _reference(dc, w))) <= 1e-9


def _matlab_as_python(code: str) -> str:
    """The emitted MATLAB function's body as Python (its statements are plain arithmetic)."""
    head, *body = [line for line in code.splitlines() if line and not line.startswith("%")]
    m = re.fullmatch(r"function \[(\w+), x\] = (\w+)\(x, (.*)\)", head)
    assert m, head
    out, name, args = m.groups()
    lines = [f"def {name}(x, {args}):"]
    for line in body:
        if line == "end":
            continue
        assert line.endswith(";"), line
        lines.append("    " + re.sub(r"x\((\d+)\)", lambda g: f"x[{int(g.group(1)) - 1}]", line[:-1]))
    lines.append(f"    return {out}")
    return "\n".join(lines)


def test_the_emitted_matlab_has_the_same_difference_equations(case):
    model, design = case
    dc = discretise_design(model, design, 0.002, "zoh")
    w = _inputs(dc)
    ns: dict = {}
    exec(_matlab_as_python(emit_matlab(dc)), ns)
    x = [0.0] * max(len(dc.states), 1)
    u = np.array([ns["motor_controller_step"](x, *row) for row in w])
    assert np.max(np.abs(u - _reference(dc, w))) <= 1e-9
    # the same right-hand sides, character for character, in all three languages
    rhs_c = re.findall(r"= (.*);", emit_c(dc).split("double motor_controller_step(")[1])
    rhs_m = [line.split(" = ", 1)[1][:-1] for line in emit_matlab(dc).splitlines()
             if re.match(r"(u|x\(\d+\)) = ", line)]
    rhs_p = [line.split(" = ", 1)[1] for line in emit_python(dc).splitlines() if re.match(r"    (u|x\[\d+\]) = ", line)]
    assert rhs_c[-len(rhs_m):] == rhs_m == rhs_p


def test_the_header_names_the_signals_units_and_limits():
    dc = discretise_design(DEMO_MODEL, design_controller(DEMO_MODEL, CASES["demo-feedback"][1]), 0.002)
    text = emit_c(dc, source="model demo.json")
    assert "model demo.json" in text and "discretised by zoh" in text
    assert "velocity [rpm]" in text and "acceleration [rpm/s]" in text and "u [V]" in text
    assert "Nyquist limit" in text and "Astrom & Wittenmark" in text
    assert text.isascii()


def test_a_long_interval_warns_with_the_rule_and_its_source():
    # sampled by c2d (tustin), the observer's poles count among the loop's
    design = design_controller(REPORT_MODEL, CASES["observer"][1])
    fast = discretise_design(REPORT_MODEL, design, 0.001, "tustin")
    assert fast.warnings == ()
    slow = discretise_design(REPORT_MODEL, design, 0.01, "tustin")
    # the fastest of the loop's poles and the controller's own (A − BK − LC: 56.7 rad/s here)
    own = np.linalg.eigvals(controller_system(REPORT_MODEL, design).A)
    fastest = max(np.max(np.abs(design.output_feedback_poles)), np.max(np.abs(own)))
    assert fastest > 50 and slow.fastest_pole_rad_s == pytest.approx(fastest, rel=1e-12)
    assert slow.ts_max_s == pytest.approx(np.pi / fastest, rel=1e-12)
    assert len(slow.warnings) == 1 and "TS*|p| = 0.57" in slow.warnings[0] and "Astrom" in slow.warnings[0]
    assert "WARNING: TS*|p| = 0.57" in emit_c(slow)


@pytest.mark.parametrize("ts", [0.0, -0.01, float("nan"), float("inf")])
def test_a_non_positive_interval_is_refused_naming_the_option(ts):
    design = design_controller(REPORT_MODEL, CASES["feedback"][1])
    with pytest.raises(OptionError, match=r"^--discrete must be a sampling interval in seconds > 0") as err:
        discretise_design(REPORT_MODEL, design, ts)
    assert "\n" not in str(err.value)


def test_an_interval_beyond_the_nyquist_limit_is_refused():
    design = design_controller(REPORT_MODEL, CASES["observer"][1])  # fastest pole 56.7 rad/s: π/56.7 = 0.0554 s
    with pytest.raises(OptionError, match=r"^--discrete 0\.06 s is at or beyond the Nyquist limit") as err:
        discretise_design(REPORT_MODEL, design, 0.06, "tustin")
    assert "\n" not in str(err.value)
    # placed on the sampled motor (zoh), the observer's poles map to e^{p·TS} exactly: only the
    # state feedback's (9 rad/s here) limit the interval, and 0.06 s keeps its loop stable
    sampled = discretise_design(REPORT_MODEL, design, 0.06)
    assert sampled.fastest_pole_rad_s == pytest.approx(9.0, rel=1e-9)
    assert sampled.loop_spectral_radius < 1


def test_an_interval_that_makes_the_sampled_loop_unstable_is_refused():
    design = design_controller(REPORT_MODEL, DesignSettings(poles=(-30.0, -35.0)))
    ts = 0.04  # below the Nyquist limit π/35 = 0.0898 s, but the high gains do not survive the hold's lag
    motor = control.c2d(_plant(REPORT_MODEL, design), ts)
    k = control.c2d(controller_system(REPORT_MODEL, design), ts)
    loop = control.interconnect([motor, k], inplist=["r"], outlist=["u"], check_unused=False)
    assert np.max(np.abs(np.linalg.eigvals(loop.A))) > 1  # independently: unstable
    with pytest.raises(OptionError, match=r"^--discrete 0\.04 s: the sampled loop is unstable"):
        discretise_design(REPORT_MODEL, design, ts)


def test_an_unstable_design_is_refused_as_such_not_for_its_interval():
    # a given ki that violates the Routh–Hurwitz condition: the design warns, sampling refuses
    design = design_controller(REPORT_MODEL, DesignSettings(poles=(-2.0, -3.0), integral=True, ki=500.0))
    assert np.max(design.closed_loop_poles.real) > 0
    with pytest.raises(OptionError, match=r"^--discrete: the designed loop itself is unstable"):
        discretise_design(REPORT_MODEL, design, 0.001)


def test_an_unknown_method_or_language_is_refused():
    design = design_controller(REPORT_MODEL, CASES["feedback"][1])
    with pytest.raises(OptionError, match=r"^--discrete-method 'magic'"):
        discretise_design(REPORT_MODEL, design, 0.001, "magic")
    dc = discretise_design(REPORT_MODEL, design, 0.001)
    with pytest.raises(OptionError, match=r"^--emit 'rust'"):
        emit(dc, "rust")
    assert set(METHODS) >= {"zoh", "tustin"}


def test_any_controller_in_state_space_form_is_emitted():
    """A PI controller u = kp (r − y) + ki ∫(r − y), given as python-control StateSpace, not a Design."""
    pi = control.ss([[0.0]], [[1.0, -1.0]], [[3.0]], [[2.0, -2.0]], inputs=["r", "velocity"], outputs=["u"])
    dc = discretise(pi, 0.01, "tustin", units={"r": "rpm", "velocity": "rpm", "u": "V"})
    w = _inputs(dc)
    assert np.max(np.abs(_run_python(emit_python(dc), w) - _reference(dc, w))) <= 1e-9
    assert "velocity [rpm]" in emit_c(dc)
    with pytest.raises(OptionError, match="continuous-time"):
        discretise(dc.system, 0.01)


def test_the_header_cannot_break_out_of_its_comment_or_docstring():
    pi = control.ss([[0.0]], [[1.0, -1.0]], [[3.0]], [[2.0, -2.0]], inputs=["r", "velocity"], outputs=["u"])
    dc = discretise(pi, 0.01, units={"velocity": "rpm*/s"}, notes=('a """ note /* with \\d',))
    head = emit_c(dc).split("*/")[0]  # the header comment, up to its first end
    assert head.count("/*") == 1 and "velocity [rpm* /s]" in head and "Ad x[k]" in head
    code = emit_python(dc)
    compile(code, "<emitted>", "exec")
    assert code.count('"""') == 6  # the module's, init's and step's docstrings


def test_a_discrete_python_control_system_is_emitted_as_given():
    """The emitters take a discrete-time StateSpace as well (a PID discretised by its own rule)."""
    pid = control.ss([[1.0, 0.0], [0.0, 0.5]], [[0.01, -0.01], [0.0, 0.2]], [[3.0, -1.0]], [[2.0, -2.5]], 0.01,
                     inputs=["r", "position"], outputs=["u"])
    w = np.column_stack([np.ones(50), np.sin(0.2 * np.arange(50))])
    want = np.ravel(control.forced_response(pid, T=np.arange(50) * 0.01, U=w.T).outputs)
    assert np.max(np.abs(_run_python(emit_python(pid), w) - want)) <= 1e-12
    assert "a discrete-time system as given" in emit_c(pid)
    with pytest.raises(OptionError, match="discrete-time system with a sampling interval"):
        emit_c(control.ss([[-1.0]], [[1.0]], [[1.0]], [[0.0]]))


@pytest.mark.parametrize("method", METHODS)
def test_every_method_gives_code_that_runs_the_discretised_controller(method):
    model, settings = CASES["integral+observer"]
    dc = discretise_design(model, design_controller(model, settings), 0.002, method)
    assert f"discretised by {method}" in emit_c(dc)
    w = _inputs(dc)
    assert np.max(np.abs(_run_python(emit_python(dc), w) - _reference(dc, w))) <= 1e-9


def test_the_sampled_loop_check_includes_the_models_dead_time():
    """A dead time of exactly two intervals is z⁻² at the motor's input: the loop's largest |z| agrees."""
    ts = 0.004
    model = REPORT_MODEL.replace(delay_s=2 * ts)
    design = design_controller(model, CASES["integral+observer"][1])
    dc = discretise_design(model, design, ts)
    plant = _plant(model, design)
    m = control.c2d(plant, ts) * control.ss(control.tf([1.0], [1.0, 0.0, 0.0], ts))
    motor = control.ss(m.A, m.B, m.C, m.D, ts, inputs=["u"], outputs=plant.output_labels)
    exact = control.interconnect([motor, dc.system], inplist=["r"], outlist=["u"], check_unused=False)
    rho = np.max(np.abs(np.linalg.eigvals(exact.A)))
    # the check's Padé approximant against the exact z⁻²: 4e-8 apart with numpy 2.4 / scipy 1.17, 4e-5
    # with numpy 2.5 / scipy 1.18 (the order-8 approximant's coefficients are ill-conditioned)
    assert dc.loop_spectral_radius == pytest.approx(rho, abs=1e-4)
    without = discretise_design(REPORT_MODEL, design, ts).loop_spectral_radius
    assert abs(rho - without) > 3e-4  # the delay is in the check, not left out (3.5e-4 here)


@pytest.mark.skipif(CC is None, reason="no C compiler (cc) on PATH")
@pytest.mark.parametrize("loop", ["velocity", "position"])
def test_a_pid_is_emitted_as_c_that_computes_its_discretised_controller(loop, tmp_path):
    from motorid.control.emit import discretise_pid
    from motorid.control.pid import PidSettings, design_pid
    from motorid.model import model_from_velocity_tf

    model = model_from_velocity_tf([2.0], [0.5, 1.0], with_position=True, delay_s=0.05)
    pid = design_pid(model, PidSettings(loop=loop, integral=True if loop == "position" else None))
    dc = discretise_pid(model, pid, 0.005)
    assert list(dc.inputs) == ["r", loop]
    # the sampled controller is python-control's c2d of the PID's own system
    want = control.c2d(pid.system(), 0.005, method="zoh")
    np.testing.assert_allclose(np.asarray(dc.system.A), np.asarray(want.A), rtol=1e-12, atol=1e-15)
    w = _inputs(dc)
    u = _run_c(dc, w, tmp_path)
    assert np.max(np.abs(u - _reference(dc, w))) <= 1e-9
    assert "PI" in emit_c(dc) and "kp = " in emit_c(dc)
