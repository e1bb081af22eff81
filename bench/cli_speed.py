"""The CLI timed as a user runs it: a fresh process, the default environment.

Run: ``python3 bench/cli_speed.py [--repeat 5] [--src DIR]``.  For each command (``--help``,
``inspect``, ``identify --method auto`` on the demo captures, and on the HSLU real log when
``../shared/real`` is there) it starts ``python -m motorid ...`` afresh ``--repeat`` times and
prints the median wall time and CPU time (user + system of the child), once in the default
environment and once with ``OPENBLAS_NUM_THREADS=1``: equal CPU in both columns means the
library's own one-thread BLAS limit works (scipy's OpenBLAS ran two
threads behind the CLI's limit, 9.1 s CPU against 2.6 s).  Benches that import scipy first
could not see that; this one imports nothing of motorid in its own process.
``--src DIR`` runs another checkout's source (``PYTHONPATH=DIR/src``) for a before/after table.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
REAL = REPO.parent / "shared" / "real" / "hslu-rtl-dcmotor" / "csv" / "06_dc_step_5_15_00.csv"
BLAS_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def run(args: list[str], env: dict[str, str]) -> tuple[float, float, int]:
    """Wall and CPU seconds of one fresh ``python -m motorid`` process, and its exit code."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "motorid", *args], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--src", type=Path, default=None, help="another checkout whose src/ to run")
    args = ap.parse_args()
    default_env = {k: v for k, v in os.environ.items() if k not in BLAS_VARS}
    if args.src is not None:
        default_env["PYTHONPATH"] = str(args.src.resolve() / "src")
    one_env = {**default_env, "OPENBLAS_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory() as tmp:
        demo = Path(tmp) / "demo"
        subprocess.run([sys.executable, "-m", "motorid", "demo", "--out", str(demo), "--force"],
                       env=one_env, capture_output=True, check=True)
        cases = [
            ("--help", ["--help"]),
            ("inspect (3 captures)", ["inspect", str(demo / "ALL0000"), str(demo / "ALL0001"), str(demo / "ALL0002")]),
            ("identify auto (demo, 3 captures)", ["identify", "--position", str(demo / "ALL0000"),
                                                  "--velocity", str(demo / "ALL0001"),
                                                  "--current", str(demo / "ALL0002")]),
        ]
        if REAL.exists():
            cases.append(("identify auto (HSLU real log)", ["identify", "--velocity", str(REAL)]))
        print(f"{'command':36s} {'wall (s)':>9s} {'CPU (s)':>8s} {'wall 1-thr':>11s} {'CPU 1-thr':>10s} "
              f"{'CPU ratio':>9s} exit")
        for label, cmd in cases:
            rows = {}
            for name, env in (("default", default_env), ("one", one_env)):
                res = [run(cmd, env) for _ in range(args.repeat)]
                rows[name] = (statistics.median(r[0] for r in res), statistics.median(r[1] for r in res),
                              sorted({r[2] for r in res}))
            d, o = rows["default"], rows["one"]
            print(f"{label:36s} {d[0]:9.2f} {d[1]:8.2f} {o[0]:11.2f} {o[1]:10.2f} {d[1] / o[1]:9.2f} {d[2]}")
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "pass"], check=True)
        print(f"{'python -c pass':36s} {time.perf_counter() - t0:9.2f}")


if __name__ == "__main__":
    main()
