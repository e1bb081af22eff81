"""Time to generate the demo experiment's HTML report (target: ≤ 3 s).

Run: ``python3 bench/report_speed.py [--repeat 3]``.  Identification is done once; the
timed part is :func:`motorid.report.assemble.make_report` (sensitivity table + every figure).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from motorid.cli.demo import run_demo
from motorid.identification.pipeline import identify_experiment
from motorid.io import read_capture
from motorid.report.assemble import make_report


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "D"
        run_demo(out, seed=0)
        caps = {r: read_capture(out / f"ALL{i:04d}") for i, r in enumerate(("position", "velocity", "current"))}
        checks = {n: read_capture(out / f"ALL{i:04d}") for i, n in ((3, "sine"), (4, "triangle"), (5, "square"))}
        ident = identify_experiment(caps)
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            page = make_report(ident, caps, validation=checks)
            times.append(time.perf_counter() - t0)
    print(f"report of the demo experiment: median {statistics.median(times):.2f} s over {args.repeat} runs "
          f"({len(page) / 1e6:.2f} MB, target ≤ 3 s)")


if __name__ == "__main__":
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):  # tiny matrices: one BLAS thread per process is fastest
        main()
