"""motorid.model.lti against scipy.signal (the functions it stands in for) on random systems."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.signal

from motorid.model import lti


def _same(ours: tuple[np.ndarray, ...], theirs: tuple[np.ndarray, ...]) -> None:
    assert len(ours) == len(theirs)
    for o, t in zip(ours, theirs, strict=True):
        o, t = np.asarray(o), np.asarray(t)
        assert o.shape == t.shape
        np.testing.assert_array_equal(o, t)  # the same arithmetic: bit for bit


@pytest.mark.parametrize("seed", range(20))
def test_tf2ss_is_scipys_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 7))
    den = np.r_[rng.uniform(0.1, 3.0), rng.normal(size=n)]
    num = rng.normal(size=int(rng.integers(1, n + 2)))
    _same(lti.tf2ss(num, den), scipy.signal.tf2ss(num, den))
    nums = rng.normal(size=(3, n + 1))  # one numerator per output
    _same(lti.tf2ss(nums, den), scipy.signal.tf2ss(nums, den))


def test_tf2ss_drops_a_zero_leading_numerator_and_warns_as_scipy_does() -> None:
    num, den = [1e-17, 2.0, 3.0], [1.0, 4.0, 5.0]
    with pytest.warns(lti.BadCoefficients):
        ours = lti.tf2ss(num, den)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scipy.signal.BadCoefficients)
        _same(ours, scipy.signal.tf2ss(num, den))
    _same(lti.tf2ss([2.0], [3.0]), scipy.signal.tf2ss([2.0], [3.0]))  # a static gain


def test_tf2ss_rejects_an_improper_tf() -> None:
    with pytest.raises(ValueError, match="Improper"):
        lti.tf2ss([1.0, 2.0, 3.0], [1.0, 2.0])


@pytest.mark.parametrize("seed", range(20))
def test_ss2tf_is_scipys_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    n, p = int(rng.integers(1, 7)), int(rng.integers(1, 4))
    a, b = rng.normal(size=(n, n)), rng.normal(size=(n, 1))
    c, d = rng.normal(size=(p, n)), rng.normal(size=(p, 1))
    _same(lti.ss2tf(a, b, c, d), scipy.signal.ss2tf(a, b, c, d))


def test_ss2tf_round_trip_and_shape_check() -> None:
    num, den = lti.ss2tf(*lti.tf2ss([2.0, 3.0], [1.0, 4.0, 5.0]))
    np.testing.assert_allclose(num[0], [0.0, 2.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(den, [1.0, 4.0, 5.0])
    with pytest.raises(ValueError, match="ss2tf needs"):
        lti.ss2tf(np.eye(2), np.ones((3, 1)), np.ones((1, 2)), np.zeros((1, 1)))


@pytest.mark.parametrize("seed", range(20))
def test_lfilter_equals_scipys_to_rounding(seed: int) -> None:
    rng = np.random.default_rng(200 + seed)
    n = int(rng.integers(1, 6))
    # a stable discrete denominator (poles inside the unit circle, a conjugate pair when n > 1),
    # scaled so that a[0] != 1 is normalised too; numerator longer or shorter than it
    poles = rng.uniform(0.2, 0.97, n).astype(complex)
    if n > 1:
        poles[:2] = 0.9 * np.exp(1j * rng.uniform(0.1, 1.0) * np.array([1, -1]))
    den = np.real(np.poly(poles)) * rng.uniform(0.5, 2.0)
    num = rng.normal(size=int(rng.integers(1, n + 3)))
    x = rng.normal(size=int(rng.integers(50, 3000)))
    ref = scipy.signal.lfilter(num, den, x)
    np.testing.assert_allclose(lti.lfilter(num, den, x), ref, rtol=0, atol=1e-11 * np.max(np.abs(ref)))


def test_lfilter_fir_and_edge_cases() -> None:
    x = np.arange(10.0)
    np.testing.assert_allclose(lti.lfilter([1.0, -2.0, 0.5], [1.0], x), scipy.signal.lfilter([1.0, -2.0, 0.5], [1.0], x))
    np.testing.assert_allclose(lti.lfilter([3.0], [2.0], x), 1.5 * x)
    assert lti.lfilter([1.0], [1.0, 0.5], np.zeros(0)).size == 0
    # a first-order recursion against its closed form: y_k = Σ_j (0.5)^j from a unit step
    np.testing.assert_allclose(lti.lfilter([1.0], [1.0, -0.5], np.ones(20)), 2.0 * (1.0 - 0.5 ** np.arange(1, 21)))
    with pytest.raises(ValueError, match="a\\[0\\]"):
        lti.lfilter([1.0], [0.0, 1.0], x)


def test_lfilter_of_several_signals_is_each_ones_filter_and_scipys():
    """Signals as the rows of a 2-D array: each row exactly as filtered alone, and scipy's along the last axis."""
    rng = np.random.default_rng(7)
    b, a = np.array([0.0, 0.3, 0.1]), np.array([1.0, -1.6, 0.64])  # a double pole at z = 0.8
    x = rng.standard_normal((3, 500))
    both = lti.lfilter(b, a, x)
    assert both.shape == x.shape
    for row, y in zip(x, both, strict=True):
        assert np.array_equal(y, lti.lfilter(b, a, row))
    assert np.allclose(both, scipy.signal.lfilter(b, a, x, axis=-1), rtol=1e-10, atol=1e-12)
    with pytest.raises(ValueError, match="1-D or 2-D"):
        lti.lfilter(b, a, x[None])


@pytest.mark.parametrize("h", [1e-3, 0.05, 0.7])
def test_zoh_equals_scipy_cont2discrete(h):
    rng = np.random.default_rng(7)
    for n, m in ((1, 1), (2, 1), (3, 2), (4, 3)):
        a = rng.normal(size=(n, n)) - 2.0 * np.eye(n)
        b = rng.normal(size=(n, m))
        phi, gamma = lti.zoh(a, b, h)
        ref = scipy.signal.cont2discrete((a, b, np.eye(n), np.zeros((n, m))), h, method="zoh")
        np.testing.assert_allclose(phi, ref[0], rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(gamma, ref[1], rtol=1e-13, atol=1e-15)


def test_zoh_discretises_a_stack_as_each_alone():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(5, 3, 3)) - 3.0 * np.eye(3)
    b = rng.normal(size=(5, 3, 1))
    phi, gamma = lti.zoh(a, b, 0.01)
    for i in range(5):
        one = lti.zoh(a[i], b[i], 0.01)
        np.testing.assert_array_equal(phi[i], one[0])
        np.testing.assert_array_equal(gamma[i], one[1])


def test_zoh_of_several_intervals_is_each_alone():
    a, b = np.array([[0.0, 1.0], [-6.0, -5.0]]), np.array([[0.0], [6.0]])
    hs = np.array([0.0, 1e-3, 0.37, 2.0])
    phi, gamma = lti.zoh(a, b, hs[:, None, None])
    for i, h in enumerate(hs):
        one = lti.zoh(a, b, float(h))
        np.testing.assert_array_equal(phi[i], one[0])
        np.testing.assert_array_equal(gamma[i], one[1])
