"""Mutations of real capture files for the readers' property tests and ``bench/fuzz.py``.

A mutation is a small, realistic damage: a truncated copy, flipped bytes, a line deleted or
duplicated, a number replaced by garbage (text, huge, NaN, a decimal comma), a changed
delimiter, a byte-order mark, CRLF line endings.  The readers must read the result or raise
:class:`~motorid.errors.MotorIdError`, never another exception.
"""

from __future__ import annotations

import re
from pathlib import Path

from hypothesis import strategies as st

REAL = Path(__file__).resolve().parents[2] / ".." / "shared" / "real"
TEK = REAL / "tek-tds2000-format-samples"
HSLU = REAL / "hslu-rtl-dcmotor" / "csv"

GARBAGE = ("abc", "", " ", "1e300", "-1e300", "nan", "NaN", "inf", "-inf", "1e999", "1,5", "0x10", "1_0",
           "--1", "1.2.3", "\u00e4", "12:00:01", '"1.0"', "9" * 400, "0", "-0", "1e-320")

_NUMBER = re.compile(rb"[-+]?\d+\.?\d*(?:[eE][-+]?\d+)?")


def real_files() -> list[Path]:
    """The three Tektronix samples and the HSLU CSV logs (empty when /work/shared is absent)."""
    files: list[Path] = []
    if TEK.is_dir():
        files += sorted(TEK.glob("*.CSV"))
    if HSLU.is_dir():
        files += sorted(HSLU.glob("*.csv"))
    return files


def _apply(data: bytes, op: tuple) -> bytes:
    kind = op[0]
    if kind == "truncate":
        return data[: int(op[1] * len(data))]
    if kind == "flip":
        pos = int(op[1] * len(data))
        return data[:pos] + bytes([op[2]]) + data[pos + 1:] if pos < len(data) else data
    lines = data.split(b"\n")
    k = min(int(op[1] * len(lines)), max(len(lines) - 1, 0))
    if kind == "delete":
        return b"\n".join(lines[:k] + lines[k + 1:])
    if kind == "duplicate":
        return b"\n".join(lines[: k + 1] + lines[k:])
    if kind == "number":
        spans = list(_NUMBER.finditer(lines[k])) if lines else []
        if not spans:
            return data
        m = spans[op[2] % len(spans)]
        lines[k] = lines[k][: m.start()] + op[3].encode() + lines[k][m.end():]
        return b"\n".join(lines)
    if kind == "delimiter":
        return data.replace(b",", op[2].encode())
    if kind == "bom":
        return b"\xef\xbb\xbf" + data
    if kind == "crlf":
        return data.replace(b"\r\n", b"\n").replace(b"\n", b"\r\n")
    if kind == "cr":
        return data.replace(b"\r\n", b"\n").replace(b"\n", b"\r")
    raise AssertionError(kind)


_frac = st.floats(0, 1, exclude_max=True)
OPS = st.one_of(
    st.tuples(st.just("truncate"), _frac),
    st.tuples(st.just("flip"), _frac, st.integers(0, 255)),
    st.tuples(st.just("delete"), _frac),
    st.tuples(st.just("duplicate"), _frac),
    st.tuples(st.just("number"), _frac, st.integers(0, 10), st.sampled_from(GARBAGE)),
    st.tuples(st.just("delimiter"), st.just(0.0), st.sampled_from([";", "\t", " ", ", ", ",,"])),
    st.tuples(st.just("bom"), st.just(0.0)),
    st.tuples(st.just("crlf"), st.just(0.0)),
    st.tuples(st.just("cr"), st.just(0.0)),
)


def mutate(data: bytes, ops: list[tuple]) -> bytes:
    """Apply the mutations in order."""
    for op in ops:
        data = _apply(data, op)
    return data
