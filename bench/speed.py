"""CPU time and error of every estimator on the same samples, side by side in one run.

Run: ``python3 bench/speed.py [--repeat 5] [--presets paper,first-order] [--seed 0]``.

For each trainer preset (``paper`` is the demo's experiment: third order, as the `third-order`
preset), one experiment is recorded with the trainer's realistic noise and 8-bit codes, then
identified in this process, warm (one call first, not timed), with ``mi.identify(exp,
method=M)`` for ``auto``, ``oe``, ``markov``, ``pinv`` and ``classic``, and with scipy's
``curve_fit`` of a first order plus dead time on the same conditioned velocity samples (the
peer a student would write). It prints, per method, the median CPU time of a call
(``time.process_time``: the machine is shared, wall time is not a measure), the ratio to
``pinv``, the evaluations of scipy's ``least_squares`` in one call (residuals and Jacobians the
solver asked for, summed over every fit the method makes: a count the machine's load does not
move), and the errors of the DC gain and of the residence time (τ + dead time) against the
trainer's truth. The load average before and after is printed with the table; one BLAS thread,
as the library uses.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.optimize

import motorid as mi
from motorid.conditioning.pipeline import ConditioningSettings, condition_experiment
from motorid.trainer import run_experiment

METHODS = ("auto", "oe", "markov", "pinv", "classic")


@dataclass(frozen=True)
class Row:
    method: str
    cpu_s: float
    dc_gain: float
    residence_s: float
    evaluations: int | None  # None: the peer (curve_fit runs MINPACK's leastsq, not least_squares)


class SolverCount:
    """Counts the evaluations of ``scipy.optimize.least_squares`` (its ``nfev``) while installed.

    Every fit of the library calls it through the module attribute, so wrapping the attribute
    sees them all; the bench runs it around one call of each method.
    """

    def __init__(self) -> None:
        self.nfev = 0
        self._real = scipy.optimize.least_squares

    def __enter__(self) -> SolverCount:
        def counted(*args, **kwargs):
            sol = self._real(*args, **kwargs)
            self.nfev += int(sol.nfev)
            return sol

        scipy.optimize.least_squares = counted
        return self

    def __exit__(self, *exc) -> None:
        scipy.optimize.least_squares = self._real


def curve_fit_fopdt(exp: mi.Experiment) -> tuple[float, float]:
    """scipy ``curve_fit`` of ``K·u·(1 − exp(−(t − θ)/τ))`` on the conditioned velocity."""
    cond = condition_experiment(dict(exp.captures), ConditioningSettings(sample_interval_s=None))
    t, v, u = cond.full_time_s, cond.full_outputs["velocity"], cond.step_volts

    def f(tt: np.ndarray, k: float, tau: float, theta: float) -> np.ndarray:
        return k * u * (1.0 - np.exp(-np.clip(tt - theta, 0.0, None) / tau))

    (k, tau, theta), _ = scipy.optimize.curve_fit(f, t, v, p0=[v[-1] / u, 0.06 * t[-1], 0.0])
    return float(k), float(tau + theta)


def interleaved_cpu(calls: dict, repeat: int) -> dict:
    """Median CPU time and last output of each call, the calls taken in turn ``repeat`` times.

    Taken in turn, a change of the machine's load during the run weighs on every method
    alike, so the ratios hold better than the absolute times.
    """
    outs = {name: fn() for name, fn in calls.items()}  # warm: first-call costs are not the method's
    times: dict = {name: [] for name in calls}
    for _ in range(repeat):
        for name, fn in calls.items():
            t0 = time.process_time()
            outs[name] = fn()
            times[name].append(time.process_time() - t0)
    return {name: (statistics.median(times[name]), outs[name]) for name in calls}


def run_preset(name: str, seed: int, repeat: int) -> tuple[list[Row], float, float]:
    rec = run_experiment(name, seed=seed, validation=False)
    exp = mi.Experiment(captures=dict(rec.captures))
    dc_true = rec.truth.dc_gain * (1.0 - rec.truth.equivalent_input_offset_v / rec.step_volts)
    res_true = rec.truth.time_constant_s  # the velocity TF's residence time by moments (no dead time)
    calls = {m: (lambda m=m: mi.identify(exp, method=m)) for m in METHODS}
    calls["scipy curve_fit (FOPDT)"] = lambda: curve_fit_fopdt(exp)
    timed = interleaved_cpu(calls, repeat)
    evaluations = {}
    for name, fn in calls.items():  # one more call each, counted (the count is the same every call)
        with SolverCount() as count:
            fn()
        evaluations[name] = count.nfev
    rows = []
    for method in METHODS:
        t, fit = timed[method]
        fo = fit.model.first_order()
        rows.append(Row(method, t, fo.dc_gain, fo.time_constant_s + fit.model.delay_s, evaluations[method]))
    t, (k, res) = timed["scipy curve_fit (FOPDT)"]
    rows.append(Row("scipy curve_fit (FOPDT)", t, k, res, None))
    return rows, dc_true, res_true


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--presets", default="paper,first-order")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    for name in args.presets.split(","):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rows, dc_true, res_true = run_preset(name, args.seed, args.repeat)
        pinv = next(r.cpu_s for r in rows if r.method == "pinv")
        print(f"\npreset {name}, seed {args.seed}: median CPU of {args.repeat} warm calls, methods in turn; truth: "
              f"DC gain {dc_true:.4f}, residence time {res_true:.4f} s")
        print(f"{'method':<26}{'CPU (ms)':>10}{'× pinv':>9}{'solver evals':>14}{'DC gain err %':>15}"
              f"{'residence err %':>17}")
        for r in rows:
            evals = "–" if r.evaluations is None else str(r.evaluations)
            print(f"{r.method:<26}{1000 * r.cpu_s:>10.1f}{r.cpu_s / pinv:>9.1f}{evals:>14}"
                  f"{100 * (r.dc_gain / dc_true - 1):>15.3f}{100 * (r.residence_s / res_true - 1):>17.3f}")
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        main()
