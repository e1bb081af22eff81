"""Speed of the vectorised (Kp, Kv) modes map vs python-control's nonlinear simulation.

Builds the lab report's model (Tsiolakis 2022) with the 3rd-order lag of ``motorid modes``, maps
a 200×200 grid with :func:`motorid.simulation.modes.mode_map` (all 40 000 saturated loops stepped
together in numpy), then simulates a random subsample of the same grid points one by one with
``control.nlsys`` + ``control.input_output_response`` (the same loop, the same record and output
times), extrapolates that to the whole grid and prints the ratio (target ≥ 100×).  It also
reports how many of the subsample's labels agree when python-control's trajectories are
classified by the same criteria.

Run: ``python bench/modes_speed.py [--grid 200] [--sample 40] [--seed 0]``
"""

from __future__ import annotations

import argparse
import time

import control
import numpy as np

from motorid.control.params import MotorParams, model_from_params
from motorid.simulation.modes import MODES, ModeCriteria, _linearised_poles, classify_grid, mode_map, servo_plants
from motorid.simulation.modes import _GridStats


def _stats_from_theta(theta: np.ndarray, r: float) -> _GridStats:
    """The window statistics of :func:`simulate_servo_grid`, from stored trajectories (steps+1, N)."""
    steps = theta.shape[0] - 1
    q = steps // 4
    th = theta[1:]
    idx = np.arange(steps)
    quarter = np.minimum(3, idx // q)
    mid, tail = th[quarter == 2], th[quarter == 3]
    d = np.diff(theta, axis=0)
    tiny = 1e-9 * abs(r)
    rev = np.zeros(theta.shape[1], dtype=np.int64)
    for j in range(theta.shape[1]):
        direction = 0.0
        for k in range(steps):
            if abs(d[k, j]) > tiny:
                cur = np.sign(d[k, j])
                if quarter[k] == 3 and direction != 0 and cur != direction:
                    rev[j] += 1
                direction = cur
    peak = np.max(np.sign(r) * (th - r), axis=0)
    return _GridStats(np.all(np.isfinite(theta), axis=0), (mid.max(0) - mid.min(0)) / 2,
                      (tail.max(0) - tail.min(0)) / 2, rev, peak / abs(r) * 100, np.abs(theta[-1] - r))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", type=int, default=200)
    ap.add_argument("--sample", type=int, default=40)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    model = model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))
    _, plant = servo_plants(model)
    crit = ModeCriteria()
    kp = np.linspace(0.0, 600.0, args.grid)
    kv = np.linspace(0.0, 40.0, args.grid)
    t0 = time.perf_counter()
    mm = mode_map(plant, kp, kv, crit)
    t_vec = time.perf_counter() - t0
    n_grid = kp.size * kv.size

    rng = np.random.default_rng(args.seed)
    gp, gv = np.meshgrid(kp, kv)
    pick = rng.choice(n_grid, size=min(args.sample, n_grid), replace=False)
    duration = 20.0 * plant.time_constant_s()
    t_eval = np.linspace(0.0, duration, mm.steps + 1)
    a, b, cp, cv = plant.A, plant.B[:, 0], plant.cp, plant.cv
    r, sat = crit.step_v, crit.saturation_v

    def rhs(t, x, u, params):
        v = params["kp"] * (r - cp @ x) - params["kv"] * (cv @ x)
        return a @ x + b * min(max(v, -sat), sat)

    sys = control.nlsys(rhs, None, states=plant.order, inputs=0, outputs=plant.order, params={"kp": 1.0, "kv": 1.0})
    thetas = np.empty((t_eval.size, pick.size))
    t0 = time.perf_counter()
    for j, i in enumerate(pick):
        resp = control.input_output_response(sys, t_eval, 0, X0=np.zeros(plant.order),
                                             params={"kp": gp.ravel()[i], "kv": gv.ravel()[i]},
                                             solve_ivp_kwargs={"rtol": 1e-6, "atol": 1e-9})
        thetas[:, j] = cp @ np.asarray(resp.states)
    t_pc = time.perf_counter() - t0
    per_point = t_pc / pick.size
    extrapolated = per_point * n_grid
    poles = _linearised_poles(plant, gp.ravel()[pick], gv.ravel()[pick])
    ref_labels = classify_grid(_stats_from_theta(thetas, r), poles, crit)
    agree = int(np.sum(ref_labels == mm.labels.ravel()[pick]))
    print(f"grid {kp.size}×{kv.size} = {n_grid} saturated 3rd-order loops, {mm.steps} RK4 steps each")
    print(f"vectorised numpy map:            {t_vec:8.2f} s  ({1e6 * t_vec / n_grid:.1f} µs per point)")
    print(f"python-control nlsys/input_output_response: {per_point * 1e3:.1f} ms per point "
          f"({pick.size} points), extrapolated {extrapolated:8.1f} s")
    print(f"speed ratio: {extrapolated / t_vec:.0f}×  (target ≥ 100×)")
    print(f"labels agreeing on the subsample: {agree}/{pick.size}")
    for k, i in enumerate(pick):
        if ref_labels[k] != mm.labels.ravel()[i]:
            print(f"  differs at Kp={gp.ravel()[i]:.3g} Kv={gv.ravel()[i]:.3g}: numpy {MODES[mm.labels.ravel()[i]]}, "
                  f"python-control {MODES[ref_labels[k]]}")


if __name__ == "__main__":
    main()
