"""The quantiser's error along a record in the output-error fit's covariance, against Monte Carlo
over the place of the signal on the code grid (the independent computation)."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.identification.output_error import OeSettings, output_error_fit
from motorid.identification.quantiser import harmonic_variances, sawtooth_basis
from motorid.identification.stages import quantisation_bias_std

K, TAU, STEP, DT, CODE = 2.0, 0.43, 5.92, 0.004, 0.08


def _quantised(v: np.ndarray, phase: float) -> np.ndarray:
    # an 8-bit scope's codes, the signal at ``phase`` (volts) on the code grid
    return np.round((v + phase) / CODE) * CODE - phase


def test_undithered_harmonics_sum_to_the_sawtooths_variance():
    # Parseval: the rounding error of a signal at a uniform place on the grid has variance q²/12
    rng = np.random.default_rng(1)
    phase = rng.uniform(0, CODE, 200_000)
    mc = np.var(np.round(phase / CODE) * CODE - phase)
    assert np.sum(harmonic_variances(CODE, 0.0, 4000)) == pytest.approx(CODE**2 / 12, rel=1e-3)
    assert mc == pytest.approx(CODE**2 / 12, rel=0.01)


def test_a_dither_shrinks_the_harmonics_and_a_level_uses_the_same_ones():
    still, dithered = harmonic_variances(CODE, 0.0), harmonic_variances(CODE, 0.03)
    assert np.all(dithered <= still) and dithered[0] < 0.5 * still[0]
    # the level's error (a plateau's samples: their spread besides q²/12 is the dither) is their sum
    y = np.r_[np.full(50, 1.0), np.full(50, 1.0 + CODE)]
    dither = np.sqrt(np.var(y) - CODE**2 / 12)
    assert quantisation_bias_std(y, CODE) == pytest.approx(np.sqrt(np.sum(harmonic_variances(CODE, dither, 32))))


def test_sawtooth_basis_is_each_harmonics_cosine_and_sine():
    s = np.linspace(-3.0, 7.0, 501)
    b = sawtooth_basis(s, CODE, 5)
    k = np.arange(1, 6)
    np.testing.assert_allclose(b[:, 0::2], np.cos(2 * np.pi * np.outer(s / CODE, k)), atol=1e-9)
    np.testing.assert_allclose(b[:, 1::2], np.sin(2 * np.pi * np.outer(s / CODE, k)), atol=1e-9)


def test_interval_of_a_quantised_step_is_as_wide_as_its_error_over_the_code_grid():
    # A noise-free first-order step on 2 V/div (two codes of 80 mV hold its last 2 %): the error of
    # τ is the quantiser's, a fixed draw for each place of the signal on the code grid.  Over 60 places
    # its RMS is the reported standard deviation (within the 9 % a 60-draw RMS scatters, and the
    # 5 % of the sawtooth's variance in the harmonics left out).  Counting every sample's error as
    # independent noise (q²/12 each) reported a 15 times smaller one.
    t = np.arange(2000) * DT
    y = K * STEP * (1 - np.exp(-t / TAU))
    est, std = [], []
    for phase in np.random.default_rng(0).uniform(0, CODE, 60):
        res = output_error_fit(t, STEP, {"velocity": _quantised(y, phase)}, {"velocity": CODE / np.sqrt(12)},
                               [0.4], 1.9, OeSettings(n_poles=1), pre={"velocity": _quantised(np.zeros(300), phase)})
        assert res.quantum == {"velocity": pytest.approx(CODE)}
        est.append(res.time_constant_s)
        std.append(res.std["time_constant"])
    ratio = np.sqrt(np.mean((np.array(est) - TAU) ** 2)) / np.sqrt(np.mean(np.square(std)))
    assert 0.75 < ratio < 1.3, ratio


def test_a_signal_off_any_code_grid_gets_no_quantiser_term():
    rng = np.random.default_rng(2)
    t = np.arange(2000) * DT
    y = K * STEP * (1 - np.exp(-t / TAU)) + rng.normal(0, 0.02, t.size)
    res = output_error_fit(t, STEP, {"velocity": y}, {"velocity": 0.02}, [0.4], 1.9, OeSettings(n_poles=1),
                           pre={"velocity": rng.normal(0, 0.02, 300)})
    assert res.quantum == {}


def test_a_counted_speed_gets_no_quantiser_term():
    # a speed counted over each line is a difference of counts, not a rounded value: its quantum is
    # not at an unknown place on a grid (the window fit's own covariance holds it)
    t = np.arange(1, 500) * 0.01
    y = np.round(K * STEP * (1 - np.exp(-t / TAU)) / 0.5) * 0.5
    res = output_error_fit(t, STEP, {"velocity": y}, {"velocity": 0.5 / np.sqrt(12)}, [0.4], 1.9,
                           OeSettings(n_poles=1, windows=(("velocity", 0.01),)))
    assert res.quantum == {}


def test_a_logged_speed_in_rpm_is_taken_for_counted_and_gets_no_quantiser_term(tmp_path):
    # through the conditioning: a speed column in rpm is a count of edges (its quantum differenced);
    # the same column in volts is a rounded reading and keeps the term
    from motorid.capture import Capture, ChannelInfo
    from motorid.conditioning.pipeline import condition_experiment
    from motorid.identification.stages import oe_settings

    t = np.arange(-50, 450) * 0.01
    u = np.where(t >= 0, STEP, 0.0)
    y = np.round(np.where(t >= 0, K * STEP * (1 - np.exp(-np.clip(t, 0, None) / TAU)), 0.0) / 0.5) * 0.5
    for unit, rounded in (("rpm", False), ("V", True)):
        cap = Capture(time_s=t, output_v=y, input_v=u, source=f"log-{unit}.csv", format="csv",
                      output_info=ChannelInfo("speed", unit))
        cond = condition_experiment({"velocity": cap})
        assert cond.responses["velocity"].rounded is rounded
        assert oe_settings(cond, (1, 0)).differenced == (() if rounded else ("velocity",))
