"""Start-up cost of the CLI: ``--help``, ``inspect`` and ``identify`` against a bare interpreter and scipy.

Run: ``python3 bench/startup.py [--repeat 7] [--src DIR]``.

Each command runs in a fresh process (``python -m motorid ...``, the console script's own code
path without the pyenv shim in front), in the default environment (no BLAS variables set here),
``--repeat`` times; the table shows the median wall time and the median CPU time (user + system
of the child, from ``getrusage(RUSAGE_CHILDREN)``) and both minus the median of ``python -c pass``
measured the same way.  Targets: ``--help`` under 0.15 s of CPU more than the bare interpreter;
``identify``'s start-up (its process CPU minus the same identification run warm in one process,
measured in a child) at most 1.5× the CPU of ``python -c "import numpy, scipy.optimize,
scipy.linalg"``.  ``--src DIR`` runs another checkout's source (``PYTHONPATH=DIR/src``), so a copy
of ``src/`` taken before a change gives the "before" column of the same table.
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
#: The target: extra CPU seconds of ``motorid --help`` over ``python -c pass``.
HELP_TARGET_S = 0.15
#: The target: identify's start-up over the CPU of importing numpy, scipy.optimize and scipy.linalg.
IDENTIFY_START_RATIO = 1.5

#: A child that identifies the demo captures twice and prints the second call's CPU seconds.
WARM = """
import sys, time, warnings
warnings.simplefilter("ignore")
import motorid as mi
d = sys.argv[1]
def once():
    exp = mi.read_experiment(position=d + "/ALL0000", velocity=d + "/ALL0001", current=d + "/ALL0002")
    fit = mi.identify(exp)
    fit.model.to_json_text()
once()
t0 = time.process_time()
once()
print(time.process_time() - t0)
"""


def run(argv: list[str], env: dict[str, str]) -> tuple[float, float, int]:
    """Wall and CPU seconds of one fresh process, and its exit code.

    Parameters
    ----------
    argv : list of str
        The command line.
    env : dict
        Its environment.

    Returns
    -------
    tuple of (float, float, int)
        Wall seconds, CPU seconds (user + system of the child) and the exit code.
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.returncode


def median_run(argv: list[str], env: dict[str, str], repeat: int) -> tuple[float, float, list[int]]:
    """Median wall and CPU seconds of ``repeat`` fresh runs, and the exit codes seen.

    Parameters
    ----------
    argv : list of str
        The command line.
    env : dict
        Its environment.
    repeat : int
        Number of runs.

    Returns
    -------
    tuple of (float, float, list of int)
        Median wall seconds, median CPU seconds, sorted distinct exit codes.
    """
    res = [run(argv, env) for _ in range(repeat)]
    return (statistics.median(r[0] for r in res), statistics.median(r[1] for r in res),
            sorted({r[2] for r in res}))


def main() -> None:
    """Print the start-up table."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--src", type=Path, default=None, help="another checkout's src/ parent to run")
    args = ap.parse_args()
    env = dict(os.environ)
    if args.src is not None:
        env["PYTHONPATH"] = str(args.src.resolve() / "src")
    motorid = [sys.executable, "-m", "motorid"]
    with tempfile.TemporaryDirectory() as tmp:
        demo = Path(tmp) / "demo"
        subprocess.run([*motorid, "demo", "--out", str(demo), "--force"], env=env, capture_output=True, check=True)
        cases = [
            ("python -c pass", [sys.executable, "-c", "pass"]),
            ("import numpy, scipy.optimize, scipy.linalg",
             [sys.executable, "-c", "import numpy, scipy.optimize, scipy.linalg"]),
            ("motorid --help", [*motorid, "--help"]),
            ("motorid inspect (demo velocity capture)", [*motorid, "inspect", str(demo / "ALL0001")]),
            ("motorid identify (demo, 3 captures)",
             [*motorid, "identify", "--position", str(demo / "ALL0000"), "--velocity", str(demo / "ALL0001"),
              "--current", str(demo / "ALL0002"), "--json", str(Path(tmp) / "m.json"), "--force"]),
        ]
        if REAL.exists():
            cases.append(("motorid inspect (HSLU real log)", [*motorid, "inspect", str(REAL)]))
        print(f"source: {args.src.resolve() / 'src' if args.src else 'installed (editable) checkout'}; "
              f"{args.repeat} runs each, medians")
        print(f"{'command':42s} {'wall (s)':>9s} {'CPU (s)':>8s} {'wall - bare':>12s} {'CPU - bare':>11s} exit")
        bare_wall = bare_cpu = 0.0
        cpus: dict[str, float] = {}
        for label, argv in cases:
            wall, cpu, codes = median_run(argv, env, args.repeat)
            if label == "python -c pass":
                bare_wall, bare_cpu = wall, cpu
            cpus[label] = cpu
            print(f"{label:42s} {wall:9.3f} {cpu:8.3f} {wall - bare_wall:12.3f} {cpu - bare_cpu:11.3f} {codes}")
        warm = statistics.median(
            float(subprocess.run([sys.executable, "-c", WARM, str(demo)], env=env, capture_output=True, text=True,
                                 check=True).stdout.split()[-1]) for _ in range(args.repeat))
        help_extra = cpus["motorid --help"] - bare_cpu
        verdict = "meets" if help_extra < HELP_TARGET_S else "misses"
        print(f"--help costs {help_extra:.3f} s CPU more than a bare interpreter: {verdict} the "
              f"{HELP_TARGET_S} s target")
        start = cpus["motorid identify (demo, 3 captures)"] - warm
        scipy_cpu = cpus["import numpy, scipy.optimize, scipy.linalg"]
        verdict = "meets" if start <= IDENTIFY_START_RATIO * scipy_cpu else "misses"
        print(f"identify: {cpus['motorid identify (demo, 3 captures)']:.3f} s CPU, of which {warm:.3f} s the "
              f"identification itself (warm, in one process): start-up {start:.3f} s = "
              f"{start / scipy_cpu:.2f}x the numpy/scipy import ({scipy_cpu:.3f} s): {verdict} the "
              f"{IDENTIFY_START_RATIO}x target")


if __name__ == "__main__":
    main()
