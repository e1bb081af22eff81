"""Which capture moves τ: the same runs identified from different sets of captures, paired.

``python3 bench/capture_sets.py [--preset electrical-7ms] [--runs 60] [--jobs 2] [--sets …] [--switching …]``:
each run of the trainer (realistic noise) is identified with ``auto`` from all three captures,
from velocity + position, from velocity + current and from the velocity alone; the table gives
each set's bias of τ + dead time against the truth's moments (with its standard error), the
number of poles chosen, and the paired difference "all three − velocity alone".
``--switching no-spikes|no-tone|none`` takes (part of) the H-bridge's switching noise off the
current capture; ``--quantiser current-off|off`` records the current capture (or every capture)
without the scope's 8-bit quantiser, the rest of the run unchanged; ``--current-noise K`` scales
the white noise on the current monitor by K (the same draws, scaled: the runs stay paired);
``--parts`` adds, per set, the bias of the DC gain, the slow and the fast pole, the zeros' and the
dead time's share of τ + dead time.
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
from accuracy import config_of, residence_tau

from motorid.conditioning.pipeline import ConditioningSettings, condition_experiment
from motorid.identification.pipeline import IdentifySettings, identify_conditioned
from motorid.trainer import experiment as trainer_experiment
from motorid.trainer.experiment import run_experiment

SETS = {"all three": ("velocity", "position", "current"), "velocity + position": ("velocity", "position"),
        "velocity + current": ("velocity", "current"), "velocity alone": ("velocity",)}


#: ``--switching``: the H-bridge's switching noise on the current capture, as recorded or in part.
SWITCHING = {"as-recorded": {}, "no-spikes": {"pwm_spike_v": 0.0}, "no-tone": {"pwm_noise_v": 0.0},
             "none": {"pwm_spike_v": 0.0, "pwm_noise_v": 0.0}}


#: ``--quantiser``: the scope's 8-bit quantiser on every capture, off the current's, or off all.
QUANTISER = ("on", "current-off", "off")


def _current_noise_scaled(k: float):
    """The trainer's current monitor with its white noise scaled by ``k`` (same draws)."""
    original = trainer_experiment.current_v

    def current_v(config, plant, rng):
        return original(replace(config, noise_v=config.noise_v * k), plant, rng)

    return current_v


def _parts(m, truth_tf) -> dict[str, float]:
    """Fitted minus true: DC gain (relative), slow and fast time constants, the zeros' moment, dead time."""
    num = np.atleast_1d(np.squeeze(truth_tf.num[0][0])).astype(float)
    den = np.atleast_1d(np.squeeze(truth_tf.den[0][0])).astype(float)
    tp = np.sort(np.abs(np.real(np.roots(den))))
    tz = np.roots(num) if num.size > 1 else np.array([])
    p = np.sort(np.abs(np.real(m.poles())))
    z = m.zeros()
    return {"gain": m.dc_gain() / float(num[-1] / den[-1]) - 1.0,
            "slow": 1 / p[0] - 1 / tp[0],
            "fast": (float(np.sum(1 / p[1:])) if p.size > 1 else 0.0) - float(np.sum(1 / tp[1:])),
            "zeros": -float(np.real(np.sum(-1 / z))) + float(np.real(np.sum(-1 / tz))) if z.size or tz.size else 0.0,
            "delay": m.delay_s}


def one_run(args: tuple[str, int, tuple[str, ...], str, str, float]) -> dict[str, tuple[float, int, dict[str, float]]]:
    preset, seed, names, switching, quantiser, current_noise = args
    warnings.simplefilter("ignore")
    if current_noise != 1.0:
        trainer_experiment.current_v = _current_noise_scaled(current_noise)  # type: ignore[assignment]
    cfg = replace(config_of(preset), **SWITCHING[switching])
    exp = run_experiment(config=cfg, seed=seed, validation=False, quantise=quantiser == "on")
    caps = dict(exp.captures)
    if quantiser == "current-off":  # one child generator per capture: the others are the same run's
        caps = {**dict(run_experiment(config=cfg, seed=seed, validation=False).captures), "current": caps["current"]}
    truth = residence_tau(exp.truth.velocity)
    out = {}
    for name, roles in SETS.items():
        if name not in names:
            continue
        cond = condition_experiment({r: caps[r] for r in roles}, ConditioningSettings(sample_interval_s=None))
        m = identify_conditioned(cond, IdentifySettings(method="auto")).model
        out[name] = (m.first_order().time_constant_s + m.delay_s - truth, len(m.poles()), _parts(m, exp.truth.velocity))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", default="electrical-7ms")
    ap.add_argument("--runs", type=int, default=60)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--sets", default=",".join(SETS), help="which capture sets, comma-separated")
    ap.add_argument("--switching", choices=list(SWITCHING), default="as-recorded",
                    help="the switching noise on the current capture (the rest of the realistic noise stays)")
    ap.add_argument("--quantiser", choices=QUANTISER, default="on",
                    help="the scope's 8-bit quantiser: on every capture, off the current's, or off all")
    ap.add_argument("--current-noise", type=float, default=1.0,
                    help="scale of the white noise on the current monitor (the same draws)")
    ap.add_argument("--parts", action="store_true",
                    help="also the bias of the DC gain, the slow and the fast pole, the zeros and the dead time")
    args = ap.parse_args()
    names = tuple(n.strip() for n in args.sets.split(","))
    if not {"all three", "velocity alone"} <= set(names) or not set(names) <= set(SETS):
        ap.error(f"--sets: a comma-separated subset of {', '.join(SETS)} holding 'all three' and 'velocity alone'")
    with Pool(args.jobs) as pool:
        res = pool.map(one_run, [(args.preset, s, names, args.switching, args.quantiser, args.current_noise)
                                 for s in range(args.runs)])
    print(f"{args.preset}, realistic noise (current's switching noise: {args.switching}; quantiser "
          f"{args.quantiser}; current's white noise × {args.current_noise:g}), {args.runs} runs: "
          "τ + dead time − truth (s)")
    print(f"{'captures':22}{'bias':>11}{'± s.e.':>10}  poles chosen")
    for name in names:
        e = np.array([r[name][0] for r in res])
        poles = np.bincount([r[name][1] for r in res])
        print(f"{name:22}{e.mean():+11.2e}{e.std(ddof=1) / np.sqrt(e.size):10.1e}  "
              + ", ".join(f"{n}: {c}" for n, c in enumerate(poles) if c))
    d = np.array([r["all three"][0] - r["velocity alone"][0] for r in res])
    print(f"paired difference all three − velocity alone: {d.mean():+.2e} ± {d.std(ddof=1) / np.sqrt(d.size):.1e} s")
    if args.parts:
        keys = ("gain", "slow", "fast", "zeros", "delay")
        # a third pole splits the fast time constant in two: compare the runs where every set chose
        # the truth's order (two poles)
        same = [r for r in res if all(r[n][1] == 2 for n in names)]
        print(f"fitted − true over the {len(same)} runs where every set chose two poles (gain relative; "
              "slow, fast: 1/|p|; zeros: −Σ 1/|z|; delay), mean ± s.e.:")
        for name in (*names, "all three − velocity alone"):
            if name.endswith("alone") and name != "velocity alone":
                vals = {k: np.array([r["all three"][2][k] - r["velocity alone"][2][k] for r in same]) for k in keys}
            else:
                vals = {k: np.array([r[name][2][k] for r in same]) for k in keys}
            print(f"  {name:28}" + "  ".join(
                f"{k} {v.mean():+.2e}±{v.std(ddof=1) / np.sqrt(v.size):.1e}" for k, v in vals.items()))


if __name__ == "__main__":
    main()
