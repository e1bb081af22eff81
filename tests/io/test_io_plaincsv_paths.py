"""The plain-CSV reader's paths give the same capture: pandas' C parser, np.loadtxt, row by row.

The fast paths are taken on large files only; here they are forced on small odd files, and each
result is compared with the careful reader's (every cell read with ``float``) and with an
independent parse (``float`` on the split text, in the test).  pyarrow's CSV reader, the first
fast parser when it is installed, is made unimportable here where pandas is meant
(tests/io/test_io_plaincsv_pyarrow.py compares it).
"""

from __future__ import annotations

import sys

import csvpaths
import numpy as np
import pytest

from motorid.errors import CaptureDataError, CaptureFormatError
from motorid.io import _common, plaincsv

pandas = pytest.importorskip("pandas")
needs_pandas3 = pytest.mark.skipif(int(pandas.__version__.split(".")[0]) < 3,
                                   reason="pandas < 3 is not used (its float parser may round differently)")

ODD_FILES, BAD, T, U, Y = csvpaths.ODD_FILES, csvpaths.BAD, csvpaths.T, csvpaths.U, csvpaths.Y
_rows, _expected = csvpaths.rows, csvpaths.expected


def _read(path, how: str, monkeypatch):
    file = str(path)
    if how == "pandas":
        csvpaths.use_parser(monkeypatch, "pandas")
        real = _common._load_with_pandas
        taken = []

        def spy(*args):
            taken.append(real(*args) is not None)
            return real(*args)

        monkeypatch.setattr(_common, "_load_with_pandas", spy)
        cap = plaincsv._read_fast(path, file, None, None, path.stat().st_size)
        assert taken == [True], "pandas did not read the file (np.loadtxt did)"
        return cap
    if how == "loadtxt":
        csvpaths.use_parser(monkeypatch, "loadtxt")  # import pandas, pyarrow.csv → ImportError
        return plaincsv._read_fast(path, file, None, None, path.stat().st_size)
    return plaincsv._read_careful(path, file, None, None)


@needs_pandas3
@pytest.mark.parametrize("name", sorted(ODD_FILES))
def test_pandas_loadtxt_and_careful_paths_give_the_same_bits(tmp_path, monkeypatch, name):
    path = tmp_path / f"{name}.csv"
    path.write_bytes(ODD_FILES[name].encode("latin-1"))
    want = _expected(ODD_FILES[name])
    for how in ("pandas", "loadtxt", "careful"):
        with monkeypatch.context() as m:
            cap = _read(path, how, m)
        np.testing.assert_array_equal(cap.time_s, want["time"], err_msg=how)
        np.testing.assert_array_equal(cap.input_v, want["input"], err_msg=how)
        np.testing.assert_array_equal(cap.output_v, want["velocity"], err_msg=how)


@needs_pandas3
def test_pandas_path_is_taken_on_a_large_file(tmp_path, monkeypatch):
    path = tmp_path / "log.csv"
    path.write_text(ODD_FILES["crlf"])
    csvpaths.use_parser(monkeypatch, "pandas")
    calls = []
    real = _common._load_with_pandas

    def spy(*args):
        calls.append(real(*args))
        return calls[-1]

    monkeypatch.setattr(_common, "_load_with_pandas", spy)
    cols = _common.load_column_arrays(path, skiprows=1, delimiter=",", usecols=None, size=path.stat().st_size)
    assert calls and calls[0] is not None and len(cols) == 3
    np.testing.assert_array_equal(cols[2], Y)


def test_small_file_does_not_import_pandas(tmp_path, monkeypatch):
    path = tmp_path / "log.csv"
    path.write_text(ODD_FILES["tab"])
    monkeypatch.delitem(sys.modules, "pandas", raising=False)
    monkeypatch.delitem(sys.modules, "pyarrow.csv", raising=False)
    cap = plaincsv.read_plain_csv(path)
    assert "pandas" not in sys.modules and "pyarrow.csv" not in sys.modules and cap.n_samples == T.size


@pytest.mark.parametrize("careful_max", [None, 1], ids=["small file", "large file (streamed scan)"])
@pytest.mark.parametrize("name", sorted(BAD))
def test_a_bad_row_names_the_file_and_its_line_on_every_path(tmp_path, monkeypatch, name, careful_max):
    bad, exc, words = BAD[name]
    rows = _rows()
    rows[100] = bad + "\n"
    path = tmp_path / "log.csv"
    path.write_text("time,input,velocity\n" + "".join(rows))
    line = 102  # header, then rows[0] on line 2
    if careful_max is not None:
        monkeypatch.setattr(_common, "CAREFUL_MAX_BYTES", careful_max)
    for parser in csvpaths.installed_parsers():
        with monkeypatch.context() as m:
            csvpaths.use_parser(m, parser)
            with pytest.raises(exc) as info:
                plaincsv.read_plain_csv(path)
        message = str(info.value)
        assert str(path) in message and f":{line}:" in message, (parser, message)
        if name != "nan" or careful_max is None:
            assert words in message, (parser, message)


def test_a_header_written_twice_is_refused_in_one_line_on_every_path(tmp_path, monkeypatch):
    """A first data row with no number (the header twice) is a format error naming the file, whichever parser
    would have read the numbers (it was an IndexError once pandas had been imported)."""
    path = tmp_path / "log.csv"
    path.write_text("time,input,velocity\ntime,input,velocity\n" + "".join(_rows()))
    for parser in csvpaths.installed_parsers():
        with monkeypatch.context() as m:
            csvpaths.use_parser(m, parser)
            with pytest.raises(CaptureFormatError) as info:
                plaincsv.read_plain_csv(path)
        assert str(path) in str(info.value), parser


# ---- pandas block by block: columns allocated once, every block copied in, errors still name their line

@needs_pandas3
@pytest.mark.parametrize("estimate", [None, 3], ids=["estimated rows", "columns grown"])
@pytest.mark.parametrize("block", [50, 700, 1 << 20], ids=["shorter than a line", "about 11 lines", "one block"])
@pytest.mark.parametrize("name", ["crlf", "blank_lines_in_body", "comments_and_blank_lines_first", "text_column"])
def test_pandas_block_by_block_gives_the_bits_of_the_independent_parse(tmp_path, monkeypatch, block, estimate, name):
    """Blocks of 50 bytes (each shorter than a line: they are joined up to a line's end), of 700 (cut
    inside lines, the last short) and one block; with the row estimate too small, the columns grow as
    the blocks come (then are cut to the rows read)."""
    path = tmp_path / "log.csv"
    path.write_bytes(ODD_FILES[name].encode("latin-1"))
    monkeypatch.setattr(_common, "PANDAS_BLOCK_BYTES", block)
    if estimate is not None:
        monkeypatch.setattr(_common, "_expected_rows", lambda _path, _size: estimate)
    cap = _read(path, "pandas", monkeypatch)
    want = _expected(ODD_FILES[name])
    for mine, key in ((cap.time_s, "time"), (cap.input_v, "input"), (cap.output_v, "velocity")):
        assert mine is not None and mine.shape == (T.size,) and mine.flags.c_contiguous
        assert mine.tobytes() == want[key].tobytes()


@needs_pandas3
def test_the_blocks_columns_own_their_memory_and_hold_the_rows_read(tmp_path, monkeypatch):
    path = tmp_path / "log.csv"
    path.write_text(ODD_FILES["blank_lines_in_body"] + "\n\n")  # blank lines at the end too
    monkeypatch.setattr(_common, "PANDAS_BLOCK_BYTES", 700)
    cols = _common._load_with_pandas(pandas.read_csv, path, 1, ",", None, path.stat().st_size)
    assert cols is not None and len(cols) == 3
    for col, want in zip(cols, (T, U, Y), strict=True):
        assert col.shape == (T.size,) and col.flags.owndata
        np.testing.assert_array_equal(col, want)


@needs_pandas3
@pytest.mark.parametrize("name", sorted(BAD))
def test_a_bad_row_in_a_later_block_names_its_line(tmp_path, monkeypatch, name):
    """The bad row (row 100 of 200, after a blank line) sits in pandas' seventh block of 1000 bytes:
    the message names its line in the file, as on the other paths."""
    bad, exc, words = BAD[name]
    rows = _rows()
    rows[100] = bad + "\n"
    rows[30] = rows[30] + "\n"  # a blank line in the first block: lines and samples differ by two
    path = tmp_path / "log.csv"
    path.write_text("time,input,velocity\n" + "".join(rows))
    csvpaths.use_parser(monkeypatch, "pandas")
    monkeypatch.setattr(_common, "PANDAS_BLOCK_BYTES", 1000)
    assert _common._load_with_pandas(pandas.read_csv, path, 1, ",", None, 1) is None  # left to loadtxt
    for careful_max in (1 << 62, 1):
        monkeypatch.setattr(_common, "CAREFUL_MAX_BYTES", careful_max)
        with pytest.raises(exc) as info:
            plaincsv.read_plain_csv(path)
        message = str(info.value)
        assert str(path) in message and ":103:" in message, message
        if name != "nan" or careful_max > 1:
            assert words in message, message


@needs_pandas3
def test_time_going_back_in_a_later_block_names_its_line(tmp_path, monkeypatch):
    """Read by pandas block by block, the time checks run on the whole column and name the file's line."""
    rows = _rows()
    rows[150] = rows[149]  # a duplicated sample: line 152
    path = tmp_path / "log.csv"
    path.write_text("time,input,velocity\n" + "".join(rows))
    csvpaths.use_parser(monkeypatch, "pandas")
    monkeypatch.setattr(_common, "PANDAS_BLOCK_BYTES", 1000)
    with pytest.raises(CaptureDataError, match="duplicated") as info:
        plaincsv.read_plain_csv(path)
    assert f"{path}:152:" in str(info.value)


@needs_pandas3
def test_a_last_block_of_blank_lines_is_no_failure(tmp_path, monkeypatch):
    """Blocks of 50 bytes over a file that ends in 200 blank lines: the last blocks hold blank lines only
    (pandas would find no columns there); the file is still read by pandas, to its last row."""
    path = tmp_path / "log.csv"
    path.write_text(ODD_FILES["crlf"] + "\n" * 200)
    monkeypatch.setattr(_common, "PANDAS_BLOCK_BYTES", 50)
    cols = _common._load_with_pandas(pandas.read_csv, path, 1, ",", None, path.stat().st_size)
    assert cols is not None
    for col, want in zip(cols, (T, U, Y), strict=True):
        assert col.tobytes() == want.tobytes()


@needs_pandas3
@pytest.mark.parametrize("block", [50, 700, 1 << 20])
def test_a_last_line_without_its_line_feed_is_read_block_by_block(tmp_path, monkeypatch, block):
    path = tmp_path / "log.csv"
    path.write_text(ODD_FILES["tab"].rstrip("\n"))
    monkeypatch.setattr(_common, "PANDAS_BLOCK_BYTES", block)
    cols = _common._load_with_pandas(pandas.read_csv, path, 1, "\t", None, path.stat().st_size)
    assert cols is not None
    for col, want in zip(cols, (T, U, Y), strict=True):
        assert col.tobytes() == want.tobytes()
