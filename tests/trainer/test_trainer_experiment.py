"""Presets and whole experiments of the virtual trainer against the documents' numbers."""

import control
import numpy as np
import pytest

from motorid.errors import OptionError
from motorid.trainer import PRESET_NAMES, preset, run_experiment, truth_of
from motorid.trainer.presets import LAB_K_0


def _after_step(cap, step_time_s):
    k0 = int(np.searchsorted(cap.time_s, step_time_s))
    return cap.output_v[k0:] - cap.output_v[:k0].mean(), cap.sample_interval_s


@pytest.mark.parametrize("seed", [0, 3])
def test_paper_preset_targets(seed):
    e = run_experiment("paper", seed=seed, validation=False)
    y, dt = _after_step(e.captures["velocity"], e.capture_truth["velocity"].step_time_s)
    final = y[-300:].mean()
    # paper: 5.92 V step → tacho settles at 5.36 V (2% allows for the 8-bit LSB of 0.08 V)
    assert final == pytest.approx(5.36, rel=0.02)
    tau63 = np.argmax(y >= 0.632 * final) * dt
    assert 0.40 <= tau63 <= 0.46  # paper: τ ≈ 0.42–0.44 s; ±1 sample and the LSB
    tr = e.truth
    assert len(control.poles(tr.velocity)) >= 2 and len(control.zeros(tr.velocity)) >= 1
    assert 0.42 <= tr.first_order.time_constant_s <= 0.44  # mean residence time


def test_paper_position_rises_one_volt_per_second_per_tacho_volt():
    tr = truth_of(preset("paper"))
    # paper eq. 39/40: Hp ≈ Hv / s, i.e. position-channel volts = ∫ tacho volts dt
    ratio = control.minreal(tr.position * control.tf("s") / tr.velocity, verbose=False)
    assert float(np.real(control.dcgain(ratio))) == pytest.approx(1.0, rel=1e-6)


def test_lab_report_preset_matches_the_report():
    cfg = preset("lab-report")
    tr = truth_of(cfg)
    rpm = 2 * np.pi / 60
    assert tr.dc_gain == pytest.approx(0.9, rel=0.02)  # km·kT, eq. 5
    # Tm by the report's own method: 63.3% of the final tacho value (eq. 6-7)
    t = np.linspace(0, 3, 30001)
    _, y = control.step_response(tr.velocity, t)
    assert t[np.argmax(y >= 0.633 * y[-1])] == pytest.approx(0.55, rel=0.02)
    assert cfg.gear_ratio == pytest.approx(1 / 36)  # kμ, eq. 8
    assert cfg.tacho_v_per_rad_s * rpm == pytest.approx(3.61e-3)  # kT in V/rpm, eq. 17
    # eq. 10/13: θ̇ = kμ·k0·ω (ω in rpm); at 10 V: ω = 9 V / kT rpm → 17.3 V/s
    omega_rpm = 0.9 * 10 / 3.61e-3
    slope = float(np.real(control.dcgain(control.minreal(tr.position * control.tf("s"), verbose=False)))) * 10
    assert slope == pytest.approx(LAB_K_0 / 36 * omega_rpm, rel=0.02)
    assert slope == pytest.approx(17.3, rel=0.02)


@pytest.mark.parametrize("name, n_zeros, slow_poles", [
    ("first-order", 0, 1), ("second-order", 0, 2), ("third-order", 1, 3),
])
def test_order_presets(name, n_zeros, slow_poles):
    tr = truth_of(preset(name))
    poles = control.poles(tr.velocity)
    # "visible" poles: within 200× of the dominant one (faster ones vanish in 4 ms samples)
    dominant = np.min(np.abs(poles))
    assert np.sum(np.abs(poles) < 200 * dominant) == slow_poles
    assert len(control.zeros(tr.velocity)) == n_zeros
    assert 0.42 <= tr.first_order.time_constant_s <= 0.44


def test_deterministic_for_a_seed():
    a = run_experiment("paper", seed=5)
    b = run_experiment("paper", seed=5)
    c = run_experiment("paper", seed=6)
    for role in ("position", "velocity", "current"):
        np.testing.assert_array_equal(a.captures[role].output_v, b.captures[role].output_v)
        np.testing.assert_array_equal(a.captures[role].input_v, b.captures[role].input_v)
        assert not np.array_equal(a.captures[role].output_v, c.captures[role].output_v)
    for kind in ("sine", "triangle", "square"):
        np.testing.assert_array_equal(a.validation[kind].output_v, b.validation[kind].output_v)


def test_a_capture_does_not_depend_on_the_other_roles():
    full = run_experiment("paper", seed=1, validation=False)
    only = run_experiment("paper", seed=1, validation=False, roles=("velocity",))
    assert set(only.captures) == {"velocity"}
    np.testing.assert_array_equal(full.captures["velocity"].output_v, only.captures["velocity"].output_v)


def test_noise_off_and_unquantised_follows_the_nonlinear_plant():
    e = run_experiment("paper", seed=0, noise=False, quantise=False, validation=False)
    cap, ct = e.captures["velocity"], e.capture_truth["velocity"]
    # before the step: exactly zero (no noise); CH1 exactly the step level after it
    before = cap.time_s < ct.step_time_s
    assert np.all(cap.output_v[before] == 0.0)
    assert np.all(cap.input_v[~before] == 5.92)
    # the old keyword spelling still works
    old = run_experiment("paper", seed=0, noise=False, quantised=False, validation=False)
    np.testing.assert_array_equal(old.captures["velocity"].output_v, cap.output_v)


def test_validation_runs():
    e = run_experiment("paper", seed=2, roles=())
    assert set(e.validation) == {"sine", "triangle", "square"}
    for kind, cap in e.validation.items():
        # CH1: the ±6.4 V test signal (8-bit at 2 V/div: LSB 0.08 V)
        assert np.max(cap.input_v) == pytest.approx(6.4, abs=0.1)
        assert np.min(cap.input_v) == pytest.approx(-6.4, abs=0.1)
        # CH2: tacho follows with about the DC gain at 0.1 Hz (well below 1/(2π·0.43) Hz)
        assert np.max(np.abs(cap.output_v)) == pytest.approx(0.9 * 6.4, rel=0.15), kind


@pytest.mark.parametrize("kwargs", [
    {"preset": "nope"}, {"step_volts": 12.0}, {"step_volts": float("nan")},
    {"roles": ("torque",)}, {"sec_per_div": 0.0},
])
def test_bad_arguments(kwargs):
    with pytest.raises(OptionError):
        run_experiment(**kwargs)


def test_every_preset_runs():
    for name in PRESET_NAMES:
        e = run_experiment(name, seed=0, validation=False, roles=("velocity",))
        assert e.captures["velocity"].n_samples == 2500


def test_the_electrical_and_underdamped_presets_are_the_motors_they_are_named_after():
    """Both were written out by hand in the accuracy bench and two test files; now the trainer has
    them. The truth's poles against python-control's, from the configuration's physics."""
    e7 = truth_of(preset("electrical-7ms"))
    p = np.sort(np.real(control.poles(e7.velocity)))
    assert p[0] == pytest.approx(-1 / 0.007, rel=0.02) and e7.time_constant_s == pytest.approx(0.43, abs=1e-9)
    under = truth_of(preset("underdamped"))
    pair = control.poles(under.velocity)
    wn = float(np.abs(pair[0]))
    assert np.all(np.abs(np.imag(pair)) > 1.0) and -float(np.real(pair[0])) / wn == pytest.approx(0.81, abs=0.005)
    cfg = preset("underdamped")
    assert cfg.la_h == pytest.approx(0.3 * cfg.ra_ohm) and cfg.amp_lead_s == cfg.amp_lag_s == 0.0
