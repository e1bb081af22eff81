"""Fuzz the capture readers with thousands of mutated real captures.

Run: ``python3 bench/fuzz.py [--examples 5000] [--seed 0]``.  Each example copies one of the
real files in ``../shared/real`` (the three Tektronix samples, the HSLU logs), applies one to
four mutations from ``tests/io/mutations.py`` (truncate, flip bytes, delete/duplicate lines,
numbers replaced by garbage/huge/NaN, other delimiters, BOM, CRLF, CR) and reads it with
``motorid.io.read_capture``.  It prints how many read, how many raised ``MotorIdError``, the
slowest read, and every other exception (a bug: the property is "a capture or MotorIdError").
Exit status 1 when any other exception occurred.
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import time
import traceback
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "io"))

from hypothesis import HealthCheck, given, seed, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from mutations import OPS, REAL, mutate, real_files  # noqa: E402

from motorid.errors import MotorIdError  # noqa: E402
from motorid.io import read_capture  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=5000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    files = real_files()
    if not files:
        print(f"skipped: real recordings not found at {REAL.resolve()}")
        return 0
    tmp = Path(tempfile.mkdtemp(prefix="motorid-fuzz-"))
    counts: collections.Counter[str] = collections.Counter()
    bugs: list[str] = []
    slowest = (0.0, "")

    @seed(args.seed)
    @settings(max_examples=args.examples, deadline=None, database=None,
              suppress_health_check=list(HealthCheck), phases=("generate",))
    @given(k=st.integers(0, 999), ops=st.lists(OPS, min_size=1, max_size=4))
    def one(k, ops):
        nonlocal slowest
        src = files[k % len(files)]
        f = tmp / src.name
        f.write_bytes(mutate(src.read_bytes(), ops))
        t0 = time.perf_counter()
        try:
            read_capture(f)
            counts["read"] += 1
        except MotorIdError as exc:
            counts["MotorIdError"] += 1
            if "\n" in str(exc) or "np.float64" in str(exc):
                bugs.append(f"{src.name} {ops}: message not one plain line: {exc!s:.200}")
        except Exception:
            counts["other"] += 1
            bugs.append(f"{src.name} {ops}:\n{traceback.format_exc(limit=3)}")
        dt = time.perf_counter() - t0
        if dt > slowest[0]:
            slowest = (dt, f"{src.name} {ops}")

    t0 = time.perf_counter()
    one()
    total = sum(counts.values())
    print(f"{total} examples from {len(files)} real files in {time.perf_counter() - t0:.1f} s: "
          f"{counts['read']} read, {counts['MotorIdError']} MotorIdError, {counts['other']} other exceptions")
    print(f"slowest read: {slowest[0] * 1e3:.0f} ms ({slowest[1][:120]})")
    for b in bugs[:20]:
        print("BUG:", b)
    return 1 if bugs else 0


if __name__ == "__main__":
    sys.exit(main())
