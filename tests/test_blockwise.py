"""Reductions a block at a time give the numbers of numpy's whole-record one-liners."""

from __future__ import annotations

import numpy as np
import pytest

from motorid import blockwise


@pytest.mark.parametrize("n", [2, 3, 1000, (1 << 18) + 7, 3 * (1 << 18)])
def test_line_slope_is_polyfits_slope(n):
    rng = np.random.default_rng(n)
    x = 1e4 + np.arange(n) * 1e-3  # far from x = 0: the naive sums would cancel
    y = 0.25 * (x - 1e4) + 7.0 + rng.normal(0, 0.01, n)
    # (x's own rounding, 2e-12 at 1e4 on steps of 1e-3, moves either slope by ~1e-9 of itself on few points)
    assert blockwise.line_slope(x, y) == pytest.approx(np.polyfit(x, y, 1)[0], rel=1e-7)


def test_line_slope_of_a_vertical_line_and_of_bad_arguments():
    assert np.isnan(blockwise.line_slope(np.ones(5), np.arange(5.0)))
    with pytest.raises(ValueError, match="same length"):
        blockwise.line_slope(np.ones(3), np.ones(4))


@pytest.mark.parametrize("n", [1, 2, 999, (1 << 18) + 1, 2 * (1 << 18)])
def test_variance_is_numpys(n):
    y = 5.0 + np.random.default_rng(n).normal(0, 0.3, n)
    assert blockwise.variance(y) == pytest.approx(float(np.var(y)), rel=1e-10, abs=1e-15)
    assert np.isnan(blockwise.variance(np.array([])))


def test_the_centred_sum_of_squares_is_the_spread_squared():
    y = 3.0 + np.random.default_rng(5).normal(0, 0.2, (1 << 18) + 11)
    assert blockwise.centred_sum_of_squares(y) == pytest.approx(float(np.linalg.norm(y - y.mean())) ** 2, rel=1e-10)
    assert blockwise.centred_sum_of_squares(np.array([])) == 0.0
