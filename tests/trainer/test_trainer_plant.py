"""The trainer's plant against independent computations (python-control, steady-state algebra)."""

from dataclasses import replace

import control
import numpy as np
import pytest

from motorid.errors import OptionError
from motorid.trainer import PRESET_NAMES, preset, simulate_plant, truth_of
from motorid.trainer.sensors import current_v, tacho_v, true_position_v

DT = 0.004  # the paper's 1 s/div
T = np.arange(2500) * DT
K_STEP = 50  # step on a sample instant: the continuous step response is then exact


def _step(level):
    return np.where(np.arange(T.size) >= K_STEP, level, 0.0)


@pytest.mark.parametrize("name", PRESET_NAMES)
def test_linear_plant_matches_python_control_step_response(name):
    cfg = preset(name).ideal()
    plant = simulate_plant(cfg, T, _step(5.0))
    tr = truth_of(cfg)
    rng = np.random.default_rng(0)  # ideal(): no noise is drawn from it
    t_rel = T[K_STEP:] - T[K_STEP]
    measured = {
        "velocity": tacho_v(cfg, plant, rng),
        "current": current_v(cfg, plant, rng),
        "position": true_position_v(cfg, plant, 0.0),
    }
    for channel, y in measured.items():
        _, ref = control.step_response(getattr(tr, channel), t_rel)
        ref = 5.0 * ref
        np.testing.assert_array_equal(y[:K_STEP], 0.0)  # at rest before the step
        # exact discretisation, so only rounding and python-control's own step-response
        # evaluation differ; 0.5% of the largest value (final value; peak for current)
        scale = np.max(np.abs(ref))
        assert np.max(np.abs(y[K_STEP:] - ref)) < 0.005 * scale, channel


def test_linear_part_is_exact_at_any_substep_count():
    # the linear plant (with the lead/lag) is discretised exactly: 1 or 32 sub-steps agree
    # to rounding (a numerical integrator would differ by its truncation error)
    cfg = preset("paper").ideal()
    one = simulate_plant(cfg, T, _step(5.0), substeps=1).motor_speed_rad_s
    many = simulate_plant(cfg, T, _step(5.0), substeps=32).motor_speed_rad_s
    np.testing.assert_allclose(one, many, rtol=0, atol=1e-9 * np.max(np.abs(many)))


def test_friction_and_dead_zone_cost_the_equivalent_input_offset():
    cfg = preset("paper").quiet()
    tr = truth_of(cfg)
    y = tacho_v(cfg, simulate_plant(cfg, T, _step(5.92)), np.random.default_rng(0))
    # steady state by hand: k·i = b·ω + Tc, V = Ra·i + k·ω ⇒ the input offset is
    # dead-zone + Ra·Tc/(k·gain), exact once the shaft slides at constant speed
    expected = tr.dc_gain * (5.92 - tr.equivalent_input_offset_v)
    assert y[-1] == pytest.approx(expected, rel=1e-3)
    assert y[-1] < tr.dc_gain * 5.92  # the nonlinearities do cost speed


def test_brake_torque_slows_the_motor_by_its_offset():
    base = preset("paper").quiet()
    braked = replace(base, brake_nm=0.1 * base.k_motor)
    tr = truth_of(braked)
    y = tacho_v(braked, simulate_plant(braked, T, _step(5.92)), np.random.default_rng(0))
    assert y[-1] == pytest.approx(tr.dc_gain * (5.92 - tr.equivalent_input_offset_v), rel=1e-3)


def test_below_dead_zone_nothing_moves():
    cfg = preset("paper").quiet()
    p = simulate_plant(cfg, T, _step(0.8 * cfg.amp_dead_zone_v))
    assert np.all(p.motor_speed_rad_s == 0.0) and np.all(p.current_a == 0.0)


def test_static_friction_holds_the_shaft_while_current_flows():
    cfg = preset("paper").quiet()
    # stall current V·gain/Ra gives a torque of 80% of the break-away torque
    level = cfg.amp_dead_zone_v + 0.8 * cfg.static_nm * cfg.ra_ohm / (cfg.k_motor * cfg.amp_gain)
    p = simulate_plant(cfg, T, _step(level))
    assert np.all(p.motor_speed_rad_s == 0.0) and np.all(p.output_angle_rad == 0.0)
    stall_a = (level - cfg.amp_dead_zone_v) * cfg.amp_gain / cfg.ra_ohm
    assert p.current_a[-1] == pytest.approx(stall_a, rel=1e-6)
    # 20% above break-away: it turns
    level2 = cfg.amp_dead_zone_v + 1.2 * cfg.static_nm * cfg.ra_ohm / (cfg.k_motor * cfg.amp_gain)
    assert simulate_plant(cfg, T, _step(level2)).motor_speed_rad_s[-1] > 0


def test_rails_limit_the_armature_voltage():
    cfg = replace(preset("paper").ideal(), amp_rail_v=3.0)
    p = simulate_plant(cfg, T, _step(5.92))
    assert np.max(p.amp_out_v) == pytest.approx(3.0)
    tr = truth_of(cfg)
    # linear DC gain for an input of rail/gain volts
    y = tacho_v(cfg, p, np.random.default_rng(0))
    assert y[-1] == pytest.approx(tr.dc_gain * 3.0 / cfg.amp_gain, rel=1e-3)


def test_initial_state_and_reverse_direction():
    cfg = preset("paper").quiet()
    p = simulate_plant(cfg, T, _step(-5.92), initial=(0.0, 0.0, 1.0))
    assert p.motor_angle_rad[0] == 1.0
    assert p.motor_speed_rad_s[-1] < 0 and p.output_angle_rad[-1] < 0


@pytest.mark.parametrize("kwargs", [{"substeps": 0}])
def test_bad_arguments_raise_option_error(kwargs):
    with pytest.raises(OptionError):
        simulate_plant(preset("paper"), T, _step(1.0), **kwargs)
    with pytest.raises(OptionError):
        simulate_plant(preset("paper"), T[::-1], _step(1.0))
    with pytest.raises(OptionError):
        replace(preset("paper"), static_nm=0.0, coulomb_nm=1.0)


def _residence_by_ode(cfg, volts):
    """The step's residence time from the friction ODE, solved by scipy (independent of the
    simulator's sub-step loop): stuck until the drive torque reaches static friction, in closed
    form, then sliding against Coulomb friction."""
    from scipy.integrate import solve_ivp

    v = cfg.amp_gain * (volts - cfg.amp_dead_zone_v)
    tau_e = cfg.la_h / cfg.ra_ohm
    i_break = (cfg.static_nm + cfg.brake_nm) / cfg.k_motor
    t_break = -tau_e * np.log(1.0 - cfg.ra_ohm * i_break / v)
    load = cfg.coulomb_nm + cfg.brake_nm
    w_final = (cfg.k_motor * v / cfg.ra_ohm - load) / (cfg.b_nms + cfg.k_motor**2 / cfg.ra_ohm)

    def rhs(_, x):
        i, w, _ = x
        return [(v - cfg.ra_ohm * i - cfg.k_motor * w) / cfg.la_h,
                (cfg.k_motor * i - cfg.b_nms * w - load) / cfg.j_kgm2,
                1.0 - w / w_final]

    span = 40 * truth_of(cfg).time_constant_s
    sol = solve_ivp(rhs, (t_break, span), [i_break, 0.0, 0.0], rtol=1e-10, atol=1e-12)
    return t_break + sol.y[2, -1]


def test_step_residence_time_of_the_linear_plant_is_its_moments_time_constant():
    from motorid.trainer import step_residence_time

    for name in ("paper", "third-order"):
        cfg = preset(name).ideal()
        # the trapezoidal rule on the 0.1 ms grid: within 1e-5 s of Σ1/p − Σ1/z
        assert step_residence_time(cfg, 5.92) == pytest.approx(truth_of(cfg).time_constant_s, abs=1e-5)


def test_step_residence_time_with_friction_against_the_ode():
    """A slow armature (La/Ra = 0.3 s) and friction: the response lengthens by 2.6 ms, which an
    independent solution of the friction ODE reproduces to 1e-5 s."""
    from motorid.trainer import step_residence_time

    cfg = preset("underdamped")
    got = step_residence_time(cfg, 5.92)
    linear = truth_of(cfg).time_constant_s
    assert got - linear == pytest.approx(0.00257, abs=2e-4)
    assert got == pytest.approx(_residence_by_ode(cfg, 5.92), abs=1e-5)


def test_step_residence_time_refuses_a_step_that_does_not_turn_the_motor():
    from motorid.trainer import step_residence_time

    cfg = preset("paper")
    with pytest.raises(OptionError, match="does not turn"):
        step_residence_time(cfg, cfg.amp_dead_zone_v / 2)
