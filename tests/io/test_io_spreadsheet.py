"""OpenChoice-style .xlsx captures (Masoud 2019, Fig. 21) and plain table sheets."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest
from openpyxl import Workbook

from iohelpers import step_capture
from motorid.errors import CaptureDataError, CaptureFormatError, OptionError, OutputExistsError
from motorid.io import read_capture, read_xlsx_capture, write_openchoice_xlsx


def test_round_trip_keeps_channels_and_metadata(tmp_path):
    cap = step_capture(n=600)
    f = write_openchoice_xlsx(tmp_path / "cap.xlsx", cap)
    back = read_xlsx_capture(f)
    assert back.format == "xlsx" and back.role_hint == "velocity"
    # openpyxl stores 16 significant digits (as Excel does): equal to ~1e-15 relative
    np.testing.assert_allclose(back.time_s, cap.time_s, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(back.input_v, cap.input_v, rtol=1e-14, atol=0)
    np.testing.assert_allclose(back.output_v, cap.output_v, rtol=1e-14, atol=0)
    assert back.input_info == cap.input_info and back.output_info == cap.output_info
    assert back.scope == cap.scope
    with pytest.raises(OutputExistsError, match="use force=True"):
        write_openchoice_xlsx(f, cap)
    write_openchoice_xlsx(f, cap, force=True)


def test_output_only_capture_and_extras(tmp_path):
    cap = step_capture(n=100, role="position")
    from dataclasses import replace

    cap = replace(cap, input_v=None, input_info=None, extra={"velocity": cap.output_v * 2, "CH3": cap.output_v})
    back = read_capture(write_openchoice_xlsx(tmp_path / "o.xlsx", cap))
    assert back.input_v is None and back.role_hint == "position"
    assert set(back.extra) == {"velocity", "CH3"}
    np.testing.assert_allclose(back.extra["velocity"], cap.output_v * 2, rtol=1e-14)


def _fig21_sheet(path, n=60, header=("Time", "Position", "Time", "Speed")):
    """A sheet laid out like Masoud 2019, Fig. 21: label, value, units, time, value per block."""
    wb = Workbook()
    ws = wb.active
    ws.title = "Sheet1"
    ws.append([None, None, None, header[0], header[1], None, None, None, header[2], header[3]])
    t = 4e-3 * (np.arange(n) + 1)
    pos = -3.4 + 0.2 * np.floor(np.arange(n) / 3)
    speed = 0.08 * np.floor(np.arange(n) / 2)
    meta = {0: ("Sample Interval", 4e-3, "s"), 1: ("Trigger Point", 0, "Samples"),
            5: ("Source", "{ch}", None), 6: ("Vertical Units", "Volts", None), 7: ("Vertical Scale", 2, None),
            8: ("Vertical Offset", 0, None), 12: ("Probe Atten", 1, None), 15: ("Note", "TDS 2012C - 9:05:34", None)}
    for i in range(n):
        row = []
        for ch, v in (("CH1", pos), ("CH2", speed)):
            label, value, unit = meta.get(i, (None, None, None))
            row += [label, value.format(ch=ch) if isinstance(value, str) else value, unit, float(t[i]), float(v[i])]
        ws.append(row)
    wb.save(path)
    return t, pos, speed


def test_fig21_layout_two_named_outputs(tmp_path):
    f = tmp_path / "fig21.xlsx"
    t, pos, speed = _fig21_sheet(f)
    cap = read_xlsx_capture(f)
    # Both blocks name a measured quantity, none the step: no input channel; the first named
    # block is the output and the other goes to extra under its role.
    # openpyxl stores 16 significant digits (as Excel does): equal to ~1e-15 relative
    np.testing.assert_allclose(cap.time_s, t, rtol=1e-14)
    assert cap.input_v is None and cap.role_hint == "position"
    np.testing.assert_allclose(cap.output_v, pos, rtol=1e-14)
    np.testing.assert_allclose(cap.extra["velocity"], speed, rtol=1e-14)
    assert cap.output_info.vertical_scale == 2 and cap.output_info.units == "Volts"
    assert cap.scope.trigger_index == 0
    cap = read_xlsx_capture(f, role="velocity")
    np.testing.assert_allclose(cap.output_v, speed, rtol=1e-14)


def test_blocks_without_names_are_ch1_input_ch2_output(tmp_path):
    f = tmp_path / "plain_blocks.xlsx"
    _t, pos, speed = _fig21_sheet(f, header=(None, None, None, None))
    cap = read_xlsx_capture(f)
    np.testing.assert_allclose(cap.input_v, pos, rtol=1e-14)
    np.testing.assert_allclose(cap.output_v, speed, rtol=1e-14)
    assert cap.role_hint is None and cap.input_info.name == "CH1"


def test_table_sheet(tmp_path):
    wb = Workbook()
    ws = wb.active
    ws.append(["time_s", "motor_voltage_V", "speed_rpm", "position_raw"])
    t = np.arange(40) * 0.01
    for k, tk in enumerate(t):
        ws.append([float(tk), 5.0 if k < 10 else 15.0, 1000.0 + k, float(k % 7)])
    f = tmp_path / "table.xlsx"
    wb.save(f)
    cap = read_capture(f)
    assert cap.format == "xlsx" and cap.role_hint == "velocity" and cap.input_info.name == "motor_voltage_V"
    np.testing.assert_array_equal(cap.extra["position"], np.arange(40) % 7)
    cap = read_xlsx_capture(f, columns={"time": "time_s", "input": "motor_voltage_V", "position": "position_raw"})
    assert cap.role_hint == "position"
    with pytest.raises(OptionError, match="'speed_rpm'"):
        read_xlsx_capture(f, columns={"velocity": "rpm"})
    with pytest.raises(OptionError, match="no sheet 'Data'"):
        read_xlsx_capture(f, sheet="Data")


def test_bad_cell_names_sheet_row_and_text(tmp_path):
    f = tmp_path / "bad.xlsx"
    _fig21_sheet(f)
    from openpyxl import load_workbook

    wb = load_workbook(f)
    wb.active["J30"] = "n/a"
    wb.save(f)
    with pytest.raises(CaptureFormatError, match=r"sheet 'Sheet1' column J: cannot read 'n/a'") as err:
        read_xlsx_capture(f)
    assert err.value.row == 30 and f"{f}:30" in str(err.value)


def test_blocks_with_different_time_axes(tmp_path):
    f = tmp_path / "mix.xlsx"
    _fig21_sheet(f)
    from openpyxl import load_workbook

    wb = load_workbook(f)
    for r in range(2, 62):
        wb.active[f"I{r}"] = wb.active[f"I{r}"].value * 2
    wb.save(f)
    with pytest.raises(CaptureDataError, match="time columns of E and J differ"):
        read_xlsx_capture(f)


def test_record_length_shorter_than_data_is_truncation(tmp_path):
    cap = step_capture(n=100)
    f = write_openchoice_xlsx(tmp_path / "c.xlsx", cap)
    from openpyxl import load_workbook

    wb = load_workbook(f)
    wb.active.delete_rows(60, 42)  # data rows 2..101: keep 2..59
    wb.save(f)
    with pytest.raises(CaptureDataError, match="truncated: 58 of the 100"):
        read_xlsx_capture(f)


@pytest.mark.parametrize("kind", ["garbage", "zip", "empty-sheet"])
def test_not_a_workbook(tmp_path, kind):
    f = tmp_path / "x.xlsx"
    if kind == "garbage":
        f.write_bytes(b"PK\x03\x04 this is no zip at all")
    elif kind == "zip":
        with zipfile.ZipFile(f, "w") as zf:
            zf.writestr("readme.txt", "hello")
    else:
        wb = Workbook()
        wb.active.append(["just", "text"])
        wb.save(f)
    with pytest.raises(CaptureFormatError, match="not a capture") as err:
        read_xlsx_capture(f)
    assert str(f) in str(err.value)
