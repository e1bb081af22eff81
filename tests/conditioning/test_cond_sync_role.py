"""Synchronisation of separately triggered captures, role guessing and the pipeline checks."""

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


@pytest.mark.parametrize("role", ["velocity", "position", "current"])
def test_guess_role_from_the_signal(role):
    cap, _ = capture(role, 400)
    assert guess_role(cap).role == role


def test_pipeline_refuses_captures_of_different_step_levels():
    cv, _ = capture("velocity", 300, level=5.92, name="ALL0001")
    cp, _ = capture("position", 400, level=4.0, name="ALL0000")
    with pytest.raises(ConditioningError, match="ALL0001.*5.92.*ALL0000.*4 V|ALL0000.*ALL0001"):
        condition_experiment({"velocity": cv, "position": cp})


def test_pipeline_reduces_to_the_paper_interval():
    cv, _ = capture("velocity", 300)
    cp, _ = capture("position", 500)
    exp = condition_experiment({"velocity": cv, "position": cp}, ConditioningSettings(record_length_s=2.4))
    assert exp.ratio == 25 and exp.sample_interval_s == pytest.approx(0.1)
    assert exp.time_s.size == 25  # 0 … 2.4 s at 0.1 s
    assert exp.step_volts == pytest.approx(5.92)
