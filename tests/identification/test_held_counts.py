"""A speed counted over several lines and logged on every line: each count is kept until the next.

A firmware that counts encoder edges over five 1 ms loops and logs every loop prints each count
five times (the pwm-encoder rig).  With ``--counted-velocity`` its samples were fitted as means
over one line ending at their own stamps: the count's window (five lines) and its hold (up to
four lines) were left in the motor's timing, and the residence time came out 6.7 % long against
an interval of ±0.45 % (seeds 0–3, every one missing the motor's own residence time).  Now the
window is the count's (five lines), it ends at the line that logged the count, and only those
lines are fitted.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from clihelpers import motorid_fresh

import motorid as mi
from motorid.capture import Capture, ChannelInfo
from motorid.conditioning.response import refresh_time, step_response
from motorid.model.uncertainty import ChannelTiming
from motorid.trainer.realsetups import write_real_setup
from motorid.trainer.sensors import encoder_velocity


@pytest.mark.parametrize("phase", [0, 1, 3, 4])
def test_the_lines_that_log_a_new_count_are_found_from_the_changes(phase):
    dt, every = 1e-3, 5
    t = np.arange(-20, 600) * dt
    angle = np.where(t > 0, 40.0 * (t - 0.05 * (1 - np.exp(-np.clip(t, 0, None) / 0.05))), 0.0)
    v = encoder_velocity(angle, dt, counts_per_rev=400, every=every, phase=phase)
    refresh = refresh_time(t, v, every)
    k = round((refresh - t[0]) / dt)
    assert k % every == phase % every
    # every value changes only on those lines
    changes = np.flatnonzero(np.diff(v) != 0) + 1
    assert changes.size > 20 and np.all(changes % every == phase % every)


def test_no_refresh_line_on_jittered_stamps_or_a_constant_record():
    t = np.cumsum(np.r_[0.0, np.full(99, 1e-3)]) + np.r_[0.0, np.full(99, 0.0)]
    t[50:] += 3e-4  # one uneven step
    assert np.isnan(refresh_time(t, np.arange(100.0) // 5, 5))
    assert np.isnan(refresh_time(np.arange(100) * 1e-3, np.zeros(100), 5))


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_a_held_count_gives_the_motors_timing_inside_its_interval(seed, tmp_path):
    """``motorid identify --counted-velocity`` on the pwm-encoder rig's log, in a fresh process."""
    rec = write_real_setup("pwm-encoder", tmp_path / "rig", seed=seed)
    out = tmp_path / "m.json"
    proc = motorid_fresh("identify", *rec.cli_args, "--counted-velocity", "--json", str(out), cwd=tmp_path)
    m = json.loads(out.read_text())
    motor = rec.truth.residence_time_s - rec.truth.sensor_lag_s  # the counting's (2·5 − 1)/2 ms taken off
    lo, hi = m["uncertainty"]["residence_time_s"]["ci95"]
    assert lo <= motor <= hi, (lo, hi, motor)
    value = m["uncertainty"]["residence_time_s"]["value"]
    assert value == pytest.approx(motor, rel=0.005)
    assert m["first_order"]["dc_gain"] == pytest.approx(rec.truth.dc_gain, rel=0.005)
    timing = m["timing"]["velocity"]
    assert timing["window_s"] == pytest.approx(0.005) and timing["count_hold"] == 5
    printed = " ".join(proc.stdout.split())
    assert "mean speed over the 5 ms before the line that logged it (each count kept for 5 lines" in printed
    assert "a read-off on the counted speed is about 4.5 ms later" in printed
    assert "sanity checks: all" in printed


def test_validate_scores_a_held_counts_means_over_the_windows_that_end_where_it_was_logged(tmp_path):
    rec = write_real_setup("pwm-encoder", tmp_path / "rig", seed=0)
    log = rec.cli_args[1]
    model = mi.identify(mi.read_experiment(velocity=log, counted_velocity=True)).model
    counted = mi.validate(model, log, counted_velocity=True)[0]
    sampled = mi.validate(model, log)[0]
    # the model's means over each count's window fit the log better than its samples, which lead
    # them by the count's 4.5 ms (before: the windows ended at every line's own stamp, 4.7 %)
    assert counted.nrmse < 0.9 * sampled.nrmse and counted.nrmse < 0.017
    assert any("each count kept for 5 lines" in n for n in counted.notes)
    assert not counted.warnings


def test_a_held_count_whose_lines_cannot_be_placed_says_so():
    # uneven stamps (one 0.3 % longer step): no fixed phase in time, so the windows end at every line
    dt, every = 1e-3, 5
    t = np.arange(-50, 600) * dt
    t[300:] += 3e-6
    angle = np.where(t > 0, 40.0 * (t - 0.05 * (1 - np.exp(-np.clip(t, 0, None) / 0.05))), 0.0)
    v = encoder_velocity(angle, dt, counts_per_rev=400, every=every, phase=2)
    cap = Capture("held.csv", "plain-csv", t - t[0], v, ChannelInfo("speed", "rad/s"), input_v=np.where(t >= 0, 6.0, 0.0),
                  input_info=ChannelInfo("voltage"), count_hold=every).counted()
    assert cap.sample_window_s == pytest.approx(every * dt)
    r = step_response(cap, "velocity")
    assert not r.count_held
    said = " ".join(r.warnings)
    assert "each count is kept for 5 lines, but the lines that logged them cannot be placed" in said
    assert "up to 4 ms quicker" in said


def test_a_count_hold_in_a_model_json_reads_back_and_a_malformed_one_reads_as_none():
    timing = ChannelTiming("its stamp", 1.0, kind="logged", window_s=0.005, count_hold=5)
    assert timing.to_dict()["count_hold"] == 5 and ChannelTiming.from_dict(timing.to_dict()) == timing
    assert timing.counting_lag_s == pytest.approx(0.0045)
    for bad in ("five", 1.5, True, 0, -3, None):
        assert ChannelTiming.from_dict({**timing.to_dict(), "count_hold": bad}).count_hold == 1
    assert "count_hold" not in ChannelTiming("its stamp", 1.0, window_s=0.001).to_dict()
