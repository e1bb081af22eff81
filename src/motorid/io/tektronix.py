"""Tektronix TDS1000/TDS2000-series CSV captures: read and write ``FnnnnCHx.CSV`` files.

The layout (``/work/shared/real/tek-tds2000-format-samples/PROVENANCE.md``): exactly
``Record Length`` lines, no header row, six fields per line ``A,B,C,D,E,``.  Columns A–B hold
metadata key/value pairs on rows 1–3 and 7–18, column D is time (s), column E the value in
``Vertical Units`` (already scaled by the probe attenuation).  Spreadsheet re-saves drop the
trailing comma (five fields) and reformat the numbers; some users add one header row.

A capture is one channel (output only), a CH1 + CH2 pair (CH1 = step input, CH2 = measured
output) or the scope's ``ALLnnnn/`` "Save All" folder.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import cast

import numpy as np

from motorid.capture import Capture, ChannelInfo, ScopeInfo
from motorid.errors import CaptureDataError, CaptureFormatError, MotorIdError, OptionError
from motorid.io._common import (
    LineOfSample,
    NoFastPathError,
    PathLike,
    binary_kind,
    check_capture_file,
    read_fast_or_careful,
    decode_text,
    iter_lines,
    load_columns,
    plain_number,
    read_head,
    check_writable,
    column_to_floats,
    parse_number,
    rail_clipping_warning,
    read_text,
    split_lines,
    validate_rows,
)

__all__ = [
    "META_ROWS",
    "NUMERIC_META",
    "TDS_FORMAT",
    "Meta",
    "TdsChannel",
    "looks_like_tds",
    "meta_key",
    "meta_number",
    "meta_text",
    "read_tds_capture",
    "read_tds_channel",
    "save_all_files",
    "write_tds_capture",
    "write_tds_channel",
]

TDS_FORMAT = "tds2000-csv"

# Metadata labels by the start of their compacted (lower-case, alphanumeric) text, so that the
# truncated labels a spreadsheet shows ("Sample Int", "Trigger Po") are recognised too.
_META_PREFIXES: tuple[tuple[str, str], ...] = (
    ("recordlen", "record_length"),
    ("sampleint", "sample_interval"),
    ("triggerpo", "trigger_point"),
    ("source", "source"),
    ("verticalu", "vertical_units"),
    ("verticalsc", "vertical_scale"),
    ("verticalo", "vertical_offset"),
    ("horizontalu", "horizontal_units"),
    ("horizontalsc", "horizontal_scale"),
    ("ptfmt", "pt_fmt"),
    ("yzero", "yzero"),
    ("probeat", "probe_atten"),
    ("modelnum", "model"),
    ("serialnum", "serial"),
    ("firmware", "firmware"),
)
NUMERIC_META = frozenset(
    {"record_length", "sample_interval", "trigger_point", "vertical_scale", "vertical_offset",
     "horizontal_scale", "yzero", "probe_atten"}
)
# Rows (0-based) of the metadata in the native layout, in the order the scope writes them.
META_ROWS: tuple[tuple[int, str, str], ...] = (
    (0, "Record Length", "record_length"),
    (1, "Sample Interval", "sample_interval"),
    (2, "Trigger Point", "trigger_point"),
    (6, "Source", "source"),
    (7, "Vertical Units", "vertical_units"),
    (8, "Vertical Scale", "vertical_scale"),
    (9, "Vertical Offset", "vertical_offset"),
    (10, "Horizontal Units", "horizontal_units"),
    (11, "Horizontal Scale", "horizontal_scale"),
    (12, "Pt Fmt", "pt_fmt"),
    (13, "Yzero", "yzero"),
    (14, "Probe Atten", "probe_atten"),
    (15, "Model Number", "model"),
    (16, "Serial Number", "serial"),
    (17, "Firmware Version", "firmware"),
)
_N_META_ROWS = 18
_CH_FILE = re.compile(r"^F(\d{4})CH(\d)\.CSV$", re.IGNORECASE)
_ALL_FOLDER = re.compile(r"^ALL\d{4}$", re.IGNORECASE)
_CH_NAME = re.compile(r"CH(\d)", re.IGNORECASE)


#: Metadata read off a capture's header, keyed by :func:`meta_key`: a float (or ``None``) under
#: every key in :data:`NUMERIC_META`, text (or ``None``) under the others.
Meta = dict[str, float | str | None]


def meta_number(meta: Mapping[str, float | str | None], key: str) -> float | None:
    """A numeric metadata field.

    Parameters
    ----------
    meta : Mapping[str, float | str | None]
        Metadata as the readers build it (:data:`Meta`).
    key : str
        A key of :data:`NUMERIC_META`.

    Returns
    -------
    float or None
        The value, ``None`` when absent or empty.
    """
    # the readers store parse_number's float (or None) under every NUMERIC_META key
    return cast("float | None", meta.get(key))


def meta_text(meta: Mapping[str, float | str | None], key: str) -> str | None:
    """A text metadata field (``model``, ``serial``, ``firmware``, ``source``, ...).

    Parameters
    ----------
    meta : Mapping[str, float | str | None]
        Metadata as the readers build it (:data:`Meta`).
    key : str
        A key not in :data:`NUMERIC_META`.

    Returns
    -------
    str or None
        The value, ``None`` when absent or empty.
    """
    # the readers store text (or None) under every key outside NUMERIC_META
    return cast("str | None", meta.get(key))


def meta_key(label: object) -> str | None:
    """The metadata field a Tektronix label names (``"Sample Interval"`` → ``sample_interval``).

    Returns ``None`` for anything else.

    Parameters
    ----------
    label : object
        A cell of column A (anything; only text can name a field).

    Returns
    -------
    str or None
        The field's key, e.g. ``sample_interval``.
    """
    if not isinstance(label, str):
        return None
    compact = re.sub(r"[^a-z0-9]", "", label.lower())
    if not compact:
        return None
    for prefix, key in _META_PREFIXES:
        if compact.startswith(prefix):
            return key
    return None


@dataclass(frozen=True, slots=True)
class TdsChannel:
    """One channel file of a TDS1000/2000 capture.

    Attributes
    ----------
    time_s : ndarray
        Column D: time relative to the trigger, in seconds.
    values_v : ndarray
        Column E: samples in ``channel.units`` (volts), probe attenuation already applied.
    channel : ChannelInfo
        ``Source``, ``Vertical Units``/``Scale``/``Offset``, ``Probe Atten``, ``Yzero``.
    scope : ScopeInfo
        ``Model Number``, ``Serial Number``, ``Firmware Version``, ``Record Length``,
        ``Horizontal Scale``, ``Trigger Point``.
    warnings : tuple of str
        Clipping at the rails, re-saved file, inconsistent metadata.
    path : str
        The file read.
    sample_interval_s : float or None
        The ``Sample Interval`` field as written.
    """

    time_s: np.ndarray
    values_v: np.ndarray
    channel: ChannelInfo
    scope: ScopeInfo
    warnings: tuple[str, ...] = ()
    path: str = ""
    sample_interval_s: float | None = None

    def __post_init__(self) -> None:
        for name in ("time_s", "values_v"):
            a = np.array(getattr(self, name), dtype=float, copy=True)
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "warnings", tuple(self.warnings))

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.time_s.size)


# --------------------------------------------------------------------------- reading


def _delimiter(lines: Sequence[str]) -> tuple[str, bool]:
    """Field delimiter and decimal-comma flag (European spreadsheets re-save with ``;``)."""
    first = next((ln for ln in lines[:3] if meta_key(re.split(r"[,;\t]", ln, maxsplit=1)[0])), lines[0])
    commas = first.count(",")
    for delim in (";", "\t"):
        if first.count(delim) >= 3 and first.count(delim) >= commas:
            return delim, True
    return ",", False


def looks_like_tds(lines: Sequence[str]) -> bool:
    """Whether text lines are a Tektronix CSV: two metadata labels in column A of the first rows.

    Parameters
    ----------
    lines : sequence of str
        The first lines of the file.

    Returns
    -------
    bool
        Whether the lines look like a Tektronix CSV.
    """
    if not lines:
        return False
    delim, _ = _delimiter(lines)
    keys = {meta_key(ln.split(delim, 1)[0].strip().strip('"')) for ln in lines[:25]}
    keys.discard(None)
    return len(keys) >= 2


def _is_header_row(fields: Sequence[str], decimal_comma: bool) -> bool:
    """A user-added header such as ``a,b,c,x,y,d``: text in D and E, no metadata label."""
    if len(fields) < 5 or meta_key(fields[0].strip()) is not None:
        return False
    d, e = fields[3].strip(), fields[4].strip()
    return bool(d) and bool(e) and parse_number(d, decimal_comma=decimal_comma) is None and (
        parse_number(e, decimal_comma=decimal_comma) is None
    )


def _read_metadata(
    split: Sequence[Sequence[str]], start: int, file: str, decimal_comma: bool
) -> Meta:
    meta: Meta = {}
    for k in range(start, min(len(split), start + 3 * _N_META_ROWS)):
        fields = split[k]
        label = fields[0].strip().strip('"')
        key = meta_key(label) if label else None
        if key is None or key in meta:
            continue
        raw = fields[1].strip().strip('"') if len(fields) > 1 else ""
        if key in NUMERIC_META:
            if not raw:
                meta[key] = None
                continue
            value = parse_number(raw, decimal_comma=decimal_comma)
            if value is None or not math.isfinite(value):
                raise CaptureFormatError(f"{label}: cannot read {raw!r} as a number", file=file, row=k + 1)
            meta[key] = value
        else:
            meta[key] = raw or None
    return meta


def _channel_name(meta: Meta, path: Path) -> str:
    source = meta.get("source")
    if isinstance(source, str) and source:
        return source
    m = _CH_NAME.search(path.stem)
    return f"CH{m.group(1)}" if m else path.stem


def _record_length(meta: Meta, file: str) -> int | None:
    rl = meta_number(meta, "record_length")
    if rl is None:
        return None
    if rl != int(rl) or rl < 2:
        raise CaptureFormatError(f"Record Length {rl!r} is not a sample count", file=file, row=None)
    return int(rl)


def _parse_tds(text: str, path: Path, file: str) -> TdsChannel:
    """The careful reader: every line split, every cell checked (small files, exact errors)."""
    lines = split_lines(text)
    if not lines:
        raise CaptureFormatError("empty file: not a capture", file=file)
    delim, decimal_comma = _delimiter(lines)
    split = [ln.split(delim) for ln in lines]
    start = 1 if _is_header_row(split[0], decimal_comma) else 0
    meta = _read_metadata(split, start, file, decimal_comma)
    if not meta:
        raise CaptureFormatError(
            "not a capture: no Tektronix metadata (Record Length, Sample Interval, …) in column A",
            file=file,
        )
    data = split[start:]
    rows = np.arange(start + 1, len(split) + 1)
    _check_length(meta, len(data), file)
    short = next((i for i, f in enumerate(data) if len(f) < 5), None)
    if short is not None:
        raise CaptureFormatError(
            f"{len(data[short])} field(s); a Tektronix CSV line has 6 (label,value,,time,value,)",
            file=file,
            row=int(rows[short]),
        )
    time_s = column_to_floats([f[3] for f in data], rows, file=file, what="column D (time)",
                              decimal_comma=decimal_comma)
    values_v = column_to_floats([f[4] for f in data], rows, file=file, what="column E (value)",
                                decimal_comma=decimal_comma)
    resaved = delim != "," or sum(len(f) == 5 for f in data) > len(data) // 2
    return _channel(meta, time_s, values_v, rows, resaved, path, file)


def _check_length(meta: Meta, n: int, file: str) -> None:
    rl = _record_length(meta, file)
    if rl is not None and n != rl:
        if n < rl:
            raise CaptureDataError(
                f"truncated: {n} of the {rl} samples its Record Length says; copy the file from the scope again",
                file=file,
            )
        raise CaptureDataError(
            f"{n} data lines but Record Length says {rl}: the file was edited; use the file the scope saved",
            file=file,
        )
    if rl is None and n < _N_META_ROWS:
        raise CaptureDataError(
            f"truncated: {n} line(s) and no Record Length; a Tektronix CSV has at least {_N_META_ROWS} "
            "(its metadata rows); copy the file from the scope again", file=file)


def _read_tds_fast(path: Path, file: str) -> TdsChannel:
    """The common case with numpy's C parser: metadata from the first lines, columns D and E."""
    head = read_head(path)
    if head.startswith((b"\xff\xfe", b"\xfe\xff")) or binary_kind(head[:8192]) is not None or b'"' in head:
        raise NoFastPathError("it is UTF-16, binary or quoted")
    cut = head.rfind(b"\n")
    lines = split_lines(decode_text(head[: cut + 1] if cut > 0 else head, file=file))[: 4 * _N_META_ROWS]
    if not lines:
        raise NoFastPathError("it is empty")
    delim, decimal_comma = _delimiter(lines)
    if decimal_comma:
        raise NoFastPathError("it uses a decimal comma")
    split = [ln.split(delim) for ln in lines]
    start = 1 if _is_header_row(split[0], decimal_comma) else 0
    meta = _read_metadata(split, start, file, decimal_comma)
    if not meta:
        raise NoFastPathError("it has no Tektronix metadata")
    arr = load_columns(path, skiprows=start, delimiter=delim, usecols=(3, 4))
    n = arr.shape[0]
    _check_length(meta, n, file)
    data = split[start:]
    resaved = delim != "," or sum(len(f) == 5 for f in data) > len(data) // 2
    return _channel(meta, arr[:, 0], arr[:, 1], LineOfSample(path, start, n), resaved, path, file)


def _first_bad_line(path: Path, file: str) -> MotorIdError:
    """The careful check of a large file, streamed: its first line without numbers in D and E."""
    head = split_lines(decode_text(read_head(path, 8192), file=file))
    delim, decimal_comma = _delimiter(head)
    start = 1 if head and _is_header_row(head[0].split(delim), decimal_comma) else 0
    for number, line in iter_lines(path, start):
        if not line:
            continue
        f = line.split(delim)
        if len(f) < 5:
            return CaptureFormatError(f"{len(f)} field(s); a Tektronix CSV line has 6 (label,value,,time,value,)",
                                      file=file, row=number)
        for k, what in ((3, "column D (time)"), (4, "column E (value)")):
            if parse_number(f[k], decimal_comma=decimal_comma) is None:
                text = f[k].strip()
                problem = "empty cell" if not text else f"cannot read {text[:40]!r} as a number"
                return CaptureFormatError(f"{what}: {problem}", file=file, row=number)
    return CaptureFormatError("cannot read columns D and E as numbers", file=file)


def _channel(meta: Meta, time_s: np.ndarray, values_v: np.ndarray, rows, resaved: bool,
             path: Path, file: str) -> TdsChannel:
    n = time_s.size
    rl = _record_length(meta, file)
    validate_rows(time_s, {"column E (value)": values_v}, file=file, rows=rows, time_name="column D (time)")

    name = _channel_name(meta, path)
    channel = ChannelInfo(
        name=name,
        units=str(meta.get("vertical_units") or "V"),
        vertical_scale=meta_number(meta, "vertical_scale"),
        vertical_offset=meta_number(meta, "vertical_offset"),
        probe_atten=meta_number(meta, "probe_atten"),
        yzero=meta_number(meta, "yzero"),
    )
    tp = meta_number(meta, "trigger_point")
    scope = ScopeInfo(
        model=meta_text(meta, "model"),
        serial=meta_text(meta, "serial"),
        firmware=meta_text(meta, "firmware"),
        record_length=rl,
        horizontal_scale_s=meta_number(meta, "horizontal_scale"),
        trigger_index=None if tp is None or abs(tp) > 1e9 else round(tp),
    )
    label = f"{path.name} ({name})"
    warnings: list[str] = []
    si = meta_number(meta, "sample_interval")
    dt = float(np.median(np.diff(time_s)))
    if si is not None and abs(dt - si) > 0.01 * abs(si):
        warnings.append(f"{label}: Sample Interval {plain_number(si)} s differs from the time column's step "
                        f"{plain_number(dt)} s; the time column is used")
    hs = meta_number(meta, "horizontal_scale")
    # The TDS1000/2000 record spans the 10 screen divisions: 10 · s/div ÷ sample interval.
    expected = 10 * hs / si if (rl is None and si and hs) else float(n)
    if math.isfinite(expected) and abs(expected) < 1e9 and round(expected) != n:
        warnings.append(f"{label}: no Record Length field, and {n} samples where the Horizontal Scale "
                        f"implies {round(expected)}: the file may be truncated")
    elif rl is None and scope.trigger_index is not None and scope.trigger_index >= n:
        warnings.append(f"{label}: no Record Length field, and its Trigger Point (sample "
                        f"{scope.trigger_index}) lies beyond its {n} samples: the file may be truncated")
    elif rl is None and not (si and hs):
        # Nothing left to check the length against: say so rather than pass a part of a record as whole.
        warnings.append(f"{label}: no Record Length field (nor Sample Interval and Horizontal Scale): "
                        f"cannot check that its {n} samples are the whole record; it may be truncated")
    if resaved:
        warnings.append(f"{label}: re-saved by a spreadsheet (not the scope's 6-field layout); "
                        "numbers may have been rounded")
    clip = rail_clipping_warning(values_v, channel, label)
    if clip:
        warnings.append(clip)
    return TdsChannel(time_s, values_v, channel, scope, tuple(warnings), file, si)


def read_tds_channel(path: PathLike) -> TdsChannel:
    """Read one Tektronix TDS1000/2000 channel file (``FnnnnCHx.CSV`` or ``TEKnnnn.CSV``).

    Parameters
    ----------
    path : str or PathLike
        The CSV file (LF or CRLF line endings; a native, spreadsheet re-saved or
        header-row variant).

    Returns
    -------
    TdsChannel
        Samples, channel and scope metadata, warnings.

    Raises
    ------
    CaptureFormatError
        Missing or binary file, no Tektronix metadata, a short line or a non-numeric cell
        (naming ``file:row`` and the cell text).
    CaptureDataError
        Fewer (or more) lines than ``Record Length`` says; NaN, duplicated, backwards or
        non-uniform time (naming the row).
    """
    p = Path(path)
    file = str(path)
    size = check_capture_file(p)
    return read_fast_or_careful(file, size, lambda: _read_tds_fast(p, file), lambda: _parse_tds(read_text(p), p, file),
                                lambda: _first_bad_line(p, file), "use the file the scope saved")


def save_all_files(folder: Path, *, _descend: bool = True) -> list[Path]:
    """The ``FnnnnCHx.CSV`` files of a Save-All folder (or of its single ``ALLnnnn`` subfolder).

    Parameters
    ----------
    folder : Path
        A Save-All folder, or a folder holding exactly one ``ALLnnnn`` folder.
    _descend : bool
        Internal: whether a single ``ALLnnnn`` subfolder may be entered (the call on it passes
        ``False``).

    Returns
    -------
    list of Path
        The channel files, in CH order.
    """
    if not os.access(folder, os.R_OK | os.X_OK):
        raise CaptureFormatError("cannot list the folder (permission denied); check its permissions",
                                 file=str(folder))
    try:
        entries = sorted(folder.iterdir())
    except OSError as exc:
        why = "permission denied" if isinstance(exc, PermissionError) else (exc.strerror or str(exc))
        raise CaptureFormatError(f"cannot list the folder ({why})", file=str(folder)) from exc
    found = [(m, e) for e in entries if e.is_file() and (m := _CH_FILE.match(e.name))]
    if not found:
        subs = [e for e in entries if e.is_dir() and _ALL_FOLDER.match(e.name)]
        if len(subs) == 1 and _descend:
            # one level only: a link from ALL0000 to itself must not name the folder 40 times
            return save_all_files(subs[0], _descend=False)
        raise CaptureFormatError(
            "no FnnnnCH1.CSV/FnnnnCH2.CSV files in this folder (the scope's 'Save All' ALLnnnn "
            "folder holds them); give the CSV files themselves",
            file=str(folder),
        )
    numbers = sorted({m.group(1) for m, _ in found})
    if len(numbers) > 1:
        raise CaptureFormatError(
            f"holds several captures ({', '.join('F' + n for n in numbers)}); give the CSV files of one",
            file=str(folder),
        )
    return [e for m, e in sorted(found, key=lambda me: int(me[0].group(2)))]


def _ch_number(text: str | None) -> int | None:
    if not text:
        return None
    m = _CH_NAME.fullmatch(text.strip()) or None
    return int(m.group(1)) if m else None


def _order_channels(chans: list[TdsChannel]) -> tuple[list[TdsChannel], list[str]]:
    """CH1 first: by the ``Source`` field, else by the file names, else as given."""
    warnings: list[str] = []
    by_source = [_ch_number(c.channel.name) for c in chans]
    by_name = [None if (m := _CH_NAME.search(Path(c.path).stem)) is None else int(m.group(1)) for c in chans]
    for c, s, f in zip(chans, by_source, by_name, strict=False):
        if s is not None and f is not None and s != f:
            warnings.append(f"{Path(c.path).name}: Source field says CH{s} but the file name says CH{f}; "
                            "the Source field is used")
    for keys in (by_source, by_name):
        known = [k for k in keys if k is not None]
        if len(known) == len(keys) and len(set(known)) == len(known):
            order = sorted(range(len(chans)), key=known.__getitem__)
            return [chans[i] for i in order], warnings
    return list(chans), warnings


def _check_same_acquisition(a: TdsChannel, b: TdsChannel, source: str) -> None:
    what = f"{a.path} and {b.path} are not one acquisition"
    fix = "save both channels with 'Save All'"
    if a.n_samples != b.n_samples:
        raise CaptureDataError(f"{what}: {a.n_samples} vs {b.n_samples} samples; {fix}", file=source)
    # the time columns' own steps (readers checked them: positive, uniform), never a metadata field
    dt_a = float(np.median(np.diff(a.time_s)))
    dt_b = float(np.median(np.diff(b.time_s)))
    if abs(dt_a - dt_b) > 1e-6 * max(abs(dt_a), abs(dt_b)):
        raise CaptureDataError(f"{what}: sample intervals {plain_number(dt_a)} s vs {plain_number(dt_b)} s; {fix}",
                               file=source)
    gap = float(np.max(np.abs(a.time_s - b.time_s)))
    if gap > 0.01 * dt_a:
        raise CaptureDataError(f"{what}: their time axes differ by up to {plain_number(gap)} s; {fix}", file=source)


def read_tds_capture(paths_or_folder: PathLike | Sequence[PathLike]) -> Capture:
    """Read a TDS1000/2000 capture: one channel file, a CH1 + CH2 pair, or an ``ALLnnnn`` folder.

    Parameters
    ----------
    paths_or_folder : path or sequence of paths
        A single ``.CSV`` (read as the output channel, no input), two to four channel files,
        or a "Save All" folder (its ``FnnnnCH1.CSV``/``FnnnnCH2.CSV``, any letter case).

    Returns
    -------
    Capture
        ``format = "tds2000-csv"``; CH1 (by ``Source``, else file name) is the input, CH2
        the output, CH3/CH4 go to ``extra`` by channel name.  ``scope.trigger_index`` is the
        ``Trigger Point``.

    Raises
    ------
    CaptureFormatError
        As :func:`read_tds_channel`; a folder without channel files.
    CaptureDataError
        Channels of different lengths, sample intervals or time axes (naming both files).
    OptionError
        No file, more than four, or the same file twice.
    """
    if isinstance(paths_or_folder, (str, os.PathLike)):
        p = Path(paths_or_folder)
        files = save_all_files(p) if p.is_dir() else [p]
        source = str(paths_or_folder)
    else:
        given = list(paths_or_folder)
        if not 1 <= len(given) <= 4:
            raise OptionError(f"a Tektronix capture is 1 to 4 channel files, got {len(given)}")
        files = [Path(x) for x in given]
        source = "+".join(str(x) for x in given)
        if len({f.resolve() for f in files}) != len(files):
            raise OptionError("the same file is given twice; give the CH1 and the CH2 file", file=source)
    chans = [read_tds_channel(f) for f in files]
    chans, warnings = _order_channels(chans)
    for other in chans[1:]:
        _check_same_acquisition(chans[0], other, source)
    for c in chans:
        warnings.extend(c.warnings)
    trig = {c.scope.trigger_index for c in chans}
    if len(trig) > 1:
        warnings.append(f"the channels' Trigger Points differ ({sorted(t for t in trig if t is not None)}); "
                        "the first channel's is used")
    if len(chans) == 1:
        out, inp = chans[0], None
        extras: list[TdsChannel] = []
    else:
        inp, out, extras = chans[0], chans[1], chans[2:]
    extra: dict[str, np.ndarray] = {}
    for c in extras:
        key = c.channel.name
        while key in extra or key in (out.channel.name, inp.channel.name if inp else None):
            key += "_"
        extra[key] = c.values_v
    return Capture(
        source=source,
        format=TDS_FORMAT,
        time_s=chans[0].time_s,
        output_v=out.values_v,
        output_info=out.channel,
        input_v=None if inp is None else inp.values_v,
        input_info=None if inp is None else inp.channel,
        scope=chans[0].scope,
        extra=extra,
        warnings=tuple(warnings),
    )


# --------------------------------------------------------------------------- writing


def _fmt_time(t: float, row: int, decimals: int) -> str:
    # The scope space-pads the times of the 18 metadata rows ("  -0.024660000000") and
    # zero-pads the rest ("-00.024640000000", "00.000020000000", t = 0 as "-00.000000000000").
    if row < _N_META_ROWS:
        return f"{t:{decimals + 5}.{decimals}f}"
    sign = "-" if t <= 0 else ""
    return f"{sign}{abs(t):0{decimals + 3}.{decimals}f}"


def _value_decimals(values_v: np.ndarray, scale: float | None) -> int:
    """Decimals of the value column: the scope's 5, more when the LSB needs them.

    With ``10**-d <= lsb/50`` the rounding error is at most 1/100 LSB, so re-reading gives
    back every 8-bit level exactly.
    """
    if scale is not None and math.isfinite(scale) and scale > 0:
        step = scale / 25.0 / 50.0
    else:
        peak = float(np.max(np.abs(values_v))) if values_v.size else 1.0
        step = 2e-9 * max(peak, 1e-12)  # no scale: keep ~9 significant digits
    return int(min(15, max(5, math.ceil(-math.log10(step) - 1e-9))))


def _fmt_meta(key: str, channel: ChannelInfo, scope: ScopeInfo, n: int, dt: float, trig: int) -> str:
    def num(x: float | None) -> str:
        return "" if x is None else f"{x:e}"

    def text(x: str | None) -> str:
        return "" if x is None else str(x).replace(",", " ")

    return {
        "record_length": num(float(n)),
        "sample_interval": num(dt),
        "trigger_point": f"{float(trig):.12e}",
        "source": text(channel.name),
        "vertical_units": text(channel.units),
        "vertical_scale": num(channel.vertical_scale),
        "vertical_offset": num(channel.vertical_offset),
        "horizontal_units": "s",
        "horizontal_scale": num(scope.horizontal_scale_s),
        "pt_fmt": "Y",
        "yzero": num(channel.yzero),
        "probe_atten": num(channel.probe_atten),
        "model": text(scope.model),
        "serial": text(scope.serial),
        "firmware": text(scope.firmware),
    }[key]


def _tds_text(time_s: np.ndarray, values_v: np.ndarray, channel: ChannelInfo, scope: ScopeInfo, file: str) -> str:
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(values_v, dtype=float)
    if t.ndim != 1 or v.shape != t.shape:
        raise CaptureDataError(f"time has {t.size} samples but the values {v.size}", file=file)
    if t.size < _N_META_ROWS:
        raise CaptureDataError(
            f"{t.size} samples: a Tektronix CSV holds at least {_N_META_ROWS} (its metadata rows)", file=file
        )
    validate_rows(t, {"value": v}, file=file, rows=np.arange(1, t.size + 1))
    n = t.size
    dt = float(np.median(np.diff(t)))
    trig = scope.trigger_index if scope.trigger_index is not None else round(-t[0] / dt)
    td = int(min(18, max(12, math.ceil(-math.log10(dt * 1e-4)))))  # time rounding ≤ 1e-4 sample
    vd = _value_decimals(v, channel.vertical_scale)
    meta = {row: (label, _fmt_meta(key, channel, scope, n, dt, trig)) for row, label, key in META_ROWS}
    lines = []
    for i in range(n):
        a, b = meta.get(i, ("", ""))
        lines.append(f"{a},{b},,{_fmt_time(float(t[i]), i, td)},{float(v[i]):{vd + 5}.{vd}f},")
    return "\n".join(lines) + "\n"


def _write(path: Path, text: str) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "w", encoding="ascii", errors="replace", newline="") as fh:
            fh.write(text)
    except OSError as exc:
        raise OptionError(f"cannot write the file ({exc.strerror or exc})", file=str(path)) from exc


def write_tds_channel(
    path: PathLike,
    time_s: np.ndarray,
    values_v: np.ndarray,
    channel: ChannelInfo,
    scope: ScopeInfo,
    *,
    force: bool = False,
) -> Path:
    """Write one channel in the scope's native CSV layout.

    Parameters
    ----------
    path : str or PathLike
        The ``.CSV`` file to write (parent folders are created).
    time_s, values_v : ndarray
        Uniformly sampled, strictly increasing time and the channel's values.
    channel : ChannelInfo
        Written as ``Source``, ``Vertical Units``/``Scale``/``Offset``, ``Yzero``, ``Probe Atten``.
    scope : ScopeInfo
        ``Trigger Point`` (default: the sample at t = 0), ``Horizontal Scale``, model, serial,
        firmware.  ``Record Length`` and ``Sample Interval`` come from the samples.
    force : bool
        Overwrite an existing file.

    Returns
    -------
    Path
        The file written.  Values use the scope's ``%10.5f`` style with more decimals when the
        LSB (``vertical_scale/25``) needs them, so reading back is exact to 1/100 LSB.

    Raises
    ------
    OutputExistsError
        The file exists and ``force`` is false.
    CaptureDataError
        Fewer than 18 samples, mismatched lengths, NaN or a non-uniform time axis.
    OptionError
        The file cannot be written.
    """
    p = Path(path)
    check_writable([p], force=force)
    _write(p, _tds_text(time_s, values_v, channel, scope, str(path)))
    return p


def write_tds_capture(folder: PathLike, capture: Capture, *, index: int = 0, force: bool = False) -> Path:
    """Write a capture as the scope's "Save All" folder ``ALLnnnn/FnnnnCH1.CSV`` + ``FnnnnCH2.CSV``.

    Parameters
    ----------
    folder : str or PathLike
        Where ``ALLnnnn`` is created.
    capture : Capture
        CH1 is its input (omitted when it has none), CH2 its output; ``extra`` channels named
        ``CH3``/``CH4`` are written too.
    index : int
        The ``nnnn`` number, 0–9999.
    force : bool
        Overwrite existing files.

    Returns
    -------
    Path
        The ``ALLnnnn`` folder.

    Raises
    ------
    OutputExistsError
        A file exists and ``force`` is false (nothing is written then).
    OptionError
        ``index`` out of range, or the folder cannot be written.
    """
    if not 0 <= int(index) <= 9999:
        raise OptionError(f"index {index} is not 0–9999")
    out_dir = Path(folder) / f"ALL{index:04d}"
    jobs: list[tuple[Path, np.ndarray, ChannelInfo]] = []
    if capture.input_v is not None:
        info = capture.input_info or ChannelInfo(name="CH1")
        jobs.append((out_dir / f"F{index:04d}CH1.CSV", capture.input_v, replace(info, name="CH1")))
    jobs.append((out_dir / f"F{index:04d}CH2.CSV", capture.output_v, replace(capture.output_info, name="CH2")))
    for key, values in capture.extra.items():
        n = _ch_number(key)
        if n in (3, 4):
            jobs.append((out_dir / f"F{index:04d}CH{n}.CSV", values, ChannelInfo(name=f"CH{n}")))
    check_writable([j[0] for j in jobs], force=force)
    texts = [(p, _tds_text(capture.time_s, v, info, capture.scope, str(p))) for p, v, info in jobs]
    for p, text in texts:
        _write(p, text)
    return out_dir

