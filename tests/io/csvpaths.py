"""Odd plain-CSV files and the means to read them with one chosen parser (not a conftest).

Shared by the tests of the plain-CSV reader's paths: pyarrow's CSV reader, pandas' C parser,
``np.loadtxt`` and the row-by-row reader must give the same bits and the same errors.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from motorid.errors import CaptureDataError, CaptureFormatError
from motorid.io import _common

RNG = np.random.default_rng(7)
# 17 significant digits: a value whose last bit a less careful parser gets wrong
T = np.arange(200) * 1e-3
U = np.where(np.arange(200) >= 20, 5.92, 0.0)
Y = RNG.normal(0.0, 1.0, 200) * 10.0 ** RNG.integers(-8, 8, 200)


def rows(delim: str = ",", end: str = "\n", trailing: str = "") -> list[str]:
    """The table's lines, each value written with ``repr`` (17 significant digits)."""
    return [f"{t!r}{delim}{u!r}{delim}{y!r}{trailing}{end}" for t, u, y in zip(T.tolist(), U.tolist(), Y.tolist(), strict=True)]


ODD_FILES = {
    "crlf": "time,input,velocity\r\n" + "".join(rows(end="\r\n")),
    "trailing_comma": "time,input,velocity,\n" + "".join(rows(trailing=",")),
    "semicolon": "time;input;velocity\n" + "".join(rows(";")),
    "tab": "time\tinput\tvelocity\n" + "".join(rows("\t")),
    "comments_and_blank_lines_first": "# DAQ log\n# rate 1 kHz\n\ntime,input,velocity\n" + "".join(rows()),
    "blank_lines_in_body": "time,input,velocity\n" + "".join(r + ("\n" if k % 50 == 7 else "")
                                                         for k, r in enumerate(rows())),
    "text_column": "time,date,input,velocity\n" + "".join(
        r.replace(",", ",2026-01-01,", 1) for r in rows()),
    "signs_and_exponents": "time,input,velocity\n" + "".join(
        f"{t:.6e},+{u:.3f},{y:+.17g}\n" for t, u, y in zip(T, U, Y, strict=True)),
    "no_last_line_feed": "time,input,velocity\n" + "".join(rows()).rstrip("\n"),
    "latin1_text_column": "time,note,input,velocity\n" + "".join(
        r.replace(",", ",Drehzahl \xb0C \xe9t\xe9,", 1) for r in rows()),
    "spaces_around_cells": "time, input, velocity\n" + "".join(r.replace(",", " , ") for r in rows()),
}


def expected(text: str) -> dict[str, np.ndarray]:
    """An independent parse: ``float`` on the cells of the lines that hold numbers."""
    lines = [ln for ln in text.replace("\r", "").split("\n") if ln.strip() and not ln.startswith("#")]
    delim = max((",", ";", "\t"), key=lines[0].count)
    names = [n.strip() for n in lines[0].split(delim)]
    cells = [ln.split(delim) for ln in lines[1:]]
    return {n: np.array([float(c[j]) for c in cells]) for j, n in enumerate(names)
            if n in ("time", "input", "velocity")}


BAD = {
    # (text of the bad line, error type, words of the message)
    "word": ("0.1,5.92,abc", CaptureFormatError, "cannot read 'abc' as a number"),
    "short_row": ("0.1,5.92", CaptureFormatError, "2 fields but the header has 3"),
    "long_row": ("0.1,5.92,1.0,7", CaptureFormatError, "4 fields but the header has 3"),
    "empty_cell": ("0.1,,1.0", CaptureFormatError, "empty cell"),
    "nan": ("0.1,5.92,nan", CaptureDataError, "not a finite number"),
}


def have_pyarrow() -> bool:
    """Whether pyarrow's CSV reader imports."""
    try:
        import pyarrow.csv  # noqa: F401
    except ImportError:
        return False
    return True


def have_pandas3() -> bool:
    """Whether pandas 3 imports (pandas 2 is not used: its float parser may round differently)."""
    try:
        import pandas
    except ImportError:
        return False
    return int(pandas.__version__.split(".")[0]) >= 3


def parsers() -> list[str]:
    """The fast parsers this install has, each a ``pytest.param`` skipped when it is missing."""
    return [pytest.param("pyarrow", marks=pytest.mark.skipif(not have_pyarrow(), reason="pyarrow is not installed")),
            pytest.param("pandas", marks=pytest.mark.skipif(not have_pandas3(), reason="pandas 3 is not installed")),
            "loadtxt"]


def installed_parsers() -> list[str]:
    """The names of the fast parsers this install has, in the reader's order (``loadtxt`` always)."""
    return [name for name, have in (("pyarrow", have_pyarrow()), ("pandas", have_pandas3()), ("loadtxt", True))
            if have]


def use_parser(monkeypatch: pytest.MonkeyPatch, parser: str) -> None:
    """Read the numbers of any file with ``parser`` (``pyarrow``, ``pandas`` or ``loadtxt``) first.

    The parsers before it in the reader's order are made unimportable, and its size threshold is
    one byte; what it refuses still goes to the next (as in use).
    """
    if parser == "pyarrow":
        monkeypatch.setattr(_common, "PYARROW_MIN_BYTES", 1)
        return
    monkeypatch.setitem(sys.modules, "pyarrow.csv", None)  # import pyarrow.csv → ImportError
    if parser == "pandas":
        monkeypatch.setattr(_common, "PANDAS_MIN_BYTES", 1)
    else:
        monkeypatch.setitem(sys.modules, "pandas", None)
