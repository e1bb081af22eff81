"""Sample reduction: the paper's sub-sampling vs anti-aliased variants, measured."""

import numpy as np
import pytest

from motorid.conditioning.resample import ratio_for_interval, sample_reduction
from motorid.errors import OptionError


def test_subsample_is_every_rth_sample():
    t = np.arange(100) * 0.004
    y = np.sin(t)
    r = sample_reduction(t, y, 25, "subsample")
    np.testing.assert_array_equal(r.values, y[::25])
    np.testing.assert_array_equal(r.time_s, t[::25])


def test_block_mean_of_a_ramp_is_the_ramp_at_block_centres():
    t = np.arange(1000) * 0.004
    r = sample_reduction(t, 3 * t + 1, 25, "block_mean")
    np.testing.assert_allclose(r.values, 3 * r.time_s + 1, atol=1e-12)


def test_fir_keeps_the_motor_band_and_removes_pwm():
    dt = 0.004
    t = np.arange(2500) * dt
    slow = np.sin(2 * np.pi * 0.3 * t)
    fast = 0.5 * np.sin(2 * np.pi * 21.0 * t)  # above the new Nyquist (1/(2·0.1 s) = 5 Hz)
    red = {m: sample_reduction(t, slow + fast, 25, m) for m in ("subsample", "block_mean", "fir")}
    err = {m: np.std((r.values - np.sin(2 * np.pi * 0.3 * r.time_s))[5:-5]) for m, r in red.items()}
    # the paper's sub-sampling aliases the 21 Hz tone (21 Hz ≡ 1 Hz at 10 S/s) untouched
    assert err["subsample"] > 0.3
    # anti-aliased variants remove it: FIR by > 30 dB, block mean (sinc zero near 20 Hz) > 10 dB
    assert err["fir"] < 0.5 * 0.7071 * 10 ** (-30 / 20) * 10
    assert err["block_mean"] < 0.3 * 10 ** (-10 / 20)


def test_white_noise_variance_after_reduction():
    rng = np.random.default_rng(0)
    y = rng.normal(0, 1, 250_000)
    t = np.arange(y.size) * 1.0
    v_sub = np.var(sample_reduction(t, y, 25, "subsample").values)
    v_blk = np.var(sample_reduction(t, y, 25, "block_mean").values)
    assert v_sub == pytest.approx(1.0, rel=0.05)
    assert v_blk == pytest.approx(1 / 25, rel=0.05)  # block mean divides the variance by r


def test_ratio_for_interval_and_errors():
    assert ratio_for_interval(0.004, 0.1) == 25
    with pytest.raises(OptionError, match="shorter than the recording"):
        ratio_for_interval(0.004, 0.001)
    with pytest.raises(OptionError):
        sample_reduction(np.arange(5.0), np.arange(5.0), 0)
    with pytest.raises(OptionError):
        sample_reduction(np.arange(5.0), np.arange(5.0), 2, "median")
