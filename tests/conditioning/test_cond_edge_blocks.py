"""The step edge's split search in blocks gives the numbers of one full-length pass."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.blockwise import BLOCK as _SPLIT_BLOCK  # the blocks _best_split works in
from motorid.conditioning.edge import _best_split


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


@pytest.mark.parametrize("n", [3, 1000, _SPLIT_BLOCK + 2, 2 * _SPLIT_BLOCK + 77])
def test_quantum_and_noise_level_are_the_full_length_formulas(n: int) -> None:
    from motorid.conditioning.edge import noise_level, quantisation_step

    rng = np.random.default_rng(n)
    lsb = 0.08
    y = np.round((np.where(np.arange(n) > n // 3, 5.92, 0.0) + rng.normal(0, 0.05, n)) / lsb) * lsb
    valid = rng.random(n - 1) > 0.3
    d = np.abs(np.diff(y))
    for below, ok in ((np.inf, None), (1.0, None), (1.0, valid), (1e-9, None)):
        dd = d if ok is None else d[ok]
        small = dd[(dd > 0) & (dd < below)]
        want = float(small.min()) if small.size else 0.0
        assert quantisation_step(y, below=below, valid=ok) == want
    steps = np.diff(y)
    assert noise_level(y) == float(1.4826 * np.median(np.abs(steps - np.median(steps))) / np.sqrt(2.0))


def _response_times_by_convolution(t: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    # the 63 % time and the start as one full-length pass each (index arrays, a convolution of the run)
    import scipy.ndimage

    from motorid.conditioning.edge import noise_level, quantisation_step
    from motorid.conditioning.timescale import PERSISTENCE

    n = v.size
    final = float(np.mean(v[-max(2, n // 10):]))
    quantum = quantisation_step(v, below=0.25 * abs(final))
    noise = max(noise_level(v), quantum / np.sqrt(12.0), 1e-12)
    z = v * np.sign(final) / abs(final)
    zs = scipy.ndimage.median_filter(z, size=int(min(max(3, n // 200 * 2 + 1), 31)), mode="nearest")
    above = np.flatnonzero(zs >= 1.0 - np.exp(-1.0))
    out = z > (3.0 * noise + quantum) / abs(final)
    run = np.convolve(out.astype(int), np.ones(PERSISTENCE, dtype=int), mode="full")[PERSISTENCE - 1:]
    started = np.flatnonzero(run[:n] >= PERSISTENCE)
    k = int(started[0]) if started.size else 0
    return (float(t[above[0]]) if above.size else float("nan")), max(float(t[k - 1]) if k > 0 else 0.0, 0.0)


@pytest.mark.parametrize("block", [1 << 18, 64, 401])
@pytest.mark.parametrize("delay", [0, 7, 400, 62, 63, 64])
def test_response_times_are_the_full_length_pass(delay: int, block: int, monkeypatch) -> None:
    # small blocks put the response's start and its run of PERSISTENCE samples across block edges
    from motorid.conditioning import timescale
    from motorid.conditioning.timescale import response_times

    monkeypatch.setattr(timescale, "BLOCK", block)

    n = 20_000
    t = np.arange(n) * 1e-3
    rng = np.random.default_rng(delay)
    k = np.maximum(np.arange(n) - delay, 0)
    v = 2.0 * -np.expm1(-k * 1e-3 / 0.3) + rng.normal(0, 0.01, n)
    got = response_times(t, v)
    assert (got.t63_s, got.dead_time_s) == _response_times_by_convolution(t, v)
