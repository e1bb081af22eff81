"""The time column's checks run in blocks: the same first bad sample as the whole-column formulas.

:func:`motorid.io._common.check_time_steps` takes the steps again in blocks of the column (no array of
a 10 M-row log's length) for the backwards, jitter and gap tests, and :func:`uniform_grid` its
uniformity test; here the blocks are 8 samples and a bad step is put at every place around their
edges, and the sample named is compared with ``np.diff`` over the whole column.
"""

from __future__ import annotations

import numpy as np
import pytest

from motorid.errors import CaptureDataError
from motorid.io import _common

N = 40


def _first_bad_sample(t: np.ndarray, *, jitter_ok: bool) -> int:
    """The whole-column formulas the checks had before they ran in blocks."""
    dt = np.diff(t)
    back = np.flatnonzero(dt <= 0)
    if back.size:
        return int(back[0]) + 1
    med = float(np.median(dt))
    if jitter_ok:
        limit = max(_common.GAP_MEDIANS * med, _common.GAP_OVER_P99 * float(np.percentile(dt, 99)))
        bad = np.flatnonzero(dt > limit)
    else:
        bad = np.flatnonzero(np.abs(dt - med) > 0.01 * med + 1e-12 * max(1.0, float(np.max(np.abs(t)))))
    return int(bad[0]) + 1


@pytest.mark.parametrize("jitter_ok", [False, True])
@pytest.mark.parametrize("kind", ["backwards", "duplicated", "gap"])
def test_the_first_bad_step_is_found_across_block_edges(monkeypatch, kind, jitter_ok):
    monkeypatch.setattr(_common, "_CHECK_BLOCK", 8)
    for k in range(1, N):
        t = np.arange(N) * 1e-3 + 5.0
        if kind == "gap":
            t[k:] += 0.02
        else:
            t[k] = t[k - 1] - (1e-4 if kind == "backwards" else 0.0)
        want = _first_bad_sample(t, jitter_ok=jitter_ok)
        with pytest.raises(CaptureDataError) as info:
            _common.check_time_steps(t, {}, file="x.csv", line_of=lambda i: i + 2, jitter_ok=jitter_ok)
        assert "x.csv:" + str(want + 2) + ":" in str(info.value), (k, str(info.value))
        assert (kind if kind != "gap" else "differs from the sample interval") in str(info.value).replace(
            "goes backwards", "backwards")


def test_the_median_step_returned_is_numpys(monkeypatch):
    monkeypatch.setattr(_common, "_CHECK_BLOCK", 8)
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.009, 0.011, 101))
    med = _common.check_time_steps(t, {}, file="x.csv", line_of=lambda i: i, jitter_ok=True).median_s
    assert med == float(np.median(np.diff(t)))


@pytest.mark.parametrize("jitter_at", [None, 0, 7, 8, 9, 38])
def test_the_uniformity_test_in_blocks_decides_as_the_whole_column(monkeypatch, jitter_at):
    monkeypatch.setattr(_common, "_CHECK_BLOCK", 8)
    t = np.arange(N) * 1e-3
    if jitter_at is not None:
        t[jitter_at + 1:] += 2e-4  # one step 20 % long: not uniform
    y = np.sin(t)
    dt = np.diff(t)
    med = float(np.median(dt))
    whole = bool(np.all(np.abs(dt - med) <= _common.UNIFORM_REL * med + 1e-12 * max(1.0, abs(t[0]), abs(t[-1]))))
    for median in (None, med):
        grid, _out, _, _, note, _res = _common.uniform_grid(t, y, None, {}, file="x.csv", median=median)
        assert (note == "") == whole and (grid is t) == whole


def _stamps(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """Time columns whose steps have few or many distinct values, the median's rank bracketed or not."""
    if kind == "printed":  # a logger's "%.4f" stamps: steps of a few values near 1e-4, in their last bits
        return np.round(np.arange(n) * 1e-4 + 3.0, 4)
    if kind == "millis":  # 10 and 11 ms
        return np.cumsum(rng.choice([0.010, 0.011], n))
    if kind == "half_and_half":  # the middle ranks fall on two different values
        return np.cumsum(np.r_[np.full(n // 2, 0.010), np.full(n - n // 2, 0.011)])
    if kind == "three_levels":
        return np.cumsum(rng.choice([0.001, 0.002, 0.003], n))
    if kind == "continuous":
        return np.cumsum(rng.uniform(0.009, 0.011, n))
    if kind == "sorted_steps":  # the steps grow along the record: an even sample still brackets them
        return np.cumsum(np.linspace(0.001, 0.002, n))
    return np.cumsum(rng.exponential(1.0, n) + 1e-3)


@pytest.mark.parametrize("kind", ["printed", "millis", "half_and_half", "three_levels", "continuous",
                                  "sorted_steps", "exponential"])
@pytest.mark.parametrize("n", [3, 101, 1000, 1001, 4097, 4098])
def test_the_median_step_counted_in_blocks_is_numpys_bit_for_bit(monkeypatch, kind, n):
    """Blocks of 64 steps and a sample of 128 (so that long records are few thousand samples): the median,
    the smallest and the largest step are those of ``np.diff`` over the whole column, odd and even counts."""
    monkeypatch.setattr(_common, "_STEP_BLOCK", 64)
    monkeypatch.setattr(_common, "_STEP_SAMPLE", 128)
    rng = np.random.default_rng(n)
    for _ in range(3):
        t = _stamps(kind, n, rng)
        dt = np.diff(t)
        count = _common._StepCount.of(t)
        assert (count.smallest, count.largest) == (float(dt.min()), float(dt.max()))
        assert count.median(t) == float(np.median(dt)), (kind, n)
        if kind == "exponential":
            continue  # (its long steps are gaps: refused)
        steps = _common.check_time_steps(t, {}, file="x.csv", line_of=lambda i: i, jitter_ok=True)
        assert steps.median_s == float(np.median(dt))


def test_a_median_outside_the_sampled_bracket_is_still_numpys(monkeypatch):
    """A sample that misses the middle (every sampled step is a long one) falls back to numpy's median."""
    monkeypatch.setattr(_common, "_STEP_BLOCK", 64)
    monkeypatch.setattr(_common, "_STEP_SAMPLE", 128)
    dt = np.full(4000, 0.010)
    dt[::31] = 0.011  # the stride of the sample is 31: it sees 11 ms steps only
    t = np.r_[0.0, np.cumsum(dt)]
    count = _common._StepCount.of(t)
    assert count.low == count.high and not count.below <= (dt.size - 1) // 2 < count.not_above
    assert count.median(t) == float(np.median(np.diff(t)))


@pytest.mark.parametrize("jitter_at", [None, 0, 7, 300, 3998])
def test_the_uniformity_test_from_the_extremes_decides_as_the_whole_column(monkeypatch, jitter_at):
    monkeypatch.setattr(_common, "_STEP_BLOCK", 64)
    t = np.arange(4000) * 1e-3
    if jitter_at is not None:
        t[jitter_at + 1:] += 2e-4  # one step 20 % long: not uniform
    y = np.sin(t)
    dt = np.diff(t)
    med = float(np.median(dt))
    whole = bool(np.all(np.abs(dt - med) <= _common.UNIFORM_REL * med + 1e-12 * max(1.0, abs(t[0]), abs(t[-1]))))
    steps = _common.check_time_steps(t, {}, file="x.csv", line_of=lambda i: i, jitter_ok=True)
    grid, _out, _, _, note, _res = _common.uniform_grid(t, y, None, {}, file="x.csv", steps=steps)
    assert (note == "") == whole and (grid is t) == whole
