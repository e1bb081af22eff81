"""A velocity-only model's position (the integral of its velocity) keeps its dead time."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.model import model_from_velocity_tf, step_nrmse

K, TAU, STEP, DEAD = 2.0, 0.43, 5.92, 0.05


def _position(t: np.ndarray) -> np.ndarray:
    # ∫ of K·u·(1 − e^(−(t−d)/τ)) from the dead time d: the closed form, computed by hand
    s = np.clip(t - DEAD, 0.0, None)
    return K * STEP * (s - TAU * (1.0 - np.exp(-s / TAU)))


def test_position_nrmse_of_a_velocity_model_with_a_dead_time_is_against_its_own_integral():
    model = model_from_velocity_tf([K], [TAU, 1.0], step_volts=STEP).replace(delay_s=DEAD)
    assert "position" not in model.outputs
    t = np.linspace(0.0, 3.0, 3001)
    # the model's own position: NRMSE zero to the integration's accuracy (the dead time used to be
    # left out: an error of K·u·d, 1.8 % of the final position here)
    assert step_nrmse(model, t, _position(t), channel="position") < 1e-6
    assert step_nrmse(model.replace(delay_s=0.0), t, _position(t), channel="position") == pytest.approx(
        DEAD / (3.0 - TAU), rel=0.2)
