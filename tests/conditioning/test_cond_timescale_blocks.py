"""The 63 % time's running median, filtered block by block, finds the sample the whole-record filter finds."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage

from motorid.conditioning import timescale


def _whole(z: np.ndarray, width: int, level: float) -> int:
    hit = scipy.ndimage.median_filter(z, size=width, mode="nearest") >= level
    first = int(np.argmax(hit))
    return first if hit[first] else -1


@pytest.mark.parametrize("width", [3, 5, 31])
def test_blocks_find_the_first_hit_of_the_whole_filter(monkeypatch, width):
    monkeypatch.setattr(timescale, "BLOCK", 16)
    rng = np.random.default_rng(width)
    n = 200
    for at in (0, 1, 14, 15, 16, 17, 40, 47, 48, 150, 199, None):
        z = rng.uniform(0.0, 0.6, n)
        if at is not None:
            z[at:] += 0.5  # reaches 0.632 from here on, noisily
        z[rng.integers(0, n, 5)] = 5.0  # spikes the running median must ignore
        want = _whole(z, width, 0.632)
        assert timescale._first_filtered_hit(z, width, 0.632, scipy.ndimage.median_filter) == want, at


def test_a_record_shorter_than_the_window_and_never_reaching_the_level():
    z = np.array([0.1, 0.9, 0.2])
    assert timescale._first_filtered_hit(z, 31, 0.632, scipy.ndimage.median_filter) == _whole(z, 31, 0.632)
    assert timescale._first_filtered_hit(np.zeros(50), 3, 0.632, scipy.ndimage.median_filter) == -1
