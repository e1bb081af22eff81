"""Monte-Carlo accuracy of the static characteristic from several step levels.

For each run: the virtual trainer records 5 levels (2, 4, 6, 8, 10 V) × 3 repeats, each a
separate 8-bit acquisition with fresh noise; the dead-zone (amplifier dead-zone + Coulomb
friction referred to the input), the linear gain and the rails are identified and compared with
the trainer's truth.  Prints one row per preset.

    python bench/multilevel_accuracy.py [--runs 100]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from motorid._threads import single_blas_thread
from motorid.identification.hammerstein import level_response
from motorid.identification.static import fit_static_characteristic
from motorid.trainer.multilevel import MULTILEVEL_PRESETS, multilevel_experiment


@single_blas_thread
def run(preset: str, runs: int) -> dict[str, float]:
    dz_err, dz_cover, gain_err, gain_cover, sat_ok, times = [], [], [], [], [], []
    for seed in range(runs):
        exp = multilevel_experiment(preset, seed=10_000 + seed)
        t0 = time.perf_counter()
        fit = fit_static_characteristic([level_response(c.capture)[0] for c in exp.captures])
        times.append(time.perf_counter() - t0)
        truth = exp.truth
        dz_err.append(fit.dead_zone_v - truth.dead_zone_v)
        dz_cover.append(fit.dead_zone_ci95[0] <= truth.dead_zone_v <= fit.dead_zone_ci95[1])
        gain_err.append(fit.gain / truth.gain - 1)
        gain_cover.append(fit.gain_ci95[0] <= truth.gain <= fit.gain_ci95[1])
        saturated = {round(p.step_volts) for p in fit.points if p.status == "saturated"}
        expected = {u for u in (2, 4, 6, 8, 10) if u > truth.saturation_input_v}
        sat_ok.append(saturated == expected)
    dz, g = np.array(dz_err), np.array(gain_err)
    return {"dz_max": float(np.abs(dz).max()), "dz_rmse": float(np.sqrt(np.mean(dz**2))),
            "dz_cover": float(np.mean(dz_cover)), "gain_bias": float(g.mean()), "gain_max": float(np.abs(g).max()),
            "gain_cover": float(np.mean(gain_cover)), "sat_ok": float(np.mean(sat_ok)),
            "ms": 1e3 * float(np.median(times))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100)
    args = ap.parse_args()
    print(f"{args.runs} runs per preset; 5 levels × 3 repeats; truth: trainer dead-zone + Coulomb offset, linear gain")
    print(f"{'preset':16} {'|u0 err| max':>12} {'u0 RMSE':>9} {'u0 cover95':>10} {'K bias':>9} "
          f"{'|K err| max':>11} {'K cover95':>9} {'rails right':>11} {'fit ms':>7}")
    for preset in MULTILEVEL_PRESETS:
        r = run(preset, args.runs)
        print(f"{preset:16} {r['dz_max']:12.4f} {r['dz_rmse']:9.4f} {r['dz_cover']:10.2f} {100 * r['gain_bias']:8.3f}% "
              f"{100 * r['gain_max']:10.3f}% {r['gain_cover']:9.2f} {r['sat_ok']:11.2f} {r['ms']:7.1f}")


if __name__ == "__main__":
    main()
