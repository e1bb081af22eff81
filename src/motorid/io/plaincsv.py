"""Plain CSV captures: a header row naming ``time`` and the channel columns (DAQ/Arduino logs).

Delimiters: comma, semicolon, tab or spaces; a decimal comma is read with a semicolon or tab
delimiter (the European spreadsheet default).  Leading ``#`` comment lines and blank lines
are skipped; every error names the line a user opens in an editor.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from motorid.capture import Capture
from motorid.errors import CaptureFormatError, MotorIdError
from motorid.io._common import (
    LineOfSample,
    NoFastPathError,
    PathLike,
    binary_kind,
    check_capture_file,
    read_fast_or_careful,
    decode_text,
    iter_lines,
    load_column_arrays,
    parse_number,
    read_head,
    read_text,
    split_lines,
)
from motorid.io._table import DATETIME_CELL, capture_from_table, check_role

__all__ = ["PLAIN_FORMAT", "read_plain_csv", "sniff_table"]

PLAIN_FORMAT = "plain-csv"

_DECIMAL_COMMA_CELL = re.compile(r"^\s*[+-]?\d*,\d+([eE][+-]?\d+)?\s*$")


def _delimiter(header: str) -> str | None:
    """The delimiter of a header line: the most frequent of ``,`` ``;`` tab; ``None`` = spaces."""
    counts = {d: header.count(d) for d in (",", ";", "\t")}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] else None


def _split(line: str, delim: str | None) -> list[str]:
    if delim is None:
        return line.split()
    if '"' not in line:
        return line.split(delim)
    try:
        return next(csv.reader([line], delimiter=delim))
    except csv.Error:  # a stray carriage return in an open quote: not a table's line, split as it stands
        return line.split(delim)


#: A units row's cell under the time column: ``(ms)``, ``[s]``, ``us``, ``µs``.
_TIME_UNIT_CELL = re.compile(r"^\s*[(\[]?\s*(s|sec|ms|us|µs|μs|ns)\s*[)\]]?\s*$", re.IGNORECASE)
#: Any units row's cell: a short unit in optional brackets (``(V)``, ``[rpm]``, ``rad/s``, ``°``).
_UNIT_CELL = re.compile(r"^\s*[(\[]?\s*[A-Za-zµμΩ°%/*^·.0-9 _-]{0,16}\s*[)\]]?\s*$")


def _with_units_row(names: Sequence[str], cells: Sequence[str]) -> list[str] | None:
    """The header names with a units row merged in (``Time`` + ``(ms)`` → ``Time (ms)``), or None.

    PicoScope's CSV export and many DAQ programs write the units on a second header line.  A
    line is taken for one when it has the header's number of fields, no number among them, a
    unit-like cell in each, and a time unit in one (the table's time column); the merged names
    carry the units the way a one-line header writes them (``time [ms]``, ``speed (rpm)``), so
    the time column is converted and each channel labelled as if the header had said so.
    """
    if len(cells) != len(names) or not any(_TIME_UNIT_CELL.match(c) for c in cells):
        return None
    if any(parse_number(c) is not None for c in cells if c.strip()) or not all(_UNIT_CELL.match(c) for c in cells):
        return None
    merged = []
    for name, unit in zip(names, cells, strict=True):
        inner = unit.strip().strip("()[]").strip()
        merged.append(f"{name.strip()} ({inner})" if inner else name)
    return merged


#: One ``label:value`` pair of an Arduino Serial Plotter line (``t:0.01,u:5.0,rpm:812``).
_PAIR = re.compile(r"([A-Za-z_][\w ]*?)\s*[:=]\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")
#: A whole line of such pairs, separated by commas, semicolons, tabs or spaces.
_LABELLED_LINE = re.compile(r"^\s*" + _PAIR.pattern + r"(?:\s*[,;\t ]\s*" + _PAIR.pattern + r")+\s*$")


def _labelled(lines: Sequence[str], idx: Sequence[int], file: str
              ) -> tuple[list[str], list[list[str]], list[int], list[str]] | None:
    """The labels, rows, their line indices and notes of a log of ``label:value`` pairs, or None.

    Arduino's Serial Plotter reads (and so many sketches print) ``t:0.01,u:5.0,rpm:812``: the
    labels are the column names.  A line whose labels differ from the first line's is named; the
    last line alone, cut in the middle (the logger stopped while writing it), is dropped and said.
    """
    if not idx or not _LABELLED_LINE.match(lines[idx[0]]):
        return None
    names = [k.strip() for k, _ in _PAIR.findall(lines[idx[0]])]
    rows, kept, notes = [], [], []
    for n, i in enumerate(idx):
        pairs = _PAIR.findall(lines[i]) if _LABELLED_LINE.match(lines[i]) else []
        if [k.strip() for k, _ in pairs] != names:
            if n == len(idx) - 1 and n > 1:
                notes.append(f"line {i + 1}, the last, is not a whole line of {', '.join(names)} (the log stopped "
                             "in the middle of it): dropped")
                break
            raise CaptureFormatError(f"not the labels of the first line ({', '.join(names)}): a log of "
                                     "label:value pairs needs the same labels on every line", file=file, row=i + 1)
        rows.append([v for _, v in pairs])
        kept.append(i)
    return names, rows, kept, notes


def _content_lines(lines: Sequence[str]) -> list[int]:
    """Indices of the lines that hold data or the header (no blank or ``#`` comment lines)."""
    return [i for i, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith("#")]


#: Lines of a headerless table that must all be rows of numbers of one width (or the file's all).
HEADERLESS_LINES = 20


def _headerless(lines: Sequence[str], idx: Sequence[int]) -> tuple[str | None, int, bool] | None:
    """``(delimiter, width, decimal_comma)`` of a table with no header row, or None.

    An Arduino sketch that prints ``millis(),volts,rpm`` with no header line writes one: its
    first :data:`HEADERLESS_LINES` content lines are each two or more numbers, all as many.
    """
    first = idx[:HEADERLESS_LINES]
    if len(first) < 2:
        return None
    # a header names the delimiter; numbers alone may hold more decimal commas than semicolons
    for delim in (";", "\t", ",", None):
        split = [_split(lines[i], delim) for i in first]
        width = len(split[0])
        if width < 2 or any(len(r) != width for r in split):
            continue
        decimal_comma = delim != "," and any(_DECIMAL_COMMA_CELL.match(c) for r in split for c in r)
        if all(parse_number(c, decimal_comma=decimal_comma) is not None for r in split for c in r):
            return delim, width, decimal_comma
    return None


def _names_columns(columns: Mapping[str, str] | None) -> bool:
    """Whether a column map names a column (``time_unit`` alone, from ``--time-unit``, names none)."""
    return any(key != "time_unit" for key in (columns or {}))


def headerless_names(width: int) -> list[str]:
    """The names of a headerless table's columns: their positions, ``"1"`` … (what ``--columns`` maps)."""
    return [str(j + 1) for j in range(width)]


def _headerless_refusal(lines: Sequence[str], idx: Sequence[int], delim: str | None, decimal_comma: bool,
                        file: str) -> CaptureFormatError:
    """No header and no ``--columns``: say so, with the mapping the first rows suggest."""
    rows = [_split(lines[i], delim) for i in idx[:2000]]
    values = np.array([[parse_number(c, decimal_comma=decimal_comma) or 0.0 for c in r] for r in rows
                       if len(r) == len(rows[0])])
    width = values.shape[1]
    steps = np.diff(values, axis=0)
    time = next((j for j in range(width) if np.all(steps[:, j] > 0)), None)
    levels = [j for j in range(width) if j != time and 1 < np.unique(values[:, j]).size <= 4]
    inp = levels[0] if levels else None
    out = next((j for j in range(width) if j not in (time, inp)), None)
    parts = [f"{role}={j + 1}" for role, j in (("time", time), ("input", inp), ("velocity", out)) if j is not None]
    seen = []
    if time is not None:
        seen.append(f"column {time + 1} increases on every line, like a time")
    if inp is not None:
        seen.append(f"column {inp + 1} holds {np.unique(values[:, inp]).size} levels, like a step input")
    hint = (f" — e.g. --columns {','.join(parts)} ({'; '.join(seen)}; name what the other column measures: "
            "velocity, position or current)") if time is not None and out is not None else ""
    return CaptureFormatError(
        f"no header row: the first line is already numbers ({width} columns). Name the columns by their "
        f"position, 1 to {width}, with --columns{hint}",
        file=file, row=idx[0] + 1)


def sniff_table(lines: Sequence[str]) -> tuple[str | None, bool] | None:
    """Whether text lines are a headed numeric table; its delimiter and decimal-comma flag.

    Parameters
    ----------
    lines : sequence of str
        The first lines of the file.

    Returns
    -------
    tuple or None
        ``(delimiter, decimal_comma)`` (delimiter ``None`` means runs of spaces) when the
        first content line names at least two columns, not all numbers, and the next has the
        same number of fields, mostly numbers; else ``None``.
    """
    idx = _content_lines(lines[:200])
    if len(idx) < 2:
        return None
    if _LABELLED_LINE.match(lines[idx[0]]) and _LABELLED_LINE.match(lines[idx[1]]):
        return ",", False  # label:value pairs (read by the careful reader)
    header, first = lines[idx[0]], lines[idx[1]]
    delim = _delimiter(header)
    names = _split(header, delim)
    cells = _split(first, delim)
    bare = _headerless(lines, idx)
    if bare is not None:
        return bare[0], bare[2]
    if len(idx) > 2 and _with_units_row(names, cells) is not None:
        idx = [idx[0], *idx[2:]]
        cells = _split(lines[idx[1]], delim)
    if len(names) < 2 or len(cells) != len(names):
        return None
    decimal_comma = delim in (";", "\t", None) and any(
        _DECIMAL_COMMA_CELL.match(c) for i in idx[1:] for c in _split(lines[i], delim))
    if all(parse_number(n, decimal_comma=decimal_comma) is not None for n in names if n.strip()):
        return None
    numbers = sum(parse_number(c, decimal_comma=decimal_comma) is not None for c in cells)
    return (delim, decimal_comma) if numbers >= max(2, (len(cells) + 1) // 2) else None


def read_plain_csv(
    path: PathLike,
    *,
    columns: Mapping[str, str] | None = None,
    role: str | None = None,
) -> Capture:
    """Read a plain CSV log whose header row names the time and channel columns.

    Parameters
    ----------
    path : str or PathLike
        The CSV file.
    columns : Mapping[str, str], optional
        Role → column name, keys ``time``, ``input``, ``position``, ``velocity``,
        ``current``, ``output`` (e.g. ``{"time": "t", "input": "u", "velocity": "rpm"}``).
        Roles not mapped are guessed from the header names (case-insensitive keywords:
        time/t/zeit/sec/s; input/u/voltage/volt/vin/ch1/Motorspannung; speed/velocity/rpm/
        tacho/omega; position/angle/theta/pos/encoder; current/ia/amp/strom).  Setpoint
        columns (setpoint, soll, ref) are never the input.  A time column named in ms or µs
        (``t_ms``, ``millis``) is converted to seconds.
    role : str, optional
        The output's role when several measured columns exist or the names do not say it.

    Returns
    -------
    Capture
        ``format = "plain-csv"``.  With both a velocity and a position column the output is
        the velocity (``role_hint = "velocity"``) and the position goes to
        ``extra["position"]``; every other numeric column goes to ``extra`` by its header.

    Raises
    ------
    OptionError
        Unknown mapping key, a mapped column not in the header (listing the columns), a bad
        ``role``.
    CaptureFormatError
        Missing, binary or empty file, no header row, no time or output column, a row with
        another number of fields than the header, a non-numeric cell (naming ``file:row``).
    CaptureDataError
        NaN, duplicated, backwards or non-uniform time (naming ``file:row``).
    """
    check_role(role)
    file = str(path)
    size = check_capture_file(path)
    return read_fast_or_careful(
        file, size, lambda: _read_fast(path, file, columns, role, size),
        lambda: _read_careful(path, file, columns, role),
        lambda: _first_bad_line(path, file), "save it as a comma-separated CSV with a '.' decimal point")


def _fast_layout(path: PathLike, file: str, headerless: bool = False) -> tuple[int, str | None, list[str], list[str]]:
    """From the file's first 64 KiB: header line index, delimiter, names, first data cells.

    ``headerless``: a table with no header row is read with its columns named by position
    (the caller was given ``columns``); otherwise it goes to the careful reading, which says how
    to name them.
    """
    head = read_head(path)
    if head.startswith((b"\xff\xfe", b"\xfe\xff")) or binary_kind(head[:8192]) is not None:
        raise NoFastPathError("it is UTF-16 or binary")
    if b'"' in head:
        raise NoFastPathError("it has quoted fields")
    cut = head.rfind(b"\n")
    text = decode_text(head[: cut + 1] if cut > 0 else head, file=file)
    lines = split_lines(text)
    idx = _content_lines(lines)
    if len(idx) < 2:
        raise NoFastPathError("it has fewer than two lines")
    h = idx[0]
    if _LABELLED_LINE.match(lines[h]):
        raise NoFastPathError("it writes label:value pairs")
    delim = _delimiter(lines[h])
    names = _split(lines[h], delim)
    first = _split(lines[idx[1]], delim)
    bare = _headerless(lines, idx)
    if bare is not None and not headerless:
        raise _headerless_refusal(lines, idx, bare[0], bare[2], file)
    if bare is not None and bare[2]:
        raise NoFastPathError("it uses a decimal comma")
    if bare is not None:
        # the data start on the first content line: the "header" is the line before it
        return h - 1, bare[0], headerless_names(bare[1]), _split(lines[h], bare[0])
    if len(names) < 2 or all(parse_number(n) is not None for n in names if n.strip()):
        raise NoFastPathError("it has no header row")
    merged = _with_units_row(names, first)
    if merged is not None:
        # the data start after the units row: it is read as the last line of the header
        if len(idx) < 3:
            raise NoFastPathError("it has no data after its units row")
        names, h, idx = merged, idx[1], idx[1:]
        first = _split(lines[idx[1]], delim)
    if delim in (";", "\t", None) and any(_DECIMAL_COMMA_CELL.match(c) for i in idx[1:21]
                                          for c in _split(lines[i], delim)):
        raise NoFastPathError("it uses a decimal comma")
    if _comment_between(lines, h, idx[1]):
        raise NoFastPathError("it has comment lines after the header")
    return h, delim, names, first


def _comment_between(lines: Sequence[str], h: int, first: int) -> bool:
    """Whether a '#' comment line sits between the header and the first data line."""
    return any(lines[k].lstrip().startswith("#") for k in range(h + 1, first))


def _read_fast(path: PathLike, file: str, columns: Mapping[str, str] | None, role: str | None,
               size: int = 0) -> Capture:
    """The common case with a C parser (numpy's, or pandas' on a large file): header, then numbers."""
    h, delim, names, first = _fast_layout(path, file, headerless=_names_columns(columns))
    width = len(names)
    if not names[-1].strip() and len(first) == width and not first[-1].strip():
        names, width = names[:-1], width - 1  # a trailing delimiter on every line
    if len(first) < width:
        raise ValueError("short first data line")
    numeric = [j for j in range(width) if parse_number(first[j]) is not None]
    if not numeric:
        # (a header line twice, a text table): the careful reading names what is wrong
        raise NoFastPathError("its first data row has no number")
    if any(DATETIME_CELL.match(first[j]) for j in range(width) if j not in numeric):
        raise NoFastPathError("it stamps its rows with a clock (date and time)")
    # all columns numeric: numpy also checks that every line has the same number of fields
    usecols = None if len(numeric) == len(first) else numeric
    arrays = load_column_arrays(path, skiprows=h + 1, delimiter=delim, usecols=usecols, size=size)
    n = arrays[0].shape[0]
    cells: list[Sequence[object] | np.ndarray] = []
    for j in range(width):
        # a text column (a date, a comment) is left out; its first cell tells the table so
        cells.append(arrays[numeric.index(j)] if j in numeric else [first[j]])
    rows = LineOfSample(path, h + 1, n)
    return capture_from_table(names, cells, rows, file=file, fmt=PLAIN_FORMAT, columns=columns, role=role)


def _first_bad_line(path: PathLike, file: str) -> MotorIdError:
    """The careful check of a large file, streamed: the first line that is not a row of numbers."""
    h, delim, names, first = _fast_layout(path, file, headerless=True)
    width = len(names)
    trailing = not names[-1].strip() and len(first) == width and not first[-1].strip()
    numeric = [j for j in range(width) if parse_number(first[j]) is not None]
    for number, line in iter_lines(path, h + 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = _split(line, delim)
        if len(cells) != width:
            return CaptureFormatError(f"{len(cells) - trailing} fields but the header has {width - trailing}",
                                      file=file, row=number)
        for j in numeric:
            if parse_number(cells[j]) is None:
                text = cells[j].strip()
                problem = "empty cell" if not text else f"cannot read {text[:40]!r} as a number"
                return CaptureFormatError(f"column {names[j].strip()!r}: {problem}", file=file, row=number)
    return CaptureFormatError("cannot read the file as a table of numbers", file=file)


def _read_careful(path: PathLike, file: str, columns: Mapping[str, str] | None, role: str | None) -> Capture:
    """Row by row, every line split and every cell checked (small files and error messages)."""
    lines = split_lines(read_text(Path(path)))
    idx = _content_lines(lines)
    if len(idx) < 2:
        raise CaptureFormatError("not a capture: fewer than two non-blank lines", file=file)
    labelled = _labelled(lines, idx, file)
    if labelled is not None:
        label_names, label_rows, kept, label_notes = labelled
        return capture_from_table(label_names, [[r[j] for r in label_rows] for j in range(len(label_names))],
                                  np.asarray(kept) + 1, file=file, fmt=PLAIN_FORMAT, columns=columns, role=role,
                                  warnings=["label:value pairs on every line (Arduino Serial Plotter): the labels "
                                            f"are the columns, {', '.join(label_names)}", *label_notes])
    h = idx[0]
    delim = _delimiter(lines[h])
    names = _split(lines[h], delim)
    if len(names) < 2:
        raise CaptureFormatError(
            "not a capture: one column only; a plain CSV needs a header naming time and channel columns",
            file=file, row=h + 1,
        )
    bare = _headerless(lines, idx)
    if bare is not None and not _names_columns(columns):
        raise _headerless_refusal(lines, idx, bare[0], bare[2], file)
    if bare is not None:
        delim = bare[0]
    if bare is None and all(parse_number(n) is not None for n in names if n.strip()):
        raise CaptureFormatError(
            "no header row: the first line must name the columns (e.g. time,input,velocity)",
            file=file, row=h + 1,
        )
    data_idx = idx[1:]
    if bare is not None:
        names, data_idx = headerless_names(bare[1]), list(idx)
    merged = None if bare is not None else _with_units_row(names, _split(lines[idx[1]], delim))
    if merged is not None:
        names, data_idx = merged, idx[2:]
        if not data_idx:
            raise CaptureFormatError("no data rows after the header and its units row", file=file, row=idx[1] + 1)
    rows_split = [_split(lines[i], delim) for i in data_idx]
    width = len(names)
    if not names[-1].strip() and all(len(r) == width and not r[-1].strip() for r in rows_split):
        names = names[:-1]  # a trailing delimiter on every line
        rows_split = [r[:-1] for r in rows_split]
        width -= 1
    bad = next((k for k, r in enumerate(rows_split) if len(r) != width), None)
    notes: list[str] = []
    if bad is not None and bad == len(rows_split) - 1 and 0 < len(rows_split[bad]) < width and bad > 0:
        # a logger stopped (or reset) in the middle of its last line: that line only is dropped, and said
        notes.append(f"line {data_idx[bad] + 1}, the last, has {len(rows_split[bad])} of {width} fields (the log "
                     "stopped in the middle of it): dropped")
        rows_split, data_idx, bad = rows_split[:-1], data_idx[:-1], None
    if bad is not None:
        raise CaptureFormatError(
            f"{len(rows_split[bad])} fields but the header has {width}", file=file, row=data_idx[bad] + 1
        )
    # a log may write whole numbers for a while (0;0;0 before the step): every row decides
    decimal_comma = delim in (";", "\t", None) and any(_DECIMAL_COMMA_CELL.match(c) for r in rows_split for c in r)
    cells = [[r[j] for r in rows_split] for j in range(width)]
    rows = np.asarray(data_idx) + 1
    return capture_from_table(names, cells, rows, file=file, fmt=PLAIN_FORMAT, columns=columns, role=role,
                              decimal_comma=decimal_comma, warnings=notes)
