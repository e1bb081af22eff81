"""The scope and DAQ real-setup presets: files as the real set-ups write them, honest truth.

(The hobby rigs' presets are checked in ``test_trainer_hobbyrigs.py``.)

Truth values are checked against independent computations: the physical steady state of the
nonlinear plant simulated long, python-control's ``dcgain``/``poles`` of the linearised TF,
and the 63 % rise time and first moment of the written files against ``forced_response`` of
the truth TF with its delay.  Identification accuracy is not asserted here (that is
``bench/real_setups.py``'s job).
"""

from __future__ import annotations

import json
import math

import control
import numpy as np
import pytest

from motorid.errors import MotorIdError, OptionError, OutputExistsError
from motorid.io import read_capture
from motorid.trainer.plant import simulate_plant
from motorid.trainer.realsetups import (
    PWM_COUNTS_PER_REV,
    PWM_DT_S,
    PWM_EVERY,
    SCOPE_AND_DAQ_SETUPS,
    real_setup_config,
    write_real_setup,
)

HSLU_HEADER = "time_s,motor_voltage_V,speed_rpm,speed_setpoint_rpm,position_raw,position_setpoint_raw"


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """Each preset written once (seed 2; seed 0 for the TBS1000 gives its 0.1 ms/pt scale)."""
    root = tmp_path_factory.mktemp("realsetups")
    return {name: write_real_setup(name, root / name, seed=0 if name == "fast-tbs1000" else 2)
            for name in SCOPE_AND_DAQ_SETUPS}


def _velocity_file(rec):
    return rec.files["velocity"] if "velocity" in rec.files else rec.files["log"]


def _response(rec):
    """Time and velocity samples of the written velocity file, as the project's reader reads them."""
    cap = read_capture(_velocity_file(rec))
    return np.asarray(cap.time_s), np.asarray(cap.output_v)


def test_every_preset_is_read_by_read_capture(recordings):
    for rec in recordings.values():
        for path in rec.files.values():
            cap = read_capture(path)
            assert cap.time_s.size >= 1000
            assert np.all(np.isfinite(cap.output_v))


def test_inspect_accepts_every_file_and_names_its_role(recordings, run_cli):
    expected = {"fast-tbs1000": ["velocity", "current"], "pwm-encoder": ["velocity"], "daq-deadtime": ["velocity"]}
    for name, rec in recordings.items():
        res = run_cli("inspect", "--json", *map(str, rec.files.values()))
        assert res.code == 0, res.err
        rows = json.loads(res.out)
        assert [r["role"] for r in rows] == expected[name]
        assert all(r["step"] is not None for r in rows)


def test_fast_tbs1000_is_a_tbs_pair_without_input_channel(tmp_path):
    for seed, dt in ((0, 1e-4), (1, 2e-4), (2, 4e-4)):
        rec = write_real_setup("fast-tbs1000", tmp_path / str(seed), seed=seed)
        ch1, ch2 = rec.files["velocity"], rec.files["current"]
        assert (ch1.name, ch2.name, ch1.parent.name) == ("F0000CH1.CSV", "F0000CH2.CSV", "ALL0000")
        assert rec.cli_args == ("--velocity", str(ch1), "--current", str(ch2), "--step-volts", "12.28")
        for path in (ch1, ch2):
            cap = read_capture(path)
            assert cap.input_v is None  # neither channel is the input
            assert cap.format == "tds2000-csv" and cap.scope.model.startswith("TBS")
            assert cap.time_s.size == 2500
            assert np.median(np.diff(cap.time_s)) == pytest.approx(dt, rel=1e-6)
        # the trigger (t = 0) is well before the step: at least 10 % of the record
        assert rec.truth.step_time_s >= 0.1 * 2500 * dt - 1e-12
        # CH1 is the tacho (it rises and settles), CH2 the shunt (it peaks and falls back)
        _, v = _response(rec)
        cur = read_capture(ch2).output_v
        assert v[-100:].mean() > 10 * abs(v[:50].mean()) + 1.0
        assert cur.max() > 1.5 * cur[-100:].mean()


def test_fast_tbs1000_current_leads_the_tacho(recordings):
    """The current's onset precedes the tacho's visible rise by about 1.4–2.1 ms."""
    rec = recordings["fast-tbs1000"]
    t = read_capture(rec.files["current"]).time_s
    cur = read_capture(rec.files["current"]).output_v
    tacho = read_capture(rec.files["velocity"]).output_v

    def visible(y):
        base, top = y[t < rec.truth.step_time_s].mean(), np.max(y)
        return t[np.argmax(y - base > 0.1 * (top - base))]

    lead = visible(tacho) - visible(cur)
    assert 1.0e-3 < lead < 3.0e-3


def test_pwm_encoder_velocity_is_held_and_quantised(recordings):
    rec = recordings["pwm-encoder"]
    text = rec.files["log"].read_text().splitlines()
    assert text[0] == "t_ms,u_V,omega_rad_s"
    cap = read_capture(rec.files["log"])
    assert cap.input_v is not None and set(np.unique(cap.input_v)) == {0.0, 9.0}
    assert np.median(np.diff(cap.time_s)) == pytest.approx(PWM_DT_S)
    w = np.asarray(cap.output_v)
    quantum = 2 * math.pi / (PWM_COUNTS_PER_REV * PWM_EVERY * PWM_DT_S)
    assert quantum == pytest.approx(0.77, abs=0.005)
    # every value is a whole number of quanta (the file keeps 4 decimals)
    assert np.allclose(w / quantum, np.round(w / quantum), atol=1e-3)
    # changes happen only every PWM_EVERY samples, at one phase
    changes = np.flatnonzero(np.diff(w) != 0) + 1
    assert changes.size > 20
    assert np.unique(changes % PWM_EVERY).size == 1
    # the dead-zone costs part of the step: the final speed is below the linear gain's
    lin = control.dcgain(rec.truth.velocity_tf)
    assert w[-300:].mean() < 0.95 * lin * 9.0


def test_encoder_velocity_of_a_constant_speed():
    """Analytic: at constant ω the held values are within one quantum of ω, and average to it."""
    from motorid.trainer.sensors import encoder_velocity

    dt, omega = 1e-3, 17.3
    t = np.arange(4000) * dt
    v = encoder_velocity(omega * t, dt, counts_per_rev=1632, every=5, phase=3)
    quantum = 2 * math.pi / (1632 * 5 * dt)
    held = v[8:]
    assert np.all(np.abs(held - omega) < quantum + 1e-9)
    # whole windows telescope: the mean over the updates is ω to within one quantum / updates
    updates = held[::5]
    assert updates.mean() == pytest.approx(omega, abs=quantum / updates.size * 2)
    assert np.all(v[:8] == 0.0)


def test_daq_deadtime_has_the_hslu_layout(recordings, real_dir):
    rec = recordings["daq-deadtime"]
    header = rec.files["log"].read_text().splitlines()[0]
    real = (real_dir / "hslu-rtl-dcmotor" / "csv" / "06_dc_step_5_15_00.csv").read_text().splitlines()[0]
    assert header == real == HSLU_HEADER
    cap = read_capture(rec.files["log"])
    assert np.median(np.diff(cap.time_s)) == pytest.approx(0.01, rel=1e-9)
    u = np.asarray(cap.input_v)
    k = int(np.argmax(u > 10))
    assert np.all(u[:k] == 5.0) and np.all(u[k:] == 15.0)
    # a step from a running speed: far from zero before the step
    assert cap.output_v[:k].mean() > 500.0
    assert rec.cli_args == ("--velocity", str(rec.files["log"]))


def _steady_speed(cfg, volts: float, seconds: float = 6.0) -> float:
    t = np.arange(0.0, seconds, 1e-3)
    plant = simulate_plant(cfg.quiet(), t, np.full(t.size, volts), substeps=4)
    return float(plant.motor_speed_rad_s[-200:].mean())


@pytest.mark.parametrize("name", SCOPE_AND_DAQ_SETUPS)
def test_truth_gain_is_the_steady_state_of_the_nonlinear_plant(name, recordings):
    """Independent: simulate the nonlinear plant long at constant input and read its level."""
    rec = recordings[name]
    cfg, truth = rec.config, rec.truth
    to = truth.from_volts + truth.step_volts
    dw = _steady_speed(cfg, to) - (_steady_speed(cfg, truth.from_volts) if truth.from_volts else 0.0)
    measured_gain = cfg.tacho_v_per_rad_s * dw / truth.step_volts
    assert measured_gain == pytest.approx(truth.dc_gain, rel=2e-3)


@pytest.mark.parametrize("name", SCOPE_AND_DAQ_SETUPS)
def test_truth_tf_matches_physics(name, recordings):
    """python-control's dcgain and poles of the TF vs closed-form motor physics."""
    rec = recordings[name]
    c, tf = rec.config, rec.truth.velocity_tf
    # ω/V = amp·k / ((La s + Ra)(J s + b) + k²)
    dc = c.amp_gain * c.k_motor / (c.ra_ohm * c.b_nms + c.k_motor**2) * c.tacho_v_per_rad_s
    assert control.dcgain(tf) == pytest.approx(dc, rel=1e-9)
    motor = np.roots([c.la_h * c.j_kgm2, c.la_h * c.b_nms + c.ra_ohm * c.j_kgm2, c.ra_ohm * c.b_nms + c.k_motor**2])
    expected = list(motor) + ([-1.0 / c.amp_lag_s] if c.amp_lag_s > 0 else [])
    assert np.sort(control.poles(tf).real) == pytest.approx(np.sort(np.real(expected)), rel=1e-6)
    tau = float(np.sum(-1.0 / np.real(expected)))  # no zeros in these presets
    assert rec.truth.time_constant_s == pytest.approx(tau, rel=1e-9)
    assert rec.truth.residence_time_s == pytest.approx(tau + rec.truth.delay_s, rel=1e-12)


def test_truth_delays():
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        daq = write_real_setup("daq-deadtime", Path(d) / "a").truth
        pwm = write_real_setup("pwm-encoder", Path(d) / "b").truth
        fast = write_real_setup("fast-tbs1000", Path(d) / "c").truth
    assert daq.dead_time_s == pytest.approx(0.035) and daq.delay_s == pytest.approx(0.035)
    # encoder: window of 5 ms (mean lag 2.5 ms) + hold of 5 samples (mean 2 ms)
    assert pwm.sensor_lag_s == pytest.approx(0.0045) and pwm.dead_time_s == 0.0
    assert fast.delay_s == 0.0
    assert daq.step_volts == 10.0 and daq.from_volts == 5.0
    assert fast.step_volts == pytest.approx(12.28)
    # the 100 Hz rig is near the authors' HSLU fit: 245.5 rpm/V, 2·T1 + Td ≈ 0.33 s
    assert daq.dc_gain == pytest.approx(245.5, rel=1e-3)
    assert daq.residence_time_s == pytest.approx(2 * 0.1468 + 0.035, rel=0.05)
    assert 0.013 <= fast.time_constant_s <= 0.021


def _normalised(t, y, t_step):
    before = t < t_step
    y0 = y[before].mean() if before.any() else y[0]
    y1 = y[t > t[0] + 0.8 * (t[-1] - t[0])].mean()
    return (y - y0) / (y1 - y0)


@pytest.mark.parametrize("name", SCOPE_AND_DAQ_SETUPS)
def test_file_rises_as_the_truth_tf_with_its_delay(name, recordings):
    """63 % time and first moment of the written file vs forced_response of truth TF + delay."""
    rec = recordings[name]
    tr = rec.truth
    t, y = _response(rec)
    z = _normalised(t, y, tr.step_time_s)
    # the truth: the linear TF driven by the step delayed by delay_s, on a fine grid
    dt = rec.sample_interval_s
    tf_fine = np.arange(t[0], t[-1], dt / 20)
    u = (tf_fine >= tr.step_time_s + tr.delay_s).astype(float)
    ref = control.forced_response(tr.velocity_tf, tf_fine, u).outputs
    ref = ref / control.dcgain(tr.velocity_tf)
    t63_ref = tf_fine[np.argmax(ref >= 0.632)] - tr.step_time_s
    after = t >= tr.step_time_s
    t63 = t[after][np.argmax(z[after] >= 0.632)] - tr.step_time_s
    # about the right time: within 2 samples plus 5 % (quantisation, the encoder's hold)
    assert t63 == pytest.approx(t63_ref, abs=2 * dt + 0.05 * t63_ref)
    # first moment of the file (∫(1 − z) dt after the step) = τ by moments + delay
    first_moment = np.trapezoid(1.0 - z[after], t[after]) + (t[after][0] - tr.step_time_s)
    assert first_moment == pytest.approx(tr.residence_time_s, rel=0.015)


def test_same_seed_same_files_and_other_seed_other_files(tmp_path):
    for name in SCOPE_AND_DAQ_SETUPS:
        a = write_real_setup(name, tmp_path / "a" / name, seed=5)
        b = write_real_setup(name, tmp_path / "b" / name, seed=5)
        c = write_real_setup(name, tmp_path / "c" / name, seed=6)
        for role in a.files:
            assert a.files[role].read_bytes() == b.files[role].read_bytes()
            assert a.files[role].read_bytes() != c.files[role].read_bytes()
        assert a.truth.step_time_s == b.truth.step_time_s


def test_user_mistakes_raise_motorid_errors(tmp_path):
    with pytest.raises(OptionError, match="unknown real set-up"):
        write_real_setup("fast", tmp_path)
    with pytest.raises(OptionError):
        real_setup_config("nope")
    write_real_setup("pwm-encoder", tmp_path)
    with pytest.raises(OutputExistsError):
        write_real_setup("pwm-encoder", tmp_path)
    assert issubclass(OutputExistsError, MotorIdError)
    write_real_setup("pwm-encoder", tmp_path, force=True)


@pytest.mark.parametrize("name", SCOPE_AND_DAQ_SETUPS)
def test_default_identify_exits_0(name, recordings, run_cli, tmp_path):
    """The user's command with default options only; accuracy is the bench's job."""
    out = tmp_path / "model.json"
    res = run_cli("identify", *recordings[name].cli_args, "--json", str(out))
    assert res.code == 0, res.err
    model = json.loads(out.read_text())
    assert math.isfinite(model["first_order"]["dc_gain"])
