"""The largest captures, end to end: ``motorid identify`` on long plain-CSV logs.

Run: ``python3 bench/large_capture.py [--rows 100000,1000000,10000000]``.  For each size it
writes a 1 kHz log of a first-order motor (τ = 0.3 s, 0.01 V noise) to a temporary file and
runs ``python -m motorid identify --velocity FILE`` in a fresh process, printing the file
size, the wall time, the child's peak resident memory (``ru_maxrss``), the exit code and the
identified DC gain and τ (truth 2.0 V/V, 0.3 s).  The readers refuse text captures above
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", default="100000,1000000,10000000")
    args = ap.parse_args()
    print(f"{'rows':>10} {'MB':>7} {'wall (s)':>9} {'peak RSS (MB)':>14} {'exit':>5} {'dc gain':>8} {'tau (s)':>8}")
    for rows in (int(x) for x in args.rows.split(",")):
        with tempfile.TemporaryDirectory() as tmp:
            log, out = Path(tmp) / "log.csv", Path(tmp) / "m.json"
            write_log(log, rows)
            before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "motorid", "identify", "--velocity", str(log),
                                   "--json", str(out)], capture_output=True, text=True, env=dict(os.environ))
            wall = time.perf_counter() - t0
            rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
            fo = json.loads(out.read_text())["first_order"] if proc.returncode == 0 else {}
            print(f"{rows:>10} {log.stat().st_size / 1e6:7.1f} {wall:9.2f} {max(rss, before) / 1024:14.0f} "
                  f"{proc.returncode:>5} {fo.get('dc_gain', float('nan')):8.4f} "
                  f"{fo.get('time_constant', float('nan')):8.4f}")


if __name__ == "__main__":
    main()
