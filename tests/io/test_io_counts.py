"""A logged speed that comes in whole encoder counts: the step is read off the raw column.

The counts are simulated independently here (a first-order motor's angle, floored to encoder
edges), printed as the sketches print them, and read back through the plain-CSV reader.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import motorid as mi
from motorid.io._counts import count_hold, count_lattice, print_resolution


def count_step(time_s: np.ndarray, values: np.ndarray) -> float:
    return count_lattice(time_s, values).step


def _angle(t: np.ndarray, t_step: float, speed: float = 120.0, tau: float = 0.08) -> np.ndarray:
    """A first-order motor's angle (rad) after a step at ``t_step`` to ``speed`` rad/s."""
    s = np.clip(t - t_step, 0.0, None)
    return speed * (s - tau * (1.0 - np.exp(-s / tau)))


def _counted_rpm(t: np.ndarray, counts_per_turn: int, nominal_dt: float | None, rng: np.random.Generator
                 ) -> np.ndarray:
    """rpm from the edges counted since the last line, over the nominal loop time or the stamped interval."""
    counts = np.floor(_angle(t, t[40]) / (2 * math.pi) * counts_per_turn + rng.uniform())
    per = np.full(t.size - 1, nominal_dt) if nominal_dt is not None else np.diff(t)
    return np.r_[0.0, np.diff(counts) / per] / counts_per_turn * 60.0


@pytest.mark.parametrize("decimals", [1, 2, 3])
def test_a_speed_counted_over_a_steady_loop_comes_in_one_counts_step(decimals):
    rng = np.random.default_rng(decimals)
    t = np.arange(300) * 0.01
    rpm = np.round(_counted_rpm(t, 700, 0.01, rng), decimals)
    step, over_stamps, _ = count_lattice(t, rpm)
    assert step == pytest.approx(60.0 / (700 * 0.01), rel=1e-4)
    assert not over_stamps  # a grid of values: an ADC's codes would look alike


def test_a_loop_that_divides_by_its_own_jittered_interval_counts_over_its_stamps():
    """A Raspberry Pi loop: the rpm is the count over the interval its clock measured (20 ± 1.5 ms)."""
    rng = np.random.default_rng(4)
    t = np.round(np.r_[0.0, np.cumsum(0.02 + rng.normal(0, 0.0015, 259))], 6)
    rpm = np.round(_counted_rpm(t, 960, None, rng), 2)
    step = 60.0 / 960 / float(np.median(np.diff(t)))
    assert count_step(t, rpm) == pytest.approx(step, rel=1e-3)
    assert count_lattice(t, rpm)[1]  # on its stamps, not on a grid of values: a count, not a sample
    # its values themselves are on no grid: divided by the nominal 20 ms the counts would be
    assert count_step(np.arange(t.size) * 0.02, rpm) == 0.0


def test_a_sampled_speed_does_not_come_in_counts():
    rng = np.random.default_rng(5)
    t = np.arange(400) * 0.01
    omega = np.gradient(_angle(t, t[40]), t)
    for printed in (np.round(omega * 9.549 + rng.normal(0, 0.8, t.size), 1),   # a tacho printed as rpm
                    (omega * 9.549 + rng.normal(0, 0.8, t.size)).astype(np.float32).astype(float),  # float32
                    np.round(omega + rng.normal(0, 0.01, t.size), 5)):          # volts, five decimals
        assert count_step(t, printed) == 0.0
    assert count_step(t[:10], np.arange(10.0)) == 0.0  # too few values to tell


def test_print_resolution_reads_the_printed_decimals():
    assert print_resolution(np.array([0.0, 1.5, 2.25])) == pytest.approx(0.01)
    assert print_resolution(np.array([3.0, 4.0])) == 1.0
    assert print_resolution(np.array([1 / 3])) == 0.0


@settings(max_examples=40, deadline=None)
@given(cpr=st.integers(100, 4000), dt_ms=st.sampled_from([5, 10, 20]), seed=st.integers(0, 10**6))
@example(cpr=1200, dt_ms=5, seed=0)
def test_the_counts_step_is_found_for_any_encoder_and_loop(cpr, dt_ms, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(300) * dt_ms * 1e-3
    rpm = np.round(_counted_rpm(t, cpr, dt_ms * 1e-3, rng), 3)
    step = count_step(t, rpm)
    expected = 60.0 / (cpr * dt_ms * 1e-3)
    if step:
        # the largest step the values are multiples of: the count's, or (if every value happens to be even) twice it
        assert step / expected == pytest.approx(round(step / expected), rel=1e-3) and step >= expected * 0.999
    # found unless it is too fine beside the print (printed to 0.001; whole numbers show no decimals at all:
    # 1200 counts at 5 ms are steps of exactly 10 rpm, printed as whole numbers, at the bound, not above it)
    assert step or expected <= 10 * print_resolution(rpm) * (1 + 1e-9)


def test_the_reader_keeps_the_step_of_the_raw_column(tmp_path):
    """Read off the column as logged, before ``millis()`` stamps (10/11 ms) are resampled."""
    rng = np.random.default_rng(6)
    true_t = 2.0 + np.arange(300) * 0.01024
    rpm = np.round(_counted_rpm(true_t, 1200, 0.01024, rng), 1)
    path = tmp_path / "sketch.csv"
    path.write_text("millis,u_V,rpm\n" + "\n".join(
        f"{math.floor(a * 1e3)},{6.0 if i >= 40 else 0.0:.1f},{r:.1f}" for i, (a, r) in enumerate(zip(true_t, rpm, strict=True)))
        + "\n")
    cap = mi.read_experiment(velocity=path).captures["velocity"]
    assert cap.count_step == pytest.approx(60.0 / (1200 * 0.01024), rel=1e-3)
    assert count_step(cap.time_s, cap.output_v) == 0.0  # the resampled column has lost it


def test_a_speed_counted_over_its_own_stamped_intervals_is_read_as_counted(tmp_path):
    """A Raspberry Pi loop's log (clock stamps, rpm = counts over the interval its clock measured): no
    sampled reading makes its values times their intervals whole counts, so it is read as counted
    without ``counted_velocity``; a steady loop's grid of values is not (an ADC's codes look alike)."""
    rng = np.random.default_rng(7)
    t = np.round(np.r_[0.0, np.cumsum(0.02 + rng.normal(0, 0.0015, 259))], 6)
    rpm = np.round(_counted_rpm(t, 960, None, rng), 2)
    path = tmp_path / "pi.csv"
    path.write_text("time_s,u_V,rpm\n" + "\n".join(
        f"{a:.6f},{9.0 if i >= 40 else 0.0:.1f},{r:.2f}" for i, (a, r) in enumerate(zip(t, rpm, strict=True))) + "\n")
    cap = mi.read_experiment(velocity=path).captures["velocity"]
    assert cap.count_over_stamps and cap.sample_window_s == pytest.approx(float(np.median(np.diff(t))), rel=0.05)
    # the reader reads it so, for every path that reads captures (a report's validation captures, the
    # several-levels path), unless the column is declared another role
    from motorid.io import read_capture

    assert read_capture(str(path)).sample_window_s == cap.sample_window_s
    as_position = read_capture(str(path), role="position")
    assert as_position.count_over_stamps and as_position.sample_window_s == 0.0
    steady = tmp_path / "steady.csv"
    ts = np.arange(300) * 0.01
    steady.write_text("time_s,u_V,rpm\n" + "\n".join(
        f"{a:.2f},{6.0 if i >= 40 else 0.0:.1f},{r:.1f}"
        for i, (a, r) in enumerate(zip(ts, np.round(_counted_rpm(ts, 700, 0.01, rng), 1), strict=True))) + "\n")
    cap = mi.read_experiment(velocity=steady).captures["velocity"]
    assert cap.count_step > 0 and not cap.count_over_stamps and cap.sample_window_s == 0.0


@settings(max_examples=300, deadline=None)
@given(v=st.lists(st.floats(-1e15, 1e15, allow_nan=False), min_size=2, max_size=80), dt=st.floats(1e-6, 10.0))
def test_any_column_gives_a_finite_step_and_no_warning(v, dt):
    """Whatever a log holds (the reader's own limits: finite, |x| ≤ 1e15), the search ends in a
    finite step or none, with no overflow (a smallest value of 3e-288 beside 6e-8 squared a count of
    1e280; a step finer than a millionth of the largest value is not looked for)."""
    import warnings

    values = np.asarray(v)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        step = count_lattice(np.arange(values.size) * dt, values).step
    assert np.isfinite(step) and step >= 0


def test_a_long_log_whose_motion_starts_late_is_looked_at_all_along():
    """300 000 lines at rest before a step: the pairs of lines looked at are spread over the whole log."""
    rng = np.random.default_rng(8)
    t = np.arange(300_300) * 0.01
    moving = _counted_rpm(t[-300:] - t[-300], 700, 0.01, rng)
    rpm = np.r_[np.zeros(300_000), np.round(moving, 1)]
    assert count_step(t, rpm) == pytest.approx(60.0 / (700 * 0.01), rel=1e-4)


def test_a_count_over_several_lines_held_between_is_told_by_its_runs():
    """A firmware that counts over five 1 ms loops and logs every loop prints each count five times."""
    rng = np.random.default_rng(9)
    t = np.arange(1500) * 0.001
    counts = np.floor(_angle(t, t[300]) / (2 * math.pi) * 1632 + rng.uniform())
    every = np.arange(t.size) // 5 * 5
    per5 = np.r_[np.zeros(5), np.diff(counts[::5])][np.arange(t.size) // 5]  # counted over the last five loops
    omega = np.round(per5 / 1632 * 2 * math.pi / 0.005, 4)
    assert every.size == omega.size
    found = count_lattice(t, omega)
    assert found.hold == 5 and found.step == pytest.approx(2 * math.pi / (1632 * 0.005), rel=1e-4)
    assert count_hold(np.round(_counted_rpm(t, 700, 0.001, rng), 1)) == 1  # counted over each line
    assert count_hold(np.zeros(50)) == 1

