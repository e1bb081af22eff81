"""response_metrics on python-control's step_info against closed forms and the old code.

A standard second-order step has closed forms for its overshoot and, found independently with
brentq on the analytic response, its 10/90 % crossings and last ±2 % band exit; the home-made
version the project used before (kept verbatim below) must agree on every random response
except where a sample lies exactly on the band edge (``>`` vs ``>=``, documented).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.optimize import brentq

from motorid.simulation.closed_loop import response_metrics


def _old_metrics(t, y, r):
    """The pre-issue-16 home-made step metrics (rise, settle, overshoot), verbatim."""
    rf = float(r[-1])
    k0 = int(np.argmax(r == rf)) if np.any(r != r[0]) else 0
    y0 = float(y[k0])
    delta = rf - y0
    frac = (y[k0:] - y0) / delta
    tt = t[k0:]
    i10 = np.flatnonzero(frac >= 0.1)
    i90 = np.flatnonzero(frac >= 0.9)
    rise = float(tt[i90[0]] - tt[i10[0]]) if i10.size and i90.size else float("nan")
    outside = np.flatnonzero(np.abs(frac - 1.0) > 0.02)
    if outside.size == 0:
        settle = 0.0
    elif outside[-1] + 1 < tt.size:
        settle = float(tt[outside[-1] + 1] - tt[0])
    else:
        settle = float("nan")
    overshoot = float(max(0.0, np.max(frac) - 1.0) * 100.0)
    return rise, settle, overshoot


def _second_order(t, zeta, wn):
    wd = wn * math.sqrt(1 - zeta**2)
    return 1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))


@pytest.mark.parametrize("zeta", [0.3, 0.5, 0.7])
def test_second_order_step_matches_closed_forms(zeta: float) -> None:
    wn, level, dt = 4.0, 2.5, 1e-4
    t = np.arange(0.0, 10.0, dt)
    y = level * _second_order(t, zeta, wn)
    r = np.full_like(t, level)
    r[0] = 0.0  # the step at sample 1: y0 = y[1] ≈ 0
    m = response_metrics(t, y, r, np.zeros_like(t), step=True)
    # overshoot: exp(-ζπ/√(1-ζ²)), exact
    assert m.overshoot_pct == pytest.approx(100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)), abs=1e-3)

    def f(x):
        return float(_second_order(np.array([x]), zeta, wn)[0])

    peak_t = math.pi / (wn * math.sqrt(1 - zeta**2))
    t10 = brentq(lambda x: f(x) - 0.1, 0.0, peak_t)
    t90 = brentq(lambda x: f(x) - 0.9, 0.0, peak_t)
    assert m.rise_time_s == pytest.approx(t90 - t10, abs=2 * dt)
    # last exit from the ±2 % band: scan the envelope's extrema, then brentq on the edge
    fine = np.arange(0.0, 10.0, 1e-3)
    out = np.flatnonzero(np.abs(_second_order(fine, zeta, wn) - 1) >= 0.02)
    a, b = fine[out[-1]], fine[out[-1] + 1]
    edge = 1.02 if f(a) > 1 else 0.98
    ts = brentq(lambda x: f(x) - edge, a, b)
    assert m.settling_time_s == pytest.approx(ts - dt, abs=2 * dt)  # time measured from the step sample


def test_same_as_the_old_definitions_on_random_responses() -> None:
    rng = np.random.default_rng(16)
    compared = 0
    for _ in range(200):
        n = int(rng.integers(50, 400))
        t = np.sort(rng.uniform(0, 5, n))
        t[0] = 0.0
        k0 = int(rng.integers(0, n // 3))
        r = np.where(np.arange(n) >= k0, rng.choice([-1, 1]) * rng.uniform(0.5, 5), 0.0)
        if k0 == 0:
            r[:] = r[-1]
        y = np.cumsum(rng.normal(0, 0.05, n)) + np.where(np.arange(n) >= k0, r[-1], 0.0) * (
            1 - np.exp(-np.clip(t - t[k0], 0, None) / rng.uniform(0.1, 2)))
        new = response_metrics(t, y, r, np.zeros(n), step=True)
        old = _old_metrics(t, y, r)
        np.testing.assert_allclose([new.rise_time_s, new.settling_time_s, new.overshoot_pct], old,
                                   rtol=1e-12, atol=1e-12, equal_nan=True)
        compared += 1
    assert compared == 200


def test_never_reaching_ninety_percent_is_nan_not_an_error() -> None:
    t = np.linspace(0, 1, 200)
    r = np.ones_like(t)
    r[0] = 0.0
    y = 0.5 * (1 - np.exp(-t / 0.1))  # settles at half the reference
    m = response_metrics(t, y, r, np.zeros_like(t), step=True)
    assert math.isnan(m.rise_time_s) and math.isnan(m.settling_time_s) and m.overshoot_pct == 0.0
    assert m.steady_state_error_v == pytest.approx(0.5, abs=1e-3)


@pytest.mark.parametrize("top", [1e100, 1e200, 1.7e308])
def test_a_diverging_loops_metrics_are_its_values_not_an_overflow(top: float) -> None:
    # a sampled loop that diverges (a design the 1 ms controller cannot realise): its output grows past
    # 1e154, whose square overflowed ("RuntimeWarning: overflow encountered in square", an error where
    # warnings are errors); the RMS, the steady-state error and the overshoot are now its own values
    t = np.arange(8001) * 1e-3
    y = np.sin(40 * t) * np.exp(np.log(top) * t / t[-1])
    r = np.ones_like(t)
    r[0] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = response_metrics(t, y, r, y, step=True)
    # the same quantities computed on the output scaled down by 1/top, where nothing overflows
    small = y / top
    half = slice(t.size // 2, None)
    rms = float(np.sqrt(np.mean((r[half] / top - small[half]) ** 2))) * top
    tail = float(np.mean(small[-(t.size // 20):])) * top
    assert m.tracking_rms_v == pytest.approx(rms, rel=1e-12)
    assert m.steady_state_error_v == pytest.approx(1.0 - tail, rel=1e-12)
    assert m.overshoot_pct > 1e90 and math.isnan(m.settling_time_s)
