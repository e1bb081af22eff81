"""Integral action and observer: placement, Routh checks, observability, JSON."""

from __future__ import annotations

import json

import control
import numpy as np
import pytest

from motorid.control import (
    ControlDesignError,
    Design,
    DesignSettings,
    MotorParams,
    affine_char_poly,
    augment_integral,
    design_controller,
    model_from_params,
    routh_conditions,
)
from motorid.errors import OptionError


@pytest.fixture(scope="module")
def model():
    return model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))


def test_integral_poles_placed(model):
    d = design_controller(model, DesignSettings(poles=(-5, -6, -7), integral=True))
    aa, ba = augment_integral(model.A, model.B, model.C[:1])
    g = np.append(d.K, d.ki).reshape(1, 3)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(aa - ba @ g).real), [-7, -6, -5], atol=1e-8)
    # integral action removes the steady-state error to a constant input disturbance
    acl = aa - ba @ g
    bcl = np.hstack([np.vstack([model.B, [[0]]]), [[0], [0], [-1]]])  # inputs: disturbance, r
    cl = control.ss(acl, bcl, [[1, 0, 0]], 0)
    dc = np.asarray(control.dcgain(cl)).ravel()
    np.testing.assert_allclose(dc, [0.0, 1.0], atol=1e-9)
    assert d.kr is None


def test_integral_pole_with_report_design(model):
    d = design_controller(model, DesignSettings(damping=1, k2=8.5, integral=True, integral_pole=-3.0))
    assert np.any(np.isclose(d.closed_loop_poles, -3.0, atol=1e-5))
    with pytest.raises(OptionError):
        design_controller(model, DesignSettings(damping=1, k2=8.5, integral=True, integral_pole=-3.0, ki=1.0))


def test_routh_text_matches_stability_on_random_gains(model):
    poly = affine_char_poly(*augment_integral(model.A, model.B, model.C[:1]), ("k1", "k2", "ki"))
    assert len(routh_conditions(poly)) == 3
    rng = np.random.default_rng(1)
    for _ in range(200):
        g = rng.uniform(-3, 10, 3)
        a = poly.at(g)[1:]
        by_routh = a[0] > 0 and a[2] > 0 and a[0] * a[1] > a[2]
        by_roots = bool(np.all(np.roots(poly.at(g)).real < 0))
        assert by_routh == by_roots


def test_unobservable_from_velocity(model):
    # the tacho alone cannot tell the position (A has an integrator fed only by x2)
    with pytest.raises(ControlDesignError, match="not observable"):
        design_controller(model, DesignSettings(damping=1, k2=8.5, observer_poles=(-50, -40), output="velocity"))


def test_wrong_observer_pole_count(model):
    with pytest.raises(OptionError, match="exactly 2"):
        design_controller(model, DesignSettings(damping=1, k2=8.5, observer_poles=(-50,)))


def test_design_json_round_trip(model):
    d = design_controller(model, DesignSettings(damping=1, k2=8.5, observer_poles=(-80, -10)))
    data = json.loads(d.to_json_text())
    assert data["schema"] == "motorid.design/1"
    assert set(data) >= {"states", "K", "kr", "ki", "L", "closed_loop_poles", "observer_poles", "routh", "warnings"}
    assert data["closed_loop_poles"][0][1] == 0.0  # the critically damped pair is printed as real
    back = Design.from_json(data)
    np.testing.assert_allclose(back.K, d.K)
    np.testing.assert_allclose(back.L, d.L)
    with pytest.raises(OptionError, match="schema"):
        Design.from_json({"schema": "motorid.model/1"}, file="x.json")
