"""FFT denoising of a PWM-noisy armature current against the clean analytic current."""

import numpy as np
import pytest

from motorid.conditioning.denoise import fft_denoise
from motorid.errors import OptionError


def test_fft_denoise_removes_pwm_and_keeps_the_transient():
    rng = np.random.default_rng(3)
    dt = 0.004
    t = np.arange(2500) * dt
    clean = 1.0 + 3.0 * np.exp(-t / 0.43)  # current spike decaying to the friction level
    noisy = clean + 0.4 * np.sign(np.sin(2 * np.pi * 97.0 * t)) + rng.normal(0, 0.1, t.size)
    out = fft_denoise(noisy, dt)
    assert out.auto and 0.5 < out.cutoff_hz < 60
    raw_err = np.std(noisy - clean)
    den_err = np.std((out.values - clean)[50:-50])
    # ~10x less error away from the record ends (the onset keeps a little Gibbs ringing)
    assert den_err < raw_err / 8


def test_given_cutoff_and_bad_cutoff():
    t = np.arange(1000) * 0.001
    y = np.sin(2 * np.pi * 2 * t) + np.sin(2 * np.pi * 200 * t)
    out = fft_denoise(y, 0.001, cutoff_hz=20.0)
    assert np.std(out.values - np.sin(2 * np.pi * 2 * t)) < 0.02
    with pytest.raises(OptionError):
        fft_denoise(y, 0.001, cutoff_hz=-1.0)
