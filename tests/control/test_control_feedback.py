"""State feedback: placement against python-control, pole specifications, bad input."""

from __future__ import annotations

import math

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motorid.control import (
    ControlDesignError,
    DesignSettings,
    MotorParams,
    check_poles,
    design_controller,
    model_from_params,
    parse_poles,
    poles_from_specs,
)
from motorid.errors import MotorIdError, OptionError
from motorid.model import MotorModel, model_from_velocity_tf


@pytest.fixture(scope="module")
def model():
    return model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))


@settings(max_examples=50, deadline=None)
@given(st.floats(0.2, 30), st.floats(0.2, 30), st.booleans())
def test_placed_poles_are_the_eigenvalues(model, a, b, as_pair):
    poles = (complex(-a, b), complex(-a, -b)) if as_pair else (-a, -a - b)
    d = design_controller(model, DesignSettings(poles=poles))
    # tolerance: eigenvalues of a 2×2 with entries ~1e3 agree to ~1e-9 relative
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(model.A - model.B @ d.K.reshape(1, 2))),
                               np.sort_complex(np.array(poles, dtype=complex)), rtol=1e-6, atol=1e-6)
    # kr gives unity DC gain (eq. 37), checked with python-control
    cl = control.ss(model.A - model.B @ d.K.reshape(1, 2), model.B * d.kr, [[1, 0]], 0)
    assert float(control.dcgain(cl)) == pytest.approx(1.0, rel=1e-8)


def test_settling_time_and_overshoot_spec_met(model):
    d = design_controller(model, DesignSettings(settling_time_s=1.0, overshoot_pct=5.0))
    cl = control.ss(model.A - model.B @ d.K.reshape(1, 2), model.B * d.kr, [[1, 0]], 0)
    info = control.step_info(cl, SettlingTimeThreshold=0.02)
    # exact 2nd-order loop: overshoot is exactly the spec; Ts = 4/(ζωn) is the envelope rule of
    # thumb, the true 2 % settling time of ζ = 0.69 is within 10 % of it
    assert info["Overshoot"] == pytest.approx(5.0, abs=0.05)
    assert info["SettlingTime"] == pytest.approx(1.0, rel=0.1)


def test_damping_with_wn_third_order_model():
    m3 = model_from_velocity_tf([2.0, 9.0], [1.0, 6.0, 5.0], with_position=True)
    d = design_controller(m3, DesignSettings(damping=0.7, wn=4.0))
    assert len(d.closed_loop_poles) == 3 and d.warnings  # extra pole reported
    assert np.all(d.closed_loop_poles.real < 0)


def test_parse_poles():
    np.testing.assert_allclose(parse_poles("-3+2j, -3-2j"), [-3 + 2j, -3 - 2j])
    with pytest.raises(OptionError):
        parse_poles("minus three")


@pytest.mark.parametrize("poles,msg", [
    ((-1, -2, -3), "exactly 2"),
    ((-1 + 2j, -3), "no conjugate"),
    ((float("nan"), -1), "finite"),
])
def test_bad_poles(model, poles, msg):
    with pytest.raises(OptionError, match=msg) as err:
        design_controller(model, DesignSettings(poles=poles))
    assert "\n" not in str(err.value)


def test_unstable_observer_poles_refused(model):
    with pytest.raises(OptionError, match="left half-plane"):
        design_controller(model, DesignSettings(damping=1, k2=8.5, observer_poles=(1.0, -3.0)))
    with pytest.raises(OptionError, match="left half-plane"):
        check_poles([0j, -1], 2, "observer", require_stable=True)


def test_non_finite_gain_refused(model):
    with pytest.raises(OptionError, match="finite"):
        design_controller(model, DesignSettings(damping=1, k2=math.inf))
    with pytest.raises(OptionError, match="finite"):
        design_controller(model, DesignSettings(poles=(-1, -2), integral=True, ki=math.nan))


def test_uncontrollable_model():
    m = MotorModel(A=[[0, 1], [0, -1]], B=[[1], [0]], C=[[1, 0], [0, 1]], D=[[0], [0]],
                   states=("position", "velocity"), outputs=("position", "velocity"))
    with pytest.raises(ControlDesignError, match="not controllable") as err:
        design_controller(m, DesignSettings(poles=(-1, -2)))
    assert isinstance(err.value, MotorIdError) and "\n" not in str(err.value)


def test_k2_below_routh_bound_has_no_stable_k1(model):
    with pytest.raises(ControlDesignError, match="no k1"):
        design_controller(model, DesignSettings(damping=1, k2=-2.0))


def test_conflicting_specs(model):
    with pytest.raises(OptionError, match="exactly one"):
        design_controller(model, DesignSettings(poles=(-1, -2), damping=1, k2=2))
    with pytest.raises(OptionError):
        design_controller(model, DesignSettings(damping=1))
    with pytest.raises(OptionError):
        poles_from_specs(1.0, 150.0, 2)
