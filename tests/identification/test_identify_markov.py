"""Markov/Hankel building blocks (paper §IV) against independent computations."""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.errors import MotorIdError
from motorid.identification.markov import (
    MarkovSettings,
    companion_realisation,
    detect_order,
    hankel_matrix,
    hankel_singular_values,
    markov_identify,
    markov_parameters,
)


def _markov_of(a, b, c, n):
    return np.array([(c @ np.linalg.matrix_power(a, k) @ b).item() for k in range(n)])


def test_hankel_matrix_layout() -> None:
    h = np.arange(1.0, 8.0)
    np.testing.assert_array_equal(hankel_matrix(h, 3), [[1, 2, 3], [2, 3, 4], [3, 4, 5]])
    np.testing.assert_array_equal(hankel_matrix(h, 2, shift=1), [[2, 3], [3, 4]])
    with pytest.raises(MotorIdError):
        hankel_matrix(h, 5)


def test_companion_realisation_reproduces_markov_parameters() -> None:
    sys = control.tf2ss(control.tf([2.0, 5.0], [1.0, 3.0, 7.0, 2.0]))
    h = _markov_of(sys.A, sys.B, sys.C, 8)
    a, b, c = companion_realisation(h, 3)
    # Same Markov parameters ⇒ same transfer function (all minimal realisations agree).
    np.testing.assert_allclose(_markov_of(a, b, c, 8), h, rtol=1e-9)
    tf_id = control.ss2tf(a, b, c, 0)
    np.testing.assert_allclose(tf_id.den[0][0], [1, 3, 7, 2], rtol=1e-9)


def test_markov_parameters_exact_for_polynomial_response() -> None:
    # y/V0 = 2 t + 3 t²/2 is exactly h0 = 2, h1 = 3 (velocity form), all others 0.
    t = np.linspace(0, 0.5, 101)
    y = 4.0 * (2 * t + 3 * t**2 / 2)
    p = markov_parameters(t, y, 4.0, 6, None)
    np.testing.assert_allclose(p.raw, [2, 3, 0, 0, 0, 0], atol=1e-7)
    np.testing.assert_allclose(p.scaled, p.raw * 0.5 ** np.arange(1, 7), atol=1e-9)


def test_detect_order_rule() -> None:
    assert detect_order([1, 0.426, 0.1, 0.009, 0.0009, 0.00009]) == 3  # paper §VI-2-B
    assert detect_order([1, 0.9, 1e-9, 1e-12, 1e-15, 0]) == 2  # σ3 below the floor
    assert detect_order([1, 0.9, 1e-3, 1e-12, 1e-15, 0]) == 3  # σ3 above it: largest drop after it
    assert detect_order([1, 1e-14, 1e-15, 0, 0, 0]) == 1
    assert detect_order([1, 0.5, 0.4, 0.3, 0.2, 0.1], max_order=2) in (1, 2)


def test_markov_identify_fixed_order_and_errors() -> None:
    g = control.tf([0.9], [0.0215, 0.48, 1.0])
    t = np.arange(0, 0.3, 0.002)
    y = control.step_response(g, t).outputs * 2.0
    r = markov_identify(t, y, 2.0, MarkovSettings(window_s=0.3, order=2))
    tf_id = control.ss2tf(r.A, r.B, r.C, 0)
    # Noise-free, but the fast pole (-20) times the window (0.3 s) is 6: the 11-term
    # series is truncated, which biases the poles by about 1 %; 2 % bounds it.
    np.testing.assert_allclose(np.roots(tf_id.den[0][0]), np.sort(g.poles()), rtol=2e-2)
    with pytest.raises(MotorIdError):
        markov_identify(t, y, 2.0, MarkovSettings(window_s=0.3, order=6))
    with pytest.raises(MotorIdError, match="samples"):
        markov_identify(t[:8], y[:8], 2.0, MarkovSettings(window_s=0.3))
    with pytest.raises(MotorIdError):
        MarkovSettings(hankel_size=7)


def test_hankel_singular_values_normalised() -> None:
    sv = hankel_singular_values((-0.5) ** np.arange(11), 6)
    assert sv[0] == 1.0
    assert sv[1] < 1e-12  # a geometric sequence has a rank-1 Hankel matrix
