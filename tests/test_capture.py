"""The Capture type: the constructor copies its arrays, ``Capture.adopt`` takes them over."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.capture import Capture, ChannelInfo
from motorid.errors import CaptureDataError


def _columns(n: int = 50) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(n) * 1e-3
    return t, np.where(t >= 0.01, 5.0, 0.0), np.sin(t)


def test_the_constructor_copies_and_a_callers_array_stays_its_own():
    t, u, y = _columns()
    cap = Capture(source="x.csv", format="plain-csv", time_s=t, output_v=y, output_info=ChannelInfo("y"), input_v=u)
    assert not np.shares_memory(cap.time_s, t) and not np.shares_memory(cap.output_v, y)
    assert t.flags.writeable and y.flags.writeable  # the caller's arrays are untouched
    y[0] = 99.0
    assert cap.output_v[0] == 0.0


def test_adopt_takes_the_arrays_over_read_only_and_equals_the_copying_constructor():
    t, u, y = _columns()
    extra = np.cos(t)
    kw = dict(source="x.csv", format="plain-csv", output_info=ChannelInfo("y"), role_hint="velocity",
              warnings=["a note"])
    copied = Capture(time_s=t, output_v=y, input_v=u, extra={"position": extra}, **kw)
    cap = Capture.adopt(time_s=t, output_v=y, input_v=u, extra={"position": extra}, **kw)
    for mine, given in ((cap.time_s, t), (cap.output_v, y), (cap.input_v, u), (cap.extra["position"], extra)):
        assert mine is given and not mine.flags.writeable
    for name in ("time_s", "output_v", "input_v"):
        np.testing.assert_array_equal(getattr(cap, name), getattr(copied, name))
    assert cap.warnings == ("a note",) and cap.scope == copied.scope and cap.input_info is None
    with pytest.raises(TypeError):
        cap.extra["x"] = t  # type: ignore[index]  # a read-only mapping, as the constructor's


def test_adopt_converts_what_is_not_a_contiguous_float_array():
    table = np.arange(30, dtype=float).reshape(10, 3)
    ints = np.arange(10)
    cap = Capture.adopt(source="x", format="plain-csv", time_s=ints, output_v=table[:, 1],
                        output_info=ChannelInfo("y"))
    assert cap.time_s.dtype == np.float64 and cap.output_v.flags.c_contiguous
    assert not np.shares_memory(cap.output_v, table) and table.flags.writeable
    np.testing.assert_array_equal(cap.output_v, table[:, 1])


def test_adopt_checks_as_the_constructor_does():
    t, _, y = _columns()
    with pytest.raises(CaptureDataError, match="different lengths"):
        Capture.adopt(source="x", format="plain-csv", time_s=t, output_v=y[:-1], output_info=ChannelInfo("y"))
    with pytest.raises(TypeError, match="output_info"):
        Capture.adopt(source="x", format="plain-csv", time_s=t, output_v=y)
    with pytest.raises(TypeError, match="unexpected"):
        Capture.adopt(source="x", format="plain-csv", time_s=t, output_v=y, output_info=ChannelInfo("y"), colour=1)
