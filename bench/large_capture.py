"""The largest captures, end to end: ``motorid identify`` on long plain-CSV logs.

Run: ``python3 bench/large_capture.py [--rows 100000,1000000,10000000] [--tds 1000000] [--src DIR]``.  For
each size it writes a 1 kHz log of a first-order motor (τ = 0.3 s, 0.01 V noise) to a temporary
file, and a Tektronix CH1/CH2 pair of ``--tds`` samples (10 µs sampling, 8-bit codes, τ = 0.4 s:
the long record of a scope), and runs ``python -m motorid identify --velocity FILE`` in a fresh
process, printing the size, the wall, user and system CPU time and the peak resident memory
(``ru_maxrss``) of the child, the exit code and the identified DC gain and τ (truth 2.0 V/V,
0.3 s for the logs; 0.2534 V/V, 0.4 s for the scope pair).  The readers refuse text captures above
512 MiB (about 20 million such rows) before reading them.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def write_log(path: Path, rows: int) -> None:
    """A step at sample 5000 of a 1 kHz log, written in chunks (bounded memory)."""
    rng = np.random.default_rng(0)
    with path.open("w") as fh:
        fh.write("time,input,velocity\n")
        for start in range(0, rows, 1_000_000):
            k = np.arange(start, min(rows, start + 1_000_000)) - 5000
            t = k * 1e-3
            u = np.where(k >= 0, 5.0, 0.0)
            y = np.where(k >= 0, 10.0 * -np.expm1(-np.maximum(t, 0.0) / 0.3), 0.0) + rng.normal(0, 0.01, k.size)
            np.savetxt(fh, np.column_stack([t, u, y]), fmt="%.6f", delimiter=",")


def identify(capture: Path, out: Path, env: dict[str, str]) -> tuple[float, float, float, float, int, dict]:
    """``motorid identify --velocity CAPTURE`` in a fresh process: wall, user and system CPU and
    peak RSS of the child, its exit code and the model's ``first_order``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "motorid", "identify", "--velocity", str(capture),
                           "--json", str(out)], capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    user, system = after.ru_utime - before.ru_utime, after.ru_stime - before.ru_stime
    fo = json.loads(out.read_text())["first_order"] if proc.returncode == 0 else {}
    return wall, user, system, max(after.ru_maxrss, before.ru_maxrss) / 1024, proc.returncode, fo


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", default="100000,1000000,10000000", help="rows of each plain-CSV log (truth 2.0, 0.3 s)")
    ap.add_argument("--tds", type=int, default=1_000_000,
                    help="samples per channel of a Tektronix CH1/CH2 pair (truth 0.2534, 0.4 s; 0: none)")
    ap.add_argument("--src", type=Path, default=None, help="run another checkout's DIR/src (the before/after table)")
    args = ap.parse_args()
    env = dict(os.environ)
    if args.src is not None:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(args.src / "src"), env.get("PYTHONPATH", "")) if p)
        print(f"motorid from {args.src / 'src'}")
    print(f"{'capture':>22} {'MB':>7} {'wall (s)':>9} {'user (s)':>9} {'sys (s)':>8} {'peak RSS (MB)':>14} {'exit':>5} "
          f"{'dc gain':>8} {'tau (s)':>8}")
    cases: list[tuple[str, int]] = [("log", int(x)) for x in args.rows.split(",") if x]
    if args.tds:
        cases.append(("tds", args.tds))
    for kind, n in cases:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "m.json"
            if kind == "log":
                capture = Path(tmp) / "log.csv"
                write_log(capture, n)
                size = capture.stat().st_size
            else:
                from read_speed import make_tds

                capture = make_tds(Path(tmp), n)
                size = sum(f.stat().st_size for f in capture.iterdir())
            wall, user, system, rss, rc, fo = identify(capture, out, env)
            gain, tau = fo.get("dc_gain", float("nan")), fo.get("time_constant", float("nan"))
            print(f"{f'{kind} {n} samples':>22} {size / 1e6:7.1f} {wall:9.2f} {user:9.2f} {system:8.2f} "
                  f"{rss:14.0f} {rc:>5} {gain:8.4f} {tau:8.4f}")


if __name__ == "__main__":
    main()
