"""CPU and error of the Markov method (Laguerre basis, polished) over presets and seeds.

Run: ``python3 bench/markov_speed.py [--seeds 6] [--presets paper,first-order,second-order,third-order,lab-report]
[--src DIR]``.

The Markov method's cost is its output-error polish of each order's realisation, and that cost
depends on the recording (how long a fit with a pole–zero pair to spare creeps on), so one seed
says little: each preset is recorded with the trainer's realistic noise for seeds ``0 … N−1`` and
identified once with ``mi.identify(exp, method="markov")`` in this process (one BLAS thread). It
prints each run's CPU (``time.process_time``), order, and DC-gain and residence-time errors
against the trainer's truth, then the median, largest and total CPU and the errors' RMS over
all runs.  ``--src DIR`` imports motorid from another checkout's ``DIR/src`` (before/after).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--presets", default="paper,first-order,second-order,third-order,lab-report")
    ap.add_argument("--src", default=None, help="a checkout whose src/ to import motorid from")
    args = ap.parse_args()
    if args.src:
        sys.path.insert(0, os.path.join(args.src, "src"))
    import motorid as mi
    from motorid.trainer import run_experiment

    print(f"motorid from {os.path.dirname(mi.__file__)}; load average before: {os.getloadavg()[0]:.2f}")
    print(f"{'preset':<14}{'seed':>5}{'CPU (s)':>9}{'order':>7}{'DC gain err %':>15}{'residence err %':>17}")
    cpu: list[float] = []
    dc_err: list[float] = []
    res_err: list[float] = []
    for name in args.presets.split(","):
        for seed in range(args.seeds):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rec = run_experiment(name, seed=seed, validation=False)
                exp = mi.Experiment(captures=dict(rec.captures))
                dc_true = rec.truth.dc_gain * (1.0 - rec.truth.equivalent_input_offset_v / rec.step_volts)
                t0 = time.process_time()
                res = mi.identify(exp, method="markov")
                dt = time.process_time() - t0
            fo = res.model.first_order()
            cpu.append(dt)
            dc_err.append(fo.dc_gain / dc_true - 1)
            res_err.append((fo.time_constant_s + res.model.delay_s) / rec.truth.time_constant_s - 1)
            print(f"{name:<14}{seed:>5}{dt:>9.2f}{res.model.order:>7}"
                  f"{100 * dc_err[-1]:>15.3f}{100 * res_err[-1]:>17.3f}", flush=True)

    def rms(xs: list[float]) -> float:
        return (sum(x * x for x in xs) / len(xs)) ** 0.5

    print(f"\n{len(cpu)} runs: CPU median {statistics.median(cpu):.2f} s, largest {max(cpu):.2f} s, total "
          f"{sum(cpu):.1f} s; RMS error DC gain {100 * rms(dc_err):.3f} %, residence time {100 * rms(res_err):.3f} %")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        main()
