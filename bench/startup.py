"""Start-up cost of the CLI: ``--help``, ``inspect`` and ``identify`` against a bare interpreter and scipy.

Run: ``python3 bench/startup.py [--repeat 7] [--src DIR] [--before DIR]``.

Each command runs in a fresh process (``python -m motorid ...``, the console script's own code
path without the pyenv shim in front), in the default environment (no BLAS variables set here;
``PYTHONDONTWRITEBYTECODE`` removed, and one run first so the bytecode is cached, as on a user's
second run),
``--repeat`` times; the table shows the median wall time and the median CPU time (user + system
of the child, from ``getrusage(RUSAGE_CHILDREN)``) and both minus the median of ``python -c pass``
measured the same way.  Targets: ``--help`` (and ``identify --help``) under 0.15 s of CPU more
than the bare interpreter; ``identify``'s start-up (its process CPU minus the same identification
run warm in one process, measured in a child) at most 1.5× the CPU of ``python -c "import numpy,
scipy.optimize, scipy.linalg"``.  ``--src DIR`` runs another checkout's source (``PYTHONPATH=DIR/src``);
``--before DIR`` runs a second source too (a copy of ``src/`` taken before a change), each of its
runs right after the same run of the first, and prints its table after the first's: on a shared
machine the two tables then see the same load.
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

#: A child that does twice what ``motorid identify`` does after starting and prints the second
#: time's CPU seconds: read the captures, identify, write the JSON, the printout with its advice
#: line (the experiment advisor's prediction, which the command computes too: leaving it out
#: counted it as start-up).
WARM = """
import sys, time, warnings
warnings.simplefilter("ignore")
import motorid as mi
d = sys.argv[1]
def once():
    exp = mi.read_experiment(position=d + "/ALL0000", velocity=d + "/ALL0001", current=d + "/ALL0002")
    fit = mi.identify(exp)
    fit.model.to_json_text()
    fit.summary()  # its advice line included
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


def cases(motorid: list[str], demo: Path, tmp: Path) -> list[tuple[str, list[str]]]:
    """The command lines measured: labels and argv."""
    out = [
        ("python -c pass", [sys.executable, "-c", "pass"]),
        ("import numpy, scipy.optimize, scipy.linalg",
         [sys.executable, "-c", "import numpy, scipy.optimize, scipy.linalg"]),
        ("motorid --help", [*motorid, "--help"]),
        ("motorid identify --help", [*motorid, "identify", "--help"]),
        ("motorid inspect (demo velocity capture)", [*motorid, "inspect", str(demo / "ALL0001")]),
        ("motorid identify (demo, 3 captures)",
         [*motorid, "identify", "--position", str(demo / "ALL0000"), "--velocity", str(demo / "ALL0001"),
          "--current", str(demo / "ALL0002"), "--json", str(tmp / "m.json"), "--force"]),
    ]
    if REAL.exists():
        out.append(("motorid inspect (HSLU real log)", [*motorid, "inspect", str(REAL)]))
    return out


def table(title: str, cpus: dict[str, list[float]], walls: dict[str, list[float]], codes: dict[str, set[int]],
          warm: list[float]) -> None:
    """Print one source's table and its verdicts."""
    med = statistics.median
    print(title)
    print(f"{'command':42s} {'wall (s)':>9s} {'CPU (s)':>8s} {'wall - bare':>12s} {'CPU - bare':>11s} exit")
    bare_wall, bare_cpu = med(walls["python -c pass"]), med(cpus["python -c pass"])
    for label in cpus:
        wall, cpu = med(walls[label]), med(cpus[label])
        print(f"{label:42s} {wall:9.3f} {cpu:8.3f} {wall - bare_wall:12.3f} {cpu - bare_cpu:11.3f} "
              f"{sorted(codes[label])}")
    for label in ("motorid --help", "motorid identify --help"):
        extra = med(cpus[label]) - bare_cpu
        verdict = "meets" if extra <= HELP_TARGET_S else "misses"
        print(f"{label[8:]} costs {extra:.3f} s CPU more than a bare interpreter: {verdict} the "
              f"{HELP_TARGET_S} s target")
    ident = med(cpus["motorid identify (demo, 3 captures)"])
    start = ident - med(warm)
    scipy_cpu = med(cpus["import numpy, scipy.optimize, scipy.linalg"])
    verdict = "meets" if start <= IDENTIFY_START_RATIO * scipy_cpu else "misses"
    print(f"identify: {ident:.3f} s CPU, of which {med(warm):.3f} s the identification itself (warm, in one "
          f"process): start-up {start:.3f} s = {start / scipy_cpu:.2f}x the numpy/scipy import ({scipy_cpu:.3f} s): "
          f"{verdict} the {IDENTIFY_START_RATIO}x target")


def main() -> None:
    """Print the start-up table (one per source, their runs interleaved)."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--src", type=Path, default=None, help="another checkout's src/ parent to run")
    ap.add_argument("--before", type=Path, default=None,
                    help="also run this checkout's src/ parent, each run next to the other's (a before/after pair)")
    args = ap.parse_args()
    sources: list[Path | None] = [args.src] + ([args.before] if args.before is not None else [])
    envs = []
    for src in sources:
        env = dict(os.environ)
        # as a user's second run: the bytecode cached (an inherited PYTHONDONTWRITEBYTECODE, as in
        # this project's shells, recompiled every module changed since its last .pyc on every run:
        # 13 modules, 28 ms of a --help)
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        if src is not None:
            env["PYTHONPATH"] = str(src.resolve() / "src")
        envs.append(env)
    motorid = [sys.executable, "-m", "motorid"]
    with tempfile.TemporaryDirectory() as tmp:
        demo = Path(tmp) / "demo"
        subprocess.run([*motorid, "demo", "--out", str(demo), "--force"], env=envs[0], capture_output=True, check=True)
        for env in envs:  # writes the bytecode of what the commands import, as any first run does
            subprocess.run([*motorid, "--help"], env=env, capture_output=True, check=True)
        todo = cases(motorid, demo, Path(tmp))
        cpus: list[dict[str, list[float]]] = [{label: [] for label, _ in todo} for _ in sources]
        walls: list[dict[str, list[float]]] = [{label: [] for label, _ in todo} for _ in sources]
        codes: list[dict[str, set[int]]] = [{label: set() for label, _ in todo} for _ in sources]
        warm: list[list[float]] = [[] for _ in sources]
        # every run of one source next to the same run of the other: a shared machine's load
        # changes over minutes, and this keeps it out of the before/after ratio
        for _ in range(args.repeat):
            for label, argv in todo:
                for i, env in enumerate(envs):
                    wall, cpu, code = run(argv, env)
                    cpus[i][label].append(cpu)
                    walls[i][label].append(wall)
                    codes[i][label].add(code)
            for i, env in enumerate(envs):
                out = subprocess.run([sys.executable, "-c", WARM, str(demo)], env=env, capture_output=True, text=True,
                                     check=True)
                warm[i].append(float(out.stdout.split()[-1]))
        for i, src in enumerate(sources):
            where = src.resolve() / "src" if src is not None else "installed (editable) checkout"
            if i:
                print()
            table(f"source: {where}; {args.repeat} runs each, medians", cpus[i], walls[i], codes[i], warm[i])


if __name__ == "__main__":
    main()
