"""Modes of the saturated position/velocity loop (Masoud 2019, Figs. 4, 11–13)."""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.control import MotorParams, model_from_params
from motorid.errors import OptionError
from motorid.simulation.modes import MODES, ModeCriteria, mode_map, modes_json, parse_range, servo_plants, simulate_servo_grid


@pytest.fixture(scope="module")
def plants():
    model = model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))
    return servo_plants(model)


def test_second_order_never_leaves_the_three_damped_modes(plants):
    second, _ = plants
    kp = np.concatenate([np.linspace(0.05, 5, 10), np.linspace(10, 2000, 30)])
    kv = np.concatenate([[0.0], np.geomspace(0.01, 100, 25)])
    mm = mode_map(second, kp, kv)
    counts = mm.counts()
    # paper §II: a 2nd-order position model is stable for all non-negative gains, saturated or not
    assert counts["unstable"] == counts["oscillatory"] == counts["chattering"] == 0
    assert counts["overdamped"] and counts["critically_damped"] and counts["underdamped"]


def test_third_order_with_saturation_shows_all_six_modes(plants):
    _, third = plants
    mm = mode_map(third, np.linspace(0, 600, 60), np.linspace(0, 40, 60))
    counts = mm.counts()
    assert all(counts[m] > 0 for m in MODES), counts  # paper Fig. 13
    data = modes_json((mm,), ModeCriteria())
    assert set(data) >= {"kp", "kv", "modes", "criteria"}
    assert len(data["modes"]) == 60 and len(data["modes"][0]) == 60


def test_grid_simulation_matches_python_control(plants):
    _, third = plants
    crit = ModeCriteria()
    kp = np.array([20.0, 300.0, 500.0])   # under-damped, chattering band, limit cycle
    kv = np.array([5.0, 20.0, 10.0])
    stats, h, steps = simulate_servo_grid(third, kp, kv, crit, record=True)
    t = np.arange(steps + 1) * h
    a, b, cp, cv = third.A, third.B[:, 0], third.cp, third.cv

    q = steps // 4
    for j in range(kp.size):
        def rhs(_t, x, _u, params, j=j):
            v = kp[j] * (1.0 - cp @ x) - kv[j] * (cv @ x)
            return a @ x + b * min(max(v, -10.0), 10.0)

        sys = control.nlsys(rhs, None, states=3, inputs=0, outputs=3)
        ref = control.input_output_response(sys, t, 0, X0=np.zeros(3),
                                            solve_ivp_kwargs={"rtol": 1e-8, "atol": 1e-10})
        theta = cp @ np.asarray(ref.states)
        # fixed-step RK4 (|λh| ≤ 0.25) vs adaptive RK45 at rtol 1e-8: RK4 loses order at the
        # saturation corners, so allow 2 % of the step over the first quarter; on a limit cycle
        # the phase drifts (it is neutrally stable), so the last quarter is compared by amplitude
        np.testing.assert_allclose(stats.theta[:q, j], theta[:q], atol=0.02)
        amp_ref = (theta[3 * q + 1:].max() - theta[3 * q + 1:].min()) / 2
        assert stats.amp_tail[j] == pytest.approx(amp_ref, rel=0.05, abs=1e-3)


def test_parse_range():
    np.testing.assert_allclose(parse_range("0:10:3", "--kp"), [0, 5, 10])
    for bad in ("0:10", "a:b:c", "-1:2:3", "0:1:0", "5:1:3"):
        with pytest.raises(OptionError):
            parse_range(bad, "--kp")
