"""What the output-error fit assumes about the data — per-capture grids, block means,
a current that jumps, coloured noise, the measured step level, an undithered position.

References are the generating models (python-control responses, known AR coefficients,
known scales) or textbook formulas, never earlier output of motorid.
"""

from __future__ import annotations

from dataclasses import replace

import control
import numpy as np
import pytest
from scipy.optimize._numdiff import approx_derivative

from motorid.conditioning.pipeline import ConditioningSettings, condition_experiment
from motorid.conditioning.unwrap import unwrap_position
from motorid.identification.output_error import (
    OeSettings,
    ar_noise_model,
    output_error_fit,
    position_closed_form,
    position_scale_fit,
)
from motorid.identification.pipeline import IdentifySettings, identify_conditioned
from motorid.identification.stages import noise_model, oe_stage, step_level_std
from motorid.trainer import preset, run_experiment

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow

STEP_V = 5.92
DT_S = 0.004


def _step(num, den, t):
    return STEP_V * control.step_response(control.tf(num, den), T=t).outputs


def test_ar_noise_model_finds_white_noise_white():
    e = np.random.default_rng(1).normal(0.0, 0.02, 4000)
    poly, sd = ar_noise_model(e)
    assert poly.tolist() == [1.0]
    assert sd == pytest.approx(0.02, rel=0.05)


def test_ar_noise_model_recovers_a_known_ar2_process():
    # e_k = 1.2 e_{k-1} − 0.5 e_{k-2} + w_k, w ~ N(0, 0.01²): whitening polynomial [1, −1.2, 0.5]
    rng = np.random.default_rng(2)
    w = rng.normal(0.0, 0.01, 20000)
    e = np.zeros_like(w)
    for k in range(2, w.size):
        e[k] = 1.2 * e[k - 1] - 0.5 * e[k - 2] + w[k]
    poly, sd = ar_noise_model(e)
    assert len(poly) >= 3
    assert poly[1] == pytest.approx(-1.2, abs=0.03)
    assert poly[2] == pytest.approx(0.5, abs=0.03)
    assert np.all(np.abs(poly[3:]) < 0.05)
    assert sd == pytest.approx(0.01, rel=0.03)


def test_oe_fits_each_capture_on_its_own_grid_and_block_means_exactly():
    """Three captures of different lengths, fitted as block means of 3 samples, one-pole
    model with a current that jumps at the step: noise-free truth recovered to 1e-4."""
    k, tau, c = 0.9, 0.43, 2.5
    cur_num = [0.4 * tau, 0.2]  # jump 0.4, final 0.2 (per volt)
    grids = {"velocity": np.arange(0.0, 8.0, DT_S), "position": np.arange(0.0, 9.2, DT_S),
             "current": np.arange(0.0, 8.6, DT_S)}
    data = {"velocity": _step([k], [tau, 1.0], grids["velocity"]),
            "position": c * STEP_V * control.step_response(control.tf([k], [tau, 1.0, 0.0]), T=grids["position"]).outputs,
            "current": _step(cur_num, [tau, 1.0], grids["current"])}
    data["current"][0] = 0.0  # sampled at the edge, before the current moved: left out by the fit
    res = output_error_fit(grids, STEP_V, data, {ch: 1e-3 for ch in data}, [0.3], 0.7,
                           OeSettings(n_poles=1, n_zeros=0), block={ch: 3 for ch in data},
                           pre={ch: np.zeros(300) for ch in data})
    assert res.dc_gain == pytest.approx(k, rel=1e-4)
    assert res.time_constant_s == pytest.approx(tau, rel=1e-4)
    assert res.position_scale == pytest.approx(c, rel=1e-4)
    assert np.allclose(res.current_num / res.current_num[0] * cur_num[0] / tau, np.array(cur_num) / tau, rtol=1e-3)
    assert all(rms < 1e-5 for rms in res.residual_rms.values())


@pytest.mark.parametrize(("delay", "blocks"), [(False, (1, 2, 1)), (True, (5, 3, 4))])
def test_oe_analytic_jacobian_equals_finite_differences(monkeypatch, delay, blocks):
    """The problem's Jacobian matches a central difference of its residuals to 1e-6 of each column
    (whitening, block means, wraps, pre-step samples, a dead time all active; every column
    analytic), and what least_squares is handed — the triangular factor of ``[J f]`` — has the
    same normal equations (``J̃ᵀJ̃ = JᵀJ``, ``J̃ᵀf̃ = Jᵀf``, ``‖f̃‖ = ‖f‖``)."""
    import scipy.optimize

    t = np.arange(0.0, 6.0, DT_S)
    num, den = [0.9, 0.9 * 0.06], np.polymul(np.polymul([0.4, 1.0], [0.02, 1.0]), [0.015, 1.0])
    wraps = (t > 2.0).astype(float) + (t > 4.0)
    data = {"velocity": _step(num, den, t), "position": 2.5 * STEP_V * control.step_response(
        control.tf(num, np.r_[den, 0.0]), T=t).outputs + 0.01 * wraps, "current": _step([0.01, 0.5, 0.2], den, t)}
    checked = []
    original = scipy.optimize.least_squares

    def spy(fun, x0, jac=None, **kw):
        x = np.clip(x0 * 1.01 + 1e-4, kw["bounds"][0] + 1e-6, kw["bounds"][1] - 1e-6)
        prob = fun.__self__.prob  # the compressed problem's full residuals and Jacobian
        numeric = approx_derivative(prob.residuals, x, method="3-point", bounds=kw["bounds"])
        analytic = prob.jacobian(x)
        scale = np.abs(numeric).max(axis=0) + 1e-12
        checked.append(np.max(np.abs(analytic - numeric) / scale, axis=0))
        f_full, j_small, f_small = prob.residuals(x), jac(x), fun(x)
        gram = analytic.T @ analytic
        assert np.allclose(j_small.T @ j_small, gram, rtol=1e-9, atol=1e-12 * np.abs(gram).max())
        assert np.allclose(j_small.T @ f_small, analytic.T @ f_full, rtol=1e-9,
                           atol=1e-12 * np.abs(analytic.T @ f_full).max())
        assert np.linalg.norm(f_small) == pytest.approx(np.linalg.norm(f_full), rel=1e-12)
        return original(fun, x0, jac=jac, **kw)

    monkeypatch.setattr(scipy.optimize, "least_squares", spy)
    output_error_fit(t, STEP_V, data, {ch: 0.01 for ch in data}, [0.35, 0.03, 0.01], 0.8,
                     OeSettings(n_poles=3, n_zeros=1, delay=delay), pre={ch: np.zeros(300) for ch in data},
                     block=dict(zip(("velocity", "position", "current"), blocks, strict=True)), init_delay_s=0.01,
                     whiten={"velocity": np.array([1.0, -0.5]), "current": np.array([1.0, 0.3, 0.1])},
                     wrap_count={"position": wraps})
    assert checked and np.all(checked[0] < 1e-6), checked[0]


def test_position_scale_fit_recovers_the_scale_and_a_span_error():
    t = np.arange(0.0, 8.0, DT_S)
    taus = [0.4, 0.03]
    vel = {"velocity": _step([0.9], np.polymul([0.4, 1.0], [0.03, 1.0]), t)}
    res = output_error_fit(t, STEP_V, vel, {"velocity": 1e-3}, taus, 0.9, OeSettings(n_poles=2, n_zeros=0))
    wraps = np.floor(t / 2.5)
    pos = 3.1 * position_closed_form(t, [0.9], taus, STEP_V) + 0.2 + 0.05 * wraps
    c = position_scale_fit(res, t, pos, STEP_V, pre=np.full(200, 0.2), wrap_count=wraps)
    assert c == pytest.approx(3.1, rel=1e-4)


def test_step_level_std_matches_monte_carlo_of_the_trainer():
    """The standard error of the step level read off the noisy input channels equals the
    spread of the level over many trainer runs (20 % tolerance for 200 runs)."""
    cfg = replace(preset("second-order").ideal(), noise_v=0.02)
    levels, predicted = [], []
    for seed in range(200):
        exp = run_experiment(config=cfg, seed=seed, quantised=False, validation=False, roles=("velocity",))
        cond = condition_experiment(dict(exp.captures), ConditioningSettings(sample_interval_s=None))
        levels.append(cond.step_volts)
        predicted.append(step_level_std(cond))
    assert np.std(levels) == pytest.approx(np.mean(predicted), rel=0.2)


def test_step_level_given_by_the_user_counts_as_exact():
    exp = run_experiment("second-order", seed=0, validation=False, roles=("velocity",))
    cap = exp.captures["velocity"]
    bare = replace(cap, input_v=None)
    cond = condition_experiment({"velocity": bare}, ConditioningSettings(sample_interval_s=None), step_volts=5.92)
    assert step_level_std(cond) == 0.0


def test_unwrap_reports_the_turns_it_added():
    t = np.arange(0.0, 4.0, DT_S)
    span = 20.0
    cont = 6.0 * t - 5.0  # −5 V … 19 V: one wrap at +10 V
    wrapped = cont - span * np.floor((cont + span / 2) / span)
    out = unwrap_position(wrapped)
    assert out.wraps == 1
    assert out.wrap_count is not None
    assert np.allclose(out.position_v, wrapped + out.span_v * out.wrap_count)


@pytest.fixture(scope="module")
def realistic():
    exp = run_experiment("third-order", seed=3, validation=False)
    return condition_experiment(dict(exp.captures), ConditioningSettings(sample_interval_s=None))


def test_noise_model_keeps_an_undithered_8bit_position_for_its_scale_only(realistic):
    init = identify_conditioned(realistic, IdentifySettings(method="pinv", order=2)).model
    noise = noise_model(realistic, init)
    assert noise.scale_only == ("position",)
    assert noise.ar_order["velocity"] > 0  # tacho ripple: coloured
    res, model = oe_stage(realistic, init, (3, 1), noise=noise)
    assert "position" not in res.residual_rms  # not in the dynamic fit
    assert "position" in model.outputs  # but the model still has its row
    assert model.extras["noise"]["position"]["use"] == "scale only"


def test_noise_model_uses_a_noisy_unquantised_position_for_the_dynamics():
    """White noise of 0.02 V on every channel: every channel carries the dynamics, and the
    noise model the final fit uses (re-estimated from its own residuals) is white at 0.02 V."""
    cfg = replace(preset("third-order").ideal(), noise_v=0.02)
    exp = run_experiment(config=cfg, seed=3, quantised=False, validation=False)
    cond = condition_experiment(dict(exp.captures), ConditioningSettings(sample_interval_s=None))
    init = identify_conditioned(cond, IdentifySettings(method="pinv", order=2)).model
    assert noise_model(cond, init).scale_only == ()
    model = identify_conditioned(cond, IdentifySettings(method="oe")).model
    for role, nm in model.extras["noise"].items():
        assert nm["use"] == "dynamics"
        assert nm["ar_order"] <= 1, role
        assert nm["sigma"] == pytest.approx(0.02, rel=0.1), role


def test_oe_recovers_a_delay_across_captures_with_their_own_shifts():
    """Velocity and position with a 50 ms dead time, the position capture also 2 ms late:
    the delay is the velocity's, the position's shift is relative to it."""
    t = np.arange(0.0, 8.0, DT_S)
    num, den = [0.9], np.polymul([0.4, 1.0], [0.03, 1.0])
    g = control.tf(num, den)
    late = {"velocity": 0.05, "position": 0.052}
    data = {"velocity": STEP_V * control.step_response(g, T=t).outputs,
            "position": 2.5 * STEP_V * control.step_response(g * control.tf([1], [1, 0]), T=t).outputs}
    data = {ch: np.interp(t - late[ch], t, y, left=0.0) for ch, y in data.items()}
    res = output_error_fit(t, STEP_V, data, {ch: 1e-3 for ch in data}, [0.3, 0.05], 0.8,
                           OeSettings(n_poles=2, n_zeros=0, delay=True, shift_bound_s=0.006),
                           pre={ch: np.zeros(300) for ch in data})
    q = dict(zip(res.param_names, res.params, strict=False))
    assert "shift_velocity" not in q
    assert res.delay_s == pytest.approx(0.05, abs=2e-4)
    assert q["shift_position"] == pytest.approx(0.002, abs=2e-4)
    assert res.time_constant_s == pytest.approx(0.43, rel=1e-3)


def test_oe_on_a_position_alone_keeps_velocity_the_derivative_of_position():
    """Without a tacho the velocity is the position's derivative (position volts per second):
    the fitted position TF is exactly the velocity TF over s, and the gain is the position
    slope per volt (the trainer scales pot and tacho so that its position TF is its velocity
    TF over s), not a free product K·c left wherever the starting point put it."""
    exp = run_experiment("second-order", seed=5, validation=False, roles=("position",))
    cond = condition_experiment(dict(exp.captures), ConditioningSettings(sample_interval_s=None))
    model = identify_conditioned(cond, IdentifySettings(method="oe")).model
    vel, pos = model.velocity_tf, model.position_tf
    w = 1j * np.array([0.3, 3.0, 30.0])
    assert np.allclose(pos(w), vel(w) / w, rtol=1e-9)
    truth_step = exp.truth.dc_gain * (1.0 - exp.truth.equivalent_input_offset_v / exp.step_volts)
    assert model.first_order().dc_gain == pytest.approx(truth_step, rel=0.01)
