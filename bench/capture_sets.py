"""Which capture moves τ: the same runs identified from different sets of captures, paired.

``python3 bench/capture_sets.py [--preset electrical-7ms] [--runs 60] [--jobs 2] [--sets …] [--switching …]``:
each run of the trainer (realistic noise) is identified with ``auto`` from all three captures,
from velocity + position, from velocity + current and from the velocity alone; the table gives
each set's bias of τ + dead time against the truth's moments (with its standard error), the
number of poles chosen, and the paired difference "all three − velocity alone".
``--switching no-spikes|no-tone|none`` takes (part of) the H-bridge's switching noise off the
current capture.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from dataclasses import replace
from multiprocessing import Pool
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from accuracy import config_of, experiment, residence_tau

from motorid.conditioning.pipeline import ConditioningSettings, condition_experiment
from motorid.identification.pipeline import IdentifySettings, identify_conditioned
from motorid.trainer.experiment import run_experiment

SETS = {"all three": ("velocity", "position", "current"), "velocity + position": ("velocity", "position"),
        "velocity + current": ("velocity", "current"), "velocity alone": ("velocity",)}


#: ``--switching``: the H-bridge's switching noise on the current capture, as recorded or in part.
SWITCHING = {"as-recorded": {}, "no-spikes": {"pwm_spike_v": 0.0}, "no-tone": {"pwm_noise_v": 0.0},
             "none": {"pwm_spike_v": 0.0, "pwm_noise_v": 0.0}}


def one_run(args: tuple[str, int, tuple[str, ...], str]) -> dict[str, tuple[float, int]]:
    preset, seed, names, switching = args
    warnings.simplefilter("ignore")
    if switching == "as-recorded":
        exp = experiment(preset, "realistic", seed, 0.0)
    else:
        cfg = replace(config_of(preset), **SWITCHING[switching])
        exp = run_experiment(config=cfg, seed=seed, validation=False)
    caps = dict(exp.captures)
    truth = residence_tau(exp.truth.velocity)
    out = {}
    for name, roles in SETS.items():
        if name not in names:
            continue
        cond = condition_experiment({r: caps[r] for r in roles}, ConditioningSettings(sample_interval_s=None))
        m = identify_conditioned(cond, IdentifySettings(method="auto")).model
        out[name] = (m.first_order().time_constant_s + m.delay_s - truth, len(m.poles()))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", default="electrical-7ms")
    ap.add_argument("--runs", type=int, default=60)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--sets", default=",".join(SETS), help="which capture sets, comma-separated")
    ap.add_argument("--switching", choices=list(SWITCHING), default="as-recorded",
                    help="the switching noise on the current capture (the rest of the realistic noise stays)")
    args = ap.parse_args()
    names = tuple(n.strip() for n in args.sets.split(","))
    if not {"all three", "velocity alone"} <= set(names) or not set(names) <= set(SETS):
        ap.error(f"--sets: a comma-separated subset of {', '.join(SETS)} holding 'all three' and 'velocity alone'")
    with Pool(args.jobs) as pool:
        res = pool.map(one_run, [(args.preset, s, names, args.switching) for s in range(args.runs)])
    print(f"{args.preset}, realistic noise (current's switching noise: {args.switching}), {args.runs} runs: "
          "τ + dead time − truth (s)")
    print(f"{'captures':22}{'bias':>11}{'± s.e.':>10}  poles chosen")
    for name in names:
        e = np.array([r[name][0] for r in res])
        poles = np.bincount([r[name][1] for r in res])
        print(f"{name:22}{e.mean():+11.2e}{e.std(ddof=1) / np.sqrt(e.size):10.1e}  "
              + ", ".join(f"{n}: {c}" for n, c in enumerate(poles) if c))
    d = np.array([r["all three"][0] - r["velocity alone"][0] for r in res])
    print(f"paired difference all three − velocity alone: {d.mean():+.2e} ± {d.std(ddof=1) / np.sqrt(d.size):.1e} s")


if __name__ == "__main__":
    main()
