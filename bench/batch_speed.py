"""``motorid batch`` speed: 50 demo experiments, ``--jobs 1`` vs ``--jobs 2`` vs a Dask LocalCluster.

Run: ``python3 bench/batch_speed.py [--n 50] [--data /tmp/motorid-batch-bench] [--no-report |
--reports full|lazy|none] [--no-dask]``.  Measure on a quiet machine (``uptime``: load below 0.5): the ratio is the
point, and other processes on the two cores take from the parallel run first.

The class: ``--n`` demo folders (:func:`motorid.cli.demo.run_demo`, seeds 0…n−1: the
paper's ALL0000–ALL0005 captures, roles guessed), written once into ``--data`` and reused.
Each run writes a fresh output folder (nothing is skipped): every experiment's model JSON
and report and the class summary, exactly what ``motorid batch`` does.

Printed: wall time and experiments a minute of each engine (and, for the pools, the batch
process's own CPU per experiment and the rate two free cores would give from the CPU times:
comparable on a busy machine, where the wall rates are not) (``--jobs 2`` twice: cold, then
with loky's workers kept from the first run, the rate of a long class), the ratio to
``--jobs 1``, the Dask cluster's start-up (cluster and workers started, separately from the
batch), and whether the ``summary.csv`` files are identical (they must be: no timings in them).  Per experiment, the
median wall time in its worker and the mean CPU time: equal CPU in every engine shows the
workers do the same work; a wall time well above the CPU time shows other processes on
the cores.  With the kernel's autogroup scheduling (``/proc/sys/kernel/sched_autogroup_enabled``)
the cores are shared between sessions, not processes: while another session is busy, the
two workers share this session's part and the ratio says nothing about the engine.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from motorid.batch import BatchSettings, parallel_map, run_batch


def _demo(job: tuple[int, str]) -> str:
    from motorid.cli.demo import run_demo

    seed, data = job
    folder = Path(data) / f"student{seed:03d}"
    run_demo(folder, seed=seed, force=True)
    return str(folder)


def _warm() -> None:
    import motorid.batch.task  # noqa: F401 - the imports a worker needs, done before the clock starts


def make_class(data: Path, n: int) -> None:
    """Write the ``n`` demo folders that are missing (in parallel: it is the engine's job too)."""
    missing = [i for i in range(n) if not (data / f"student{i:03d}" / "report.html").exists()]
    if missing:
        print(f"writing {len(missing)} demo experiments into {data} ...", flush=True)
        for _ in parallel_map(_demo, [(str(i), (i, str(data))) for i in missing], jobs=2):
            pass
    for extra in sorted(data.glob("student*")):  # a larger class left from an earlier --n
        if int(extra.name[7:]) >= n:
            shutil.rmtree(extra)


def timed(label: str, roots: list[Path], out: Path, settings: BatchSettings, **kw) -> float:
    shutil.rmtree(out, ignore_errors=True)
    t0, c0 = time.perf_counter(), time.process_time()
    result = run_batch(roots, out, settings, **kw)
    wall, parent_cpu = time.perf_counter() - t0, time.process_time() - c0
    counts = {s: sum(r.status == s for r in result.rows) for s in ("ok", "warning", "failed")}
    # each experiment's time in its worker: it grows when other processes share the cores
    recs = [json.loads(p.read_text()) for p in out.rglob("result.json")]
    per = statistics.median(r["seconds"] for r in recs)
    cpu = sum(r["cpu_seconds"] for r in recs)
    print(f"{label:<30}{wall:7.1f} s {60 * len(result.computed) / wall:6.0f}/min   "
          f"{len(result.computed)} computed: {counts['ok']} ok, "
          f"{counts['warning']} warning, {counts['failed']} failed; per experiment in its worker: median "
          f"{per:.2f} s wall, {cpu / len(recs):.2f} s CPU", flush=True)
    if kw.get("jobs", 1) != 1:
        # the batch's own process (discovery, hashes, writing, the summary) shares the cores with
        # the workers: the rate two free cores would give, whatever else the machine runs
        cap = 2 * 60 / (cpu / len(recs) + parent_cpu / len(recs))
        print(f"{'':30}batch process {1e3 * parent_cpu / len(recs):.0f} ms CPU per experiment; "
              f"CPU-bound rate on two free cores {cap:.0f}/min", flush=True)
    return wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=50)
    ap.add_argument("--data", type=Path, default=Path(tempfile.gettempdir()) / "motorid-batch-bench")
    ap.add_argument("--no-report", action="store_true", help="models only (no HTML report per experiment)")
    ap.add_argument("--reports", choices=("full", "lazy", "none"), default=None,
                    help="full reports, lazy ones (a small page each, the report on demand) or none")
    ap.add_argument("--no-dask", action="store_true")
    args = ap.parse_args()
    data = args.data / "class"
    data.mkdir(parents=True, exist_ok=True)
    make_class(data, args.n)
    reports = args.reports or ("none" if args.no_report else "full")
    settings = (BatchSettings(report=True, lazy_reports=True) if reports == "lazy"
                else BatchSettings(report=reports != "none"))
    outs = args.data / "out"
    load = os.getloadavg()[0]
    print(f"{args.n} experiments, reports {reports}; {os.cpu_count()} cores; "
          f"load average {load:.2f}" + ("  (busy machine: the ratio is not meaningful)" if load > 1 else ""))
    t1 = timed("--jobs 1 (this process)", [data], outs / "jobs1", settings, jobs=1)
    t2 = timed("--jobs 2 (loky, cold start)", [data], outs / "jobs2", settings, jobs=2)
    # loky keeps its workers between calls in one process: the second run is what a long class
    # sees once the workers' imports are paid (the fixed cost amortised)
    t2w = timed("--jobs 2 (loky, workers warm)", [data], outs / "jobs2warm", settings, jobs=2)
    print(f"ratio jobs1/jobs2: {t1 / t2:.2f} (cold), {t1 / t2w:.2f} (warm)")
    summaries = [outs / "jobs1" / "summary.csv", outs / "jobs2" / "summary.csv", outs / "jobs2warm" / "summary.csv"]
    if not args.no_dask:
        from distributed import Client, LocalCluster

        t0 = time.perf_counter()
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            with Client(cluster) as client:
                client.wait_for_workers(2)
                client.run(_warm)  # each worker imports motorid once
            startup = time.perf_counter() - t0
            print(f"{'Dask LocalCluster start-up':<30}{startup:7.1f} s   (2 worker processes, motorid imported)")
            td = timed("Dask LocalCluster (2 workers)", [data], outs / "dask", settings,
                       scheduler=cluster.scheduler_address)
        print(f"ratio jobs1/dask: {t1 / td:.2f} (start-up excluded), {t1 / (td + startup):.2f} (included)")
        summaries.append(outs / "dask" / "summary.csv")
    same = len({p.read_bytes() for p in summaries}) == 1
    print(f"summary.csv identical across engines: {same}; load average now {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
