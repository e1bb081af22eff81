"""Recognise a capture file's format from its content and read it with the right reader.

The extension is not trusted: a Tektronix CSV renamed ``.txt`` is still one, a workbook is
recognised by its zip signature, and an image or a JSON file is refused with
``not a capture: …``.
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

from motorid.capture import Capture
from motorid.errors import CaptureFormatError, OptionError
from motorid.io._common import TEXT_SNIFF_BYTES, PathLike, binary_kind, decode_text, read_head, split_lines
from motorid.io._table import check_role, parse_column_map
from motorid.io.plaincsv import PLAIN_FORMAT, read_plain_csv, sniff_table
from motorid.io.spreadsheet import XLSX_FORMAT, read_xlsx_capture
from motorid.io.tektronix import TDS_FORMAT, save_all_files, looks_like_tds, read_tds_capture

__all__ = ["detect_format", "read_capture"]


def detect_format(path: PathLike) -> str:
    """The capture format of a file (or ``ALLnnnn`` folder), from its content.

    Parameters
    ----------
    path : str or PathLike
        A capture file, or a "Save All" folder.

    Returns
    -------
    str
        ``"tds2000-csv"``, ``"xlsx"`` or ``"plain-csv"``.

    Raises
    ------
    CaptureFormatError
        Missing file, a folder without channel files, or a file that is not a capture
        (``not a capture: a PNG image`` …).
    """
    p = Path(path)
    file = str(path)
    if p.is_dir():
        save_all_files(p)  # raises when the folder holds no channel files
        return TDS_FORMAT
    head = read_head(p)  # refuses pipes and devices before opening them (they would block)
    if head.startswith(b"PK\x03\x04"):
        try:
            with zipfile.ZipFile(p) as zf:
                if "xl/workbook.xml" in zf.namelist():
                    return XLSX_FORMAT
        except (zipfile.BadZipFile, OSError, ValueError, EOFError):
            raise CaptureFormatError("not a capture: a damaged zip/.xlsx file", file=file) from None
        raise CaptureFormatError("not a capture: a zip archive, not an .xlsx workbook", file=file)
    kind = binary_kind(head[:TEXT_SNIFF_BYTES])
    if kind is not None:
        raise CaptureFormatError(f"not a capture: {kind}", file=file)
    text = decode_text(_whole_lines(head) if len(head) == HEAD_BYTES else head, file=file)
    stripped = text.lstrip()
    if not stripped:
        raise CaptureFormatError("empty file: not a capture", file=file)
    lines = split_lines(text)
    if looks_like_tds(lines):
        return TDS_FORMAT
    if sniff_table(lines) is not None:
        return PLAIN_FORMAT
    if len(head) == HEAD_BYTES and all(not ln.strip() or ln.lstrip().startswith("#") for ln in lines):
        # more than the head of comments (a logger's preamble): look past them
        longer = split_lines(decode_text(_whole_lines(read_head(p, LONG_HEAD_BYTES)), file=file))
        if sniff_table([ln for ln in longer if ln.strip() and not ln.lstrip().startswith("#")]) is not None:
            return PLAIN_FORMAT
    if stripped[0] in "{[":
        raise CaptureFormatError("not a capture: a JSON file", file=file)
    if stripped.startswith("<"):
        raise CaptureFormatError("not a capture: an XML/HTML file", file=file)
    raise CaptureFormatError(
        "not a capture: neither a Tektronix CSV nor a table with a header row naming time and channels",
        file=file,
    )


#: Bytes read to recognise a file's format.
HEAD_BYTES = 64 * 1024
#: Bytes read when the head holds nothing but comment lines.
LONG_HEAD_BYTES = 4 * 1024 * 1024


def _whole_lines(head: bytes) -> bytes:
    """``head`` cut after its last complete line (a partial last line confuses the sniffing).

    UTF-16 is cut after a whole newline code unit, on an even byte: cut at the newline byte
    alone, a little-endian file was left with half a character and refused as unreadable.
    """
    newline = {b"\xff\xfe": b"\n\x00", b"\xfe\xff": b"\x00\n"}.get(head[:2])  # UTF-16 LE, BE
    if newline is not None:  # a whole code unit, starting on an even byte
        i = head.rfind(newline)
        while i > 0 and i % 2:
            i = head.rfind(newline, 0, i)
        return head[: i + 2] if i > 0 else head[: len(head) // 2 * 2]
    return head[: head.rfind(b"\n") + 1] or head


def read_capture(
    path_or_paths: PathLike | Sequence[PathLike],
    *,
    columns: Mapping[str, str] | str | None = None,
    role: str | None = None,
) -> Capture:
    """Read any supported capture, choosing the reader from the content.

    Parameters
    ----------
    path_or_paths : path or sequence of paths
        A folder (the scope's ``ALLnnnn``), two to four Tektronix channel files (CH1 = input,
        CH2 = output), an ``.xlsx`` workbook, or a Tektronix/plain CSV file.
    columns : Mapping[str, str] or str, optional
        Column map for plain tables (see :func:`~motorid.io.read_plain_csv`), or its text
        (``"time=t,input=u,velocity=rpm"``, :func:`~motorid.io._table.parse_column_map`).
    role : str, optional
        Declares the output's role (``position``, ``velocity``, ``current``); it becomes
        the capture's ``role_hint``.

    Returns
    -------
    Capture

    Raises
    ------
    CaptureFormatError, CaptureDataError
        From the readers; ``not a capture: …`` for files of no supported format.
    OptionError
        ``columns`` given for a scope capture; a bad ``role``; several files that are not all
        Tektronix CSVs.
    """
    check_role(role)
    columns = parse_column_map(columns)
    if isinstance(path_or_paths, (str, os.PathLike)):
        paths = [path_or_paths]
    else:
        paths = list(path_or_paths)
        if not paths:
            raise OptionError("no capture file given")
    if len(paths) > 1:
        for p in paths:
            if detect_format(p) != TDS_FORMAT or Path(p).is_dir():
                raise OptionError(
                    "several files make one capture only as Tektronix channel files (CH1.CSV+CH2.CSV)",
                    file=str(p),
                )
        fmt = TDS_FORMAT
    else:
        fmt = detect_format(paths[0])
    if fmt == TDS_FORMAT:
        if columns:
            raise OptionError("--columns applies to plain CSV/table files, not to Tektronix captures",
                              file="+".join(map(str, paths)))
        capture = read_tds_capture(paths[0] if len(paths) == 1 else paths)
    elif fmt == XLSX_FORMAT:
        return read_xlsx_capture(paths[0], columns=columns, role=role)
    else:
        return read_plain_csv(paths[0], columns=columns, role=role)
    return capture if role is None else replace(capture, role_hint=role)
