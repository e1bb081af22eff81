"""Plain CSV logs: the HSLU DC-motor files, column guessing and mapping, delimiters, errors."""

from __future__ import annotations

import numpy as np
import pytest

from iohelpers import HSLU, need
from motorid.errors import CaptureDataError, CaptureFormatError, OptionError
from motorid.io import read_capture, read_plain_csv

HSLU_FILES = [
    "06_dc_step_5_15_00.csv", "06_dc_step_5_15_05.csv", "09_dc_step_20_25_00.csv",
    "09_dc_step_20_25_05.csv", "12_dc_step_20_25_00.csv", "12_dc_step_20_25_05.csv",
]


@pytest.mark.parametrize("name", HSLU_FILES)
def test_hslu_logs(name):
    path = need(HSLU / name)
    cap = read_plain_csv(path)
    ref = np.loadtxt(path, delimiter=",", skiprows=1)  # independent parse
    assert cap.format == "plain-csv" and cap.n_samples == ref.shape[0]
    assert cap.input_info.name == "motor_voltage_V" and cap.output_info.name == "speed_rpm"
    assert cap.role_hint == "velocity" and cap.output_info.units == "rpm" and cap.input_info.units == "V"
    np.testing.assert_array_equal(cap.time_s, ref[:, 0])
    np.testing.assert_array_equal(cap.input_v, ref[:, 1])
    np.testing.assert_array_equal(cap.output_v, ref[:, 2])
    np.testing.assert_array_equal(cap.extra["position"], ref[:, 4])
    assert set(cap.extra) == {"position", "speed_setpoint_rpm", "position_setpoint_raw"}
    # 100 Hz and uniform: every step within 1e-9 of 10 ms (the log's float noise is ~1e-15)
    assert cap.sample_interval_s == pytest.approx(0.01, rel=1e-9)
    assert np.max(np.abs(np.diff(cap.time_s) - 0.01)) < 1e-9


def test_hslu_open_loop_sizes_and_step():
    cap = read_capture(need(HSLU / "06_dc_step_5_15_00.csv"))
    assert cap.n_samples == 1221
    # PROVENANCE.md: 5 V -> 15 V between index 323 and 324
    assert cap.input_v[323] == 5.0 and cap.input_v[324] == 15.0


def _write(tmp_path, text: str, name: str = "log.csv"):
    f = tmp_path / name
    f.write_text(text)
    return f


def _table(n: int = 50, dt: float = 0.01) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(n) * dt
    u = np.where(t >= 0.1, 6.0, 0.0)
    y = 2.0 * (1 - np.exp(-np.maximum(t - 0.1, 0) / 0.2))
    return t, u, y


def test_column_mapping(tmp_path):
    t, u, y = _table()
    lines = ["t,u,rpm,other"] + [f"{a!r},{b!r},{c!r},1.0" for a, b, c in zip(t.tolist(), u.tolist(), y.tolist(), strict=False)]
    f = _write(tmp_path, "\n".join(lines))
    cap = read_plain_csv(f, columns={"time": "t", "input": "u", "velocity": "rpm"})
    np.testing.assert_array_equal(cap.output_v, y)
    np.testing.assert_array_equal(cap.input_v, u)
    assert cap.role_hint == "velocity" and list(cap.extra) == ["other"]
    with pytest.raises(OptionError, match="'t', 'u', 'rpm', 'other'") as err:
        read_plain_csv(f, columns={"time": "t", "velocity": "speed"})
    assert str(f) in str(err.value)
    with pytest.raises(OptionError, match=r"unknown column role 'speed'.*'rpm'"):
        read_plain_csv(f, columns={"speed": "rpm"})
    with pytest.raises(OptionError, match="role"):
        read_plain_csv(f, role="torque")


@pytest.mark.parametrize(
    "header, input_name, output_name, role",
    [
        ("time,input,output", "input", "output", None),
        ("Zeit;Motorspannung;Geschwindigkeit", "Motorspannung", "Geschwindigkeit", "velocity"),
        ("t_ms\tvin\tangle_deg", "vin", "angle_deg", "position"),
        ("sec,CH1,CH2", "CH1", "CH2", None),
        ("time,voltage,tacho_voltage", "voltage", "tacho_voltage", "velocity"),
        ("time,u,i_a", "u", "i_a", "current"),
    ],
)
def test_guessing_by_keywords(tmp_path, header, input_name, output_name, role):
    delim = ";" if ";" in header else ("\t" if "\t" in header else ",")
    t, u, y = _table()
    scale = 1000.0 if header.startswith("t_ms") else 1.0
    body = [delim.join(f"{v!r}" for v in row) for row in zip((t * scale).tolist(), u.tolist(), y.tolist(), strict=False)]
    cap = read_plain_csv(_write(tmp_path, "\n".join([header, *body])))
    assert cap.input_info.name == input_name and cap.output_info.name == output_name
    assert cap.role_hint == role
    np.testing.assert_allclose(cap.time_s, t, rtol=1e-12, atol=0)  # ms converted to s


def test_setpoint_is_not_the_input_and_position_goes_to_extra(tmp_path):
    t, u, y = _table()
    lines = ["time_s,speed_setpoint,position,velocity"] + [f"{a!r},{b!r},{a * 3!r},{c!r}" for a, b, c in zip(t.tolist(), u.tolist(), y.tolist(), strict=False)]
    cap = read_plain_csv(_write(tmp_path, "\n".join(lines)))
    assert cap.input_v is None and cap.output_info.name == "velocity" and cap.role_hint == "velocity"
    assert set(cap.extra) == {"position", "speed_setpoint"}
    cap = read_plain_csv(tmp_path / "log.csv", role="position")
    assert cap.output_info.name == "position" and cap.role_hint == "position" and "velocity" in cap.extra


def test_european_semicolon_decimal_comma_quotes_comments(tmp_path):
    t, u, y = _table()
    body = [f'{a:.2f};{b:.1f};{c:.6f}'.replace(".", ",") for a, b, c in zip(t.tolist(), u.tolist(), y.tolist(), strict=False)]
    text = "# logged by my DAQ\n\n" + '"Zeit [s]";"Spannung [V]";"Drehzahl [rpm]"\n' + "\n".join(body) + "\n\n"
    cap = read_plain_csv(_write(tmp_path, text))
    np.testing.assert_allclose(cap.output_v, y, rtol=0, atol=5e-7)  # written with 6 decimals
    np.testing.assert_array_equal(cap.input_v, np.round(u, 1))
    assert cap.output_info.units == "rpm" and cap.role_hint == "velocity"


def test_trailing_delimiter_and_crlf(tmp_path):
    t, u, y = _table()
    text = "time,u,y,\r\n" + "".join(f"{a!r},{b!r},{c!r},\r\n" for a, b, c in zip(t.tolist(), u.tolist(), y.tolist(), strict=False))
    cap = read_plain_csv(_write(tmp_path, text))
    np.testing.assert_array_equal(cap.output_v, y)


def _bad(tmp_path, edit_row: int, new: str) -> tuple:
    """A 50-sample log with line ``edit_row`` (1-based, header = 1) replaced."""
    t, u, y = _table()
    lines = ["time,u,y"] + [f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), u.tolist(), y.tolist(), strict=False)]
    lines[edit_row - 1] = new
    return _write(tmp_path, "\n".join(lines)), lines


@pytest.mark.parametrize(
    "row, line, exc, match",
    [
        (7, "0.05,6.0,abc", CaptureFormatError, "cannot read 'abc' as a number"),
        (9, "0.07,,1.0", CaptureFormatError, "empty cell"),
        (12, "0.1,6.0", CaptureFormatError, "2 fields but the header has 3"),
        (20, "0.18,6.0,nan", CaptureDataError, "not a finite number"),
        (30, "0.27,6.0,1.0", CaptureDataError, "duplicated"),
    ],
)
def test_errors_name_the_row(tmp_path, row, line, exc, match):
    f, _ = _bad(tmp_path, row, line)
    with pytest.raises(exc, match=match) as err:
        read_plain_csv(f)
    assert err.value.row == row and f"{f}:{row}" in str(err.value)


def test_row_numbers_count_skipped_lines(tmp_path):
    t, u, y = _table()
    lines = ["# comment", "", "time,u,y"] + [f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), u.tolist(), y.tolist(), strict=False)]
    lines.insert(10, "")  # a blank line inside the data
    lines[20] = "0.16,6.0,oops"
    f = _write(tmp_path, "\n".join(lines))
    with pytest.raises(CaptureFormatError) as err:
        read_plain_csv(f)
    assert err.value.row == 21


@pytest.mark.parametrize(
    "text, match",
    [
        ("time,u,y\n", "fewer than two"),
        ("1.0,2.0\n2.0,3.0\n", "no header row"),
        ("a,b,c\n1,2,3\n2,3,4\n", "no time column"),
        ("time,alpha,beta\n0,1,2\n1,2,3\n", "which column is the measured output"),
        ("values\n1\n2\n", "one column only"),
    ],
)
def test_unusable_tables(tmp_path, text, match):
    f = _write(tmp_path, text)
    with pytest.raises(CaptureFormatError, match=match) as err:
        read_plain_csv(f)
    assert str(f) in str(err.value)


def test_one_late_stamp_is_jitter_resampled_with_a_note(tmp_path):
    """A stamp 5 ms late in a 10 ms log used to be refused as "gap or corrupt record"; it is jitter:
    the log is put on a uniform grid and the note says how."""
    f, _ = _bad(tmp_path, 40, "0.385,6.0,1.0")
    cap = read_capture(f)
    assert np.allclose(np.diff(cap.time_s), np.diff(cap.time_s)[0], rtol=1e-9)
    assert any("the time stamps jitter" in w and "resampled" in w for w in cap.warnings)


@pytest.mark.parametrize("careful_max", [None, 1], ids=["careful reader", "vectorised reader"])
def test_a_units_row_under_the_header_gives_the_units(tmp_path, monkeypatch, careful_max):
    """PicoScope's CSV export (``Time,Channel A,Channel B`` / ``(ms),(V),(V)`` / a blank line) and DAQ
    logs with a units line were refused: "not a capture: neither a Tektronix CSV nor a table with
    a header row".  The units row now labels each column; the time column in ms is converted."""
    from motorid.io import _common

    t, u, y = _table()
    body = "\n".join(f"{1e3 * a:.6f},{b:.6f},{c:.6f}" for a, b, c in zip(t, u, y, strict=True))
    f = _write(tmp_path, "Time,Channel A,Channel B\n(ms),(V),(V)\n\n" + body + "\n", "pico.csv")
    if careful_max is not None:
        monkeypatch.setattr(_common, "CAREFUL_MAX_BYTES", careful_max)
        monkeypatch.setattr(_common, "PANDAS_MIN_BYTES", 1 << 62)
    with pytest.raises(CaptureFormatError, match=r'e\.g\. --columns "input=Channel A,velocity=Channel B"'):
        read_capture(f)  # channels named A and B: the message shows the map with this file's names
    cap = read_capture(f, columns={"time": "Time", "input": "Channel A", "velocity": "Channel B"})
    np.testing.assert_allclose(cap.time_s, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cap.output_v, y, atol=1e-6)
    assert cap.output_info.units == "V" and cap.n_samples == t.size
    # a tab-separated log with its units on the second line: rpm labels, read without --columns
    rows = "\n".join(f"{a:.3f}\t{b:.2f}\t{100 * c:.4f}" for a, b, c in zip(t, u, y, strict=True))
    cap = read_capture(_write(tmp_path, "time\tvoltage\tspeed\ns\tV\trpm\n" + rows + "\n", "daq.tsv"))
    assert cap.output_info.units == "rpm" and cap.n_samples == t.size and cap.input_v is not None
    # a second line of words that are not units is still a header written twice: refused
    with pytest.raises(CaptureFormatError):
        read_capture(_write(tmp_path, "time,u,y\ntime,u,y\n" + body + "\n", "twice.csv"))


def test_a_last_line_cut_in_the_middle_is_dropped_and_said(tmp_path):
    """An Arduino log stopped (or reset) while writing its last line: before, the whole file was
    refused ("2 fields but the header has 3"); now that line alone is dropped with a warning.  A
    short line anywhere else is still refused, naming it."""
    t, u, y = _table()
    lines = ["time,u,y"] + [f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), u.tolist(), y.tolist(), strict=True)]
    cap = read_plain_csv(_write(tmp_path, "\n".join([*lines, "0.5,6."]) + "\n"))
    assert cap.n_samples == t.size
    assert any("line 52, the last, has 2 of 3 fields" in w and "dropped" in w for w in cap.warnings)
    with pytest.raises(CaptureFormatError, match="2 fields but the header has 3"):
        read_plain_csv(_write(tmp_path, "\n".join([*lines[:20], "0.5,6.", *lines[20:]]) + "\n", "mid.csv"))


def test_a_time_column_of_clock_stamps_is_read_as_seconds(tmp_path):
    """A logger that stamps rows with the clock (``2024-05-01 12:00:00.010``, or ``12:00:00.010``)
    was refused: "no time column among 'timestamp', …" although the column is named for it."""
    t, u, y = _table()
    base = np.datetime64("2024-05-01T12:00:00.000")
    stamps = [str(base + np.timedelta64(round(1e3 * a), "ms")).replace("T", " ") for a in t]
    lines = ["timestamp,u,y"] + [f"{s},{b!r},{c!r}" for s, b, c in zip(stamps, u.tolist(), y.tolist(), strict=True)]
    cap = read_plain_csv(_write(tmp_path, "\n".join(lines) + "\n"))
    np.testing.assert_allclose(cap.time_s, t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cap.output_v, y)
    assert any("holds clock stamps: read as seconds from its first, 2024-05-01 12:00:00.000" in w for w in cap.warnings)
    # times of day only
    lines = ["time,u,y"] + [f"{s.split(' ')[1]},{b!r},{c!r}" for s, b, c in zip(stamps, u.tolist(), y.tolist(),
                                                                              strict=True)]
    cap = read_plain_csv(_write(tmp_path, "\n".join(lines) + "\n", "tod.csv"))
    np.testing.assert_allclose(cap.time_s, t, rtol=0, atol=1e-9)
    # a stamp that is not one is named by its line
    lines[9] = "12:00:0x.080,0.0,0.0"
    with pytest.raises(CaptureFormatError, match=r"cannot read '12:00:0x\.080' as a date and time") as err:
        read_plain_csv(_write(tmp_path, "\n".join(lines) + "\n", "bad.csv"))
    assert err.value.row == 10


@pytest.mark.parametrize("sep", [",", " ", "\t"])
def test_label_value_pairs_of_the_arduino_serial_plotter_are_a_table(tmp_path, sep):
    """``t:0.01,u:6.0,rpm:812`` on every line (what Arduino's Serial Plotter reads, so what many
    sketches print) was refused: "not a capture: neither a Tektronix CSV nor a table …"."""
    t, u, y = _table()
    lines = [sep.join(f"{k}:{v!r}" for k, v in (("t", a), ("u", b), ("rpm", 100 * c)))
             for a, b, c in zip(t.tolist(), u.tolist(), y.tolist(), strict=True)]
    f = _write(tmp_path, "\n".join([*lines, "t:0.5" + sep + "u:6."]) + "\n", "serial.txt")
    cap = read_capture(f)
    np.testing.assert_allclose(cap.time_s, t)
    np.testing.assert_allclose(cap.output_v, 100 * y)
    np.testing.assert_allclose(cap.input_v, u)
    assert cap.output_info.units == "rpm"
    assert any("the last, is not a whole line of t, u, rpm" in w for w in cap.warnings)
    lines[10] = sep.join(("t:0.1", "u:6.0", "speed:3.0"))
    with pytest.raises(CaptureFormatError, match=r"not the labels of the first line \(t, u, rpm\)") as err:
        read_capture(_write(tmp_path, "\n".join(lines) + "\n", "mixed.txt"))
    assert err.value.row == 11
