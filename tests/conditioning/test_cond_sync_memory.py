"""The synchronised grid and a constant input without their full-length temporaries: the same bits."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.capture import Capture, ChannelInfo
from motorid.conditioning.response import step_response
from motorid.conditioning.sync import grid_times, level_throughout, synchronise


@pytest.mark.parametrize("n", [1, 2, 3, 1000, 300_001])
@pytest.mark.parametrize("dt", [1e-3, 0.0009999999999763531, 1e-5, 0.1, 1 / 3])
def test_grid_times_is_the_integer_arange_times_dt(n, dt):
    assert grid_times(n, dt).tobytes() == (np.arange(n) * dt).tobytes()


def _interp_from_one(time, xp, fp, level):
    u = np.interp(time, xp, fp)
    u[0] = level
    return u


def _cases():
    rng = np.random.default_rng(3)
    xp = (np.arange(-50, 2000) * 1e-3).round(6)  # parsed decimals: not the grid's k·dt
    step = np.where(xp >= 0, 5.0, 0.0)
    time = grid_times(1500, 0.0009999999999763531)
    yield time, xp, step, 5.0, True  # a logged step that stays at its level
    yield grid_times(3000, 1e-3), xp, step, 5.0, True  # the grid runs past the last node (np.interp's right)
    wiggle = step.copy()
    wiggle[1200] = 5.0 + 1e-12
    yield time, xp, wiggle, 5.0, False  # one node off the level inside the record
    late = step.copy()
    late[-1] = 4.0
    yield grid_times(3000, 1e-3), xp, late, 5.0, False  # the right end differs
    yield time, xp, late, 5.0, True  # ... but the record stops before it
    yield time, xp, step + rng.normal(0, 1e-3, xp.size), 5.0, False  # a sampled input with noise
    yield time, xp, np.zeros_like(xp), 0.0, False  # a zero level is left to np.interp
    yield time + 1.0, xp + 2.0, step, 5.0, False  # samples left of the first node
    neg = np.where(xp >= 0, -2.5, 0.0)
    yield time, xp, neg, -2.5, True


@pytest.mark.parametrize("case", list(range(9)))
def test_level_throughout_holds_exactly_when_np_interp_gives_the_level(case):
    time, xp, fp, level, expected = list(_cases())[case]
    got = level_throughout(time, xp, fp, level)
    assert got == expected
    want = _interp_from_one(time, xp, fp, level)
    if got:  # then the constant is the interpolation, bit for bit
        assert np.full(time.size, level).tobytes() == want.tobytes()


def test_level_throughout_reads_every_block():
    xp = np.arange(-10, 700_000) * 1e-3
    fp = np.where(xp >= 0, 1.0, 0.0)
    time = grid_times(690_000, 1e-3)
    assert level_throughout(time, xp, fp, 1.0)
    for k in (10 + (1 << 18) - 1, 10 + (1 << 18), 10 + 2 * (1 << 18) + 5, 10 + 689_998):
        bad = fp.copy()
        bad[k] = 1.0 - 2**-52
        assert not level_throughout(time, xp, bad, 1.0)


def _capture(u):
    k = np.arange(4000)
    t = (k - 700) * 1e-3
    rng = np.random.default_rng(8)
    y = np.where(k >= 700, 2.0 * -np.expm1(-(k - 700) * 1e-3 / 0.1), 0.0) + rng.normal(0, 0.01, k.size)
    return Capture(source="log.csv", format="plain-csv", time_s=t, output_v=y, output_info=ChannelInfo("velocity"),
                   input_v=u)


@pytest.mark.parametrize("noisy", [False, True])
def test_the_synchronised_input_is_the_interpolated_one(noisy):
    k = np.arange(4000)
    u = np.where(k >= 700, 5.0, 0.0) + (np.random.default_rng(1).normal(0, 1e-3, k.size) if noisy else 0.0)
    r = step_response(_capture(u), "velocity")
    if noisy:
        # a noisy input column is a measured voltage, timed as a scope's (test_cond_measured_input.py):
        # the log's own grid, under test here, is a logged command's
        from dataclasses import replace

        assert r.timing == "sampled"
        r = replace(r, timing="logged")
    s = synchronise([r])
    # a log on its grid: the grid's step is the stamps' mean step from the edge, the velocity the log's own samples
    i0 = r.edge.index
    want_t = np.arange(s.time_s.size) * ((r.time_s[-1] - r.time_s[i0]) / (r.time_s.size - 1 - i0))
    want_u = _interp_from_one(want_t, r.time_s, r.input_v, r.input_v[r.edge.index])
    assert s.time_s.tobytes() == want_t.tobytes()
    assert np.ascontiguousarray(s.input_v).tobytes() == want_u.tobytes()
    assert s.input_v.flags.writeable is noisy  # the constant is a read-only view of one number
    velocity = s.outputs["velocity"]
    assert np.shares_memory(velocity, r.output_v) and not velocity.flags.writeable  # a view, never written
    assert velocity.tobytes() == r.output_v[i0 : i0 + velocity.size].tobytes()
    # what the interpolation onto the grid gives, to a millionth of a sample's change
    step = float(np.max(np.abs(np.diff(r.output_v))))
    assert np.max(np.abs(velocity - np.interp(want_t, r.time_s, r.output_v))) <= 1e-6 * step


@pytest.mark.parametrize("case", ["jittered", "scope"])
def test_a_log_off_its_grid_and_a_scope_capture_are_interpolated(case):
    from dataclasses import replace

    k = np.arange(4000)
    cap = _capture(np.where(k >= 700, 5.0, 0.0))
    if case == "jittered":  # stamps off k·dt by 1e-3 of a sample: the interpolation's grid, as always
        cap = replace(cap, time_s=cap.time_s + 1e-6 * np.random.default_rng(4).uniform(-1.0, 1.0, k.size))
    r = step_response(cap, "velocity")
    if case == "scope":
        r = replace(r, timing="sampled")
    s = synchronise([r])
    want_t = np.arange(s.time_s.size) * r.sample_interval_s
    assert s.time_s.tobytes() == want_t.tobytes()
    assert s.outputs["velocity"].tobytes() == np.interp(want_t, r.time_s, r.output_v).tobytes()
    assert not np.shares_memory(s.outputs["velocity"], r.output_v)


@pytest.mark.parametrize("t0", [0.0, 1.5, 0.0005, -0.25])
def test_the_samples_after_the_step_are_the_masked_ones(t0):
    """The sanity gate's recorded input: a tail view, the same values as the mask ``time_s >= 0``."""
    from motorid.conditioning.response import split_at

    k = np.arange(4000)
    u = np.where(k >= 700, 5.0, 0.0) + np.random.default_rng(2).normal(0, 1e-3, k.size)
    r = step_response(_capture(u), "velocity")
    for time_s in (r.time_s, r.time_s - t0, np.array([-1.0, -0.0, 0.0, 2.0]), np.array([-2.0, -1.0])):
        values = np.arange(time_s.size, dtype=float)
        got = split_at(time_s, values)[1]
        assert np.shares_memory(got, values) or got.size == 0
        assert got.tobytes() == values[time_s >= 0].tobytes()


def test_blocked_interpolation_has_the_bits_of_numpys(monkeypatch):
    """Block by block, each block with the nodes that bracket it: every sample has the whole call's bracket."""
    from motorid.conditioning import sync

    monkeypatch.setattr(sync, "BLOCK", 16)
    rng = np.random.default_rng(3)
    for trial in range(200):
        n = int(rng.integers(2, 150))
        xp = np.cumsum(rng.uniform(0.01, 1.0, n))
        fp = rng.normal(size=n)
        fp[int(rng.integers(0, n))] = -0.0  # a node's −0.0 stays −0.0 only with its own bracket
        x = xp.copy() if trial % 3 == 0 else np.sort(rng.uniform(xp[0] - 1.0, xp[-1] + 1.0, int(rng.integers(1, 200))))
        if trial % 5 == 0:
            x = np.sort(np.r_[x, xp[-1], xp[0]])  # the ends exactly
        assert sync.blocked_interp(x, xp, fp).tobytes() == np.interp(x, xp, fp).tobytes(), trial
