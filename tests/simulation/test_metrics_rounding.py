"""The printed metrics carry no floating-point noise: an error at the simulation's rounding is 0."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.simulation.closed_loop import ROUNDING, response_metrics


def test_an_error_at_rounding_level_is_zero_and_a_real_one_stays():
    t = np.linspace(0.0, 2.0, 2001)
    r = np.where(t >= 0.1, 5.0, 0.0)
    y = r * (1 - np.exp(-np.clip(t - 0.1, 0, None) / 0.05))
    noisy = y.copy()
    noisy[-200:] = 5.0 - 1.776e-15  # what a loop with integral action ends on
    m = response_metrics(t, noisy, r, np.zeros_like(t), True)
    assert m.steady_state_error_v == 0.0
    off = y.copy()
    off[-200:] = 5.0 - 1e3 * ROUNDING * 5.0  # a real (small) error is kept as it is
    m = response_metrics(t, off, r, np.zeros_like(t), True)
    assert m.steady_state_error_v == pytest.approx(1e3 * ROUNDING * 5.0, rel=1e-6)
