"""The readers: any file in, a capture or one clear line out, in bounded time and memory.

Cases that could hang or eat memory (pipes, devices, large files, zip bombs) run the real
command line in a child process with a timeout and an address-space limit
(``resource.setrlimit(RLIMIT_AS)``); the others call the readers in-process.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

import motorid.io._common as common
import motorid.io.tektronix as tektronix
from motorid.errors import CaptureDataError, CaptureFormatError, MotorIdError
from motorid.io import read_capture, read_tds_capture

from iohelpers import TDS2012B, native_lines, need, write_lines

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
GIB = 1 << 30


def _cli(*args: str, timeout: float = 30.0, mem: int = 2 * GIB) -> subprocess.CompletedProcess:
    """``motorid ARGS`` in a child process, limited in time and address space."""

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (mem, mem))

    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO / "src"))
    return subprocess.run([sys.executable, "-m", "motorid", *args], capture_output=True, text=True,
                          timeout=timeout, preexec_fn=limit, env=env)


def _one_line_exit_2(proc: subprocess.CompletedProcess, name: str) -> str:
    err = proc.stderr.strip()
    assert proc.returncode == 2, err
    assert 1 <= len(err.splitlines()) <= 3, err
    assert "Traceback" not in err and name in err, err
    return err


def _log(path: Path, n: int = 200, *, header: str = "time,input,velocity", pre: tuple[str, ...] = (),
         edit=None) -> Path:
    """A plain log: time 0.01 s steps, a step at sample 50, a first-order response."""
    t = np.arange(n) * 0.01
    u = np.where(np.arange(n) >= 50, 5.0, 0.0)
    y = np.where(np.arange(n) >= 50, 1.5 * (1 - np.exp(-(t - 0.5).clip(0) / 0.3)), 0.0)
    rows = [[f"{a:.2f}", f"{b:g}", f"{c:.6f}"] for a, b, c in zip(t, u, y, strict=False)]
    if edit is not None:
        edit(rows)
    return write_lines(path, [*pre, header, *(",".join(r) for r in rows)])


def _message(exc: pytest.ExceptionInfo) -> str:
    text = str(exc.value)
    assert "\n" not in text and "np.float64" not in text, text
    return text


# --------------------------------------------------------------------------- not regular files


def test_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "F0000CH1.CSV"
    os.mkfifo(fifo)
    t0 = time.perf_counter()
    _one_line_exit_2(_cli("inspect", str(fifo), timeout=20), "named pipe")
    assert time.perf_counter() - t0 < 20


def test_fifo_in_process(tmp_path):
    fifo = tmp_path / "log.csv"
    os.mkfifo(fifo)
    with pytest.raises(CaptureFormatError, match="named pipe") as err:
        read_capture(fifo)  # would block forever if opened
    assert str(fifo) in _message(err)


def test_device_is_refused():
    if not Path("/dev/zero").exists():
        pytest.skip("no /dev/zero on this system")
    _one_line_exit_2(_cli("inspect", "/dev/zero", timeout=20), "/dev/zero")
    with pytest.raises(CaptureFormatError, match="character device"):
        read_capture("/dev/zero")


def test_unreadable_file_names_it(tmp_path, monkeypatch):
    f = _log(tmp_path / "log.csv")
    # tests run as root, where chmod 000 does not stop reads: simulate what a user sees
    monkeypatch.setattr(common.os, "access", lambda *a, **k: False)
    with pytest.raises(CaptureFormatError, match="permission denied") as err:
        read_capture(f)
    assert str(f) in _message(err)


def test_open_failing_with_permission_error_names_it(tmp_path, monkeypatch):
    f = _log(tmp_path / "log.csv")

    def refuse(path):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(common, "_open", refuse)
    with pytest.raises(CaptureFormatError, match="permission denied") as err:
        read_capture(f)
    assert _message(err).startswith(str(f))


def test_unreadable_folder_names_it(tmp_path, monkeypatch):
    folder = tmp_path / "ALL0000"
    folder.mkdir()
    monkeypatch.setattr(tektronix.os, "access", lambda *a, **k: False)
    with pytest.raises(CaptureFormatError, match="permission denied") as err:
        read_capture(folder)
    assert str(folder) in _message(err)


def test_folder_linking_to_itself_is_named_once(tmp_path):
    folder = tmp_path / "ALL0000"
    folder.mkdir()
    (folder / "ALL0001").symlink_to(folder)
    with pytest.raises(CaptureFormatError) as err:
        read_capture(folder)
    assert _message(err).count("ALL000") <= 3


# --------------------------------------------------------------------------- values


def _set(i: int, j: int, text: str):
    def edit(rows):
        rows[i][j] = text
    return edit


def _gap_from(i: int, seconds: float):
    """Samples lost: the stamps from row ``i`` on jump ``seconds`` later (a gap, not jitter)."""
    def edit(rows):
        for r in rows[i:]:
            r[0] = f"{float(r[0]) + seconds:.2f}"
    return edit


@pytest.mark.parametrize("careful_max", [common.CAREFUL_MAX_BYTES, 0], ids=["small-file", "large-file-path"])
@pytest.mark.parametrize(
    "edit, line, column, words",
    [
        (_set(120, 2, "nan"), 122, "velocity", "not a finite number"),
        (_set(7, 1, "inf"), 9, "input", "not a finite number"),
        (_set(99, 2, "1e300"), 101, "velocity", "1e+300"),
        (_set(99, 2, "abc"), 101, "velocity", "cannot read 'abc'"),
        (_set(99, 2, ""), 101, "velocity", "empty cell"),
        (_set(150, 0, "1.4"), 152, "time", "goes backwards (1.49 then 1.4)"),
        (_set(60, 0, "0.59"), 62, "time", "duplicated"),
        # one stamp 5 ms late in a 10 ms log is jitter now (resampled, with a note); lost samples are a gap
        (_gap_from(60, 0.5), 62, "time", "differs from the sample interval"),
    ],
)
def test_row_errors_name_the_line_and_column_with_plain_numbers(tmp_path, monkeypatch, careful_max, edit, line,
                                                                column, words):
    # line = 1 header line + 1-based sample; the "large file" path streams instead of re-reading
    monkeypatch.setattr(common, "CAREFUL_MAX_BYTES", careful_max)
    f = _log(tmp_path / "log.csv", edit=edit)
    with pytest.raises(MotorIdError) as err:
        read_capture(f)
    msg = _message(err)
    assert msg.startswith(f"{f}:{line}: "), msg
    assert column in msg and words in msg


def test_line_counts_comment_and_blank_lines(tmp_path):
    f = _log(tmp_path / "log.csv", pre=("# DAQ log", "", "# rate 100 Hz"), edit=_set(999 - 800, 2, "nan"))
    with pytest.raises(CaptureDataError) as err:
        read_capture(f)
    assert _message(err).startswith(f"{f}:{3 + 1 + 199 + 1}: ")  # 3 lines, header, sample 199


def test_huge_values_everywhere(tmp_path):
    f = write_lines(tmp_path / "big.csv", ["time,input,velocity", *("1e300,1e300,1e300",) * 50])
    with pytest.raises(CaptureDataError, match=r"1e\+300 is out of range") as err:
        read_capture(f)
    msg = _message(err)
    assert msg.startswith(f"{f}:2: ") and len(msg) < 300


@pytest.mark.parametrize("dt, words", [(1e5, "outside"), (1e-15, "outside"), (0.0, "duplicated"),
                                       (-0.01, "goes backwards")])
def test_time_steps_out_of_range(tmp_path, dt, words):
    lines = ["time,input,velocity", *(f"{i * dt!r},{5.0 * (i > 20)},{0.1 * i}" for i in range(60))]
    f = write_lines(tmp_path / "t.csv", lines)
    with pytest.raises(CaptureDataError, match=words) as err:
        read_capture(f)
    assert str(f) in _message(err)


def test_one_row_without_newline(tmp_path):
    f = tmp_path / "one.csv"
    f.write_bytes(b"time,input,velocity\n0.0,5.0,1.0")
    with pytest.raises(CaptureDataError, match="only 1 sample") as err:
        read_capture(f)
    assert str(f) in _message(err)


def test_nan_in_an_unused_column_is_a_warning(tmp_path):
    def edit(rows):
        for k, r in enumerate(rows):
            r.append("nan" if k == 30 else "20.5")
    f = _log(tmp_path / "log.csv", header="time,input,velocity,temperature", edit=edit)
    cap = read_capture(f)
    assert cap.n_samples == 200
    warn = [w for w in cap.warnings if "'temperature'" in w]
    assert warn and "line 32" in warn[0] and "not used" in warn[0]


def test_tds_value_error_names_the_file_line(tmp_path, monkeypatch):
    lines = native_lines(need(TDS2012B))
    fields = lines[999].split(",")
    fields[4] = "nan"
    lines[999] = ",".join(fields)
    f = write_lines(tmp_path / "F0000CH1.CSV", lines, "\r\n")
    for careful_max in (common.CAREFUL_MAX_BYTES, 0):
        monkeypatch.setattr(common, "CAREFUL_MAX_BYTES", careful_max)
        with pytest.raises(CaptureDataError) as err:
            read_capture(f)
        msg = _message(err)
        assert msg.startswith(f"{f}:1000: column E (value) value nan"), msg


def test_tds_garbage_cell_on_the_large_file_path(tmp_path, monkeypatch):
    lines = native_lines(need(TDS2012B))
    fields = lines[1499].split(",")
    fields[3] = "12:00"
    lines[1499] = ",".join(fields)
    f = write_lines(tmp_path / "F0000CH1.CSV", lines)
    monkeypatch.setattr(common, "CAREFUL_MAX_BYTES", 0)
    with pytest.raises(CaptureFormatError, match="column D") as err:
        read_capture(f)
    assert _message(err).startswith(f"{f}:1500: ")


def test_tds_pair_with_absurd_sample_interval_fields(tmp_path):
    lines = native_lines(need(TDS2012B))
    ch1 = tmp_path / "F0000CH1.CSV"
    ch2 = tmp_path / "F0000CH2.CSV"
    write_lines(ch1, lines)
    bad = list(lines)
    f = bad[1].split(",")
    f[1] = "-2.000000e-05"  # Sample Interval negative; the time column is fine
    bad[1] = ",".join(f)
    write_lines(ch2, bad)
    cap = read_tds_capture([ch1, ch2])
    assert cap.n_samples == 2500
    assert not any("differ by up to 0 s" in w for w in cap.warnings)


def test_truncated_tds_without_record_length(tmp_path):
    lines = native_lines(need(TDS2012B))[1:4]  # Record Length row gone, 3 lines left
    f = write_lines(tmp_path / "F0000CH1.CSV", lines)
    with pytest.raises(CaptureDataError, match="truncated"):
        read_capture(f)


# --------------------------------------------------------------------------- size


def test_file_above_the_limit_is_refused_at_once(tmp_path):
    f = tmp_path / "huge.csv"
    with open(f, "wb") as fh:
        fh.write(b"time,input,velocity\n0,0,0\n")
        fh.truncate(common.MAX_TEXT_BYTES + 1)  # sparse: no disk used
    t0 = time.perf_counter()
    with pytest.raises(CaptureFormatError, match="MiB") as err:
        read_capture(f)
    assert time.perf_counter() - t0 < 1.0
    assert str(f) in _message(err)


def _write_big_log(path: Path, n: int) -> None:
    i = np.arange(n)
    t = i * 1e-4
    y = np.where(i >= n // 10, 1.5 * (1 - np.exp(-(i - n // 10) * 1e-4 / 0.4)), 0.0)
    with open(path, "w") as fh:
        fh.write("time,input,velocity\n")
        fh.write("".join(f"{a:.4f},{5.0 if k >= n // 10 else 0.0},{b:.6f}\n"
                         for k, (a, b) in enumerate(zip(t.tolist(), y.tolist(), strict=False))))


def test_million_row_log_reads_in_bounded_time_and_memory(tmp_path):
    f = tmp_path / "big.csv"
    _write_big_log(f, 1_000_000)
    t0 = time.perf_counter()
    # 1 GiB of address space: the interpreter, numpy and scipy take ~600 MB of it; the
    # row-by-row reader needed ~590 MB resident for this file and failed here
    proc = _cli("inspect", "--json", str(f), timeout=60, mem=GIB + GIB // 2)
    assert proc.returncode == 0, proc.stderr
    assert '"n_samples": 1000000' in proc.stdout
    assert time.perf_counter() - t0 < 60


def test_bad_line_in_a_large_file_is_found_by_streaming(tmp_path):
    f = tmp_path / "big.csv"
    _write_big_log(f, 900_000)  # ~19 MB: above CAREFUL_MAX_BYTES
    assert f.stat().st_size > common.CAREFUL_MAX_BYTES
    data = f.read_bytes()
    k = data.index(b"\n", len(data) * 3 // 4) + 1  # the start of a line 3/4 in
    line = data[:k].count(b"\n") + 1
    f.write_bytes(data[:k] + b"x" + data[k:])
    proc = _cli("inspect", str(f), timeout=60, mem=GIB + GIB // 2)
    err = _one_line_exit_2(proc, f"{f}:{line}: ")
    assert "column 'time'" in err


# --------------------------------------------------------------------------- xlsx


def _zip(path: Path, members: dict[str, bytes | int]) -> Path:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, content in members.items():
            if isinstance(content, int):  # that many bytes of one repeated string, streamed
                with zf.open(name, "w", force_zip64=True) as fh:
                    chunk = b"<si><t>a</t></si>" * 65536
                    for _ in range(content // len(chunk)):
                        fh.write(chunk)
            else:
                zf.writestr(name, content)
    return path


def test_xlsx_bomb_is_refused_before_parsing(tmp_path):
    f = _zip(tmp_path / "bomb.xlsx", {"xl/workbook.xml": b"<workbook/>", "xl/sharedStrings.xml": 200 << 20})
    assert f.stat().st_size < 2 << 20
    t0 = time.perf_counter()
    _one_line_exit_2(_cli("inspect", str(f), timeout=30, mem=GIB + GIB // 2), "zip bomb")
    assert time.perf_counter() - t0 < 30
    with pytest.raises(CaptureFormatError, match="expands") as err:
        read_capture(f)
    assert str(f) in _message(err)


def test_xlsx_too_much_xml_is_refused(tmp_path, monkeypatch):
    import motorid.io.spreadsheet as spreadsheet

    f = _zip(tmp_path / "big.xlsx", {"xl/workbook.xml": b"<workbook/>", "xl/worksheets/sheet1.xml": b"<x/>" * 5000})
    monkeypatch.setattr(spreadsheet, "MAX_XLSX_UNCOMPRESSED", 10_000)
    with pytest.raises(CaptureFormatError, match="MiB of XML"):
        read_capture(f)


def test_openpyxl_error_text_becomes_one_line(tmp_path, monkeypatch):
    import openpyxl

    f = _zip(tmp_path / "w.xlsx", {"xl/workbook.xml": b"<workbook/>"})

    def broken(*a, **k):
        raise ValueError("first line\nsecond line\n\tthird line")

    monkeypatch.setattr(openpyxl, "load_workbook", broken)
    with pytest.raises(CaptureFormatError) as err:
        read_capture(f)
    assert "first line second line third line" in _message(err)
