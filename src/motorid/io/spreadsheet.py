"""Spreadsheet (``.xlsx``) captures as OpenChoice writes them: channel blocks side by side.

Masoud 2019, Fig. 21 ("Excel sheet from digital oscilloscope"): each channel is a block of
the Tektronix CSV columns — metadata label, metadata value, (units or empty), time, value —
and the blocks of CH1 and CH2 stand side by side, often under a header row such as
``Time, Position, Time, Speed``.  A sheet holding just a header row and columns (a logged
table, like the plain CSV) is read too.
"""

from __future__ import annotations

import io
import math
import re
import warnings
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from motorid.capture import ROLES, Capture, ChannelInfo, ScopeInfo
from motorid.errors import CaptureDataError, CaptureFormatError, MotorIdError, OptionError
from motorid.io._common import PathLike, check_writable, column_to_floats, parse_number, rail_clipping_warning
from motorid.io._common import read_bytes, validate_rows
from motorid.io._table import capture_from_table, check_role, classify_name
from motorid.io.tektronix import META_ROWS, NUMERIC_META, Meta, meta_key, meta_number, meta_text

__all__ = ["XLSX_FORMAT", "read_xlsx_capture", "write_openchoice_xlsx"]

XLSX_FORMAT = "xlsx"

#: Largest workbook file read (bytes, compressed).
MAX_XLSX_BYTES = 64 * 1024 * 1024
#: Largest uncompressed content of a workbook (sum over its zip members, from the zip
#: directory, checked before parsing): 64 MiB of XML is about a million cells (300 000 rows
#: of three columns), some 20 s of openpyxl.  An OpenChoice sheet of 2500 rows is 2 MiB.
MAX_XLSX_UNCOMPRESSED = 64 * 1024 * 1024
#: Largest compression ratio of a zip member above 1 MiB: spreadsheet XML compresses 5–20×;
#: a "zip bomb" (1.5 GB of repeated shared strings) thousands of times.
MAX_XLSX_RATIO = 100

_DECIMAL_COMMA = re.compile(r"^\s*[+-]?\d+,\d*([eE][+-]?\d+)?\s*$")
_HEADER_BY_ROLE = {"velocity": "Speed", "position": "Position", "current": "Current"}


def _col_letter(j: int) -> str:
    s = ""
    j += 1
    while j:
        j, r = divmod(j - 1, 26)
        s = chr(65 + r) + s
    return s


def _cell_number(v: object) -> float | None:
    x = parse_number(v)
    if x is None and isinstance(v, str) and _DECIMAL_COMMA.match(v):
        x = parse_number(v, decimal_comma=True)
    return x


@dataclass(frozen=True, slots=True)
class _Grid:
    """A sheet's cells with their numeric/text classification."""

    cells: list[list[object]]
    num: np.ndarray  # float values (NaN where not a number)
    isnum: np.ndarray  # bool
    istext: np.ndarray  # bool: non-empty and not a number
    sheet: str

    @property
    def shape(self) -> tuple[int, int]:
        return self.num.shape


def _grid(rows: list[tuple], sheet: str) -> _Grid:
    width = max((len(r) for r in rows), default=0)
    cells = [list(r) + [None] * (width - len(r)) for r in rows]
    num = np.full((len(cells), width), np.nan)
    isnum = np.zeros((len(cells), width), dtype=bool)
    istext = np.zeros((len(cells), width), dtype=bool)
    for i, row in enumerate(cells):
        for j, v in enumerate(row):
            if v is None or (isinstance(v, str) and not v.strip()):
                continue
            x = _cell_number(v)
            if x is None:
                istext[i, j] = True
            else:
                num[i, j], isnum[i, j] = x, True
    return _Grid(cells, num, isnum, istext, sheet)


def _time_columns(g: _Grid) -> list[tuple[int, int]]:
    """(column, first data row) of every column that looks like a time axis followed by values.

    A column's data start at its first two consecutive numeric cells (headers above are text)
    and end at its last filled cell.  It is a time column when at least 90 % of the steps
    between its numbers increase and the column to its right is numeric on 90 % of those
    rows; the few corrupt cells this tolerates are then reported by the row checks, not
    skipped.
    """
    out = []
    n_cols = g.shape[1]
    c = 0
    while c < n_cols - 1:
        col = g.isnum[:, c]
        starts = np.flatnonzero(col[:-1] & col[1:])
        if starts.size:
            r0 = int(starts[0])
            r1 = _last_row(g, c, r0)
            ok = g.isnum[r0:r1 + 1, c]
            t = g.num[r0:r1 + 1, c][ok]
            with np.errstate(invalid="ignore"):
                rising = np.count_nonzero(np.diff(t) > 0)
            values_ok = np.count_nonzero(g.isnum[r0:r1 + 1, c + 1])
            if rising >= 0.9 * (t.size - 1) and values_ok >= 0.9 * (r1 + 1 - r0):
                out.append((c, r0))
                c += 2
                continue
        c += 1
    return out


def _last_row(g: _Grid, c: int, r0: int) -> int:
    filled = np.flatnonzero(g.isnum[r0:, c] | g.istext[r0:, c])
    return r0 + int(filled[-1]) if filled.size else r0


@dataclass(frozen=True, slots=True)
class _Block:
    time_s: np.ndarray
    values: np.ndarray
    meta: Meta
    header: str | None
    column: str  # letter of the value column


def _block_meta(g: _Grid, lo: int, hi: int, r_end: int) -> Meta:
    """Metadata label/value pairs in columns lo..hi-1 (left of a block's time column)."""
    meta: Meta = {}
    for r in range(min(r_end, g.shape[0])):
        row = g.cells[r]
        for j in range(lo, hi):
            key = meta_key(row[j]) if g.istext[r, j] else None
            if key is None:
                continue
            value = next((row[k] for k in range(j + 1, hi) if g.istext[r, k] or g.isnum[r, k]), None)
            if key in NUMERIC_META:
                x = _cell_number(value)
                if x is not None and math.isfinite(x):
                    meta.setdefault(key, x)
            elif value is not None:
                meta.setdefault(key, str(value).strip())
            break
    return meta


def _header(g: _Grid, r0: int, lo: int, c: int) -> str | None:
    """The name above a block's value column (or elsewhere over the block, not 'Time')."""
    if r0 == 0:
        return None
    r = r0 - 1
    if g.istext[r, c + 1]:
        return str(g.cells[r][c + 1]).strip()
    for j in range(c, lo - 1, -1):
        if g.istext[r, j] and classify_name(str(g.cells[r][j])) != "time" and meta_key(g.cells[r][j]) is None:
            return str(g.cells[r][j]).strip()
    return None


def _read_block(g: _Grid, c: int, r0: int, lo: int, file: str) -> _Block:
    r1 = max(_last_row(g, c, r0), _last_row(g, c + 1, r0))
    rows = np.arange(r0 + 1, r1 + 2)
    where = f"sheet {g.sheet!r} column"
    t = column_to_floats([g.cells[r][c] for r in range(r0, r1 + 1)], rows, file=file,
                         what=f"{where} {_col_letter(c)} (time)")
    v = column_to_floats([g.cells[r][c + 1] for r in range(r0, r1 + 1)], rows, file=file,
                         what=f"{where} {_col_letter(c + 1)}")
    meta = _block_meta(g, lo, c, r1 + 1)
    rl = meta_number(meta, "record_length")
    if rl is not None and int(rl) != t.size:
        if t.size < rl:
            raise CaptureDataError(f"sheet {g.sheet!r} column {_col_letter(c)}: truncated: {t.size} of the "
                                   f"{int(rl)} samples its Record Length says", file=file)
        raise CaptureDataError(f"sheet {g.sheet!r} column {_col_letter(c)}: {t.size} samples but Record "
                               f"Length says {int(rl)}: the sheet was edited", file=file)
    validate_rows(t, {f"column {_col_letter(c + 1)}": v}, file=file, rows=rows)
    return _Block(t, v, meta, _header(g, r0, lo, c), _col_letter(c + 1))


def _ch_number(source: object) -> int | None:
    m = re.fullmatch(r"\s*CH(\d)\s*", source, re.IGNORECASE) if isinstance(source, str) else None
    return int(m.group(1)) if m else None


def _channel_info(b: _Block, fallback: str) -> ChannelInfo:
    m = b.meta
    return ChannelInfo(
        name=str(m.get("source") or b.header or fallback),
        units=str(m.get("vertical_units") or "V"),
        vertical_scale=meta_number(m, "vertical_scale"),
        vertical_offset=meta_number(m, "vertical_offset"),
        probe_atten=meta_number(m, "probe_atten"),
        yzero=meta_number(m, "yzero"),
    )


def _capture_from_blocks(blocks: list[_Block], g: _Grid, file: str, role: str | None) -> Capture:
    numbers = [_ch_number(b.meta.get("source")) for b in blocks]
    known = [n for n in numbers if n is not None]
    if len(known) == len(numbers) and len(set(known)) == len(known):
        blocks = [b for _, b in sorted(zip(known, blocks, strict=False), key=lambda nb: nb[0])]
    first = blocks[0]
    for b in blocks[1:]:
        same = b.time_s.size == first.time_s.size
        if same:
            dt = float(np.median(np.diff(first.time_s)))
            same = float(np.max(np.abs(b.time_s - first.time_s))) <= 0.01 * dt
        if not same:
            raise CaptureDataError(
                f"sheet {g.sheet!r}: the time columns of {first.column} and {b.column} differ; "
                "the channels must come from one acquisition",
                file=file,
            )
    cats = [classify_name(b.header) if b.header else None for b in blocks]
    outputs = [i for i, cat in enumerate(cats) if cat in (*ROLES, "output")]
    inputs = [i for i, cat in enumerate(cats) if cat == "input"]
    if len(blocks) == 1:
        i_in, i_out = None, 0
    elif inputs:
        i_in = inputs[0]
        i_out = outputs[0] if outputs else next(i for i in range(len(blocks)) if i != i_in)
    elif outputs:
        # Two outputs and no step channel (Fig. 21 names its blocks Position and Speed).
        i_in, i_out = None, outputs[0]
    else:
        i_in, i_out = 0, 1
    if role is not None and cats[i_out] != role and role in cats:
        i_out = cats.index(role)
        if i_in == i_out:
            i_in = None
    out = blocks[i_out]
    hint = role or (cats[i_out] if cats[i_out] in ROLES else None)
    extra: dict[str, np.ndarray] = {}
    for i, b in enumerate(blocks):
        if i in (i_in, i_out):
            continue
        cat = cats[i]
        named = b.header or str(b.meta.get("source") or f"column {b.column}")
        key = cat if cat is not None and cat in ROLES else named
        while key in extra:
            key += "_"
        extra[key] = b.values
    notes = []
    for i, b in enumerate(blocks):
        info = _channel_info(b, f"CH{i + 1}")
        clip = rail_clipping_warning(b.values, info, f"sheet {g.sheet!r} column {b.column} ({info.name})")
        if clip:
            notes.append(clip)
    m = blocks[i_in if i_in is not None else i_out].meta
    tp = meta_number(m, "trigger_point")
    rl = meta_number(m, "record_length")
    scope = ScopeInfo(
        model=meta_text(m, "model"), serial=meta_text(m, "serial"), firmware=meta_text(m, "firmware"),
        record_length=None if rl is None else int(rl), horizontal_scale_s=meta_number(m, "horizontal_scale"),
        trigger_index=None if tp is None else round(tp),
    )
    return Capture(
        source=file,
        format=XLSX_FORMAT,
        time_s=first.time_s,
        output_v=out.values,
        output_info=_channel_info(out, "CH2"),
        input_v=None if i_in is None else blocks[i_in].values,
        input_info=None if i_in is None else _channel_info(blocks[i_in], "CH1"),
        scope=scope,
        role_hint=hint,
        extra=extra,
        warnings=tuple(notes),
    )


def _is_block_layout(g: _Grid, tcols: list[tuple[int, int]]) -> bool:
    """Scope blocks (metadata labels, or several identical time columns) vs one table."""
    keys = {meta_key(g.cells[r][j]) for r in range(min(g.shape[0], 60)) for j in range(g.shape[1]) if g.istext[r, j]}
    keys.discard(None)
    if len(keys) >= 2:
        return True
    c0, r0 = tcols[0]
    n = _last_row(g, c0, r0) + 1 - r0
    t0 = g.num[r0:r0 + n, c0]
    same = sum(1 for c, r in tcols[1:] if r == r0 and np.array_equal(g.num[r:r + n, c], t0, equal_nan=True))
    return same >= 1 or r0 == 0 or not g.istext[r0 - 1].any()


def _capture_from_sheet(
    g: _Grid, file: str, columns: Mapping[str, str] | None, role: str | None
) -> Capture:
    tcols = _time_columns(g)
    if _is_block_layout(g, tcols):
        if columns:
            raise OptionError("columns= applies to plain tables; this sheet holds oscilloscope channel blocks",
                              file=file)
        blocks = []
        lo = 0
        for c, r0 in tcols:
            blocks.append(_read_block(g, c, r0, lo, file))
            lo = c + 2
        return _capture_from_blocks(blocks, g, file, role)
    c0, r0 = tcols[0]
    r1 = _last_row(g, c0, r0)
    hr = r0 - 1
    cols = [j for j in range(g.shape[1]) if g.istext[hr, j]]
    names = [str(g.cells[hr][j]).strip() for j in cols]
    cells = [[g.cells[r][j] for r in range(r0, r1 + 1)] for j in cols]
    return capture_from_table(names, cells, np.arange(r0 + 1, r1 + 2), file=file, fmt=XLSX_FORMAT,
                              columns=columns, role=role, where=f"sheet {g.sheet!r} column")


def _one_line(exc: BaseException, limit: int = 160) -> str:
    """An exception's text on one line (openpyxl's messages hold newlines), shortened."""
    text = " ".join(str(exc).split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _check_zip_sizes(zf: zipfile.ZipFile, file: str) -> None:
    """Refuse a workbook whose zip directory promises too much XML (before parsing any)."""
    total = 0
    for info in zf.infolist():
        total += info.file_size
        if info.file_size > 2**20 and info.file_size > MAX_XLSX_RATIO * max(info.compress_size, 1):
            raise CaptureFormatError(
                f"refused: {info.filename} expands {info.file_size / max(info.compress_size, 1):.0f}-fold to "
                f"{info.file_size / 2**20:.0f} MiB (a zip bomb?); save the capture as CSV", file=file)
    if total > MAX_XLSX_UNCOMPRESSED:
        raise CaptureFormatError(
            f"refused: the workbook holds {total / 2**20:.0f} MiB of XML, above the {MAX_XLSX_UNCOMPRESSED >> 20} MiB "
            "read from spreadsheets; save the capture as CSV (read up to 512 MiB)", file=file)


def _open_workbook(path: Path, file: str):
    import openpyxl  # deferred: only spreadsheet users pay for the import

    data = read_bytes(path, max_bytes=MAX_XLSX_BYTES)
    if not data.startswith(b"PK\x03\x04"):
        raise CaptureFormatError("not a capture: not an .xlsx workbook (no zip signature)", file=file)
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            if "xl/workbook.xml" not in zf.namelist():
                raise CaptureFormatError("not a capture: a zip archive, not an .xlsx workbook", file=file)
            _check_zip_sizes(zf, file)
        with warnings.catch_warnings():
            # openpyxl warns about styles and extensions it ignores; they do not matter here
            warnings.simplefilter("ignore")
            # a file object, because openpyxl refuses names not ending in .xlsx/.xlsm
            return openpyxl.load_workbook(io.BytesIO(data), read_only=True, data_only=True)
    except MotorIdError:
        raise
    except Exception as exc:
        raise CaptureFormatError(f"not a capture: unreadable .xlsx workbook ({type(exc).__name__}: "
                                 f"{_one_line(exc)})", file=file) from exc


def read_xlsx_capture(
    path: PathLike,
    *,
    sheet: str | int | None = None,
    columns: Mapping[str, str] | None = None,
    role: str | None = None,
) -> Capture:
    """Read an OpenChoice-style spreadsheet capture (Masoud 2019, Fig. 21).

    Parameters
    ----------
    path : str or PathLike
        The ``.xlsx`` workbook.
    sheet : str or int, optional
        Sheet name or 0-based index; by default the first sheet that holds a time column.
    columns : Mapping[str, str], optional
        For a plain table sheet: role → column header (as :func:`motorid.io.read_plain_csv`).
    role : str, optional
        Declares the output's role (``position``, ``velocity``, ``current``).

    Returns
    -------
    Capture
        ``format = "xlsx"``.  Channel blocks (a strictly increasing time column followed by a
        value column) are ordered by their ``Source`` metadata, else left to right: the first
        is the input (CH1), the second the output (CH2), the rest go to ``extra``.  Header
        names over the blocks (Position, Speed, Velocity, Tacho, Current…) set
        ``role_hint``; when the headers name only measured quantities (no input), there is
        no input channel and the first named block is the output.

    Raises
    ------
    CaptureFormatError
        Not a workbook, no time/value columns, a non-numeric cell (naming the row and column).
    CaptureDataError
        NaN or bad time axis (naming the row), blocks with different time axes, a block
        shorter than its ``Record Length``.
    OptionError
        Unknown sheet, bad ``columns`` or ``role``.
    """
    check_role(role)
    p = Path(path)
    file = str(path)
    wb = _open_workbook(p, file)
    try:
        names = list(wb.sheetnames)
        if sheet is None:
            candidates = list(range(len(names)))
        elif isinstance(sheet, int) and 0 <= sheet < len(names):
            candidates = [sheet]
        elif isinstance(sheet, str) and sheet in names:
            candidates = [names.index(sheet)]
        else:
            raise OptionError(f"no sheet {sheet!r}; sheets: {', '.join(map(repr, names))}", file=file)
        for k in candidates:
            try:
                rows = list(wb.worksheets[k].iter_rows(min_row=1, min_col=1, values_only=True))
            except Exception as exc:
                raise CaptureFormatError(f"not a capture: unreadable sheet {names[k]!r} ({type(exc).__name__}: "
                                         f"{_one_line(exc)})", file=file) from exc
            g = _grid(rows, names[k])
            if _time_columns(g):
                return _capture_from_sheet(g, file, columns, role)
    finally:
        wb.close()
    raise CaptureFormatError(
        "not a capture: no sheet has a time column followed by a value column", file=file
    )


def write_openchoice_xlsx(path: PathLike, capture: Capture, *, force: bool = False) -> Path:
    """Write a capture as an OpenChoice-style sheet: one TDS column block per channel.

    Block 1 is the input (header ``Input``, Source CH1), block 2 the output (header
    ``Position``/``Speed``/``Current`` from ``role_hint``, else ``Output``; Source CH2), then
    one block per ``extra`` channel headed by its key.  Each block holds the scope's
    metadata labels and values, an empty column, time and value (Masoud 2019, Fig. 21).

    Parameters
    ----------
    path : str or PathLike
        The ``.xlsx`` file to write.
    capture : Capture
        What to write.
    force : bool
        Overwrite an existing file.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    OutputExistsError
        The file exists and ``force`` is false.
    OptionError
        The file cannot be written.
    """
    from openpyxl import Workbook

    p = Path(path)
    check_writable([p], force=force)
    blocks: list[tuple[str, np.ndarray, ChannelInfo]] = []
    if capture.input_v is not None:
        blocks.append(("Input", capture.input_v, _renamed(capture.input_info, "CH1")))
    out_header = _HEADER_BY_ROLE.get(capture.role_hint or "", "Output")
    blocks.append((out_header, capture.output_v, _renamed(capture.output_info, "CH2")))
    for key, values in capture.extra.items():
        blocks.append((key, values, ChannelInfo(name=f"CH{len(blocks) + 1}")))
    t = capture.time_s
    n = t.size
    dt = capture.sample_interval_s
    scope = capture.scope
    trig = scope.trigger_index if scope.trigger_index is not None else round(-t[0] / dt)
    n_rows = max(n, 18)
    wb = Workbook(write_only=True)
    ws = wb.create_sheet("Capture")
    header: list[object] = []
    for name, _, _ in blocks:
        header += [None, None, None, "Time", name, None]
    ws.append(header)
    metas = [_meta_cells(info, scope, n, dt, trig) for _, _, info in blocks]
    for i in range(n_rows):
        row: list[object] = []
        for (_, values, _), meta in zip(blocks, metas, strict=False):
            label, value = meta.get(i, (None, None))
            row += [label, value, None]
            row += [float(t[i]), float(values[i])] if i < n else [None, None]
            row.append(None)
        ws.append(row)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        wb.save(p)
    except OSError as exc:
        raise OptionError(f"cannot write the file ({exc.strerror or exc})", file=str(path)) from exc
    return p


def _renamed(info: ChannelInfo | None, name: str) -> ChannelInfo:
    from dataclasses import replace

    return ChannelInfo(name=name) if info is None else replace(info, name=name)


def _meta_cells(info: ChannelInfo, scope: ScopeInfo, n: int, dt: float, trig: int) -> dict[int, tuple[str, object]]:
    values: dict[str, object] = {
        "record_length": float(n), "sample_interval": dt, "trigger_point": float(trig),
        "source": info.name, "vertical_units": info.units, "vertical_scale": info.vertical_scale,
        "vertical_offset": info.vertical_offset, "horizontal_units": "s",
        "horizontal_scale": scope.horizontal_scale_s, "pt_fmt": "Y", "yzero": info.yzero,
        "probe_atten": info.probe_atten, "model": scope.model, "serial": scope.serial, "firmware": scope.firmware,
    }
    return {row: (label, values[key]) for row, label, key in META_ROWS if values[key] is not None}
