"""Property tests: random valid captures survive write → read in every writable format."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motorid.capture import Capture, ChannelInfo, ScopeInfo
from motorid.io import read_capture, read_tds_channel, write_openchoice_xlsx, write_tds_capture, write_tds_channel

_SETTINGS = settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

# The TDS1000/2000 vertical scales (1-2-5 steps, 2 mV/div … 5 V/div) times the probe factors.
_SCALES = [m * 10.0**k for k in range(-3, 1) for m in (1, 2, 5) if 2e-3 <= m * 10.0**k <= 5]
_TEXT = st.text(alphabet="ABCDEFGHJKLMNPRSTUVWXYZ0123456789:.v-", min_size=1, max_size=10)


@st.composite
def scope_captures(draw, with_input: bool = True) -> Capture:
    """A capture as a TDS scope records it: uniform time with t = 0 at the trigger index,
    8-bit samples (-128…127 levels of V/div / 25 around the screen centre)."""
    n = draw(st.integers(18, 400))
    dt = draw(st.sampled_from([1, 2, 4, 5])) * 10.0 ** draw(st.integers(-7, -2))
    trig = draw(st.integers(0, n - 1))
    t = (np.arange(n) - trig) * dt

    def channel(name: str) -> tuple[np.ndarray, ChannelInfo]:
        scale = draw(st.sampled_from(_SCALES)) * draw(st.sampled_from([1.0, 10.0]))
        lsb = scale / 25
        offset = draw(st.integers(-100, 100)) * lsb
        levels = np.array(draw(st.lists(st.integers(-128, 127), min_size=n, max_size=n)), dtype=float)
        info = ChannelInfo(name, "V", scale, offset, draw(st.sampled_from([1.0, 10.0])), 0.0)
        return levels * lsb - offset, info

    y, yi = channel("CH2")
    u, ui = channel("CH1") if with_input else (None, None)
    scope = ScopeInfo(draw(_TEXT), draw(_TEXT), draw(_TEXT), n, 250 * dt, trig)
    return Capture("<hyp>", "trainer", t, y, yi, u, ui, scope)


def _assert_same_levels(got: np.ndarray, want: np.ndarray, info: ChannelInfo) -> None:
    # The writers promise every 8-bit level back, to within 1/100 LSB.
    assert np.max(np.abs(got - want)) <= info.lsb / 100
    np.testing.assert_array_equal(np.round((got - want) / info.lsb), 0)


def _same_meta(a, b) -> bool:
    """Metadata equal, numbers to the 7 significant digits the scope's ``%e`` fields keep."""
    for name in a.__slots__:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, float) and isinstance(y, float):
            if abs(x - y) > 1e-6 * max(abs(x), abs(y)):
                return False
        elif x != y:
            return False
    return True


def _assert_same_time(got: np.ndarray, want: np.ndarray, dt: float) -> None:
    # Times are written with >= 12 decimals and at most 1e-4 sample of rounding.
    assert np.max(np.abs(got - want)) <= max(0.5e-12, 1e-4 * dt) + 1e-15


@_SETTINGS
@given(cap=scope_captures(with_input=False))
def test_tds_single_channel_round_trip(tmp_path, cap):
    f = write_tds_channel(tmp_path / "F0000CH2.CSV", cap.time_s, cap.output_v, cap.output_info, cap.scope, force=True)
    ch = read_tds_channel(f)
    _assert_same_time(ch.time_s, cap.time_s, cap.sample_interval_s)
    _assert_same_levels(ch.values_v, cap.output_v, cap.output_info)
    assert _same_meta(ch.channel, cap.output_info) and _same_meta(ch.scope, cap.scope)


@_SETTINGS
@given(cap=scope_captures(), index=st.integers(0, 9999))
def test_tds_all_folder_round_trip(tmp_path, cap, index):
    folder = write_tds_capture(tmp_path, cap, index=index, force=True)
    back = read_capture(folder)
    _assert_same_time(back.time_s, cap.time_s, cap.sample_interval_s)
    _assert_same_levels(back.input_v, cap.input_v, cap.input_info)
    _assert_same_levels(back.output_v, cap.output_v, cap.output_info)
    assert _same_meta(back.input_info, cap.input_info) and _same_meta(back.output_info, cap.output_info)
    assert _same_meta(back.scope, cap.scope)
    pair = read_capture([folder / f"F{index:04d}CH2.CSV", folder / f"F{index:04d}CH1.CSV"])
    np.testing.assert_array_equal(pair.input_v, back.input_v)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cap=scope_captures())
def test_xlsx_round_trip(tmp_path, cap):
    back = read_capture(write_openchoice_xlsx(tmp_path / "c.xlsx", cap, force=True))
    # .xlsx keeps 16 significant digits (Excel's own precision)
    np.testing.assert_allclose(back.time_s, cap.time_s, rtol=1e-14, atol=1e-300)
    np.testing.assert_allclose(back.input_v, cap.input_v, rtol=1e-14, atol=1e-300)
    np.testing.assert_allclose(back.output_v, cap.output_v, rtol=1e-14, atol=1e-300)
    assert _same_meta(back.input_info, cap.input_info) and _same_meta(back.output_info, cap.output_info)
    assert _same_meta(back.scope, cap.scope)
