"""Position unwrapping with glitches: 0 to 50 wraps, span detected from the data."""

import numpy as np
import pytest

from motorid.conditioning.unwrap import count_wraps, unwrap_position

SPAN = 20.4  # the paper's pot span (Masoud 2019, section V-2 snippets)
LSB = 5.0 / 25  # 5 V/div, 8 bit: 25 codes per division


def motor_like(turns, n=2500, onset=300, tau=107):
    """Output-shaft position of a motor started at `onset` (first-order speed rise)."""
    t = np.arange(n, dtype=float)
    tt = np.clip(t - onset, 0, None)
    p = tt - tau * (1 - np.exp(-tt / tau))
    return -3.0 + turns * SPAN * p / max(p[-1], 1.0)


def sawtooth(pos, rng, glitches=True, noise=0.03):
    wrapped = (pos + SPAN / 2) % SPAN - SPAN / 2
    jumps = np.flatnonzero(np.abs(np.diff(wrapped)) > SPAN / 2) + 1
    y = np.round((wrapped + rng.normal(0, noise, pos.size)) / LSB) * LSB
    if glitches:
        for j in jumps:  # 0-3 near-zero samples while the wiper crosses the gap (Fig. 22)
            g = int(rng.integers(0, 4))
            seg = y[j : j + g]
            y[j : j + g] = rng.normal(0, 0.3, seg.size)
    return y, jumps.size


@pytest.mark.parametrize("turns", [0, 1, 2, 3, 5, 10, 25, 50])
def test_unwrap_counts_turns_and_tracks_every_sample(turns):
    rng = np.random.default_rng(100 + turns)
    pos = motor_like(turns)
    y, true_wraps = sawtooth(pos, rng)
    res = unwrap_position(y)
    assert res.wraps == true_wraps == turns
    err = np.abs(res.position_v - pos) / LSB
    # with the span given, only quantisation (0.5 LSB) and glitch interpolation remain
    known = np.abs(unwrap_position(y, span_v=SPAN).position_v - pos) / LSB
    assert known.max() <= 2.0
    # with the span estimated from the data its error accumulates over the wraps (the
    # span's standard error falls as 1/sqrt(wraps), the accumulated error grows as
    # sqrt(wraps)).  The brief's criterion: within 2 LSB on every sample after a baseline
    # shift (the constant that best aligns the two records).
    e = res.position_v - pos
    shifted = np.abs(e - 0.5 * (e.max() + e.min())) / LSB
    assert shifted.max() <= 2.0
    # anchored at the first sample: within 2 LSB up to 25 wraps; at 50 wraps the 8-bit
    # data cannot pin the span closer than ~0.03% (measured worst of 20 seeds: 3.5 LSB)
    assert err.max() <= (2.0 if turns <= 25 else 4.0)
    if turns:
        assert res.span_v == pytest.approx(SPAN, rel=2e-3)


def test_unwrap_backwards_rotation_and_isolated_spike():
    rng = np.random.default_rng(7)
    pos = -motor_like(4)
    y, _ = sawtooth(pos, rng, glitches=False)
    y[1000] = 0.0 if abs(y[1000]) > 3 else 9.0  # a lone spike, not a wrap
    res = unwrap_position(y)
    assert res.wraps == 4
    assert 1000 in res.glitch_indices
    assert np.abs(res.position_v - pos).max() <= 2 * LSB


def test_no_wraps_on_a_quantised_constant():
    y = np.round((1.0 + np.random.default_rng(0).normal(0, 0.05, 2500)) / LSB) * LSB
    assert count_wraps(y) == 0


def test_unwrap_real_hslu_encoder(real_dir):
    """The HSLU lab logs the encoder as a 0..230 sawtooth: a span the paper never saw."""
    f = real_dir / "hslu-rtl-dcmotor" / "csv" / "06_dc_step_5_15_00.csv"
    d = np.genfromtxt(f, delimiter=",", names=True)
    raw = d["position_raw"]
    res = unwrap_position(raw)
    big = int(np.sum(np.abs(np.diff(raw)) > 100))  # independent count of the resets
    assert res.wraps == big > 0
    assert 200 < res.span_v < 260
    # the motor turns one way throughout: the unwrapped position never steps back by more
    # than the encoder noise
    assert np.diff(res.position_v).min() > -2.0


def test_the_span_fit_equals_a_dense_least_squares():
    """The span's spline fit solves its normal equations from the sparse design (a fifth of the
    cost); a dense least squares of the same columns (numpy's, BIC over the same knot spacings)
    gives the same span."""
    from scipy.interpolate import BSpline

    from motorid.conditioning.unwrap import _fit_span

    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 2500)
    theta = 90.0 * (t - 0.3 * (1 - np.exp(-t / 0.3)))  # a motor's angle (V of a 10 V encoder): six turns
    wraps = np.floor(theta / 10.0)
    y = np.round((theta - 10.0 * wraps + rng.normal(0, 0.02, t.size)) / 0.08) * 0.08  # 8-bit codes
    good = np.ones(t.size, bool)
    best = None
    for spacing in (100, 50, 25):
        inner = np.linspace(t[0], t[-1], int(np.clip(t.size // spacing, 2, 400)))
        design = BSpline.design_matrix(t, np.r_[[t[0]] * 3, inner, [t[-1]] * 3], 3).toarray()
        cols = np.column_stack([design, -wraps])
        sol = np.linalg.lstsq(cols, y, rcond=None)[0]
        rss = float(np.sum((cols @ sol - y) ** 2))
        bic = t.size * np.log(rss / t.size) + cols.shape[1] * np.log(t.size)
        if best is None or bic < best[0]:
            best = (bic, sol[-1])
    assert _fit_span(t, y, wraps, good) == pytest.approx(best[1], rel=1e-10)
    assert best[1] == pytest.approx(10.0, rel=1e-3)
