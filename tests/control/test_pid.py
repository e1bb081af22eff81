"""PID design (velocity PI, position PD/PID by SIMC or pole placement) against independent
computations: Skogestad's SIMC formulas worked by hand, the closed loop and the margins from
python-control's ``feedback``, ``pade`` and ``stability_margins`` of a loop built here."""

from __future__ import annotations

import json
import math

import control
import numpy as np
import pytest

import motorid as mi
from motorid.control.pid import PidDesign, PidSettings, design_pid, reduce_half_rule
from motorid.errors import MotorIdError
from motorid.model.motor import model_from_velocity_tf

UNITS = {"velocity": "rpm", "position": "rev"}


def _fopdt(delay_s=0.1):
    """2 rpm/V, τ = 0.5 s, θ = 0.1 s; the position (rev) integrates the velocity (rev/s per rpm… as a test unit)."""
    return model_from_velocity_tf([2.0], [0.5, 1.0], with_position=True, delay_s=delay_s, units=UNITS)


def _second():
    return model_from_velocity_tf([3.0], np.polymul([0.5, 1.0], [0.05, 1.0]), with_position=True, delay_s=0.02)


def _third():
    # a zero at −20 (as identified models have) and three real lags
    den = np.polymul(np.polymul([1.0, 1.0], [0.2, 1.0]), [0.05, 1.0])
    return model_from_velocity_tf([0.05 * 1.5, 1.5], den, with_position=True)


@pytest.fixture(scope="module")
def demo_model(demo_run):
    return mi.MotorModel.from_json(json.loads((demo_run.folder / "model.json").read_text()))


def _pid_tf(p):
    """The PID from the error, built here: kp + ki/s + kd s/(tf s + 1)."""
    s = control.tf("s")
    c = p.kp + 0 * s
    if p.ki:
        c = c + p.ki / s
    if p.kd:
        c = c + p.kd * s / (p.tf_s * s + 1)
    return c


def _plant(model, channel):
    g = model.velocity_tf if channel == "velocity" else model.position_tf
    g = control.tf(g.num[0][0], g.den[0][0])
    if model.delay_s > 0:
        g = g * control.tf(*control.pade(model.delay_s, 8))
    return g


# ---------------------------------------------------------------- SIMC by hand

def test_simc_pi_on_a_fopdt_model_is_skogestads_formula():
    p = design_pid(_fopdt(), PidSettings())
    k, tau, theta = 2.0, 0.5, 0.1
    tau_c = max(theta, 0.25 * tau)  # the default τc: 0.125 s
    kc = tau / (k * (tau_c + theta))  # Skogestad 2003, SIMC PI: Kc = τ1 / (k (τc + θ))
    tau_i = min(tau, 4 * (tau_c + theta))  # τI = min(τ1, 4 (τc + θ))
    assert p.tau_c_s == pytest.approx(0.125)
    assert p.kp == pytest.approx(kc, rel=1e-12) and p.kp == pytest.approx(1.0 / 0.9)
    assert p.ki == pytest.approx(kc / tau_i, rel=1e-12)
    assert p.kd == 0 and p.tf_s == 0 and p.kind == "PI"
    assert p.units == {"kp": "V per rpm", "ki": "V per (rpm·s)", "kd": "V·s per rpm", "tf_s": "s"}
    given = design_pid(_fopdt(), PidSettings(tau_c_s=0.1))  # SIMC's "tight" τc = θ
    assert given.kp == pytest.approx(0.5 / (2 * 0.2)) and given.ki == pytest.approx(given.kp / min(0.5, 0.8))


def test_simc_position_pd_and_pid_are_the_integrating_process_rule():
    k1, tau2, theta = 2.0, 0.5, 0.1  # position: 2/(s(0.5 s + 1)) e^(−0.1 s)
    tau_c = 0.125
    kc = 1.0 / (k1 * (tau_c + theta))  # integrating process: Kc = 1 / (k' (τc + θ)), τD = τ2
    pd = design_pid(_fopdt(), PidSettings(loop="position"))
    assert pd.kind == "PD" and pd.kp == pytest.approx(kc) and pd.kd == pytest.approx(kc * tau2)
    assert pd.tf_s == pytest.approx(tau2 / 10)  # Td / N with N = 10
    assert pd.units["kp"] == "V per rev"
    pid = design_pid(_fopdt(), PidSettings(loop="position", integral=True))
    tau_i = 4 * (tau_c + theta)  # τI = 4 (τc + θ); series → parallel form
    assert pid.kp == pytest.approx(kc * (1 + tau2 / tau_i))
    assert pid.ki == pytest.approx(kc / tau_i) and pid.kd == pytest.approx(kc * tau2)


def test_half_rule_by_hand():
    den = np.polymul(np.polymul([1.0, 1.0], [0.2, 1.0]), [0.05, 1.0])
    red = reduce_half_rule(np.array([4.0]), den, 0.02, integrating=False)
    # τ1 = 1 + 0.2/2, θ = 0.02 + 0.2/2 + 0.05 (Skogestad 2003, §3.1)
    assert red.gain == pytest.approx(4.0) and red.tau_s == pytest.approx(1.1) and red.theta_s == pytest.approx(0.17)
    assert any("half rule" in n for n in red.notes)
    integ = reduce_half_rule(np.array([4.0]), np.polymul(den, [1.0, 0.0]), 0.0, integrating=True, channel="position")
    assert integ.integrating and integ.tau_s == pytest.approx(1.1) and integ.theta_s == pytest.approx(0.15)
    # a right-half-plane zero's time constant is dead time
    rhp = reduce_half_rule(np.array([-0.1 * 4.0, 4.0]), np.polymul([1.0, 1.0], [0.2, 1.0]), 0.0, integrating=False)
    assert rhp.theta_s == pytest.approx(0.1 + 0.1) and rhp.tau_s == pytest.approx(1.1)


def test_the_reduction_is_stated_in_the_warnings(demo_model):
    p = design_pid(demo_model, PidSettings())
    assert p.approximation.order == 3
    assert any("Skogestad's half rule" in w for w in p.warnings)


def test_placement_puts_the_approximations_poles_at_zeta_wn():
    m = model_from_velocity_tf([2.0], [0.5, 1.0], with_position=True)  # no dead time: exact
    p = design_pid(m, PidSettings(rule="placement", damping=0.8, wn=6.0))
    want = np.roots([1, 2 * 0.8 * 6, 36])
    got = np.asarray(control.feedback(_plant(m, "velocity") * _pid_tf(p), 1).poles())
    assert np.sort_complex(got) == pytest.approx(np.sort_complex(want), rel=1e-9)
    # the placement neglects the derivative filter: with a fast one (N = 1000) the loop's other
    # poles are the pair and −ωn to within a few tenths of a percent of ωn
    pid = design_pid(m, PidSettings(loop="position", integral=True, rule="placement", damping=0.7, wn=4.0,
                                    derivative_filter=1000.0))
    cl = np.asarray(control.feedback(_plant(m, "position") * _pid_tf(pid), 1).poles())
    slow = np.sort_complex(cl[np.abs(cl) < 100])
    want = np.sort_complex(np.concatenate([np.roots([1, 2 * 0.7 * 4, 16]), [-4.0]]))
    assert slow == pytest.approx(want, abs=0.02)


# ------------------------------------------------- stability and margins on the full model

MODELS = {"first-order + dead time": _fopdt, "second-order + dead time": _second, "third-order with a zero": _third}


@pytest.mark.parametrize("name", list(MODELS))
@pytest.mark.parametrize("settings", [PidSettings(), PidSettings(loop="position"),
                                      PidSettings(loop="position", integral=True)], ids=["PI", "PD", "PID"])
def test_the_closed_loop_is_stable_and_the_margins_are_python_controls(name, settings):
    model = MODELS[name]()
    p = design_pid(model, settings)
    loop = _pid_tf(p) * _plant(model, settings.loop)
    closed = control.feedback(loop, 1)
    assert np.all(np.real(closed.poles()) < 0), (name, p.gains())
    gm, pm, _sm, _wpc, wgc, _ = control.stability_margins(loop)
    assert p.margins.phase_deg == pytest.approx(pm, rel=1e-6)
    assert p.margins.crossover_rad_s == pytest.approx(wgc, rel=1e-6)
    if math.isfinite(gm):
        assert p.margins.gain_db == pytest.approx(20 * math.log10(gm), rel=1e-6)
    assert not any(w.startswith("UNSTABLE") for w in p.warnings)
    # the reported closed-loop poles are the same loop's
    assert np.max(p.closed_loop_poles.real) == pytest.approx(np.max(np.real(closed.poles())), rel=1e-6)


@pytest.mark.parametrize("settings", [PidSettings(), PidSettings(loop="position"),
                                      PidSettings(loop="position", integral=True)], ids=["PI", "PD", "PID"])
def test_the_demo_model(demo_model, settings):
    p = design_pid(demo_model, settings)
    loop = _pid_tf(p) * _plant(demo_model, settings.loop)
    assert np.all(np.real(control.feedback(loop, 1).poles()) < 0)
    _gm, pm, _sm, _wpc, wgc, _ = control.stability_margins(loop)
    assert p.margins.phase_deg == pytest.approx(pm, rel=1e-6) and p.margins.crossover_rad_s == pytest.approx(wgc)
    assert p.margins.phase_deg > 45


def test_a_too_fast_placement_on_a_dead_time_is_called_unstable():
    p = design_pid(_fopdt(), PidSettings(rule="placement", damping=0.8, wn=10.0))
    assert np.any(np.real(control.feedback(_pid_tf(p) * _plant(_fopdt(), "velocity"), 1).poles()) > 0)
    assert any(w.startswith("UNSTABLE") for w in p.warnings)


# --------------------------------------------------------- python-control objects, JSON

def test_system_has_the_derivative_on_the_measurement():
    p = design_pid(_fopdt(), PidSettings(loop="position", integral=True))
    sys = p.system()
    assert sys.input_labels == ["r", "position"] and sys.output_labels == ["u"]
    w = 1j * np.array([0.3, 2.0, 15.0])
    from_r = np.array([complex(sys[0, 0](x)) for x in w])
    from_y = np.array([complex(sys[0, 1](x)) for x in w])
    assert from_y == pytest.approx(-np.array([complex(_pid_tf(p)(x)) for x in w]), rel=1e-9)
    assert from_r == pytest.approx(p.kp + p.ki / w, rel=1e-9)  # no derivative of r
    assert np.array([complex(p.tf()(x)) for x in w]) == pytest.approx(-from_y, rel=1e-9)


def test_design_json_round_trip():
    p = design_pid(_fopdt(), PidSettings(loop="position"))
    doc = json.loads(p.to_json_text())
    assert doc == json.loads(json.dumps(p.to_json()))
    assert doc["schema"] == "motorid.design/1" and doc["K"] == [] and doc["kr"] is None
    assert {"kp", "ki", "kd", "tf_s", "loop", "rule", "units"} <= set(doc["pid"])
    back = PidDesign.from_json(doc)
    assert (back.kp, back.ki, back.kd, back.tf_s, back.loop, back.output) == (p.kp, p.ki, p.kd, p.tf_s, "position",
                                                                             "position")
    assert back.margins.phase_deg == pytest.approx(p.margins.phase_deg)
    doc["pid"]["kd"] = "x"
    with pytest.raises(MotorIdError, match=r"pid\.kd"):
        PidDesign.from_json(doc)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"loop": "current"}, "--pid-loop"),
    ({"rule": "zn"}, "--pid-rule"),
    ({"rule": "placement", "damping": 0.7}, "needs --damping and --wn"),
    ({"damping": 0.7, "wn": 3.0}, "add --pid-rule placement"),
    ({"tau_c_s": -1.0}, "--tau-c"),
    ({"derivative_filter": 0.0}, "--derivative-filter"),
])
def test_settings_refuse_in_one_line(kwargs, message):
    with pytest.raises(MotorIdError, match=message):
        PidSettings(**kwargs)


def test_a_position_loop_needs_a_position_output():
    m = model_from_velocity_tf([2.0], [0.5, 1.0])
    with pytest.raises(MotorIdError, match="no position output"):
        design_pid(m, PidSettings(loop="position"))


def test_simc_slows_down_until_the_full_models_loop_is_robust():
    # a lightly damped pair (ζ = 0.1) taken as two lags: SIMC's τc gives an unstable loop on the
    # full model, so τc is doubled until python-control's loop has Ms ≤ 2, and the warning says so
    m = model_from_velocity_tf([2.0], [1.0, 0.4, 4.0], with_position=True)
    p = design_pid(m, PidSettings())
    loop = _pid_tf(p) * _plant(m, "velocity")
    assert np.all(np.real(control.feedback(loop, 1).poles()) < 0)
    _gm, _pm, sm, *_ = control.stability_margins(loop)
    assert 1 / sm <= 2.0 + 1e-6 and p.margins.ms <= 2.0
    assert any(w.startswith("τc raised from 0.25 s") for w in p.warnings)
    given = design_pid(m, PidSettings(tau_c_s=0.25))  # a τc given is kept, and called unstable
    assert given.tau_c_s == 0.25 and any(w.startswith("UNSTABLE") for w in given.warnings)


def test_the_emitter_takes_the_pid_system():
    # the same signal names as a state-feedback controller's: the emitter discretises and writes it
    from motorid.control.emit import discretise, emit_c

    p = design_pid(_fopdt(), PidSettings(loop="position", integral=True))
    dc = discretise(p.system(), 0.002, "zoh", units={"r": "rev", "position": "rev", "u": "V"})
    code = emit_c(dc)
    assert "position" in code and "_step(" in code
    # its difference equations are python-control's c2d of the system
    want = control.c2d(p.system(), 0.002, method="zoh")
    assert np.allclose(dc.Ad, want.A) and np.allclose(dc.Bd, want.B)
