"""Median time per identification on the demo captures, each method, and python-control's ERA.

Run: ``python3 bench/identify_speed.py [--repeat 20]``.  Prints a table: the median wall time
of ``identify_experiment`` per method (reading of files excluded; conditioning included), and
the same job — a velocity model from the step response — done with python-control's
``eigensys_realization`` (ERA) on the Markov parameters of the sampled system (the
differenced step response), converted to continuous time; ratio = ours / ERA.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import control
import numpy as np
import scipy.linalg

from motorid.conditioning.pipeline import condition_experiment
from motorid.cli.demo import run_demo
from motorid.identification.pipeline import IdentifySettings, identify_conditioned, identify_experiment
from motorid.io import read_capture


def timed(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def era_model(cond, order: int):
    """python-control ERA on the differenced, reduced velocity step response → continuous."""
    t, v = cond.time_s, cond.outputs["velocity"]
    dt = float(t[1] - t[0])
    markov = np.diff(np.r_[0.0, v]) / cond.step_volts  # impulse response of the ZOH system
    # python-control's discrete impulse is a pulse of area 1 (height 1/dt): scale to match
    sysd, _ = control.eigensys_realization((markov / dt).reshape(1, 1, -1), r=order, dt=dt)
    # python-control 0.10 has no d2c: invert the ZOH with the matrix logarithm of the
    # augmented [[Ad, Bd], [0, I]] = expm([[A, B], [0, 0]]·dt)
    n = sysd.nstates
    aug = np.eye(n + 1)
    aug[:n, :n], aug[:n, n:] = sysd.A, sysd.B
    log = np.real(scipy.linalg.logm(aug)) / dt
    return control.ss(log[:n, :n], log[:n, n:], sysd.C, sysd.D)


def run_truth(seed: int) -> tuple[float, float]:
    from motorid.trainer import preset, truth_of

    tr = truth_of(preset("paper"))
    return tr.dc_gain, tr.time_constant_s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "demo"
        run_demo(out, seed=args.seed)
        caps = {
            "position": read_capture(out / "ALL0000"),
            "velocity": read_capture(out / "ALL0001"),
            "current": read_capture(out / "ALL0002"),
        }
    rows = []
    for method in ("pinv", "markov", "classic", "auto"):
        s = IdentifySettings(method=method)
        med, res = timed(lambda s=s: identify_experiment(caps, s), args.repeat)
        fo = res.model.first_order()
        rows.append((method, med, res.model.order, fo.dc_gain, fo.time_constant_s))
    cond = condition_experiment(caps, IdentifySettings().conditioning)
    t_cond, _ = timed(lambda: condition_experiment(caps, IdentifySettings().conditioning), args.repeat)
    t_era, sys_era = timed(lambda: era_model(cond, 2), args.repeat)
    poles_era = control.poles(sys_era)
    tau_era = float(np.sum(-1.0 / np.real(poles_era)) - np.sum(-1.0 / np.real(control.zeros(sys_era))))
    t_pinv_only, _ = timed(lambda: identify_conditioned(cond, IdentifySettings(method="pinv")), args.repeat)
    dc_era = float(np.real(control.dcgain(sys_era)))
    print(f"demo captures (paper preset, seed {args.seed}), median of {args.repeat} runs")
    print(f"{'method':<22}{'median time (ms)':>18}{'order':>7}{'dc gain':>10}{'tau (s)':>10}")
    for method, med, order, dc, tau in rows:
        print(f"{'motorid ' + method:<22}{1000 * med:>18.2f}{order:>7}{dc:>10.4f}{tau:>10.4f}")
    print(f"{'conditioning alone':<22}{1000 * t_cond:>18.2f}")
    print(f"{'control ERA (r=2)':<22}{1000 * t_era:>18.2f}{2:>7}{dc_era:>10.4f}{tau_era:>10.4f}")
    truth = run_truth(args.seed)
    print(f"{'truth (linearised)':<22}{'':>18}{'':>7}{truth[0]:>10.4f}{truth[1]:>10.4f}")
    print(f"ratio pinv identification (after conditioning) / ERA: {t_pinv_only / t_era:.2f}")
    print(f"ratio pinv end-to-end (conditioning included) / ERA alone: {rows[0][1] / t_era:.2f}")


if __name__ == "__main__":
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):  # tiny matrices: one BLAS thread per process is fastest
        main()
