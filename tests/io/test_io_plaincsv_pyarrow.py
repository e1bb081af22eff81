"""pyarrow's CSV reader, the plain-CSV reader's first fast parser, gives the bits and errors of the others.

Forced on small odd files (it is taken on large ones), its capture is compared bit for bit with the
row-by-row reader's, with ``np.loadtxt``'s and pandas' (when pandas 3 is installed) and with an
independent parse; a bad row is named by file and line whichever parser met it first.
"""

from __future__ import annotations

import csvpaths
import numpy as np
import pytest

from motorid.io import _common, plaincsv

pa_csv = pytest.importorskip("pyarrow.csv")

ODD_FILES, BAD, T, U, Y = csvpaths.ODD_FILES, csvpaths.BAD, csvpaths.T, csvpaths.U, csvpaths.Y


def _read_with(path, parser: str, monkeypatch):
    """The capture read by ``parser`` first (``careful``: the row-by-row reader)."""
    if parser == "careful":
        return plaincsv._read_careful(path, str(path), None, None)
    with monkeypatch.context() as m:
        csvpaths.use_parser(m, parser)
        taken = []
        if parser == "pyarrow":
            real = _common._load_with_pyarrow

            def spy(*args):
                taken.append(real(*args))
                return taken[-1]

            m.setattr(_common, "_load_with_pyarrow", spy)
        cap = plaincsv._read_fast(path, str(path), None, None, path.stat().st_size)
        if parser == "pyarrow":
            assert len(taken) == 1 and taken[0] is not None, "pyarrow did not read the file"
    return cap


@pytest.mark.parametrize("name", sorted(ODD_FILES))
def test_pyarrow_gives_the_bits_of_every_other_path(tmp_path, monkeypatch, name):
    path = tmp_path / f"{name}.csv"
    path.write_bytes(ODD_FILES[name].encode("latin-1"))
    want = csvpaths.expected(ODD_FILES[name])
    mine = _read_with(path, "pyarrow", monkeypatch)
    others = ["careful", *[p for p in csvpaths.installed_parsers() if p != "pyarrow"]]
    for other in others:
        theirs = _read_with(path, other, monkeypatch)
        for field in ("time_s", "input_v", "output_v"):
            assert getattr(mine, field).tobytes() == getattr(theirs, field).tobytes(), (other, field)
        assert mine.warnings == theirs.warnings and sorted(mine.extra) == sorted(theirs.extra), other
    for got, key in ((mine.time_s, "time"), (mine.input_v, "input"), (mine.output_v, "velocity")):
        assert got.tobytes() == want[key].tobytes(), key


def test_lone_cr_line_ends_give_the_same_bits_whichever_parser_reads_them(tmp_path, monkeypatch):
    """A file whose lines end in CR alone (no line feed to skip the header by) is left to np.loadtxt by
    pyarrow's and pandas' paths: the same bits as the row-by-row reader's."""
    text = "time,input,velocity\r" + "".join(csvpaths.rows(end="\r"))
    path = tmp_path / "log.csv"
    path.write_bytes(text.encode("latin-1"))
    careful = _read_with(path, "careful", monkeypatch)
    for parser in csvpaths.installed_parsers():
        with monkeypatch.context() as m:
            csvpaths.use_parser(m, parser)
            cap = plaincsv._read_fast(path, str(path), None, None, path.stat().st_size)
        for field in ("time_s", "input_v", "output_v"):
            assert getattr(cap, field).tobytes() == getattr(careful, field).tobytes(), (parser, field)
    assert careful.output_v.tobytes() == Y.tobytes()


@pytest.mark.parametrize("block", [128, 700, 1 << 20], ids=["about two lines", "about 11 lines", "one block"])
@pytest.mark.parametrize("estimate", [None, 3], ids=["estimated rows", "columns grown"])
@pytest.mark.parametrize("name", ["crlf", "blank_lines_in_body", "text_column", "no_last_line_feed", "tab"])
def test_pyarrow_block_by_block_gives_the_bits_of_the_independent_parse(tmp_path, monkeypatch, block, estimate,
                                                                        name):
    """pyarrow's blocks of 128 bytes (it cuts them at a line's end), of 700 and one block; with the row
    estimate too small the columns grow as the blocks come, then are cut to the rows read."""
    path = tmp_path / "log.csv"
    path.write_bytes(ODD_FILES[name].encode("latin-1"))
    monkeypatch.setattr(_common, "PYARROW_BLOCK_BYTES", block)
    if estimate is not None:
        monkeypatch.setattr(_common, "_expected_rows", lambda _path, _size: estimate)
    cap = _read_with(path, "pyarrow", monkeypatch)
    want = csvpaths.expected(ODD_FILES[name])
    for mine, key in ((cap.time_s, "time"), (cap.input_v, "input"), (cap.output_v, "velocity")):
        assert mine is not None and mine.shape == (T.size,) and mine.flags.c_contiguous
        assert mine.tobytes() == want[key].tobytes()


def test_a_line_longer_than_a_block_is_left_to_the_next_parser(tmp_path, monkeypatch):
    """pyarrow needs a whole line in a block (1 MiB in use): the file is read by the next parser, the same bits."""
    path = tmp_path / "log.csv"
    path.write_bytes(ODD_FILES["text_column"].encode("latin-1"))
    monkeypatch.setattr(_common, "PYARROW_BLOCK_BYTES", 50)
    assert _common._load_with_pyarrow(pa_csv, path, 1, ",", [0, 2, 3], path.stat().st_size) is None
    with monkeypatch.context() as m:
        csvpaths.use_parser(m, "pyarrow")
        cap = plaincsv._read_fast(path, str(path), None, None, path.stat().st_size)
    assert cap.output_v.tobytes() == Y.tobytes()


def test_the_columns_own_their_memory_and_hold_the_rows_read(tmp_path, monkeypatch):
    path = tmp_path / "log.csv"
    path.write_text(ODD_FILES["blank_lines_in_body"] + "\n\n")  # blank lines at the end too
    monkeypatch.setattr(_common, "PYARROW_BLOCK_BYTES", 700)
    cols = _common._load_with_pyarrow(pa_csv, path, 1, ",", None, path.stat().st_size)
    assert cols is not None and len(cols) == 3
    for col, want in zip(cols, (T, U, Y), strict=True):
        assert col.shape == (T.size,) and col.flags.owndata
        assert col.tobytes() == want.tobytes()


@pytest.mark.parametrize("body", [
    '0.1,"5.92",1.0\n',  # quoted: np.loadtxt (no quote character) refuses it too
    "0.1,,1.0\n",  # an empty cell is no null value
    "0.1,NA,1.0\n",
    "0.1,5.92\n",  # a short row is not padded
    "0.1,5.92,1.0,7\n",
    "   \n",  # a line of spaces is a row of one field for np.loadtxt too
    "0.1,0x10,1.0\n",
])
def test_pyarrow_leaves_to_the_next_parser_what_loadtxt_refuses(tmp_path, body):
    path = tmp_path / "log.csv"
    rows = csvpaths.rows()
    path.write_text("time,input,velocity\n" + "".join(rows[:100]) + body + "".join(rows[100:]))
    assert _common._load_with_pyarrow(pa_csv, path, 1, ",", None, path.stat().st_size) is None
    with pytest.raises(ValueError):
        _common.load_columns(path, skiprows=1, delimiter=",", usecols=None)


@pytest.mark.parametrize("cell", ["nan", "-inf", "Infinity", "1e400", "1e-400", "+.5", "5.", " 7 "])
def test_pyarrow_reads_the_cells_loadtxt_reads_to_the_same_bits(tmp_path, cell):
    """NaN and infinities are values to both (the checks after reading name them), read the same."""
    path = tmp_path / "log.csv"
    rows = csvpaths.rows()
    rows[50] = f"0.05,{cell},1.0\n"
    path.write_text("time,input,velocity\n" + "".join(rows))
    cols = _common._load_with_pyarrow(pa_csv, path, 1, ",", None, path.stat().st_size)
    table = _common.load_columns(path, skiprows=1, delimiter=",", usecols=None)
    assert cols is not None
    for k, col in enumerate(cols):
        assert col.tobytes() == np.ascontiguousarray(table[:, k]).tobytes()


@pytest.mark.parametrize("careful_max", [None, 1], ids=["small file", "large file (streamed scan)"])
@pytest.mark.parametrize("name", sorted(BAD))
def test_a_bad_row_in_a_later_block_names_its_line(tmp_path, monkeypatch, name, careful_max):
    """The bad row (row 100 of 200, after a blank line) sits in pyarrow's seventh block of 1000 bytes: the
    message names its line in the file, as when pandas or np.loadtxt read it."""
    bad, exc, words = BAD[name]
    rows = csvpaths.rows()
    rows[100] = bad + "\n"
    rows[30] = rows[30] + "\n"  # a blank line in the first block: lines and samples differ by two
    path = tmp_path / "log.csv"
    path.write_text("time,input,velocity\n" + "".join(rows))
    monkeypatch.setattr(_common, "PYARROW_BLOCK_BYTES", 1000)
    if careful_max is not None:
        monkeypatch.setattr(_common, "CAREFUL_MAX_BYTES", careful_max)
    messages = {}
    for parser in csvpaths.installed_parsers():
        with monkeypatch.context() as m:
            csvpaths.use_parser(m, parser)
            with pytest.raises(exc) as info:
                plaincsv.read_plain_csv(path)
        messages[parser] = str(info.value)
        assert str(path) in messages[parser] and ":103:" in messages[parser], (parser, messages[parser])
        if name != "nan" or careful_max is None:
            assert words in messages[parser], (parser, messages[parser])
    assert len(set(messages.values())) == 1, messages


def test_time_going_back_in_a_later_block_names_its_line(tmp_path, monkeypatch):
    rows = csvpaths.rows()
    rows[150] = rows[149]  # a duplicated sample: line 152
    path = tmp_path / "log.csv"
    path.write_text("time,input,velocity\n" + "".join(rows))
    csvpaths.use_parser(monkeypatch, "pyarrow")
    monkeypatch.setattr(_common, "PYARROW_BLOCK_BYTES", 1000)
    with pytest.raises(Exception, match="duplicated") as info:
        plaincsv.read_plain_csv(path)
    assert f"{path}:152:" in str(info.value)


def test_a_file_with_no_row_after_its_header_is_left_to_the_next_parser(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("time,input,velocity\n\n\n")
    assert _common._load_with_pyarrow(pa_csv, path, 1, ",", None, path.stat().st_size) is None


def test_columns_chosen_by_position_are_read_alone(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text(ODD_FILES["text_column"])
    cols = _common._load_with_pyarrow(pa_csv, path, 1, ",", [0, 2, 3], path.stat().st_size)
    assert cols is not None
    for col, want in zip(cols, (T, U, Y), strict=True):
        assert col.tobytes() == want.tobytes()
    assert _common._load_with_pyarrow(pa_csv, path, 1, ",", [0, 9], path.stat().st_size) is None
