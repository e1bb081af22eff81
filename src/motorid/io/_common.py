"""Helpers shared by the capture readers and writers: file access, numbers, row-exact errors.

Private to :mod:`motorid.io`.  Every function here turns a problem with the user's file into
a :class:`~motorid.errors.MotorIdError` subclass that names the file (and the row).
"""

from __future__ import annotations

import csv
import math
import os
import stat
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np

from motorid.capture import ChannelInfo
from motorid.errors import CaptureDataError, CaptureFormatError, MotorIdError, OutputExistsError
from motorid.options import switch_words

__all__ = [
    "CAREFUL_MAX_BYTES",
    "MAX_ABS_VALUE",
    "MAX_TEXT_BYTES",
    "MIN_SAMPLES",
    "SAMPLE_INTERVAL_RANGE_S",
    "TEXT_SNIFF_BYTES",
    "PathLike",
    "TimeSteps",
    "binary_kind",
    "check_capture_file",
    "check_time_steps",
    "check_writable",
    "column_to_floats",
    "parse_number",
    "plain_number",
    "rail_clipping_warning",
    "read_bytes",
    "read_head",
    "read_text",
    "resample_column",
    "split_lines",
    "time_gaps",
    "uniform_grid",
    "validate_rows",
]

PathLike = str | os.PathLike

#: Bytes read to recognise a file's kind (magic numbers, first lines).
TEXT_SNIFF_BYTES = 8192

# Magic numbers of files users commonly pick up by mistake next to their captures (the scope's
# own .JPG/.BMP screenshots and .SET/.ISF files, MATLAB exports, PDFs of the lab sheet).
_MAGIC: tuple[tuple[bytes, str], ...] = (
    (b"\x89PNG", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image (the scope's screenshot?)"),
    (b"GIF8", "a GIF image"),
    (b"BM", "a BMP image (the scope's screenshot?)"),
    (b"%PDF", "a PDF document"),
    (b"\xd0\xcf\x11\xe0", "a legacy .xls/.doc file; save it as .xlsx or CSV"),
    (b"MATLAB 5.0 MAT-file", "a MATLAB .mat file; export the variables as CSV"),
    (b":WFMPRE:", "a Tektronix .ISF binary waveform; save it as a spreadsheet (.CSV) on the scope"),
    (b"\x1f\x8b", "a gzip archive"),
    (b"PK\x03\x04", "a zip archive"),
)


#: Largest text capture (CSV) read, in bytes: 512 MiB, about 20 million rows of a
#: ``time,input,velocity`` log (26 bytes a row) or 11 million rows of a Tektronix CSV.
MAX_TEXT_BYTES = 512 * 1024 * 1024
#: Above this size a file that the vectorised parser cannot read is not re-read row by row
#: into memory (about 23 bytes of memory per byte of file); its first bad line is found by
#: a streaming scan instead.
CAREFUL_MAX_BYTES = 16 * 1024 * 1024
T = TypeVar("T")


class NoFastPathError(Exception):
    """The file needs the row-by-row reader (the reason, in words, is the message)."""


def read_fast_or_careful(
    file: str,
    size: int,
    fast: Callable[[], T],
    careful: Callable[[], T],
    first_bad_line: Callable[[], MotorIdError],
    advice: str,
) -> T:
    """The vectorised reader, with the careful row-by-row one for what it cannot read.

    The careful reader gives the exact line of a bad cell, but holds about 23 bytes of
    memory per byte of file: above :data:`CAREFUL_MAX_BYTES` a file the fast reader refuses
    is refused with ``advice`` (a layout it cannot read) or with its first bad line, found by
    a streaming scan (a bad cell).
    """
    try:
        return fast()
    except NoFastPathError as why:
        if size > CAREFUL_MAX_BYTES:
            raise CaptureFormatError(
                f"is {size / 2**20:.0f} MiB and {why}: such files are read up to {CAREFUL_MAX_BYTES >> 20} MiB; "
                f"{advice}", file=file) from None
    except (ValueError, MotorIdError) as exc:
        if size > CAREFUL_MAX_BYTES:
            if isinstance(exc, MotorIdError):
                raise
            raise first_bad_line() from None
    return careful()


#: Fewest samples a file may hold to be read as a capture (the identification asks for more:
#: the step detection needs 10 samples before the step and 20 after).
MIN_SAMPLES = 2
#: Largest magnitude accepted in a time or value column: no instrument writes 1e300 volts;
#: raw encoder counts and epoch time stamps in microseconds stay below it.
MAX_ABS_VALUE = 1e15
#: Sample intervals (seconds) a capture may have: 1 ps (faster than any scope) to 3 h.
SAMPLE_INTERVAL_RANGE_S = (1e-12, 1e4)

_NOT_REGULAR = (
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _open(path: PathLike):
    """Open for binary reading (one place, so tests can simulate a permission error as root)."""
    return open(path, "rb")


def check_capture_file(path: PathLike, *, max_bytes: int = MAX_TEXT_BYTES) -> int:
    """Check that ``path`` is a regular, readable file of a size the readers support.

    Nothing is opened before :func:`os.stat` says the path is a regular file, so a named
    pipe or a device (``/dev/zero``) is refused at once instead of blocking or never ending.

    Parameters
    ----------
    path : str or PathLike
        The capture file.
    max_bytes : int
        Largest size accepted.

    Returns
    -------
    int
        The file size in bytes.

    Raises
    ------
    CaptureFormatError
        Missing, a folder, not a regular file, not readable, or larger than ``max_bytes``.
    """
    file = str(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise CaptureFormatError("no such file; check the path", file=file) from None
    except OSError as exc:
        raise CaptureFormatError(f"cannot access the file ({exc.strerror or exc})", file=file) from None
    if stat.S_ISDIR(st.st_mode):
        raise CaptureFormatError("is a folder, not a capture file", file=file)
    if not stat.S_ISREG(st.st_mode):
        what = next((w for test, w in _NOT_REGULAR if test(st.st_mode)), "not a regular file")
        raise CaptureFormatError(f"is {what}, not a capture file; give a regular file", file=file)
    if not os.access(path, os.R_OK):
        raise CaptureFormatError("cannot read the file (permission denied); check its permissions", file=file)
    if st.st_size > max_bytes:
        raise CaptureFormatError(
            f"is {st.st_size / 2**20:.0f} MiB; the largest capture read is {max_bytes / 2**20:.0f} MiB "
            "(about 20 million rows): shorten or decimate the record first",
            file=file,
        )
    return int(st.st_size)


def _os_error(exc: OSError, file: str) -> CaptureFormatError:
    why = "permission denied; check its permissions" if isinstance(exc, PermissionError) else (
        exc.strerror or str(exc))
    return CaptureFormatError(f"cannot read the file ({why})", file=file)


def read_head(path: PathLike, n: int = 64 * 1024) -> bytes:
    """The first ``n`` bytes of a capture file (checked by :func:`check_capture_file`)."""
    check_capture_file(path)
    try:
        with _open(path) as fh:
            return fh.read(n)
    except OSError as exc:
        raise _os_error(exc, str(path)) from exc


def read_bytes(path: PathLike, *, max_bytes: int = MAX_TEXT_BYTES) -> bytes:
    """Read a whole file, turning OS errors into :class:`CaptureFormatError`.

    Raises
    ------
    CaptureFormatError
        When the file is missing, is a folder, a pipe or a device, is larger than
        ``max_bytes`` or cannot be read.
    """
    check_capture_file(path, max_bytes=max_bytes)
    try:
        with _open(path) as fh:
            return fh.read(max_bytes + 1)
    except OSError as exc:
        raise _os_error(exc, str(path)) from exc


def binary_kind(head: bytes) -> str | None:
    """Describe a binary (non-text) file from its first bytes, or ``None`` for text."""
    for magic, what in _MAGIC:
        if head.startswith(magic):
            return what
    if head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return None  # UTF-16 text (Excel's "Unicode text" export)
    if b"\x00" in head:
        return "a binary file"
    return None


def decode_text(data: bytes, *, file: str) -> str:
    """Decode a text capture: UTF-8 (with or without BOM), UTF-16 with BOM, else Latin-1.

    Raises
    ------
    CaptureFormatError
        On a binary file (image, archive, …): ``not a capture: …``.
    """
    kind = binary_kind(data[:TEXT_SNIFF_BYTES])
    if kind is not None:
        raise CaptureFormatError(f"not a capture: {kind}", file=file)
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            return data.decode("utf-16")
        except UnicodeDecodeError as exc:
            raise CaptureFormatError("not a capture: unreadable UTF-16 text", file=file) from exc
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        # Spreadsheets on Windows save in a legacy code page; Latin-1 maps every byte, and
        # only the header names (never the numbers) can contain non-ASCII characters.
        return data.decode("latin-1")


def read_text(path: PathLike) -> str:
    """Read a text capture file (see :func:`read_bytes` and :func:`decode_text`).

    Raises
    ------
    CaptureFormatError
        Missing file, folder, binary file or empty file.
    """
    text = decode_text(read_bytes(path), file=str(path))
    if not text.strip():
        raise CaptureFormatError("empty file: not a capture", file=str(path))
    return text


def split_lines(text: str) -> list[str]:
    """Split into lines the way an editor numbers them (LF, CRLF or lone CR endings).

    Trailing blank lines are dropped; ``str.splitlines`` is not used because it also
    breaks at form feeds and Unicode separators, which would shift the row numbers.
    """
    sep = "\n" if "\n" in text else "\r"
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in text.split(sep)]
    while lines and not lines[-1].strip():
        lines.pop()
    return lines


def parse_number(cell: object, *, decimal_comma: bool = False) -> float | None:
    """A spreadsheet/CSV cell as a float, or ``None`` if it is not a number.

    ``int``/``float`` cells are returned as floats (``bool`` is not a number); text is
    stripped (and quotes removed) and read with :func:`float`, after turning a decimal comma
    into a point when ``decimal_comma``.
    """
    if isinstance(cell, bool):
        return None
    if isinstance(cell, (int, float, np.integer, np.floating)):
        return float(cell)
    if not isinstance(cell, str):
        return None
    s = cell.strip().strip('"').strip()
    if not s or "_" in s:  # float() accepts "1_000"; no instrument writes that
        return None
    if decimal_comma:
        s = s.replace(",", ".")
    try:
        return float(s)
    except ValueError:
        return None


def column_to_floats(
    cells: Sequence[object] | np.ndarray,
    rows: Sequence[int] | np.ndarray,
    *,
    file: str,
    what: str,
    decimal_comma: bool = False,
) -> np.ndarray:
    """Convert one column of cells to floats, naming the first bad cell's row.

    Parameters
    ----------
    cells : sequence
        The cells (text or numbers), one per sample.
    rows : sequence of int
        1-based file row of each cell.
    file : str
        File name for the error message.
    what : str
        The column's name in the message (``"column D (time)"``).
    decimal_comma : bool
        Read ``1,5`` as 1.5.

    Returns
    -------
    ndarray of float

    Raises
    ------
    CaptureFormatError
        On an empty or non-numeric cell: ``file:row: <what>: cannot read 'abc' as a number``.
    """
    if isinstance(cells, np.ndarray) and cells.dtype.kind == "f":
        return cells  # already parsed by the vectorised reader
    if not decimal_comma and all(isinstance(c, str) for c in cells):
        try:
            # numpy's C conversion is ~30x faster than a Python loop; it raises on the first
            # bad cell without saying which, so the slow loop below then finds it.
            out = np.array(cells, dtype=float)
            if not any(isinstance(c, str) and "_" in c for c in cells):
                return out
        except ValueError:
            pass
    out = np.empty(len(cells), dtype=float)
    for i, cell in enumerate(cells):
        v = parse_number(cell, decimal_comma=decimal_comma)
        if v is None:
            text = "" if cell is None else str(cell).strip()
            problem = "empty cell" if not text else f"cannot read {_short(text)!r} as a number"
            raise CaptureFormatError(f"{what}: {problem}", file=file, row=int(rows[i]))
        out[i] = v
    return out


def _short(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[: limit - 1] + "…"


def plain_number(x: float) -> str:
    """A number as a user writes it: ``2.404``, ``1e+300``, ``nan`` (never ``np.float64(2.404)``)."""
    return f"{float(x):.10g}"


#: Samples checked at a time by the range check: its temporaries stay small on a 10 M-row log.
_CHECK_BLOCK = 1 << 20


def _first_out_of_range(col: np.ndarray) -> np.ndarray:
    """Index (as a 0- or 1-element array) of the first value that is NaN or beyond :data:`MAX_ABS_VALUE`."""
    for start in range(0, col.size, _CHECK_BLOCK):
        block = col[start : start + _CHECK_BLOCK]
        # the block's extremes first (two reductions, no temporaries; NaN makes them NaN): the
        # elementwise test only for a block that has a bad value
        lo, hi = float(np.min(block)), float(np.max(block))
        if lo >= -MAX_ABS_VALUE and hi <= MAX_ABS_VALUE:
            continue
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~(np.abs(block) <= MAX_ABS_VALUE))
        if bad.size:
            return bad[:1] + start
    return np.empty(0, dtype=np.intp)


@dataclass(frozen=True, slots=True)
class TimeSteps:
    """Order statistics of a time column's steps ``np.diff(time_s)``, as :func:`check_time_steps` found them.

    Attributes
    ----------
    median_s : float
        ``np.median`` of the steps (s), the same bits.
    smallest_s, largest_s : float
        The smallest and largest step (s).
    """

    median_s: float
    smallest_s: float
    largest_s: float


def check_time_steps(
    time_s: np.ndarray,
    channels: Mapping[str, np.ndarray],
    *,
    file: str,
    line_of: Callable[[int], int | None],
    rel_jitter: float = 0.01,
    min_samples: int = MIN_SAMPLES,
    time_name: str = "time",
    jitter_ok: bool = False,
) -> TimeSteps:
    """Check a record's samples; raise naming the file line of the first bad one.

    The checks of :func:`motorid.capture.validate_samples` (finite values, strictly
    increasing and uniform time) plus a range check (``|x| <= MAX_ABS_VALUE``), a sample
    interval in :data:`SAMPLE_INTERVAL_RANGE_S` and at least ``min_samples`` samples.
    Numbers in messages are plain (``2.404``).

    Parameters
    ----------
    time_s : ndarray
        Sample times (s).
    channels : Mapping[str, ndarray]
        The used value columns by the name a message gives them (``"column 'velocity'"``).
    file : str
        File name for the message.
    line_of : callable
        Sample index → 1-based line (row) of the file; called only to build a message.
    rel_jitter : float
        Allowed deviation of a time step from the median step, relative.
    min_samples : int
        Fewest samples accepted.
    time_name : str
        How a message names the time column (``"column D (time)"``).
    jitter_ok : bool
        A log's stamps may jitter (``millis()`` at 10/11 ms, a host loop at 4–22 ms): only a gap
        (:func:`time_gaps`) is refused; :func:`uniform_grid` then puts the record on a uniform grid.

    Returns
    -------
    TimeSteps
        The median, smallest and largest time step (s), for :func:`uniform_grid`.

    Raises
    ------
    CaptureDataError
        The first problem found, as ``file:line: what``.
    """
    t = np.asarray(time_s, dtype=float)
    n = t.size
    for name, col in ((time_name, t), *channels.items()):
        col = np.asarray(col, dtype=float)
        if col.shape != t.shape:
            raise CaptureDataError(f"{name} has {col.size} values but time has {n}", file=file)
        bad = _first_out_of_range(col)
        if bad.size:
            i = int(bad[0])
            x = float(col[i])
            why = "is not a finite number" if not math.isfinite(x) else (
                f"is out of range (|x| > {MAX_ABS_VALUE:g}): not a measurement; check the column and its units")
            raise CaptureDataError(f"{name} value {plain_number(x)} {why}", file=file, row=line_of(i))
    if n < min_samples:
        raise CaptureDataError(f"only {n} sample(s): a capture needs at least {min_samples}", file=file)
    # the steps' smallest and largest (and their median, an order statistic) decide the tests that
    # need the steps in order, which take them again in blocks of the time column only to find the
    # first bad one (a record that passes, the usual case, is not scanned again)
    count = _StepCount.of(t)
    smallest, largest = count.smallest, count.largest
    back = _first_step(t, lambda d: d <= 0) if smallest <= 0 else None
    if back is not None:
        what = "duplicated" if t[back] == t[back - 1] else "goes backwards"
        raise CaptureDataError(f"{time_name} {what} ({plain_number(t[back - 1])} then {plain_number(t[back])}): "
                               "time must increase", file=file, row=line_of(back))
    med = count.median(t)
    lo, hi = SAMPLE_INTERVAL_RANGE_S
    if not lo <= med <= hi:
        raise CaptureDataError(
            f"sample interval {plain_number(med)} s is outside {lo:g}…{hi:g} s: the time column is not in "
            "seconds (or not a time axis); map the right column, or give --time-unit ms or us", file=file)
    # (rounding is monotonic: no step is beyond a bound that the largest and the smallest are within)
    if jitter_ok:
        # a gap is beyond GAP_MEDIANS medians in any case: below that, no percentile is needed
        limit = _gap_limit(np.diff(t), med) if largest > GAP_MEDIANS * med else largest
        gap = _first_step(t, lambda d: d > limit) if largest > limit else None
    else:
        # (increasing times: the largest magnitude is at an end)
        tol = rel_jitter * med + 1e-12 * max(1.0, abs(float(t[0])), abs(float(t[-1])))
        within = abs(largest - med) <= tol and abs(smallest - med) <= tol
        gap = None if within else _first_step(t, lambda d: np.abs(d - med) > tol)
    if gap is not None:
        raise CaptureDataError(
            f"time step {plain_number(t[gap] - t[gap - 1])} s differs from the sample interval {plain_number(med)} s "
            "(gap or corrupt record)", file=file, row=line_of(gap))
    return TimeSteps(med, smallest, largest)


#: Steps taken at a time by the median's counting passes: a block's steps stay in the cache.
_STEP_BLOCK = 1 << 16
#: Steps sampled (evenly over the record) to bracket the median before counting.
_STEP_SAMPLE = 1 << 16
#: Fraction of the steps each side of the middle the sampled bracket spans (about five standard
#: deviations of a sampled median's rank).
_BRACKET = 0.01


@dataclass(frozen=True, slots=True)
class _StepCount:
    """One counting pass over a time column's steps, in blocks: extremes and a bracket of the median.

    ``below`` steps are under ``low`` and ``not_above`` are at most ``high`` (``low`` and ``high`` from
    an even sample of the steps): when the middle ranks lie between, the median is among the few
    steps in ``[low, high]`` (a single value when ``low == high``, the usual case of a logger's
    nearly constant steps), found without an array of the record's length.
    """

    size: int
    smallest: float
    largest: float
    low: float
    high: float
    below: int
    not_above: int

    @classmethod
    def of(cls, t: np.ndarray) -> _StepCount:
        """Count the steps of ``t`` (finite, at least two samples)."""
        m = t.size - 1
        if m <= 2 * _STEP_BLOCK:
            # a short record: its steps are about one block, their median numpy's (below)
            steps = np.diff(t)
            ends = (float(steps.min()), float(steps.max())) if steps.size else (1.0, 1.0)
            return cls(m, *ends, 0.0, -1.0, 0, 0)
        stride = max(1, m // _STEP_SAMPLE)
        sample = np.sort(t[1::stride][: m // stride] - t[:-1:stride][: m // stride])
        k = sample.size // 2
        margin = int(_BRACKET * sample.size) + 1
        low, high = float(sample[max(0, k - margin)]), float(sample[min(sample.size - 1, k + margin)])
        buf = np.empty(_STEP_BLOCK)
        smallest, largest, below, not_above = math.inf, -math.inf, 0, 0
        for start in range(0, m, _STEP_BLOCK):
            stop = min(m, start + _STEP_BLOCK)
            d = np.subtract(t[start + 1 : stop + 1], t[start:stop], out=buf[: stop - start])  # np.diff's steps
            smallest, largest = min(smallest, float(d.min())), max(largest, float(d.max()))
            below += int(np.count_nonzero(d < low))
            not_above += int(np.count_nonzero(d <= high))
        return cls(m, smallest, largest, low, high, below, not_above)

    def median(self, t: np.ndarray) -> float:
        """``np.median(np.diff(t))``, bit for bit: the middle step(s) by rank, averaged as numpy does."""
        m = self.size
        ranks = sorted({(m - 1) // 2, m // 2})
        inside = self.not_above - self.below
        if not (self.below <= ranks[0] and ranks[-1] < self.not_above) or (self.low < self.high and inside > m // 8):
            # not bracketed, or a bracket holding many steps of more than one value: numpy's median
            return float(np.median(np.diff(t), overwrite_input=True))
        if self.low == self.high:
            middle = np.full(len(ranks), self.low)
        else:
            # the steps in the bracket, and the middle ranks among them
            kept = []
            for start in range(0, m, _STEP_BLOCK):
                d = np.diff(t[start : min(m, start + _STEP_BLOCK) + 1])
                kept.append(d[(d >= self.low) & (d <= self.high)])
            near = np.concatenate(kept)
            offsets = [r - self.below for r in ranks]
            near.partition(offsets)
            middle = near[offsets]
        # numpy's median is the mean of the middle element(s) (one for an odd count of steps)
        return float(np.mean(middle))


def _first_step(t: np.ndarray, bad: Callable[[np.ndarray], np.ndarray]) -> int | None:
    """The sample ``i`` whose step ``t[i] − t[i−1]`` is the first that ``bad(steps)`` marks.

    The steps are taken in blocks of :data:`_CHECK_BLOCK` (each the same ``np.diff`` values as the
    whole column's): no array of the column's length.
    """
    for start in range(0, t.size - 1, _CHECK_BLOCK):
        hit = np.flatnonzero(bad(np.diff(t[start : start + _CHECK_BLOCK + 1])))
        if hit.size:
            return start + int(hit[0]) + 1
    return None


#: A step longer than this many median steps, and than :data:`GAP_OVER_P99` × the 99th
#: percentile of the steps, is a gap (samples lost), not jitter: a host loop stepping 4–22 ms
#: around a 10 ms median has its 99th percentile near 21 ms; one lost stretch in a regular log
#: stands alone above it.
GAP_MEDIANS, GAP_OVER_P99 = 3.0, 1.5


def time_gaps(dt: np.ndarray, *, median: float | None = None, scratch: np.ndarray | None = None) -> np.ndarray:
    """Indices of the time steps that are gaps rather than jitter (see :data:`GAP_MEDIANS`).

    Parameters
    ----------
    dt : ndarray
        Time steps (positive).
    median : float, optional
        ``np.median(dt)`` when the caller has it.
    scratch : ndarray, optional
        A copy of ``dt`` in any order that may be reordered (saves a copy of a long record).

    Returns
    -------
    ndarray of int
    """
    if scratch is None:
        scratch = dt.copy()
    med = float(np.median(scratch, overwrite_input=True)) if median is None else median
    return np.flatnonzero(dt > _gap_limit(scratch, med))


def _gap_limit(scratch: np.ndarray, median: float) -> float:
    """The step beyond which a step is a gap (:data:`GAP_MEDIANS`, :data:`GAP_OVER_P99`).

    ``scratch`` holds the steps in any order; it is reordered.
    """
    return max(GAP_MEDIANS * median, GAP_OVER_P99 * float(np.percentile(scratch, 99, overwrite_input=True)))


#: Stamps whose steps deviate from their median by less than this (relative) are uniform.
UNIFORM_REL = 0.01


def uniform_grid(time_s: np.ndarray, output: np.ndarray, inp: np.ndarray | None,
                 extra: Mapping[str, np.ndarray], *, file: str, median: float | None = None,
                 steps: TimeSteps | None = None,
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, dict[str, np.ndarray], str, float]:
    """A log with jittered stamps on a uniform grid, the note that says so ('' when uniform), their resolution.

    The grid keeps the number of samples, at the mean step (``millis()`` at 10/11 ms has a mean
    of 10.24 ms, its median is 10), and is placed so that the input's largest change falls on a
    grid point: the logged command applies from the stamp it is logged at, so the step instant
    stays exact.  Measured columns are interpolated by monotone piecewise cubics
    (:func:`resample_column`), apart on each side of that step; the input is held at its last
    logged value.  Everything downstream (conditioning, every estimator,
    validation) assumes a uniform grid: resampling once here keeps them all exact.

    Parameters
    ----------
    time_s, output : ndarray
        Stamps (s, increasing, no gap) and the output column.
    inp : ndarray or None
        The input column.
    extra : Mapping[str, ndarray]
        Further columns (interpolated too).
    file : str
        For the note.
    median : float, optional
        ``np.median(np.diff(time_s))`` when the caller has it (:func:`check_time_steps` returns it):
        then the steps are tested in blocks, with no array of the log's length.
    steps : TimeSteps, optional
        What :func:`check_time_steps` found: its median, and its smallest and largest steps,
        which decide uniform stamps without taking the steps again.

    Returns
    -------
    tuple
        ``(time_s, output, input, extra, note, resolution_s)``: ``resolution_s`` is the clock's
        resolution the jittered stamps are rounded to (:func:`stamp_resolution`; 0 when the stamps
        are uniform, taken as exact).
    """
    t = np.asarray(time_s, dtype=float)
    if t.size < 3:
        return time_s, output, inp, dict(extra), "", 0.0
    if steps is not None:
        median = steps.median_s
    if median is None:
        median = float(np.median(np.diff(t), overwrite_input=True))
    med = median
    tol = UNIFORM_REL * med + 1e-12 * max(1.0, abs(float(t[0])), abs(float(t[-1])))
    # (rounding is monotonic: every step is within a bound that the smallest and the largest are within)
    if steps is not None and abs(steps.largest_s - med) <= tol and abs(steps.smallest_s - med) <= tol:
        return time_s, output, inp, dict(extra), "", 0.0
    if _first_step(t, lambda d: ~(np.abs(d - med) <= tol)) is None:
        return time_s, output, inp, dict(extra), "", 0.0
    dt = np.diff(t)
    step = (t[-1] - t[0]) / (t.size - 1)
    anchor, split = t[0], 0
    if inp is not None and inp.size > 1:
        k = int(np.argmax(np.abs(np.diff(inp)))) + 1
        if np.diff(inp)[k - 1] != 0:
            anchor, split = t[k], k
    first = anchor - np.floor((anchor - t[0]) / step + 1e-9) * step
    grid = first + np.arange(int(np.floor((t[-1] - first) / step + 1e-9)) + 1) * step
    out = resample_column(grid, t, output, split)
    held = None
    if inp is not None:
        held = inp[np.clip(np.searchsorted(t, grid + 1e-9 * step, side="right") - 1, 0, t.size - 1)]
    ext = {k: resample_column(grid, t, v, split) if np.all(np.isfinite(v)) else v[:0] for k, v in extra.items()}
    ext = {k: v for k, v in ext.items() if v.size == grid.size}
    p5, p95 = np.percentile(dt, [5, 95])
    note = (f"the time stamps jitter (steps {1e3 * med:.3g} ms median, {1e3 * p5:.3g}–{1e3 * p95:.3g} ms "
            f"for 90 % of them, {1e3 * float(dt.min()):.3g}–{1e3 * float(dt.max()):.3g} ms in all): resampled to a "
            f"uniform {1e3 * step:.4g} ms grid (measured columns interpolated by monotone piecewise cubics, PCHIP, "
            "apart before and after the input's step; the input held at its last logged value; the grid placed on "
            "that step)")
    resolution = stamp_resolution(dt)
    if resolution > 0:
        note += (f"; the stamps are whole multiples of {1e3 * resolution:.3g} ms, a clock that rounds the instant each "
                 f"sample was taken: the step instant is known to ±{1e3 * resolution / np.sqrt(12):.2g} ms (rms), "
                 "which the timing intervals include")
    return grid, out, held, ext, note, resolution


def resample_column(grid: np.ndarray, time_s: np.ndarray, values: np.ndarray, split: int = 0) -> np.ndarray:
    """A measured column at the grid's instants: monotone piecewise cubic (PCHIP), apart at ``split``.

    Linear interpolation misses a curve by up to h²·|y''|/8 between stamps h apart: on an EV3
    position logged 4–22 ms apart that is a few degrees during the acceleration, ten times the
    whole-degree rounding, and the output-error fit answered it with a pole and a zero that
    nearly cancel (five seeds of five) and, once, a fit that never converged.  scipy's
    :class:`~scipy.interpolate.PchipInterpolator` (Fritsch–Carlson) misses it 3–7× less and stays
    between its two samples (no overshoot on the rounding steps or the noise at rest); a cubic
    spline misses it far less still but carries up to twice the samples' noise between a short
    and a long step, PCHIP at most 1.1× (``tests/io/test_io_resample.py``), and the fit then chased
    that noise on one seed of five.  The step's kink (the acceleration starts there) would spread
    over those neighbours, so the samples before the step (``time_s[:split + 1]``) and from it
    (``time_s[split:]``) are interpolated apart; the grid point on the step is a sample of both.

    Parameters
    ----------
    grid : ndarray
        Instants (s) inside ``[time_s[0], time_s[-1]]``.
    time_s : ndarray
        The stamps (s), strictly increasing.
    values : ndarray
        The column at the stamps, finite.
    split : int, optional
        Index of the stamp of the input's step (0: none).

    Returns
    -------
    ndarray
        The column on the grid.
    """
    from scipy.interpolate import PchipInterpolator  # only logs with jittered stamps need it

    out = np.empty(grid.size)
    cut = np.searchsorted(grid, time_s[split], side="left") if split > 0 else 0
    for lo, hi, sl in ((0, split + 1, slice(0, cut)), (split, time_s.size, slice(cut, grid.size))):
        part = grid[sl]
        if part.size == 0:
            continue
        if hi - lo < 3:  # two stamps: a line
            out[sl] = np.interp(part, time_s[lo:hi], values[lo:hi])
        else:
            out[sl] = PchipInterpolator(time_s[lo:hi], values[lo:hi], extrapolate=True)(part)
    return out


#: Below this, a clock's rounding of the stamps is left out of the timing (s): a microsecond clock.
MIN_STAMP_RESOLUTION_S = 1e-5


def stamp_resolution(steps_s: np.ndarray) -> float:
    """The resolution jittered stamps are rounded to: the greatest common step, or 0 if negligible.

    ``millis()`` stamps a 10.24 ms loop with steps of 10 and 11 ms: the stamps are the loop's
    instants rounded down to whole ms, each off by 0 to 1 ms. Every sample and the logged step
    share that rounding; what is left in the step instant against the samples is one stamp's
    error, uniform over the resolution (``resolution/√12`` rms, zero mean). The resolution is
    the greatest common divisor of the steps on a 1 µs lattice (a step off that lattice by more
    than rounding, or a resolution under :data:`MIN_STAMP_RESOLUTION_S`, gives 0). numpy has no
    greatest common divisor of floats, hence the integer lattice.

    Parameters
    ----------
    steps_s : ndarray
        The stamps' steps (s), positive.

    Returns
    -------
    float
        Seconds; 0 when the stamps are finer than :data:`MIN_STAMP_RESOLUTION_S`.
    """
    steps = np.unique(np.asarray(steps_s, dtype=float))
    if steps.size == 0 or not np.all(np.isfinite(steps)) or steps[0] <= 0:
        return 0.0
    us = np.round(steps * 1e6)
    if np.max(np.abs(us - steps * 1e6)) > 1e-3:  # not on a 1 µs lattice: a finer clock
        return 0.0
    resolution = float(np.gcd.reduce(us.astype(np.int64))) * 1e-6
    return resolution if resolution >= MIN_STAMP_RESOLUTION_S else 0.0


def validate_rows(
    time_s: np.ndarray,
    channels: Mapping[str, np.ndarray],
    *,
    file: str,
    rows: Sequence[int] | np.ndarray,
    time_name: str = "time",
    jitter_ok: bool = False,
) -> float:
    """:func:`check_time_steps` with the file row of every sample given as a sequence: its median step.

    Returns
    -------
    float
        The median time step (s).

    Raises
    ------
    CaptureDataError
        As :func:`check_time_steps`, with the row a user can open.
    """
    return check_time_steps(time_s, channels, file=file, time_name=time_name, jitter_ok=jitter_ok,
                            line_of=lambda i: int(rows[i]) if 0 <= i < len(rows) else None).median_s


def check_writable(
    paths: Sequence[Path | None] | Mapping[str, Path | None],
    *,
    force: bool,
    create_parents: bool = True,
    folder: bool = False,
) -> None:
    """Check output paths before any work: refuse what could not or should not be written.

    Parameters
    ----------
    paths : sequence of Path, or mapping of option name to Path
        The outputs (``None`` entries: no output asked).  With a mapping (``{"--json": p}``)
        every message starts with the option's name.
    force : bool
        Allow overwriting existing files.  It never allows writing a file onto a folder,
        into a missing folder (``create_parents=False``) or below a file.
    create_parents : bool
        The writer creates missing parent folders (the scope-folder writers do); when
        ``False`` a missing parent folder is refused (the command line's ``--json``).
    folder : bool
        The paths are folders to write into (``demo --out``): an existing file is refused,
        an existing folder is fine.

    Raises
    ------
    OutputExistsError
        Naming the first existing file (without ``force``).
    OptionError
        A folder given as a file (or a file as a folder), a missing parent folder, a parent
        that is a file, a folder that cannot be written, or one file given for two outputs.
    """
    from motorid.errors import OptionError

    items = list(paths.items()) if isinstance(paths, Mapping) else [("", p) for p in paths]
    seen: dict[Path, str] = {}
    for option, raw in items:
        if raw is None:
            continue
        p = Path(raw)
        what = option or "the output"
        key = Path(os.path.abspath(p))
        if key in seen:
            raise OptionError(f"given for {seen[key] or 'another output'} and {what}: give each output "
                              "its own file", file=str(p))
        seen[key] = option
        if p.is_symlink() and not (folder and p.is_dir()):
            try:
                where = f" to {os.readlink(p)}"
            except OSError:
                where = ""
            if not force:  # with --force the committed file replaces the link, not what it points to
                raise OutputExistsError(f"is a symbolic link{where}; an output is written where it is named: use "
                                        f"{switch_words('--force', 'force')} to replace the link itself with the "
                                        "file, or give another path", file=str(p))
        if folder:
            if p.exists() and not p.is_dir():
                raise OptionError(f"is a file, not a folder: give {what} a folder to write into", file=str(p))
        elif p.is_dir():
            raise OptionError(f"is a folder: give {what} a file name (a file in that folder)", file=str(p))
        elif p.exists() and not p.is_file():
            # a device, FIFO or socket: writing would block, fail, or (renamed onto) replace it
            raise OptionError(f"is a device, pipe or socket, not a file: give {what} a regular file path "
                              "(to drop an output, leave the option out)", file=str(p))
        # the nearest existing ancestor must be a writable folder
        parent = p if folder and p.exists() else p.parent
        missing = not parent.exists()
        while not parent.exists() and parent != parent.parent:
            parent = parent.parent
        if not parent.is_dir():
            raise OptionError(f"{parent} is a file, not a folder: give {what} a path in a folder", file=str(p))
        if missing and not create_parents:
            raise OptionError(f"the folder {p.parent} does not exist: create it first, or give {what} "
                              "a path in an existing folder", file=str(p))
        if not os.access(parent, os.W_OK | os.X_OK):
            raise OptionError(f"cannot write into the folder {parent} (permission denied) for {what}", file=str(p))
        if not folder and not force and p.exists():
            raise OutputExistsError(f"already exists; use {switch_words('--force', 'force')} to overwrite it",
                                    file=str(p))


def rail_clipping_warning(values_v: np.ndarray, info: ChannelInfo, label: str) -> str | None:
    """A warning when a scope channel sits at the 8-bit ADC rails for much of the record.

    The TDS1000/2000 digitise -128…127 levels at 25 levels per division around the screen
    centre, whose value is ``yzero - vertical_offset`` (programmer manual, WFMPre:YOFf:
    ``value = (code - yoff)·ymult + yzero``).  A channel is clipped when at least 5 % of its
    samples equal its maximum (or minimum) and that value is within 3 levels of a rail.

    Parameters
    ----------
    values_v : ndarray
        The channel's samples (volts).
    info : ChannelInfo
        Its metadata; nothing is checked without ``vertical_scale``.
    label : str
        How the message names the channel (``"F0000CH2.CSV (CH2)"``).

    Returns
    -------
    str or None
        ``"<label> clipped at the scope rails on N% of the record; increase V/div"``.
    """
    scale = info.vertical_scale
    if scale is None or not math.isfinite(scale) or scale <= 0 or values_v.size == 0:
        return None
    lsb = scale / 25.0
    yzero = info.yzero or 0.0
    offset = info.vertical_offset or 0.0
    # Which sign the CSV's "Vertical Offset" carries cannot be confirmed from the samples we
    # have, so both screen centres are tried; a false hit needs a flat stretch more than 4 div
    # off screen anyway, where "increase V/div" is still the right advice.
    centres = {yzero - offset, yzero + offset}
    n = values_v.size
    clipped = 0
    for extreme, sign, levels in ((float(values_v.max()), 1.0, 127), (float(values_v.min()), -1.0, 128)):
        at = int(np.count_nonzero(np.abs(values_v - extreme) <= 0.01 * lsb))
        near_rail = any(abs(extreme - (c + sign * levels * lsb)) <= 3.0 * lsb for c in centres)
        if near_rail and at >= 0.05 * n:
            clipped += at
    if clipped == 0:
        return None
    pct = 100.0 * min(clipped, n) / n
    return f"{label} clipped at the scope rails on {pct:.0f}% of the record; increase V/div"


# --------------------------------------------------------------------------- large files

#: Encoding of the vectorised parser: the numbers are ASCII, Latin-1 maps every byte.
FAST_ENCODING = "latin-1"


#: From this file size on, pandas' C parser reads the numbers when pandas is installed: it parses
#: about 3× faster than ``np.loadtxt`` (7 against 25 ms of CPU a MB), which repays importing pandas
#: (about 0.35 s of CPU) from about 20 MB.  Smaller files use it when pandas is imported already.
PANDAS_MIN_BYTES = 16 * 1024 * 1024


def _pandas_reader(size: int):
    """``pandas.read_csv`` when it is worth importing and its float parser is exact, else ``None``.

    pandas 3 converts every float with ``fast_float`` (correctly rounded, as ``np.loadtxt``), so
    both give the same bits; pandas 2's default converter may differ in the last bit, so it is
    not used.  pandas is imported here, lazily: never when the command line starts.
    """
    if size <= 0 or (size < PANDAS_MIN_BYTES and "pandas" not in sys.modules):
        return None  # size 0: the caller did not ask
    try:
        import pandas
    except ImportError:
        return None
    return pandas.read_csv if int(pandas.__version__.split(".")[0]) >= 3 else None


#: Bytes per block of the file given to pandas' parser at a time (cut after a line's end): each block's
#: numbers are copied into columns allocated once, so the peak is the columns plus one block's frame
#: (about 17 MB for three columns), not pandas' parsed blocks and their concatenation (about twice
#: the columns).  Blocks of 16 MiB cost no more CPU than one call on the whole file (``chunksize``
#: cost half as much again as the whole parse, smaller blocks the call's overhead).
PANDAS_BLOCK_BYTES = 16 << 20


def _expected_rows(path: PathLike, size: int) -> int:
    """Rows to allocate for: the file's size over the mean line length of its first 64 KiB, plus a quarter.

    Only an estimate (the columns grow when it is short, :func:`_load_with_pandas`); pages never
    written are never resident, so too many rows cost address space, not memory.
    """
    head = read_head(path)
    lines = head.count(b"\n")
    if not lines or len(head) >= size:
        return max(lines + 1, 1)
    return int(size * lines / len(head) * 1.25) + 1024


def _load_with_pandas(read_csv, path: PathLike, skiprows: int, delimiter: str,
                      usecols: Sequence[int] | None, size: int = 0) -> list[np.ndarray] | None:
    """The numeric columns by pandas' C parser, or ``None`` when ``np.loadtxt`` must decide.

    pandas pads a short row with NaN and reads some cells ``np.loadtxt`` refuses, and the reverse;
    any failure, and any NaN in the result, leaves the file to ``np.loadtxt`` so that what is
    accepted and refused (and where) does not depend on whether pandas is installed.  The file is
    parsed in blocks of :data:`PANDAS_BLOCK_BYTES` cut after a line feed (a file with lone CR line
    ends has none: it is left to ``np.loadtxt``), each block's columns copied into one contiguous
    array per column allocated once and checked for NaN while in cache: one copy of the table in
    memory.
    """
    import io
    import warnings as _warnings

    columns: list[np.ndarray] = []
    n = 0
    try:
        with _warnings.catch_warnings(), _open(path) as fh:
            _warnings.simplefilter("error")
            for _ in range(skiprows):
                fh.readline()
            chunk = PANDAS_BLOCK_BYTES
            while True:
                # a block cut after its last line feed; the file read again from there (one copy of
                # the block, not a concatenation with the last one's rest and then a cut)
                start = fh.tell()
                data = fh.read(chunk)
                block = len(data) == chunk  # (a short read of a regular file is its end)
                if block:
                    cut = data.rfind(b"\n") + 1
                    if cut == 0:  # a line longer than the block: read more of it at once
                        fh.seek(start)
                        chunk *= 2
                        continue
                    if cut < len(data):
                        fh.seek(start + cut)
                        data = data[:cut]
                if not data or data.isspace():
                    if block:
                        continue
                    break
                frame = read_csv(io.BytesIO(data), sep=delimiter, header=None, usecols=usecols, dtype=np.float64,
                                 engine="c", na_filter=False, comment=None, quoting=csv.QUOTE_NONE,
                                 skip_blank_lines=True)
                del data
                m = frame.shape[0]
                if not columns:
                    rows = max(_expected_rows(path, size), m)
                    columns = [np.empty(rows) for _ in range(frame.shape[1])]
                if frame.shape[1] != len(columns):
                    return None
                if n + m > columns[0].size:  # the first lines were longer than the rest
                    rows = max(n + m, int(columns[0].size * 1.5))
                    columns = [_grown(c, n, rows) for c in columns]
                for k, col in enumerate(columns):
                    np.copyto(col[n : n + m], frame.iloc[:, k].to_numpy(dtype=np.float64, copy=False))
                    if np.isnan(np.min(col[n : n + m])):  # (the minimum is NaN when any value is: no mask)
                        return None
                n += m
                del frame
                if not block:
                    break
        # (UTF-8, pandas' native decoder: latin-1 would go through Python's codec, 1.5× slower; a
        # byte that is not UTF-8 is not a number either and fails here)
    except (ValueError, Warning):  # pandas' ParserError and EmptyDataError, UnicodeDecodeError
        return None
    except OSError as exc:
        raise _os_error(exc, str(path)) from None
    if not columns or n == 0:
        return None
    for col in columns:
        col.resize(n, refcheck=False)  # in place (realloc): the pages beyond n were never written
    return columns


#: From this file size on, pyarrow's CSV reader reads the numbers when pyarrow is installed (before
#: pandas): its parse takes about a fifth less CPU than pandas' on a DAQ log and its import a quarter
#: of pandas' (about 0.1 against 0.4 s).  Smaller files use it when it is imported already.
PYARROW_MIN_BYTES = 16 * 1024 * 1024
#: Bytes of the file pyarrow parses at a time (a line must fit in one: a longer line leaves the file
#: to pandas): each block's columns are copied into the columns allocated once while they are still
#: in the cache, and the C library's allocator reuses the same memory for every block.  Larger blocks
#: (1 MiB) took more fresh pages from the kernel, about three times the page faults and more CPU.
PYARROW_BLOCK_BYTES = 128 << 10


def _pyarrow_csv(size: int):
    """``pyarrow.csv`` when pyarrow 16 or later is installed and worth importing, else ``None``.

    Its float conversion is correctly rounded (as ``np.loadtxt``'s and pandas 3's), and with
    quoting off and no null values it accepts the cells and rows ``np.loadtxt`` accepts
    (tests/io/test_io_plaincsv_paths.py).  It is imported here, lazily: never when the command
    line starts.
    """
    if size <= 0 or (size < PYARROW_MIN_BYTES and "pyarrow.csv" not in sys.modules):
        return None
    try:
        import pyarrow.csv
    except ImportError:
        return None
    # (fast_float since Arrow 3; 16 is the first with numpy 2, the oldest the test extra allows)
    return pyarrow.csv if int(pyarrow.__version__.split(".")[0]) >= 16 else None


def _load_with_pyarrow(pa_csv, path: PathLike, skiprows: int, delimiter: str,
                       usecols: Sequence[int] | None, size: int = 0) -> list[np.ndarray] | None:
    """The numeric columns by pyarrow's CSV reader, or ``None`` when the next parser must decide.

    The file is streamed (``open_csv``, one thread) in blocks of :data:`PYARROW_BLOCK_BYTES`, each
    block's columns copied into one array per column allocated once.  Every cell of the columns
    read is converted to float64 (no type guessing, no null values, no quoting: ``""`` and
    ``"1.0"`` in quotes are failures, as for ``np.loadtxt``); a row with another number of fields,
    a cell that is not a number, any failure leaves the file to the next parser, so that where an
    error points does not depend on pyarrow.  NaN and infinities are read as ``np.loadtxt`` reads
    them (the checks after reading name them).
    """
    import pyarrow

    columns: list[np.ndarray] = []
    n = 0
    try:
        with _open(path) as fh:
            for _ in range(skiprows):
                if not fh.readline(1 << 16).endswith(b"\n"):
                    return None  # no line feed in 64 KiB (lone CR line ends): not read whole here
            # the first line with a field in the next 64 KiB (any line end): how many fields the rows have
            start = fh.tell()
            head = fh.read(1 << 16)
            fh.seek(start)
            first = next((line for line in head.replace(b"\r", b"\n").split(b"\n") if line), b"")
            if not first:
                return None
            width = first.count(delimiter.encode()) + 1  # (no quoting)
            names = [f"f{j}" for j in range(width)]
            wanted = [names[j] for j in (range(width) if usecols is None else usecols) if 0 <= j < width]
            if usecols is not None and len(wanted) != len(usecols):
                return None
            reader = pa_csv.open_csv(
                fh,
                read_options=pa_csv.ReadOptions(use_threads=False, block_size=PYARROW_BLOCK_BYTES, column_names=names),
                parse_options=pa_csv.ParseOptions(delimiter=delimiter, quote_char=False, escape_char=False,
                                                  newlines_in_values=False, ignore_empty_lines=True),
                convert_options=pa_csv.ConvertOptions(
                    column_types=dict.fromkeys(wanted, pyarrow.float64()), include_columns=wanted, null_values=[],
                    strings_can_be_null=False, quoted_strings_can_be_null=False),
                # the C library's allocator, not pyarrow's own (mimalloc): it reserves hundreds of MB
                # of address space that it keeps, and a later array fails under a limit on it
                memory_pool=pyarrow.system_memory_pool())
            for batch in reader:
                m = batch.num_rows
                if not columns:
                    columns = [np.empty(max(_expected_rows(path, size), m)) for _ in wanted]
                if n + m > columns[0].size:  # the first lines were longer than the rest
                    rows = max(n + m, int(columns[0].size * 1.5))
                    columns = [_grown(c, n, rows) for c in columns]
                for k, col in enumerate(columns):
                    values = batch.column(k)
                    if values.null_count:
                        return None
                    # the data buffer as it is (``to_numpy`` would import pandas, 0.3 s of CPU)
                    col[n : n + m] = np.frombuffer(values.buffers()[1], dtype=np.float64, count=m,
                                                   offset=8 * values.offset)
                n += m
    except (ValueError, pyarrow.ArrowException):  # ArrowInvalid: a bad cell or row
        return None
    except OSError as exc:
        raise _os_error(exc, str(path)) from None
    if not columns or n == 0:
        return None
    for col in columns:
        col.resize(n, refcheck=False)  # in place (realloc): the pages beyond n were never written
    return columns


def _grown(col: np.ndarray, n: int, rows: int) -> np.ndarray:
    """``col``'s first ``n`` values in a new array of ``rows``."""
    out = np.empty(rows)
    out[:n] = col[:n]
    return out


def load_columns(
    path: PathLike, *, skiprows: int, delimiter: str | None, usecols: Sequence[int] | None
) -> np.ndarray:
    """Numeric columns of a text table with numpy's C parser (``np.loadtxt``), streamed.

    The file is read in blocks, so the memory is the result (8 bytes a value), not the text.
    Empty lines are skipped; anything else that is not a number raises :class:`ValueError`
    (the caller then finds the exact line with a careful, row-by-row reading).

    Returns
    -------
    ndarray, shape (rows, columns)
    """
    import warnings as _warnings

    with _warnings.catch_warnings():
        _warnings.simplefilter("error")  # "input contained no data" is a failure, not a warning
        return np.loadtxt(path, dtype=float, delimiter=delimiter, skiprows=skiprows, usecols=usecols,
                          comments=None, quotechar=None, encoding=FAST_ENCODING, ndmin=2)


def load_column_arrays(
    path: PathLike, *, skiprows: int, delimiter: str | None, usecols: Sequence[int] | None, size: int = 0,
) -> list[np.ndarray]:
    """Numeric columns of a text table with a C parser, streamed, one array per column.

    ``np.loadtxt``, or on a large file pyarrow's CSV reader (:data:`PYARROW_MIN_BYTES`) when pyarrow
    is installed, else pandas' C parser (:data:`PANDAS_MIN_BYTES`) when pandas 3 is, with the same
    values; what one refuses goes to the next.  Each reads the text in blocks, never the whole file
    at once, into columns allocated once (8 bytes a value).  Empty lines are skipped; anything else
    that is not a number raises :class:`ValueError` (the caller then finds the exact line with a
    careful, row-by-row reading).

    Returns
    -------
    list of ndarray
        One array per column read (``usecols``, or all), each contiguous or a column of one
        ``np.loadtxt`` table.
    """
    pa_csv = _pyarrow_csv(size) if delimiter in (",", ";", "\t") else None
    if pa_csv is not None:
        cols = _load_with_pyarrow(pa_csv, path, skiprows, delimiter or ",", usecols, size)
        if cols is not None:
            return cols
    read_csv = _pandas_reader(size) if delimiter in (",", ";", "\t") else None
    if read_csv is not None:
        cols = _load_with_pandas(read_csv, path, skiprows, delimiter or ",", usecols, size)
        if cols is not None:
            return cols
    arr = load_columns(path, skiprows=skiprows, delimiter=delimiter, usecols=usecols)
    return [arr[:, k] for k in range(arr.shape[1])]


def iter_lines(path: PathLike, start: int = 0):
    """``(line number, text)`` of a text file from 0-based line ``start``, streamed (no list)."""
    with open(path, encoding=FAST_ENCODING, newline=None) as fh:
        for k, line in enumerate(fh):
            if k >= start:
                yield k + 1, line.rstrip("\r\n")


class LineOfSample(Sequence):
    """The file line of sample ``i`` of a table read by :func:`load_columns`, found lazily.

    Used only to name a line in an error message: it scans the file from ``start`` counting
    the non-empty lines as numpy does, so a 10-million-row file is scanned once, in seconds,
    and only when something is wrong.
    """

    def __init__(self, path: PathLike, start: int, n: int) -> None:
        self._path, self._start, self._n = path, start, n

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, i):
        if isinstance(i, slice):
            raise TypeError("LineOfSample does not slice")
        k = -1
        for number, text in iter_lines(self._path, self._start):
            if text:
                k += 1
                if k == i:
                    return number
        return None
