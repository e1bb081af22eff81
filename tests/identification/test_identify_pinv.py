"""Pseudo-inverse method (paper §III) on noise-free data of known systems."""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.errors import MotorIdError
from motorid.identification.pinv import PinvSettings, pinv_identify


def _simulate(a: np.ndarray, b: np.ndarray, step: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact step response (python-control, ZOH exact for a step) and analytic derivative."""
    n = a.shape[0]
    sys = control.ss(a, b, np.eye(n), np.zeros((n, 1)))
    u = np.full(t.size, step)
    x = control.forced_response(sys, t, u).states
    x_dot = a @ x + b * u  # analytic derivative, so the regression is exact
    return x, x_dot, u


A2 = np.array([[0.0, 1.0], [0.0, -2.3]])
B2 = np.array([[0.0], [2.1]])
A3 = np.array([[0.0, 1.0, 0.0], [-0.01, -2.47, 0.62], [-0.003, -0.07, -0.22]])
B3 = np.array([[0.0], [2.34], [0.08]])


@pytest.mark.parametrize("structure", ["free", "known"])
@pytest.mark.parametrize(("a", "b", "states"), [(A2, B2, "reduced"), (A3, B3, "extended")])
def test_pinv_recovers_exact_system(a, b, states, structure) -> None:
    t = np.arange(0.0, 3.0, 0.01)
    x, x_dot, u = _simulate(a, b, 5.92, t)
    r = pinv_identify(x, x_dot, u, PinvSettings(states=states, structure=structure))
    # Noise-free, exactly consistent data: only round-off remains (the regressor's
    # condition number is ~1e3-1e5, so 1e-8 relative is a loose bound).
    np.testing.assert_allclose(r.A, a, atol=1e-8 * np.abs(a).max())
    np.testing.assert_allclose(r.B, b, atol=1e-8 * np.abs(b).max())
    assert r.n_samples == t.size - 4
    assert r.warnings == ()
    if structure == "known":
        assert r.A[0].tolist() == [0.0, 1.0] + [0.0] * (a.shape[0] - 2)
        assert r.B[0, 0] == 0.0


def test_pinv_known_structure_matches_free_when_first_row_is_true() -> None:
    t = np.arange(0.0, 2.4, 0.1)
    x, x_dot, u = _simulate(A2, B2, 1.0, t)
    free = pinv_identify(x, x_dot, u, PinvSettings(structure="free"))
    known = pinv_identify(x, x_dot, u, PinvSettings(structure="known"))
    np.testing.assert_allclose(free.A, known.A, atol=1e-8)


def test_pinv_warns_on_ill_conditioned_regressor() -> None:
    # Velocity proportional to position: the columns of [X U] are collinear.
    t = np.linspace(0.0, 1.0, 50)
    pos = t.copy()
    x = np.vstack([pos, 3.0 * pos])
    x_dot = np.vstack([np.ones_like(t), 3.0 * np.ones_like(t)])
    r = pinv_identify(x, x_dot, np.ones_like(t))
    assert any("condition number" in w for w in r.warnings)
    assert r.condition > 1e8


def test_pinv_too_few_samples_says_how_many() -> None:
    x = np.zeros((2, 6))
    with pytest.raises(MotorIdError, match="at least 7 samples"):
        pinv_identify(x, x, np.ones(6))


def test_pinv_rejects_bad_shapes_and_warns_on_nonzero_start() -> None:
    with pytest.raises(MotorIdError):
        pinv_identify(np.zeros((3, 10)), np.zeros((3, 10)), np.ones(10))
    t = np.arange(0.0, 3.0, 0.05)
    x, x_dot, u = _simulate(A2, B2, 1.0, t)
    r = pinv_identify(x + 1.0, x_dot, u)
    assert any("initial state" in w for w in r.warnings)
