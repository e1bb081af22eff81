"""The step edge's split search in blocks gives the numbers of one full-length pass."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.conditioning.edge import _SPLIT_BLOCK, _best_split


def _full_length(y: np.ndarray, lo: int, hi: int) -> tuple[int, float]:
    # the search as one vectorised pass over every candidate (the formula of the two-level fit)
    n = y.size
    c1, c2 = np.cumsum(y), np.cumsum(y * y)
    k = np.arange(lo, hi)
    s_left, q_left = c1[k - 1], c2[k - 1]
    s_right, q_right = c1[-1] - s_left, c2[-1] - q_left
    sse = (q_left - s_left**2 / k) + (q_right - s_right**2 / (n - k))
    j = int(np.argmin(sse))
    return int(k[j]), float(sse[j])


@pytest.mark.parametrize("n", [40, 5000, 2 * _SPLIT_BLOCK + 333])
@pytest.mark.parametrize("where", [0.1, 0.7, 0.999])
def test_blocks_give_the_full_length_split(n: int, where: float) -> None:
    rng = np.random.default_rng(n)
    y = np.where(np.arange(n) >= int(where * n), 5.92, 0.0) + rng.normal(0, 0.01, n)
    for lo, hi in ((1, n), (10, n - 19)):
        assert _best_split(y, lo, hi) == _full_length(y, lo, hi)


def test_ties_keep_the_first_split_and_nan_stops() -> None:
    flat = np.zeros(_SPLIT_BLOCK + 50)
    assert _best_split(flat, 1, flat.size) == _full_length(flat, 1, flat.size)
    y = np.where(np.arange(_SPLIT_BLOCK + 50) > 100, 1.0, 0.0)
    y[_SPLIT_BLOCK + 10] = np.nan
    k, sse = _best_split(y, 1, y.size)
    k_ref, sse_ref = _full_length(y, 1, y.size)
    assert k == k_ref and np.isnan(sse) and np.isnan(sse_ref)
