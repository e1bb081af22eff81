"""The step search and the input check without full-length temporaries: the same numbers.

``find_steps`` held three arrays of the log's length at once (the jumps, the differences for the
noise level and their median's copy: 240 MB on a 10 M-row log) and the plateau check two more; the
sanity gate's input check two.  Each blocked or in-place form is compared here with the formula it
replaces.
"""

from __future__ import annotations

import numpy as np
import pytest

from motorid.blockwise import BLOCK
from motorid.conditioning import segment
from motorid.conditioning.edge import noise_level
from motorid.identification import sanity


def _noise_level_as_it_was(y: np.ndarray) -> float:
    d = np.diff(np.asarray(y, dtype=float))
    d -= np.median(d)
    np.abs(d, out=d)
    return float(1.4826 * np.median(d, overwrite_input=True) / np.sqrt(2.0))


@pytest.mark.parametrize("n", [2, 3, 1000, 600_001])
def test_the_noise_level_with_its_medians_in_place_is_the_same_bits(n):
    y = np.cumsum(np.random.default_rng(n).normal(0, 1, n))
    y[n // 2:] += 10.0
    assert noise_level(y) == _noise_level_as_it_was(y)


@pytest.mark.parametrize("n", [0, 1, 5, BLOCK - 1, BLOCK, 2 * BLOCK + 7])
def test_the_samples_off_a_level_are_counted_in_blocks(n):
    u = np.random.default_rng(n).normal(2.0, 0.3, n)
    assert segment._count_off(u, 2.0, 0.25) == np.count_nonzero(np.abs(u - 2.0) > 0.25)


@pytest.mark.parametrize("n", [1, 5, BLOCK, 3 * BLOCK + 11])
def test_the_input_checks_mean_square_in_blocks(n):
    u = np.random.default_rng(n).normal(5.0, 0.05, n)
    assert sanity._mean_square_about(u, 5.0) == pytest.approx(float(np.mean((u - 5.0) ** 2)), rel=1e-12)
