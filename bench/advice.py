"""Monte Carlo of the experiment advisor: does re-recording with its advice give the intervals it predicts?

Run: ``python3 bench/advice.py [--seeds 10] [--roles velocity] [--cases two-divisions,short-record,
coarse-sampling,well-recorded] [--jobs 1]``.

For each case the paper's trainer (velocity τ ≈ 0.43 s, 5.92 V step) is recorded at the case's
scope settings with one seed; ``motorid.advise`` reads that first capture; the trainer records again
with a fresh seed at the advice's combined settings; that capture is identified as ``motorid
identify`` does.  Printed per case:

- ``first``: the setting the advice names first (the one that narrows τ's interval most) and in
  how many runs;
- ``now pred/id``: the predicted widths for the first capture over the ones ``identify`` reports
  (median; 1 = the prediction is the identification's own interval);
- ``gain act/pred``, ``τ act/pred``: the widths ``identify`` reports on the re-recorded capture over
  the advice's prediction for it (median and range over the seeds), without the spread between
  candidate structures (the Fisher interval of the chosen structure: what the advice predicts);
- ``τ +spread``: the same with that spread (the interval ``identify`` prints);
- ``τ narrower``: the first capture's τ width over the re-recorded one's, as ``identify`` prints
  them (median, min);
- ``nothing``: the runs in which the advice said nothing is worth changing.

Widths are full 95 % widths over the estimate.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections import Counter
from typing import Any

from joblib import Parallel, delayed

from motorid.analysis.advice import advise
from motorid.identification.pipeline import identify_experiment
from motorid.trainer.experiment import run_experiment

#: The first capture's settings of each case.
CASES: dict[str, dict[str, Any]] = {
    # the velocity at 5 V/div: about one of the eight divisions, the quantiser's step 0.2 V
    "two-divisions": dict(volts_per_div={"velocity": 5.0}, sec_per_div=0.5, trigger_position_pct=10.0),
    # 100 ms/div, 30 % before the trigger: the record ends at about 1.6 τ
    "short-record": dict(sec_per_div=0.1, trigger_position_pct=30.0),
    # 5 s/div: 20 ms samples, about 20 per τ (the ladder has no 16-per-τ setting near it)
    "coarse-sampling": dict(sec_per_div=5.0, trigger_position_pct=10.0),
    # 250 ms/div, 2 V/div, 10 % before the trigger
    "well-recorded": dict(sec_per_div=0.25, trigger_position_pct=10.0),
}


def _reported(ident: Any, key: str, *, spread: bool = False) -> float:
    """The identification's 95 % width over the estimate; with ``spread``, the structures' spread included."""
    u = ident.model.uncertainty[key]
    std = float(u["std"]) if spread else math.sqrt(max(float(u["std"]) ** 2 - float(u.get("structure_std", 0)) ** 2, 0))
    return 2 * 1.96 * std / abs(float(u["value"]))


def one_run(case: str, seed: int, roles: tuple[str, ...]) -> dict[str, Any]:
    """First capture → advice → capture at the combined settings → identification."""
    t0 = time.perf_counter()
    exp = run_experiment("paper", seed=seed, roles=roles, validation=False, **CASES[case])
    ident = identify_experiment(exp.captures)
    adv = advise(ident, exp.captures)
    c = adv.combined
    again = run_experiment("paper", seed=seed + 1000, roles=roles, validation=False,
                           volts_per_div=dict(c.volts_per_div), sec_per_div=c.time_per_div_s,
                           trigger_position_pct=c.trigger_position_pct, averages=c.averages, step_volts=c.step_volts)
    ident2 = identify_experiment(again.captures)
    first = adv.most_important
    return {
        "first": "nothing" if first is None else (f"{first.setting}({first.channel})" if first.channel
                                                  else first.setting),
        "worth": adv.worth_changing,
        "combined": f"{c.time_per_div_s:g} s/div {c.trigger_position_pct:g} % "
                    + " ".join(f"{k} {v:g}" for k, v in c.volts_per_div.items() if k != "input"),
        "now_dc": adv.now.dc_gain / _reported(ident, "dc_gain"),
        "now_tau": adv.now.time_constant / _reported(ident, "time_constant"),
        "dc": _reported(ident2, "dc_gain") / adv.combined_predicted.dc_gain,
        "tau": _reported(ident2, "time_constant") / adv.combined_predicted.time_constant,
        "tau_spread": _reported(ident2, "time_constant", spread=True) / adv.combined_predicted.time_constant,
        "narrower": _reported(ident, "time_constant", spread=True) / _reported(ident2, "time_constant", spread=True),
        "seconds": time.perf_counter() - t0,
    }


def _spread(values: list[float]) -> str:
    ok = [v for v in values if math.isfinite(v)]
    if not ok:
        return "—"
    return f"{statistics.median(ok):.2f} [{min(ok):.2f}, {max(ok):.2f}]"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--roles", default="velocity", help="captures recorded, e.g. velocity,current")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()
    roles = tuple(r.strip() for r in args.roles.split(",") if r.strip())
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    jobs = [(case, seed) for case in cases for seed in range(args.seeds)]
    t0 = time.perf_counter()
    rows = Parallel(n_jobs=args.jobs)(delayed(one_run)(case, seed, roles) for case, seed in jobs)
    by_case: dict[str, list[dict[str, Any]]] = {}
    for (case, _), row in zip(jobs, rows, strict=True):
        by_case.setdefault(case, []).append(row)
    head = (f"{'case':16} {'runs':>4}  {'first (runs)':28} {'now pred/id dc, τ':18} {'gain act/pred':20} "
            f"{'τ act/pred':20} {'τ +spread':20} {'τ narrower':18} {'nothing':>7}")
    print(f"advice bench: trainer 'paper', captures {','.join(roles)}, {args.seeds} seeds per case")
    print(head)
    print("-" * len(head))
    for case, rs in by_case.items():
        first, n_first = Counter(r["first"] for r in rs).most_common(1)[0]
        now = f"{statistics.median(r['now_dc'] for r in rs):.2f}, {statistics.median(r['now_tau'] for r in rs):.2f}"
        narrower = [r["narrower"] for r in rs]
        print(f"{case:16} {len(rs):>4}  {f'{first} ({n_first})':28} {now:18} {_spread([r['dc'] for r in rs]):20} "
              f"{_spread([r['tau'] for r in rs]):20} {_spread([r['tau_spread'] for r in rs]):20} "
              f"{statistics.median(narrower):.2f} (min {min(narrower):.2f})".ljust(18)
              + f" {sum(not r['worth'] for r in rs):>7}")
    combined = Counter(r["combined"] for rs in by_case.values() for r in rs)
    print("combined settings suggested (runs): " + "; ".join(f"{k} ({v})" for k, v in combined.most_common(6)))
    print(f"{len(jobs)} runs in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
