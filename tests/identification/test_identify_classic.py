"""Classic first-order method (lab report §1.1) against an analytic step response."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.errors import MotorIdError
from motorid.identification.classic import classic_first_order


def test_classic_recovers_analytic_first_order() -> None:
    k, tau, step = 0.905, 0.424, 5.92
    t = np.arange(0.0, 5.0, 0.004)
    y = k * step * (1 - np.exp(-t / tau))
    r = classic_first_order(t, y, step)
    # 0.5 %: the 63.2 % crossing is interpolated linearly between 4 ms samples and the
    # final value is a tail mean (both far below 0.5 % for 12 time constants of record).
    assert r.dc_gain == pytest.approx(k, rel=5e-3)
    assert r.time_constant_s == pytest.approx(tau, rel=5e-3)
    assert r.k == pytest.approx(k / tau, rel=1e-2)
    assert r.p == pytest.approx(1 / tau, rel=5e-3)
    assert r.warnings == ()


def test_classic_step_edge_offset() -> None:
    t = np.arange(-0.5, 5.0, 0.002)
    y = np.where(t >= 0.2, 2.0 * (1 - np.exp(-(t - 0.2) / 0.3)), 0.0)
    r = classic_first_order(t, y, 1.0, t0=0.2)
    assert r.time_constant_s == pytest.approx(0.3, rel=5e-3)


def test_classic_warns_when_not_settled() -> None:
    t = np.arange(0.0, 0.8, 0.004)
    y = 1 - np.exp(-t / 0.424)
    r = classic_first_order(t, y, 1.0)
    assert any("not settled" in w for w in r.warnings)


def test_classic_rejects_flat_response() -> None:
    t = np.arange(0.0, 1.0, 0.01)
    with pytest.raises(MotorIdError):
        classic_first_order(t, np.zeros_like(t), 1.0)
    with pytest.raises(MotorIdError):
        classic_first_order(t, t, 0.0)


def test_first_crossing_in_blocks_is_the_first_sample_past_the_level() -> None:
    """The search runs in blocks of ``BLOCK`` samples: a crossing on either side of a block edge, a level
    never reached, a negative level and a NaN are found as by the whole-array ``flatnonzero``."""
    import numpy as np

    from motorid.blockwise import BLOCK  # the blocks the crossing search works in
    from motorid.identification import classic

    n = 3 * BLOCK + 5
    t = np.arange(n) * 1e-3
    for at in (0, 1, BLOCK - 1, BLOCK, BLOCK + 1, 2 * BLOCK, n - 1):
        for sign in (1.0, -1.0):
            y = np.where(np.arange(n) >= at, 2.0, 0.5) * sign
            if at >= 4:
                y[at // 2] = np.nan  # a NaN before the crossing is not past the level
            level = 1.26 * sign
            want = int(np.flatnonzero((y - level) * sign >= 0)[0])
            time, i = classic.first_crossing(t, y, level)
            assert i == want == at
            if at:
                assert time == t[at - 1] + (level - y[at - 1]) / (y[at] - y[at - 1]) * (t[at] - t[at - 1])
    never, i = classic.first_crossing(t, np.zeros(n), 1.0)
    assert np.isnan(never) and i == -1
