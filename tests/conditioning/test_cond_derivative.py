"""Numerical derivatives (Masoud 2019, eqs. 15-17) against analytic derivatives."""

import numpy as np
import pytest

from motorid.conditioning.derivative import derivative
from motorid.errors import OptionError

DT = 0.01
T = np.arange(200) * DT


@pytest.mark.parametrize(
    "method, degree, nan_front, nan_back",
    [("euler", 1, 1, 0), ("central", 2, 1, 1), ("five_point", 4, 2, 2), ("savgol", 3, 0, 0)],
)
def test_exact_on_polynomials_of_its_degree(method, degree, nan_front, nan_back):
    c = np.arange(1, degree + 2, dtype=float)
    y = np.polyval(c, T)
    expected = np.polyval(np.polyder(c), T)
    d = derivative(y, DT, method)
    assert d.shape == y.shape
    assert np.all(np.isnan(d[:nan_front])) and (nan_back == 0 or np.all(np.isnan(d[-nan_back:])))
    inner = slice(nan_front, y.size - nan_back)
    np.testing.assert_allclose(d[inner], expected[inner], rtol=1e-8, atol=1e-8)


def test_error_orders_on_a_sine():
    y = np.sin(3 * T)
    exact = 3 * np.cos(3 * T)
    err = {m: np.nanmax(np.abs(derivative(y, DT, m) - exact)[3:-3]) for m in ("euler", "central", "five_point")}
    # truncation errors O(h), O(h^2), O(h^4): each formula an order of magnitude better
    assert err["five_point"] < err["central"] / 100 < err["euler"] / 100


def test_savgol_is_less_noisy_than_five_point():
    rng = np.random.default_rng(0)
    y = np.sin(3 * T) + rng.normal(0, 1e-3, T.size)
    exact = 3 * np.cos(3 * T)
    e5 = np.nanstd((derivative(y, DT, "five_point") - exact)[5:-5])
    esg = np.std((derivative(y, DT, "savgol") - exact)[5:-5])
    assert esg < e5


def test_unknown_method():
    with pytest.raises(OptionError, match="five_point"):
        derivative(T, DT, "spline")
