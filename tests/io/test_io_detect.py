"""Format detection from content, read_capture dispatch, and rejection of non-captures."""

from __future__ import annotations

import contextlib
import json

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from iohelpers import HSLU, TDS2012B, TDS2024B, need, step_capture
from motorid.errors import CaptureFormatError, MotorIdError, OptionError
from motorid.io import (
    detect_format,
    read_capture,
    write_openchoice_xlsx,
    write_tds_capture,
)


def test_detect_from_content_not_extension(tmp_path):
    renamed = tmp_path / "scope.txt"
    renamed.write_bytes(need(TDS2012B).read_bytes())
    assert detect_format(renamed) == "tds2000-csv"
    assert detect_format(TDS2024B) == "tds2000-csv"
    assert detect_format(need(HSLU / "06_dc_step_5_15_00.csv")) == "plain-csv"
    xlsx = write_openchoice_xlsx(tmp_path / "cap.xlsx", step_capture(n=50))
    disguised = tmp_path / "cap.dat"
    disguised.write_bytes(xlsx.read_bytes())
    assert detect_format(disguised) == "xlsx"
    assert read_capture(disguised).format == "xlsx"
    folder = write_tds_capture(tmp_path, step_capture(n=50))
    assert detect_format(folder) == "tds2000-csv"


def test_read_capture_dispatch(tmp_path):
    cap = step_capture(n=80)
    folder = write_tds_capture(tmp_path, cap)
    pair = [folder / "F0000CH2.CSV", folder / "F0000CH1.CSV"]
    for got in (read_capture(folder), read_capture(pair), read_capture([str(p) for p in pair])):
        assert got.format == "tds2000-csv"
        np.testing.assert_allclose(got.input_v, cap.input_v, atol=1e-12)
    single = read_capture(folder / "F0000CH2.CSV")
    assert single.input_v is None
    assert read_capture(folder, role="position").role_hint == "position"
    with pytest.raises(OptionError, match="--columns"):
        read_capture(folder, columns={"time": "t"})
    with pytest.raises(OptionError, match="role"):
        read_capture(folder, role="speed")
    log = tmp_path / "log.csv"
    log.write_text("t,u,y\n0,0,0\n1,1,0.5\n2,1,0.8\n")
    with pytest.raises(OptionError, match="Tektronix channel files"):
        read_capture([folder / "F0000CH1.CSV", log])
    assert read_capture(log, columns={"output": "y"}).output_info.name == "y"


@pytest.mark.parametrize(
    "name, content, match",
    [
        ("shot.png", b"\x89PNG\r\n\x1a\n" + bytes(64), "PNG"),
        ("F0000TEK.JPG", b"\xff\xd8\xff\xe0" + bytes(64), "JPEG"),
        ("model.json", json.dumps({"schema": "motorid.model/1", "order": 2}).encode(), "JSON"),
        ("notes.txt", b"Lab 3: the motor hums.\nIt turns.\n", "not a capture"),
        ("empty.csv", b"", "empty file"),
        ("data.mat", b"MATLAB 5.0 MAT-file, Platform: Win32NT" + bytes(100), "MATLAB"),
        ("doc.zip", None, "zip archive"),
    ],
)
def test_not_a_capture(tmp_path, name, content, match):
    f = tmp_path / name
    if content is None:
        import zipfile

        with zipfile.ZipFile(f, "w") as zf:
            zf.writestr("a.txt", "x")
    else:
        f.write_bytes(content)
    for fn in (detect_format, read_capture):
        with pytest.raises(CaptureFormatError, match=match) as err:
            fn(f)
        assert str(f) in str(err.value)


def test_missing_file(tmp_path):
    f = tmp_path / "F0001CH1.CSV"
    with pytest.raises(CaptureFormatError, match="no such file") as err:
        read_capture(f)
    assert str(f) in str(err.value)


_FUZZ = settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@_FUZZ
@given(data=st.binary(max_size=3000))
def test_garbage_bytes_are_rejected_with_motoriderror(tmp_path, data):
    f = tmp_path / "garbage.csv"
    f.write_bytes(data)
    with pytest.raises(MotorIdError):
        read_capture(f)


@_FUZZ
@given(text=st.text(max_size=2000))
@example(text='0\n\r"')  # a carriage return in an open quote: csv's own error escaped as an internal error
def test_garbage_text_is_rejected_with_motoriderror(tmp_path, text):
    f = tmp_path / "garbage.txt"
    f.write_text(text, encoding="utf-8")
    with pytest.raises(MotorIdError):
        read_capture(f)


@_FUZZ
@given(
    lines=st.lists(
        st.lists(st.sampled_from(["", "1", "-0.5", "nan", "x", "Record Length", "2.5e3", "time", "Source", "CH1"]),
                 min_size=1, max_size=6).map(",".join),
        max_size=40,
    )
)
def test_csv_shaped_garbage_is_rejected_with_motoriderror(tmp_path, lines):
    # Garbage close to the real formats reaches deeper into the parsers than random bytes.
    f = tmp_path / "g.csv"
    f.write_text("\n".join(lines))
    # a tiny valid table may come out of it; any other exception than MotorIdError fails the test
    with contextlib.suppress(MotorIdError):
        read_capture(f)


@_FUZZ
@given(cut=st.integers(0, 79086), flips=st.lists(st.tuples(st.integers(0, 79085), st.integers(0, 255)), max_size=5))
# Found by this test: both "Record Length" and "Horizontal Scale" damaged, 44 of 2500 lines left.
@example(cut=1735, flips=[(0, 1), (540, 1)])
def test_damaged_real_file_gives_capture_or_motoriderror(tmp_path, cut, flips):
    data = bytearray(need(TDS2012B).read_bytes()[:cut])
    for pos, byte in flips:
        if pos < len(data):
            data[pos] = byte
    f = tmp_path / "F0000CH1.CSV"
    f.write_bytes(bytes(data))
    try:
        cap = read_capture(f)
    except MotorIdError:
        return
    # survived only if the damage left a whole record, or it says it may be truncated
    assert cap.n_samples == 2500 or any("truncated" in w for w in cap.warnings)


@pytest.mark.parametrize("labels", [
    ("Record Length", "Horizontal Scale"),  # the Trigger Point (1250) lies beyond the 44 lines kept
    ("Record Length", "Horizontal Scale", "Trigger Point"),  # nothing left to check the length against
])
def test_part_of_a_record_without_its_length_fields_is_called_possibly_truncated(tmp_path, labels):
    text = need(TDS2012B).read_text()
    for label in labels:
        text = text.replace(label, "x" * len(label), 1)
    f = tmp_path / "F0000CH1.CSV"
    f.write_text("".join(text.splitlines(keepends=True)[:44]))
    cap = read_capture(f)
    assert cap.n_samples == 44
    assert any("truncated" in w and "Record Length" in w for w in cap.warnings), cap.warnings


def test_whole_record_without_its_length_field_is_not_called_truncated(tmp_path):
    # the Horizontal Scale (10 divisions) confirms the 2500 samples: no warning to cry wolf
    text = need(TDS2012B).read_text().replace("Record Length", "x" * 13, 1)
    f = tmp_path / "F0000CH1.CSV"
    f.write_text(text)
    cap = read_capture(f)
    assert cap.n_samples == 2500
    assert not any("truncated" in w for w in cap.warnings), cap.warnings
