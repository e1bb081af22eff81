"""Time of ``mi.identify`` on the demo captures, as a notebook user runs it (< 2 s).

Run: ``python3 bench/frontdoor_speed.py [--repeat 5]``.  Writes the demo once, then runs
``import motorid as mi; mi.read_experiment(...); mi.identify(exp)`` in a fresh interpreter
per repeat (imports and first-call costs included, as in a new notebook) and prints the time
of ``import motorid``, of the first ``mi.identify`` call, and of a second call in the same
interpreter.  The BLAS thread count is left as the user has it: the library limits itself to
one thread around its entry points (``motorid._threads``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

CHILD = """
import json, sys, time
t0 = time.perf_counter()
import motorid as mi
t1 = time.perf_counter()
d = sys.argv[1]
exp = mi.read_experiment(position=f"{d}/ALL0000", velocity=f"{d}/ALL0001", current=f"{d}/ALL0002")
t2 = time.perf_counter()
fit = mi.identify(exp)
t3 = time.perf_counter()
mi.identify(exp)
t4 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "read": t2 - t1, "first": t3 - t2, "second": t4 - t3}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    from motorid.cli.demo import run_demo

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "D"
        run_demo(out, seed=0)
        runs = [json.loads(subprocess.run([sys.executable, "-c", CHILD, str(out)], capture_output=True,
                                          text=True, check=True).stdout) for _ in range(args.repeat)]
    print(f"{'step':<28}{'median (s)':>12}{'max (s)':>10}")
    for key, label in (("import", "import motorid"), ("read", "mi.read_experiment"),
                       ("first", "mi.identify (first call)"), ("second", "mi.identify (again)")):
        vals = [r[key] for r in runs]
        print(f"{label:<28}{statistics.median(vals):>12.3f}{max(vals):>10.3f}")
    print(f"{args.repeat} fresh interpreters; the target is mi.identify under 2 s")


if __name__ == "__main__":
    main()
