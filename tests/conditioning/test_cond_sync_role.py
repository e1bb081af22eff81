"""Synchronisation of separately triggered captures, role guessing and the pipeline checks."""

import re
from dataclasses import replace

import numpy as np
import pytest

from motorid.capture import Capture, ChannelInfo
from motorid.conditioning.pipeline import ConditioningSettings, condition_experiment
from motorid.conditioning.response import step_response
from motorid.conditioning.role import classify_response, guess_role
from motorid.conditioning.sync import synchronise
from motorid.errors import ConditioningError

DT = 0.004


def capture(role, k_step, level=5.92, name=None, phase=0.0):
    """A capture triggered so that the step is at sample k_step (own time axis)."""
    n = 2500
    t = (np.arange(n) - 250) * DT
    ts = (k_step - 250) * DT - phase  # true step time on this file's axis
    tt = np.clip(t - ts, 0, None)
    if role == "velocity":
        y = 0.905 * level * (1 - np.exp(-tt / 0.43))
    elif role == "position":
        y = 0.905 * level * (tt - 0.43 * (1 - np.exp(-tt / 0.43)))
    else:
        y = 0.3 * level * np.exp(-tt / 0.43) * (tt > 0) + 0.05 * level * (tt > 0)
    u = np.where(t >= ts, level, 0.0)
    return Capture(
        source=name or f"{role}.csv", format="plain-csv", time_s=t, output_v=y,
        output_info=ChannelInfo("CH2"), input_v=u, input_info=ChannelInfo("CH1"),
    ), ts


def test_synchronise_aligns_different_trigger_offsets():
    (cv, _), (cp, _) = capture("velocity", 300), capture("position", 611)
    rv, rp = step_response(cv, "velocity"), step_response(cp, "position")
    s = synchronise([rv, rp], length_s=2.9)
    assert s.time_s[0] == 0 and s.time_s[-1] == pytest.approx(2.9, abs=DT)
    tt = s.time_s
    np.testing.assert_allclose(s.outputs["velocity"], 0.905 * 5.92 * (1 - np.exp(-tt / 0.43)), atol=1e-9)
    s_idx = synchronise([rv, rp], length_s=2.9, method="index")
    np.testing.assert_allclose(s_idx.outputs["velocity"], s.outputs["velocity"], atol=1e-9)
    with pytest.raises(ConditioningError, match="longer than"):
        synchronise([rv, rp], length_s=100.0)


def test_classify_analytic_responses():
    t = np.arange(600) * DT
    assert classify_response(1 - np.exp(-t / 0.4)).role == "velocity"
    assert classify_response(t - 0.4 * (1 - np.exp(-t / 0.4))).role == "position"
    assert classify_response(3 * np.exp(-t / 0.4) + 0.5).role == "current"


def test_a_transient_that_falls_back_to_zero_says_so_without_an_absurd_ratio():
    """A spike that returns to its pre-step level (a Tek sample's encoder pulse) was described as
    "peaks at 1000000000.0× its final value"."""
    t = np.linspace(0, 2, 500)
    g = classify_response(np.exp(-t / 0.05) - np.exp(-t / 0.01))
    assert g.role == "current" and "×" not in g.reason and "falls back to" in g.reason and "% of its peak" in g.reason
    assert re.fullmatch(r"peaks at [0-9.]+× its final value and falls back",
                        classify_response(3 * np.exp(-t / 0.4) + 0.5).reason)
    assert "past its pre-step level" in classify_response(np.exp(-t / 0.05) - 1.1 * np.exp(-t / 0.01) - 0.05).reason


@pytest.mark.parametrize("role", ["velocity", "position", "current"])
def test_guess_role_from_the_signal(role):
    cap, _ = capture(role, 400)
    assert guess_role(cap).role == role


def test_pipeline_refuses_captures_of_different_step_levels():
    cv, _ = capture("velocity", 300, level=5.92, name="ALL0001")
    cp, _ = capture("position", 400, level=4.0, name="ALL0000")
    with pytest.raises(ConditioningError, match=r"ALL0001.*5\.92.*ALL0000.*4 V|ALL0000.*ALL0001"):
        condition_experiment({"velocity": cv, "position": cp})


def test_pipeline_reduces_to_the_paper_interval():
    cv, _ = capture("velocity", 300)
    cp, _ = capture("position", 500)
    exp = condition_experiment({"velocity": cv, "position": cp}, ConditioningSettings(record_length_s=2.4, sample_interval_s=0.1))
    assert exp.ratio == 25 and exp.sample_interval_s == pytest.approx(0.1)
    assert exp.time_s.size == 25  # 0 … 2.4 s at 0.1 s
    assert exp.step_volts == pytest.approx(5.92)


# --- role_conflict: the check behind --position/--velocity/--current ---------------------------

ROLES3 = ("position", "velocity", "current")


@pytest.mark.parametrize("preset", ["paper", "lab-report", "first-order", "second-order", "third-order"])
def test_role_conflict_never_fires_on_the_trainer_and_always_on_a_wrong_slot(preset):
    from motorid.conditioning.role import role_conflict
    from motorid.trainer import run_experiment

    for seed in (0, 1):
        caps = run_experiment(preset, seed=seed).captures
        for role, cap in caps.items():
            assert role_conflict(cap, role) is None, (preset, seed, role)
            for other in ROLES3:
                if other != role:
                    looks = role_conflict(cap, other)
                    assert looks is not None and looks.role == role, (preset, seed, role, other, looks)


def test_role_conflict_on_the_written_demo_folders(tmp_path):
    from motorid.conditioning.role import role_conflict
    from motorid.io import read_capture, write_tds_capture
    from motorid.trainer import run_experiment

    exp = run_experiment("paper", seed=0)
    for i, role in enumerate(ROLES3):  # the demo's layout: ALL0000 position, ALL0001 velocity, ALL0002 current
        folder = write_tds_capture(tmp_path, exp.captures[role], index=i)
        assert role_conflict(read_capture(folder, role=role), role) is None
        swapped = ROLES3[(i + 1) % 3]
        assert role_conflict(read_capture(folder, role=swapped), swapped).role == role


def test_role_conflict_real_speed_log_from_a_running_operating_point(real_dir):
    from motorid.conditioning.role import role_conflict
    from motorid.io import read_capture

    files = sorted((real_dir / "hslu-rtl-dcmotor" / "csv").glob("06_*.csv"))
    assert files
    for f in files:
        assert role_conflict(read_capture(f, role="velocity"), "velocity") is None
        # the signal alone (label hidden) says velocity too: 5 -> 15 V, 35 ms dead time
        cap = read_capture(f, role="velocity")
        bare = replace(cap, role_hint=None, output_info=replace(cap.output_info, name="CH2"))
        assert guess_role(bare).role == "velocity"
        assert role_conflict(bare, "position").role == "velocity"
        # given as --position, the file's own column (position_raw) is picked: no conflict
        assert role_conflict(read_capture(f, role="position"), "position") is None


def test_role_conflict_uses_the_column_label():
    from motorid.conditioning.role import role_conflict

    cap, _ = capture("velocity", 400)
    labelled = replace(cap, output_info=ChannelInfo("position_raw"))
    looks = role_conflict(labelled, "velocity")
    assert looks.role == "position" and "position_raw" in looks.reason
    assert role_conflict(labelled, "position") is None


def test_unknown_or_unsure_guesses_never_conflict():
    from motorid.conditioning.role import role_conflict

    t = (np.arange(2500) - 250) * DT
    flat = Capture(source="flat.csv", format="plain-csv", time_s=t, output_v=np.zeros_like(t),
                   output_info=ChannelInfo("CH2"))
    for role in ROLES3:
        assert role_conflict(flat, role) is None
    # a position ramping at a constant rate into a stop: settles, but not like a velocity
    y = np.clip(t - 0.2, 0, 3.0)
    stop = Capture(source="stop.csv", format="plain-csv", time_s=t, output_v=y, output_info=ChannelInfo("CH2"),
                   input_v=np.where(t >= 0.2, 5.0, 0.0), input_info=ChannelInfo("CH1"))
    assert guess_role(stop).role == "velocity" and not guess_role(stop).confident
    assert role_conflict(stop, "position") is None


def test_a_velocity_cut_before_it_settles_is_not_called_a_position():
    t = np.arange(300) * DT
    # one time constant of a first-order rise: still rising, but slowing down
    assert classify_response(1 - np.exp(-t / (t[-1]))).role != "position"
    # an integrator past its transient keeps its rate
    assert classify_response(t - 0.2 * (1 - np.exp(-t / 0.2))).role == "position"
