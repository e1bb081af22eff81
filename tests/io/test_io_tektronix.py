"""Tektronix TDS1000/2000 CSV reader and writer: real files, variants, pairs, folders, errors."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from iohelpers import TDS2012B, TDS2014C, TDS2024B, native_lines, need, step_capture, write_lines
from motorid.capture import ChannelInfo, ScopeInfo
from motorid.errors import CaptureDataError, CaptureFormatError, MotorIdError, OptionError, OutputExistsError
from motorid.io import read_capture, read_tds_capture, read_tds_channel, write_tds_capture, write_tds_channel


def _independent_columns(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Columns D and E parsed by the csv module, independently of the reader under test."""
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return np.array([float(r[3]) for r in rows]), np.array([float(r[4]) for r in rows])


REAL_CASES = [
    # file, sample interval, trigger point, model, probe atten, V/div, vertical offset
    (TDS2012B, 2e-5, 1250, "TDS2012B", 10.0, 0.5, 0.0),
    (TDS2014C, 4e-5, 1250, "TDS2014C", 1.0, 2.0, -0.72),
    (TDS2024B, 4e-5, 760, "TDS2024B", 1.0, 0.1, 0.0),
]


@pytest.mark.parametrize("path, dt, trig, model, atten, scale, offset", REAL_CASES, ids=["2012B", "2014C", "2024B"])
def test_real_samples_read_with_all_metadata(path, dt, trig, model, atten, scale, offset):
    ch = read_tds_channel(need(path))
    assert ch.n_samples == 2500
    assert ch.sample_interval_s == dt
    # the time column itself must step by the Sample Interval (uniform to float rounding)
    assert np.allclose(np.diff(ch.time_s), dt, rtol=1e-6, atol=0)
    assert ch.scope.trigger_index == trig
    assert ch.scope.record_length == 2500
    assert ch.scope.model == model
    assert ch.channel.probe_atten == atten
    assert ch.channel.vertical_scale == scale
    assert ch.channel.vertical_offset == offset
    assert ch.channel.name == "CH1" and ch.channel.units == "V"
    # Trigger Point is the sample index of t = 0: within half a sample of zero
    assert abs(ch.time_s[trig]) < dt / 2
    t_ref, v_ref = _independent_columns(path)
    np.testing.assert_array_equal(ch.time_s, t_ref)
    np.testing.assert_array_equal(ch.values_v, v_ref)
    cap = read_tds_capture(path)
    assert cap.format == "tds2000-csv" and cap.input_v is None
    assert cap.scope.trigger_index == trig and cap.output_info.probe_atten == atten


def test_real_serial_and_firmware():
    ch = read_tds_channel(need(TDS2012B))
    assert (ch.scope.serial, ch.scope.firmware, ch.scope.horizontal_scale_s) == ("C065333", "FV:v22.16", 5e-3)
    assert ch.channel.yzero == 0.0


def test_native_values_lie_on_the_8bit_grid():
    # Vertical Scale / 25 is the LSB: every native value is an integer number of levels.
    for path in (TDS2012B, TDS2014C):
        ch = read_tds_channel(need(path))
        levels = ch.values_v / ch.channel.lsb
        assert np.max(np.abs(levels - np.round(levels))) < 1e-6


def test_excel_resaved_variant_warns():
    ch = read_tds_channel(need(TDS2024B))
    assert any("re-saved by a spreadsheet" in w for w in ch.warnings)
    assert not read_tds_channel(need(TDS2012B)).warnings


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_line_endings_and_trailing_blank_line(tmp_path, newline):
    lines = native_lines(need(TDS2012B))
    f = write_lines(tmp_path / "F0000CH1.CSV", [*lines, ""], newline)
    a, b = read_tds_channel(f), read_tds_channel(TDS2012B)
    np.testing.assert_array_equal(a.values_v, b.values_v)
    np.testing.assert_array_equal(a.time_s, b.time_s)


def test_user_header_row_is_skipped_and_rows_still_exact(tmp_path):
    lines = ["a,b,c,x,y,d", *native_lines(need(TDS2012B))]
    ch = read_tds_channel(write_lines(tmp_path / "h.csv", lines))
    assert ch.n_samples == 2500 and ch.scope.trigger_index == 1250
    # the 500th sample sits on file line 501 now; a bad cell there must be reported at 501
    lines[500] = lines[500].replace("-00.", "x-00.", 1)
    with pytest.raises(CaptureFormatError) as err:
        read_tds_channel(write_lines(tmp_path / "h.csv", lines))
    assert err.value.row == 501 and "h.csv:501" in str(err.value)


def test_semicolon_decimal_comma_resave(tmp_path):
    lines = [ln.rstrip(",").replace(",", ";").replace(".", ",") for ln in native_lines(need(TDS2012B))]
    ch = read_tds_channel(write_lines(tmp_path / "eu.csv", lines))
    np.testing.assert_allclose(ch.values_v, read_tds_channel(TDS2012B).values_v, rtol=0, atol=1e-12)
    assert ch.channel.vertical_scale == 0.5


def test_writer_reproduces_native_files_byte_for_byte(tmp_path):
    # Reading a native file and writing it back must give the scope's own bytes: metadata
    # formats, space- then zero-padded times, %10.5f values, trailing comma.
    for path in (TDS2012B, TDS2014C):
        ch = read_tds_channel(need(path))
        out = write_tds_channel(tmp_path / path.name, ch.time_s, ch.values_v, ch.channel, ch.scope)
        assert out.read_bytes() == path.read_bytes()


def test_writer_uses_more_decimals_when_the_lsb_needs_them(tmp_path):
    t = np.arange(100) * 1e-3
    lsb = 2e-3 / 25  # 2 mV/div: LSB 80 µV, below the scope's 5 decimals' 10 µV rounding step
    v = np.round(np.sin(t * 40) * 100) * lsb
    info = ChannelInfo("CH1", "V", 2e-3, 0.0, 1.0, 0.0)
    f = write_tds_channel(tmp_path / "mv.csv", t, v, info, ScopeInfo())
    back = read_tds_channel(f).values_v
    assert np.max(np.abs(back - v)) <= lsb / 100  # the writer's promise: 1/100 LSB
    np.testing.assert_array_equal(np.round(back / lsb), np.round(v / lsb))


def test_overwrite_is_refused_without_force(tmp_path):
    cap = step_capture(n=100)
    f = tmp_path / "F0000CH1.CSV"
    write_tds_channel(f, cap.time_s, cap.output_v, cap.output_info, cap.scope)
    with pytest.raises(OutputExistsError, match="use force=True") as err:
        write_tds_channel(f, cap.time_s, cap.output_v, cap.output_info, cap.scope)
    assert str(f) in str(err.value)
    write_tds_channel(f, cap.time_s, cap.output_v, cap.output_info, cap.scope, force=True)
    folder = write_tds_capture(tmp_path, cap)
    ch1 = folder / "F0000CH1.CSV"
    ch1.unlink()  # one of the two exists: nothing may be written
    with pytest.raises(OutputExistsError, match=r"F0000CH2\.CSV"):
        write_tds_capture(tmp_path, cap)
    assert not ch1.exists()
    write_tds_capture(tmp_path, cap, force=True)
    assert ch1.exists()


# ----------------------------------------------------------------------------- pairs, folders


def test_all_folder_round_trip(tmp_path):
    cap = step_capture()
    folder = write_tds_capture(tmp_path, cap, index=7)
    assert folder.name == "ALL0007"
    assert sorted(p.name for p in folder.iterdir()) == ["F0007CH1.CSV", "F0007CH2.CSV"]
    back = read_tds_capture(folder)
    np.testing.assert_allclose(back.time_s, cap.time_s, rtol=0, atol=1e-12)  # 12 decimals
    # values on the 8-bit grid come back as the same levels, to far below one LSB
    for got, want, info in ((back.input_v, cap.input_v, cap.input_info), (back.output_v, cap.output_v, cap.output_info)):
        np.testing.assert_array_equal(np.round(got / info.lsb), np.round(want / info.lsb))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert back.input_info == cap.input_info and back.output_info == cap.output_info
    assert back.scope == cap.scope
    assert back.source == str(folder)


def test_pair_order_from_source_field_then_file_name(tmp_path):
    cap = step_capture(n=200)
    folder = write_tds_capture(tmp_path, cap)
    ch1, ch2 = folder / "F0000CH1.CSV", folder / "F0000CH2.CSV"
    back = read_tds_capture([ch2, ch1])  # given in the wrong order
    np.testing.assert_array_equal(back.input_v, cap.input_v)
    # Source fields blanked: the file names decide
    for f in (ch1, ch2):
        f.write_text(f.read_text().replace("Source,CH1,", "Source,,").replace("Source,CH2,", "Source,,"))
    back = read_tds_capture([ch2, ch1])
    np.testing.assert_array_equal(back.input_v, cap.input_v)
    # Source fields swapped against the names: the Source field wins, with a warning
    a, b = tmp_path / "x_CH1.CSV", tmp_path / "x_CH2.CSV"
    a.write_text(ch1.read_text().replace("Source,,", "Source,CH2,"))
    b.write_text(ch2.read_text().replace("Source,,", "Source,CH1,"))
    back = read_tds_capture([a, b])
    np.testing.assert_array_equal(back.input_v, cap.output_v)
    assert any("Source field says CH2 but the file name says CH1" in w for w in back.warnings)


def test_folder_case_insensitive_with_extra_channels(tmp_path):
    cap = step_capture(n=100)
    folder = write_tds_capture(tmp_path, cap)
    (folder / "F0000CH1.CSV").rename(folder / "f0000ch1.csv")
    f3 = folder / "F0000CH3.CSV"
    write_tds_channel(f3, cap.time_s, cap.output_v * 0 + 0.04, ChannelInfo("CH3", vertical_scale=1.0), cap.scope)
    back = read_tds_capture(folder)
    np.testing.assert_array_equal(back.input_v, cap.input_v)
    assert set(back.extra) == {"CH3"} and np.all(back.extra["CH3"] == 0.04)
    assert read_capture(tmp_path).n_samples == 100  # a parent holding one ALLnnnn folder


def test_pair_mismatch_names_both_files(tmp_path):
    cap = step_capture(n=100, dt=1e-3)
    a = write_tds_channel(tmp_path / "F0000CH1.CSV", cap.time_s, cap.input_v, cap.input_info, cap.scope)
    cases = {
        "sample intervals": (cap.time_s * 2, cap.output_v),
        "samples": (cap.time_s[:80], cap.output_v[:80]),
        "time axes": (cap.time_s + 5e-3, cap.output_v),
    }
    for what, (t, v) in cases.items():
        b = write_tds_channel(tmp_path / "F0000CH2.CSV", t, v, cap.output_info, replace(cap.scope, trigger_index=None),
                              force=True)
        with pytest.raises(CaptureDataError, match=what) as err:
            read_tds_capture([a, b])
        assert str(a) in str(err.value) and str(b) in str(err.value)


def test_folder_errors(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(CaptureFormatError, match=r"no FnnnnCH1\.CSV"):
        read_tds_capture(tmp_path)
    with pytest.raises(CaptureFormatError, match=r"no FnnnnCH1\.CSV") as err:
        read_capture(tmp_path)
    assert str(tmp_path) in str(err.value)
    with pytest.raises(OptionError):
        read_tds_capture([TDS2012B, TDS2012B])


# ----------------------------------------------------------------------------- bad files


def _native_copy(tmp_path: Path, name: str = "F0000CH1.CSV") -> tuple[Path, list[str]]:
    return tmp_path / name, native_lines(need(TDS2012B))


def test_truncated_file_says_how_many(tmp_path):
    f, lines = _native_copy(tmp_path)
    with pytest.raises(CaptureDataError, match="1200 of the 2500") as err:
        read_tds_channel(write_lines(f, lines[:1200]))
    assert str(f) in str(err.value)
    # cut in the middle of a line (copy interrupted): still "truncated", not a parse error
    f.write_bytes("\n".join(lines).encode()[:40000])
    with pytest.raises(CaptureDataError, match="truncated"):
        read_tds_channel(f)
    with pytest.raises(CaptureDataError, match="Record Length says 2500"):
        read_tds_channel(write_lines(f, [*lines, ",,,00.025000000000,   0.10000,"]))


def test_non_numeric_cell_names_file_row_and_text(tmp_path):
    f, lines = _native_copy(tmp_path)
    lines[499] = lines[499].replace("-0.", "-0.1x", 1)
    value = lines[499].split(",")[4].strip()
    with pytest.raises(CaptureFormatError) as err:
        read_tds_channel(write_lines(f, lines))
    assert err.value.row == 500 and f"{f}:500" in str(err.value) and repr(value) in str(err.value)


def test_short_line_names_its_row(tmp_path):
    f, lines = _native_copy(tmp_path)
    lines[99] = ",,,-00.023000000000"
    with pytest.raises(CaptureFormatError, match=r"4 field\(s\)") as err:
        read_tds_channel(write_lines(f, lines))
    assert err.value.row == 100


@pytest.mark.parametrize(
    "row, edit, match",
    [
        (700, lambda ln: ln.rsplit(",", 2)[0] + ",nan,", "not a finite number"),
        (900, None, "duplicated"),
        (1500, "backwards", "goes backwards"),
    ],
)
def test_bad_samples_name_their_row(tmp_path, row, edit, match):
    f, lines = _native_copy(tmp_path)
    if edit is None:  # same time as the line before
        prev = lines[row - 2].split(",")
        cur = lines[row - 1].split(",")
        cur[3] = prev[3]
        lines[row - 1] = ",".join(cur)
    elif edit == "backwards":
        cur = lines[row - 1].split(",")
        cur[3] = "-00.500000000000"
        lines[row - 1] = ",".join(cur)
    else:
        lines[row - 1] = edit(lines[row - 1])
    with pytest.raises(CaptureDataError, match=match) as err:
        read_tds_channel(write_lines(f, lines))
    assert err.value.row == row and f"{f}:{row}" in str(err.value)


def test_non_uniform_time_names_its_row(tmp_path):
    f, lines = _native_copy(tmp_path)
    cur = lines[1999].split(",")
    cur[3] = "00.014985000000"  # a quarter sample early
    lines[1999] = ",".join(cur)
    with pytest.raises(CaptureDataError, match="differs from the sample interval") as err:
        read_tds_channel(write_lines(f, lines))
    assert err.value.row == 2000


@pytest.mark.parametrize(
    "content, match",
    [
        (b"", "empty file"),
        (b"\n\n  \n", "empty file"),
        (b"\x89PNG\r\n\x1a\n" + bytes(100), "PNG"),
        (b'{"schema": "motorid.model/1"}', "not a capture"),
        (b"hello, this is my lab report\nwith some text\n", "not a capture"),
    ],
)
def test_not_a_capture(tmp_path, content, match):
    f = tmp_path / "F0000CH1.CSV"
    f.write_bytes(content)
    with pytest.raises(CaptureFormatError, match=match) as err:
        read_tds_channel(f)
    assert str(f) in str(err.value)


def test_missing_file_is_named(tmp_path):
    f = tmp_path / "nope" / "F0000CH1.CSV"
    with pytest.raises(MotorIdError, match="no such file") as err:
        read_tds_channel(f)
    assert str(f) in str(err.value)
    with pytest.raises(MotorIdError, match="no such file"):
        read_tds_capture([f, tmp_path / "F0000CH2.CSV"])


# ----------------------------------------------------------------------------- clipping


def _clip_file(tmp_path: Path, values: np.ndarray, scale: float, offset: float = 0.0) -> Path:
    t = np.arange(values.size) * 1e-3
    info = ChannelInfo("CH2", "V", scale, offset, 1.0, 0.0)
    return write_tds_channel(tmp_path / "F0000CH2.CSV", t, values, info, ScopeInfo(), force=True)


def test_clipping_at_the_rails_is_warned(tmp_path):
    lsb = 1.0 / 25
    # a 20 V-amplitude sine at 1 V/div: the ADC stops at +127 and -128 levels
    levels = np.clip(np.round(8.0 * np.sin(np.linspace(0, 4 * np.pi, 2500)) / lsb), -128, 127)
    cap = read_tds_capture(_clip_file(tmp_path, levels * lsb, 1.0))
    frac = np.mean((levels == 127) | (levels == -128)) * 100  # independent count
    msg = [w for w in cap.warnings if "clipped at the scope rails" in w]
    assert len(msg) == 1 and f"on {frac:.0f}% of the record; increase V/div" in msg[0]
    # the same with the trace moved by the vertical offset: the rails move with it
    cap = read_tds_capture(_clip_file(tmp_path, levels * lsb - 2.0, 1.0, offset=2.0))
    assert any("clipped" in w for w in cap.warnings)


def test_no_clipping_warning_for_a_flat_step_inside_the_screen(tmp_path):
    lsb = 1.0 / 25
    step = np.where(np.arange(2500) > 500, 3.0, 0.0)  # 3 div: on screen, far from the rails
    assert not read_tds_capture(_clip_file(tmp_path, step, 1.0)).warnings
    assert not read_tds_capture(_clip_file(tmp_path, np.sin(np.arange(2500) / 50) * 100 * lsb, 1.0)).warnings
