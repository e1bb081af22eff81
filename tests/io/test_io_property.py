"""Property tests of every reader on mutated REAL captures: a capture or MotorIdError, nothing else.

The sources are the three Tektronix sample files and the HSLU CSV logs in ``../shared/real``
(skipped, with the reason printed, when that folder is absent).  ``bench/fuzz.py`` runs the
same property with many more examples.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motorid.capture import Capture
from motorid.errors import MotorIdError
from motorid.io import read_capture, read_plain_csv, read_tds_channel, read_xlsx_capture

from mutations import OPS, REAL, mutate, real_files

FILES = real_files()
pytestmark = [pytest.mark.slow, pytest.mark.skipif(not FILES, reason=f"real recordings not found at {REAL.resolve()}")]
_SETTINGS = settings(max_examples=300, deadline=None, derandomize=True,
                     suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
_TEK = [f for f in FILES if f.suffix == ".CSV"]
_CSV = [f for f in FILES if f.suffix == ".csv"]


def _check(reader, path: Path) -> None:
    try:
        cap = reader(path)
    except MotorIdError as exc:
        text = str(exc)
        assert "\n" not in text and "np.float64" not in text, text
        assert len(text) < 600, text
        return
    if isinstance(cap, Capture):
        assert cap.n_samples >= 2
        assert np.all(np.isfinite(cap.time_s)) and np.all(np.diff(cap.time_s) > 0)
        assert np.all(np.isfinite(cap.output_v))
    else:  # a TdsChannel
        assert np.all(np.isfinite(cap.values_v))


@_SETTINGS
@given(k=st.integers(0, 99), ops=st.lists(OPS, min_size=1, max_size=3))
def test_read_capture_on_mutated_real_files(tmp_path, k, ops):
    src = FILES[k % len(FILES)]
    f = tmp_path / src.name
    f.write_bytes(mutate(src.read_bytes(), ops))
    _check(read_capture, f)


@_SETTINGS
@given(k=st.integers(0, 99), ops=st.lists(OPS, min_size=1, max_size=3))
def test_tds_reader_on_mutated_tektronix_files(tmp_path, k, ops):
    if not _TEK:
        pytest.skip("no Tektronix samples")
    src = _TEK[k % len(_TEK)]
    f = tmp_path / "F0000CH1.CSV"
    f.write_bytes(mutate(src.read_bytes(), ops))
    _check(read_tds_channel, f)


@_SETTINGS
@given(k=st.integers(0, 99), ops=st.lists(OPS, min_size=1, max_size=3))
def test_plain_reader_on_mutated_logs(tmp_path, k, ops):
    if not _CSV:
        pytest.skip("no HSLU logs")
    src = _CSV[k % len(_CSV)]
    f = tmp_path / "log.csv"
    f.write_bytes(mutate(src.read_bytes(), ops))
    _check(read_plain_csv, f)


def _xlsx_from(src: Path, out: Path) -> Path:
    """A workbook holding a real log's first 300 rows as a table (openpyxl, no reader of ours)."""
    from openpyxl import Workbook

    wb = Workbook()
    ws = wb.active
    for line in src.read_text(errors="replace").splitlines()[:300]:
        cells = line.split(",")
        row = []
        for c in cells:
            try:
                row.append(float(c))
            except ValueError:
                row.append(c)
        ws.append(row)
    wb.save(out)
    return out


@settings(max_examples=100, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(ops=st.lists(st.one_of(st.tuples(st.just("truncate"), st.floats(0, 1, exclude_max=True)),
                              st.tuples(st.just("flip"), st.floats(0, 1, exclude_max=True), st.integers(0, 255))),
                    min_size=1, max_size=3))
def test_xlsx_reader_on_damaged_workbooks(tmp_path_factory, ops):
    if not _CSV:
        pytest.skip("no HSLU logs")
    base = tmp_path_factory.getbasetemp() / "xlsx_base.xlsx"
    if not base.exists():
        _xlsx_from(_CSV[0], base)
    f = tmp_path_factory.mktemp("x") / "w.xlsx"
    f.write_bytes(mutate(base.read_bytes(), ops))
    _check(read_xlsx_capture, f)


def test_xlsx_of_a_real_log_reads(tmp_path):
    if not _CSV:
        pytest.skip("no HSLU logs")
    cap = read_xlsx_capture(_xlsx_from(_CSV[0], tmp_path / "w.xlsx"))
    assert cap.n_samples == 299
    assert zipfile.is_zipfile(tmp_path / "w.xlsx")
