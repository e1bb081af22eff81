"""The step-response checks read a long record through views and one temporary: the values of the masks they replace."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.blockwise import max_abs
from motorid.conditioning import checks
from motorid.conditioning.response import split_at


def test_the_split_at_the_step_is_the_masks():
    rng = np.random.default_rng(0)
    t = np.sort(rng.uniform(-1.0, 3.0, 500))
    y = rng.normal(size=500)
    for t0 in (-2.0, -0.5, 0.0, float(t[17]), 3.5):
        pre, post = split_at(t, y, t0)
        assert np.array_equal(pre, y[t < t0]) and np.array_equal(post, y[t >= t0])
        assert np.shares_memory(post, y) or post.size == 0  # a view, not a copy


def test_the_one_temporary_helpers_are_the_formulas(monkeypatch):
    monkeypatch.setattr(checks, "BLOCK", 16)
    rng = np.random.default_rng(1)
    y = rng.normal(size=1001)
    y[[5, 700]] = y.max() + 1e-12  # near the extreme: inside a tolerance
    assert max_abs(y) == float(np.max(np.abs(y)))
    assert checks._abs_percentile(y, 0.3, 95) == float(np.percentile(np.abs(y - 0.3), 95))
    top = float(y.max())
    for tol in (0.0, 1e-9, 0.5):
        assert np.array_equal(checks._near(y, top, tol), np.abs(y - top) <= tol)
    assert max_abs(np.array([])) == 0.0


@pytest.mark.parametrize("values", [[0.0, 1.0, -3.0, 2.0], [0.0, 3.0, -3.0], [0.0, -3.0, 3.0], [2.0, 2.0], [1.0, -0.5]])
def test_the_peak_change_is_the_argmax_of_its_magnitude(values):
    y = np.array(values)
    for base in (0.0, 0.5, -1.0):
        change = y - base
        assert checks._peak_change(y, base) == float(change[np.argmax(np.abs(change))])


def test_the_checks_still_refuse_and_warn_on_their_cases():
    from motorid.capture import Capture, ChannelInfo
    from motorid.conditioning.response import step_response

    t = (np.arange(3000) - 500) * 1e-3
    u = np.where(t >= 0, 5.0, 0.0)
    flat = Capture(source="f.csv", format="plain-csv", time_s=t, output_v=np.full(t.size, 0.2),
                   output_info=ChannelInfo("velocity"), input_v=u)
    assert checks.stalled_response(step_response(flat, "velocity")) == "its output stays constant after the step"
    jump = Capture(source="j.csv", format="plain-csv", time_s=t, output_v=np.where(t >= 0, 2.0, 0.0),
                   output_info=ChannelInfo("velocity"), input_v=u)
    assert "within one sample" in checks.no_dynamics(step_response(jump, "velocity"))
    back = np.where(t >= 0, np.where(t < 1.5, -np.expm1(-t / 0.1), 0.0), 0.0)
    stop = Capture(source="b.csv", format="plain-csv", time_s=t, output_v=back, output_info=ChannelInfo("velocity"),
                   input_v=u)
    warning = checks.falls_back_to_rest(step_response(stop, "velocity"))
    assert warning is not None and "--record-length" in warning
    assert checks.falls_back_to_rest(step_response(stop, "velocity"), record_length_s=1.2) is None
