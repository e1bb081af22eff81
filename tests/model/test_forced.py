"""The forced and free responses of :mod:`motorid.model.forced` against python-control's.

``validate`` simulated with ``control.forced_response`` and ``control.initial_response`` (a
Python loop over the samples); it now runs the same first-order hold in block recursions.  The
references are python-control's own functions on the same systems, and a plain loop for the
recursion.
"""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.model.forced import RECURSION_BLOCK, held_states, linear_hold_response

# a servo with a fast electrical pole (stiff: −5 and −150 rad/s) and a position integrator
A3 = np.array([[0.0, 1.0, 0.0], [0.0, -5.0, 30.0], [0.0, -2.0, -150.0]])
B3 = np.array([[0.0], [0.0], [40.0]])


@pytest.mark.parametrize("row", [0, 1, 2])
@pytest.mark.parametrize("n", [1, 2, RECURSION_BLOCK - 1, RECURSION_BLOCK, 3 * RECURSION_BLOCK + 5, 5000])
def test_equals_python_controls_forced_and_initial_response(row, n):
    rng = np.random.default_rng(n + row)
    c, d = np.eye(3)[row:row + 1], np.array([[0.3 if row == 1 else 0.0]])
    t = np.arange(n) * 1e-3
    u = np.sin(2 * np.pi * 3 * t) + 0.1 * rng.standard_normal(n)
    sys = control.ss(A3, B3, c, d)
    forced, free = linear_hold_response(A3, B3, c, d, 1e-3, u, np.eye(3))
    if n > 1:
        ref = np.ravel(control.forced_response(sys, t, u).outputs)
        scale = max(float(np.max(np.abs(ref))), 1e-300)
        assert np.max(np.abs(forced - ref)) <= 1e-12 * scale
        for i in range(3):
            ref_i = np.ravel(control.initial_response(sys, t, X0=np.eye(3)[i]).outputs)
            assert np.max(np.abs(free[:, i] - ref_i)) <= 1e-12 * max(1.0, float(np.max(np.abs(ref_i))))
    else:
        assert forced[0] == pytest.approx(d[0, 0] * u[0]) and np.array_equal(free[0], c[0])


def test_without_initial_states_there_are_no_free_responses():
    forced, free = linear_hold_response(A3, B3, np.eye(3)[1:2], np.zeros((1, 1)), 1e-3, np.ones(50))
    assert free.shape == (50, 0) and forced.shape == (50,)


def test_an_unstable_model_overflows_to_nan_or_inf_not_to_numbers():
    a = np.array([[400.0]])
    forced, free = linear_hold_response(a, np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), 1.0, np.ones(10),
                                        np.eye(1))
    assert not np.all(np.isfinite(forced)) and not np.all(np.isfinite(free))


def test_held_states_is_the_sample_by_sample_recursion():
    rng = np.random.default_rng(3)
    f = np.array([[0.9, 0.1], [-0.05, 0.8]])
    x0, g = rng.standard_normal((2, 3)), rng.standard_normal((2, 3))
    for n, w in ((1, None), (RECURSION_BLOCK + 1, None), (200, rng.standard_normal(200))):
        x, expected = x0.copy(), []
        for k in range(n):
            expected.append(x)
            x = f @ x + g * (1.0 if w is None else w[k])
        np.testing.assert_allclose(held_states(f, x0, g, w, n), np.array(expected), rtol=1e-12, atol=1e-12)


def test_a_model_that_grows_much_over_a_sample_keeps_its_digits():
    """e^40 per sample: a recursion on x − B₁u would cancel every digit; python-control's loop does not."""
    t, u = np.arange(10.0), np.ones(10)
    forced, _ = linear_hold_response(np.array([[40.0]]), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), 1.0, u)
    ref = np.ravel(control.forced_response(control.ss(40.0, 1.0, 1.0, 0.0), t, u).outputs)
    np.testing.assert_allclose(forced, ref, rtol=1e-12)
