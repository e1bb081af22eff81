"""A speed counted over each sample interval, fitted as the mean over that interval.

Arduino sketches print the encoder edges counted since the last line as rpm: each value is the
mean speed over the interval before it, not a sample.  Fitted as samples, that boxcar's lag
(half an interval) went into the motor's dead time and its shape into a second pole, and the
residence time's interval (noise only) missed the truth.  Here the closed forms' window means
are checked against independent quadrature, their derivatives against finite differences, and
the identification against the l298n-rpm rig's truth through the command line as a user runs it.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from clihelpers import motorid_fresh
import scipy.integrate

from motorid.capture import Capture, ChannelInfo
from motorid.identification.closed_form import PartialFractions, ResponseBasis, WindowBasis, residues
from motorid.identification.output_error import OeSettings, output_error_fit
from motorid.identification.result import IdentificationError
from motorid.model.motor import model_from_velocity_tf
from motorid.model.response import recorded_step_response, step_response
from motorid.trainer.hobbyrigs import COUNTED_SPEED_RIGS
from motorid.trainer.realsetups import write_real_setup

TAUS = np.array([0.08, 0.012])
NUM = np.array([0.003 * 180.0, 180.0])  # a zero at −1/0.003
WINDOW = 0.01


def _quad_mean(t: float, window: float) -> float:
    """Mean of the sampled closed form over (t − window, t] by adaptive quadrature."""
    p, r, n0 = residues(NUM, TAUS)

    def y(s: float) -> float:
        return float(ResponseBasis(np.array([s]), p).step(r, n0)[0])

    lo = t - window
    breaks = [0.0] if lo < 0 < t else None
    return scipy.integrate.quad(y, lo, t, points=breaks, epsabs=1e-12, epsrel=1e-12)[0] / window


def test_window_means_equal_quadrature_of_the_sampled_response_across_the_step():
    p, r, n0 = residues(NUM, TAUS)
    t = np.r_[-0.02, -0.004, 0.003, 0.0099, np.arange(0.01, 0.5, 0.037)]
    ours = WindowBasis(t, p, WINDOW).step(r, n0)
    ref = np.array([_quad_mean(x, WINDOW) for x in t])
    np.testing.assert_allclose(ours, ref, rtol=1e-9, atol=1e-9 * np.max(np.abs(ref)))
    assert ours[0] == 0.0 and 0 < ours[2] < ResponseBasis(t[2:3], p).step(r, n0)[0]


def test_block_means_of_window_means_equal_their_plain_average():
    p, r, n0 = residues(NUM, TAUS)
    m, dt = 5, 0.004
    t = np.arange(-3, 60) * m * dt + 0.0013
    blocked = WindowBasis(t, p, WINDOW, (m, dt)).step(r, n0)
    plain = np.array([WindowBasis(x + dt * np.arange(m), p, WINDOW).step(r, n0).mean() for x in t])
    np.testing.assert_allclose(blocked, plain, rtol=1e-10, atol=1e-10 * np.max(np.abs(plain)))


@pytest.mark.parametrize("block", [None, (4, 0.005)])
def test_window_derivatives_equal_differences(block):
    """∂/∂ln τ and ∂/∂(zero's time constant) by central differences of the closed form; the slope
    (what a time shift's Jacobian column is made of) by differences in time."""
    from motorid.identification.output_error import _vel_num

    t = np.arange(-4, 120) * 0.005 + 0.0007
    k, zeros = 180.0, np.array([0.003])
    dnums = [np.polymul(_vel_num(k, np.delete(zeros, 0)), [1.0, 0.0])]

    def mean_of(taus: np.ndarray, zs: np.ndarray, times: np.ndarray = t) -> np.ndarray:
        p, r, n0 = residues(_vel_num(k, zs), taus)
        return WindowBasis(times, p, WINDOW, block).step(r, n0)

    pf = PartialFractions(TAUS)
    ours = WindowBasis(t, pf.p, WINDOW, block).shape("step", _vel_num(k, zeros), pf, dnums)
    scale = np.max(np.abs(mean_of(TAUS, zeros)))
    h = 1e-6
    for j in range(TAUS.size):
        up, down = TAUS.copy(), TAUS.copy()
        up[j] *= np.exp(h)
        down[j] *= np.exp(-h)
        ref = (mean_of(up, zeros) - mean_of(down, zeros)) / (2 * h)
        np.testing.assert_allclose(ours[:, j], ref, atol=1e-6 * scale)
    ref = (mean_of(TAUS, zeros + h) - mean_of(TAUS, zeros - h)) / (2 * h)
    np.testing.assert_allclose(ours[:, -1], ref, atol=1e-5 * scale / 0.003)
    p, r, n0 = residues(_vel_num(k, zeros), TAUS)
    slope = WindowBasis(t, p, WINDOW, block).slope(r, n0)
    ref = (mean_of(TAUS, zeros, t + 1e-7) - mean_of(TAUS, zeros, t - 1e-7)) / 2e-7
    np.testing.assert_allclose(slope, ref, atol=1e-5 * np.max(np.abs(ref)))


def test_a_window_mean_of_a_position_is_refused():
    p, _, _ = residues(NUM, TAUS)
    with pytest.raises(ValueError, match="step response only"):
        WindowBasis(np.arange(5) * 0.01, p, WINDOW).shape("position", NUM, TAUS)


def test_the_recorded_response_is_the_quadrature_of_the_model_across_its_dead_time():
    """The model's response as a counted sensor records it: exact across the dead time's kink,
    where Simpson's rule on three samples was 0.5 % of the response off."""
    model = model_from_velocity_tf([180.0], [0.08, 1.0]).replace(delay_s=0.035)
    t = np.arange(0, 0.3, 0.01)
    ours = recorded_step_response(model, t, 6.0, velocity_window_s=WINDOW)["velocity"]

    def y(s: float) -> float:
        return float(step_response(model, np.array([s]), 6.0)["velocity"][0])

    ref = np.array([scipy.integrate.quad(y, x - WINDOW, x, points=[0.035] if x - WINDOW < 0.035 < x else None,
                                         epsabs=1e-10)[0] / WINDOW for x in t])
    np.testing.assert_allclose(ours, ref, atol=1e-8 * np.max(ref))
    plain = recorded_step_response(model, t, 6.0)["velocity"]
    np.testing.assert_array_equal(plain, step_response(model, t, 6.0)["velocity"])


def test_a_window_is_a_velocitys_and_positive():
    t = np.arange(200) * 0.01
    v = 100.0 * (1 - np.exp(-t / 0.08))
    for windows in ((("position", 0.01),), (("velocity", 0.0),), (("velocity", float("nan")),)):
        with pytest.raises(IdentificationError, match="only a velocity"):
            output_error_fit(t, 6.0, {"velocity": v}, {"velocity": 0.1}, [0.08], 16.0,
                             OeSettings(n_poles=1, windows=windows))
    with pytest.raises(ValueError, match="sample_window_s"):
        Capture("x", "plain-csv", t, v, ChannelInfo("speed"), sample_window_s=-0.01)


def test_a_noise_free_counted_response_is_fitted_to_its_own_time_constant_and_dead_time():
    """Window means of a first order plus dead time, fitted with and without the window: with it
    τ and the dead time come back to 1e-6; as samples, the dead time is half a window late."""
    dt, tau, theta, k = 0.01, 0.08, 0.03, 30.0
    t = np.arange(1, 300) * dt
    p, r, n0 = residues(np.array([k]), [tau])
    v = 6.0 * WindowBasis(t - theta, p, dt).step(r, n0)
    fits = {}
    for windows in ((), (("velocity", dt),)):
        res = output_error_fit(t, 6.0, {"velocity": v}, {"velocity": 1e-3}, [0.07], 25.0,
                               OeSettings(n_poles=1, delay=True, shifts=False, windows=windows),
                               init_delay_s=0.02)
        fits[bool(windows)] = res
    assert fits[True].delay_s == pytest.approx(theta, abs=1e-6)
    assert -1.0 / fits[True].poles[0].real == pytest.approx(tau, rel=1e-6)
    assert fits[False].delay_s == pytest.approx(theta + dt / 2, abs=2e-4)


@pytest.mark.parametrize(("seed", "sampled_covers"), [(0, False), pytest.param(2, False, marks=pytest.mark.slow)])
def test_the_counted_rig_log_gives_the_motors_timing_inside_its_interval(seed, sampled_covers, tmp_path):
    """``motorid identify --counted-velocity`` on the l298n-rpm rig's log, in a fresh process with the
    default environment: the residence time's 95 % interval covers the motor's own (the truth less
    the counting's half interval), which the default fit's interval misses (before: the boxcar's lag
    and shape in a dead time, +0.04 to +0.06 % against an interval of ±0.03 %)."""
    assert "l298n-rpm" in COUNTED_SPEED_RIGS
    rec = write_real_setup("l298n-rpm", tmp_path / "rig", seed=seed)
    models = {}
    for counted in (False, True):
        out = tmp_path / f"m{int(counted)}.json"
        args = [*rec.cli_args, *(["--counted-velocity"] if counted else []), "--json", str(out)]
        proc = motorid_fresh("identify", *args, cwd=tmp_path)
        models[counted] = (json.loads(out.read_text()), proc.stdout)
    motor = rec.truth.residence_time_s - rec.truth.sensor_lag_s
    for counted, (m, _) in models.items():
        lo, hi = m["uncertainty"]["residence_time_s"]["ci95"]
        assert (lo <= motor <= hi) == (counted or sampled_covers), (counted, lo, hi, motor)
        assert m["first_order"]["dc_gain"] == pytest.approx(rec.truth.dc_gain, rel=0.002)
    counted_model, printed = models[True]
    assert counted_model["timing"]["velocity"]["window_s"] == pytest.approx(0.01)
    assert "window_s" not in models[False][0]["timing"]["velocity"]
    assert "mean speed over the 10 ms before it" in " ".join(printed.split())
    assert "a read-off on the counted speed is about 5 ms later" in " ".join(printed.split())
    assert "what a scope read-off measures" in models[False][1]
    # the default says what it assumed, and what the option would change
    hint = "if the log counts encoder edges over each line"
    assert hint in " ".join(models[False][1].split()) and hint not in " ".join(printed.split())
    assert "sanity checks: all" in printed


def test_counted_velocity_needs_a_velocity_capture(tmp_path, run_cli):
    rec = write_real_setup("host-loop", tmp_path / "rig", seed=0)
    res = run_cli("identify", "--position", rec.files["log"], "--counted-velocity")
    assert res.code == 2 and "--counted-velocity describes a velocity capture" in res.err
    import motorid as mi
    from motorid.errors import OptionError

    with pytest.raises(OptionError, match=r"^counted_velocity=True describes a velocity capture: give it with velocity="):
        mi.read_experiment(position=rec.files["log"], counted_velocity=True)
    with pytest.raises(OptionError, match=r"^counted_velocity must be True or False, got .yes.$"):
        mi.read_experiment(position=rec.files["log"], velocity=rec.files["log"], counted_velocity="yes")


def _counted_level(volts: float, *, window: float) -> Capture:
    """A logged step to ``volts`` of 30·(1 − 0.5/V) per volt through 1/(0.08 s + 1): the speed counted over 10 ms."""
    t = np.arange(300) * 0.01
    p, r, n0 = residues(np.array([1.0]), [0.08])
    basis = WindowBasis(t - t[50], p, 0.01) if window else ResponseBasis(t - t[50], p)
    speed = 30.0 * (volts - 0.5) * basis.step(r, n0)
    u = np.where(np.arange(300) >= 50, volts, 0.0)
    return Capture(f"level{volts:g}.csv", "plain-csv", t, speed, ChannelInfo("speed"), input_v=u,
                   input_info=ChannelInfo("voltage"), sample_window_s=window)


def test_the_several_levels_fit_takes_counted_speeds_as_means():
    """Three counted levels, noise-free: with their windows the shared time constant is the motor's;
    the same records taken as samples put the counting's half interval into it."""
    import motorid as mi

    counted = mi.identify_levels([_counted_level(v, window=0.01) for v in (2.0, 4.0, 6.0)])
    tau = counted.model.first_order().time_constant_s
    assert tau == pytest.approx(0.08, rel=1e-4)
    assert "counted over each 10 ms interval" in counted.dynamics_note
    as_samples = mi.identify_levels([dataclasses.replace(_counted_level(v, window=0.01), sample_window_s=0.0)
                                     for v in (2.0, 4.0, 6.0)])
    assert as_samples.model.first_order().time_constant_s > 0.08 + 0.002  # about +T/2


def test_a_capture_marked_counted_keeps_its_samples_and_takes_its_interval_as_window():
    cap = _counted_level(4.0, window=0.0)
    counted = cap.counted()
    assert counted.sample_window_s == pytest.approx(cap.sample_interval_s) and cap.sample_window_s == 0.0
    np.testing.assert_array_equal(counted.output_v, cap.output_v)
    assert counted.counted() is counted  # a window already given is kept
