"""A step response shares the capture's read-only columns where its subtraction is by +0.0 (same bits)."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.capture import Capture, ChannelInfo
from motorid.conditioning.response import _minus, step_response


def _capture(t_step: float, u_rest: float) -> Capture:
    k = np.arange(2000)
    t = (k - 500) * 1e-3 + t_step
    u = np.where(k >= 500, 5.0, u_rest)
    rng = np.random.default_rng(5)
    y = np.where(k >= 500, 2.0 * -np.expm1(-(k - 500) * 1e-3 / 0.1), 0.0) + rng.normal(0, 0.01, k.size)
    return Capture(source="log.csv", format="plain-csv", time_s=t, output_v=y, output_info=ChannelInfo("velocity"),
                   input_v=u)


def test_a_step_at_zero_from_zero_volts_shares_time_and_input_with_the_capture():
    cap = _capture(0.0, 0.0)
    r = step_response(cap, "velocity")
    assert r.edge.time_s == 0.0
    assert r.time_s is cap.time_s and r.input_v is cap.input_v
    assert not np.shares_memory(r.output_v, cap.output_v)  # its baseline is the noise's mean
    for mine, col, base in ((r.time_s, cap.time_s, r.edge.time_s), (r.input_v, cap.input_v, 0.0)):
        assert mine.tobytes() == (col - base).tobytes()


def test_elsewhere_the_response_holds_its_own_differences():
    cap = _capture(1.5, 0.2)
    r = step_response(cap, "velocity")
    assert not np.shares_memory(r.time_s, cap.time_s) and not np.shares_memory(r.input_v, cap.input_v)
    np.testing.assert_array_equal(r.time_s, cap.time_s - r.edge.time_s)
    np.testing.assert_array_equal(r.input_v, cap.input_v - float(np.mean(cap.input_v[: r.edge.index])))


def test_minus_zero_shares_only_a_read_only_float_array_and_only_plus_zero():
    a = np.array([-0.0, 0.0, 1.5, np.inf])
    frozen = a.copy()
    frozen.setflags(write=False)
    assert _minus(frozen, 0.0) is frozen
    assert _minus(a, 0.0) is not a  # a writable array could change under the response
    signs = np.signbit(_minus(frozen, -0.0))
    assert _minus(frozen, -0.0) is not frozen and not signs[0]  # −0.0 − (−0.0) is +0.0
    np.testing.assert_array_equal(_minus(frozen, 2.0), a - 2.0)


def test_the_reduced_record_is_the_reduction_of_the_stacked_full_rate_record():
    """The pipeline reduces each channel on its own (no stack of the full-rate channels): the same array."""
    from motorid.conditioning.pipeline import ConditioningSettings, condition_experiment
    from motorid.conditioning.resample import sample_reduction

    cap = _capture(1.5, 0.2)
    for ratio in (1, 3, 7):
        cond = condition_experiment({"velocity": cap}, ConditioningSettings(ratio=ratio))
        want = sample_reduction(cond.full_time_s, np.vstack([cond.full_input_v, cond.full_outputs["velocity"]]),
                                ratio, "subsample")
        assert cond.ratio == ratio
        assert cond.time_s.tobytes() == want.time_s.tobytes()
        assert cond.input_v.tobytes() == want.values[0].tobytes()
        assert cond.outputs["velocity"].tobytes() == want.values[1].tobytes()


def test_a_responses_sample_interval_is_computed_once_and_travels_with_it():
    """The median of the steps is taken once per response (an identification asks for it over
    a hundred times); a replaced response with other times computes its own."""
    import dataclasses
    import pickle

    from motorid.conditioning.response import StepResponse

    t = np.arange(-5, 20) * 0.01
    r = StepResponse("f", "velocity", t, np.ones_like(t), np.ones_like(t), 1.0, None, 0, ())  # type: ignore[arg-type]
    assert r.sample_interval_s == pytest.approx(0.01)
    assert r._dt_cache == [r.sample_interval_s]
    assert pickle.loads(pickle.dumps(r)).sample_interval_s == r.sample_interval_s
    other = dataclasses.replace(r, time_s=t * 2)
    assert other.sample_interval_s == pytest.approx(0.02) and r.sample_interval_s == pytest.approx(0.01)
