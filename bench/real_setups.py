"""Default-options accuracy on the real-setup presets and the HSLU recordings, run as a user runs it.

For each preset of :mod:`motorid.trainer.realsetups` × seeds, and for each open-loop file of
``../shared/real/hslu-rtl-dcmotor/csv/06_*.csv``, this runs ``python -m motorid identify
<args> --json OUT`` in a fresh process with the default environment (no BLAS thread limit
set here: the tool must set its own) and compares the model JSON with the truth:

- DC gain: ``first_order.dc_gain`` vs the incremental gain the step shows;
- mean residence time: ``Σ1/p − Σ1/z`` of the reported ``velocity_tf`` + the reported
  ``delay_s`` (top level, else ``extras.delay_s``) vs the truth's τ + dead time (+ encoder lag);
- whether the headline (``first_order``) lies inside ``uncertainty``'s ci95 intervals;
- whether the truth's DC gain and residence time lie inside them (is the interval honest).

HSLU references (PROVENANCE.md, the authors' PT2 + dead time fit, hand-refined values): gain
245.5 rpm/V (no brake) and 150.5 rpm/V (brake 0.5); residence time 2·T1 + Td =
2·0.1468 + 0.035 = 0.3286 s and 2·0.1015 + 0.045 = 0.248 s.  These are the authors' fit, not
ground truth.

Usage::

    python bench/real_setups.py [--seeds 5] [--src DIR] [--setups a,b] [--no-real] [--counted]

``--counted`` also runs each rig whose speed column counts encoder edges over each interval
(:data:`~motorid.trainer.hobbyrigs.COUNTED_SPEED_RIGS`, and ``pwm-encoder``, whose speed is counted over
five lines and logged on each) with ``--counted-velocity``, the rows
named ``RIG +counted``. A model that fitted its velocity as counted (``timing.velocity.window_s``:
said so, or read off a log whose speed times its own stamped intervals is whole counts) is the
motor's, so its residence time is compared with the truth's less the counting's lag
(``sensor_lag_s``, half the interval).

``--src DIR`` runs another checkout's source (``PYTHONPATH=DIR/src``), e.g. the code before
the real-set-up work: ``git worktree add /tmp/motorid-before 595a727`` then ``--src /tmp/motorid-before``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "src"))

from motorid.trainer.hobbyrigs import COUNTED_SPEED_RIGS  # noqa: E402

#: Rigs whose speed column is counted: over each line, or over five and kept for five (pwm-encoder).
COUNTED = (*COUNTED_SPEED_RIGS, "pwm-encoder")
from motorid.trainer.realsetups import REAL_SETUPS, write_real_setup  # noqa: E402

REAL = ROOT.parent / "shared" / "real" / "hslu-rtl-dcmotor" / "csv"
#: authors' gain (rpm/V) and 2·T1 + Td (s) with their hand-refined T1, Td (PROVENANCE.md)
HSLU_REFERENCE = {
    "06_dc_step_5_15_00.csv": (245.5, 2 * 0.1468 + 0.035),
    "06_dc_step_5_15_05.csv": (150.5, 2 * 0.1015 + 0.045),
}


def counted(model: dict) -> bool:
    """Whether the model fitted its velocity as counted over a window (``timing.velocity.window_s``)."""
    return bool(((model.get("timing") or {}).get("velocity") or {}).get("window_s"))


def residence_time(model: dict) -> float:
    """Mean residence time of the reported velocity TF by moments, plus the reported delay."""
    tf = model.get("velocity_tf")
    if not tf:
        return float("nan")
    poles = np.roots(np.asarray(tf["den"], float))
    zeros = np.roots(np.asarray(tf["num"], float)) if len(tf["num"]) > 1 else np.array([])
    tau = float(np.real(np.sum(-1.0 / poles) - np.sum(-1.0 / zeros)))
    delay = model.get("delay_s")
    if delay is None:
        delay = (model.get("extras") or {}).get("delay_s")
    return tau + float(delay or 0.0)


def inside_ci(model: dict) -> str:
    """``yes`` when the headline DC gain and τ both lie in their ci95, ``no``, or ``—``."""
    unc = model.get("uncertainty") or {}
    fo = model.get("first_order") or {}
    keys = [("dc_gain", "dc_gain"), ("time_constant", "time_constant")]
    checks = []
    for head, key in keys:
        if key not in unc or head not in fo or not unc[key].get("ci95"):
            continue
        lo, hi = unc[key]["ci95"]
        checks.append(lo <= fo[head] <= hi)
    if not checks:
        return "—"
    return "yes" if all(checks) else "no"


def truth_in_ci(model: dict, dc_true: float, res_true: float) -> str:
    """``yes`` when the truth's DC gain and residence time both lie in the model's ci95, ``no``, or ``—``.

    Unlike :func:`inside_ci` (the headline against its own interval), this asks whether the
    interval is honest: a preset's truth is known.
    """
    unc = model.get("uncertainty") or {}
    checks = []
    for key, truth in (("dc_gain", dc_true), ("residence_time_s", res_true)):
        ci = (unc.get(key) or {}).get("ci95")
        if ci and np.isfinite(truth):
            checks.append(ci[0] <= truth <= ci[1])
    if not checks:
        return "—"
    return "yes" if all(checks) else "no"


def run_identify(args: list[str], out: Path, src: Path | None) -> tuple[int, dict | None, float, str]:
    """One ``python -m motorid identify`` in a fresh process; exit code, JSON, wall time, stderr."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src / "src") + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, "-m", "motorid", "identify", *args, "--json", str(out)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tempfile.gettempdir())
    wall = time.perf_counter() - t0
    model = json.loads(out.read_text()) if proc.returncode == 0 and out.exists() else None
    return proc.returncode, model, wall, proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else ""


def pct(x: float, ref: float) -> float:
    return 100.0 * (x - ref) / ref


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--src", type=Path, default=None, help="checkout whose src/ to run (PYTHONPATH)")
    ap.add_argument("--setups", default=",".join(REAL_SETUPS))
    ap.add_argument("--no-real", action="store_true", help="skip ../shared/real")
    ap.add_argument("--counted", action="store_true",
                    help="also run the counted-speed rigs with --counted-velocity (against the motor's own timing)")
    opts = ap.parse_args(argv)
    setups = [s for s in opts.setups.split(",") if s]
    rows = []
    with tempfile.TemporaryDirectory(prefix="motorid-real-") as tmp:
        work = Path(tmp)
        cases = []
        for name in setups:
            for seed in range(opts.seeds):
                rec = write_real_setup(name, work / f"{name}-{seed}", seed=seed)
                cases.append((name, str(seed), list(rec.cli_args), rec.truth.dc_gain, rec.truth.residence_time_s,
                              rec.truth.sensor_lag_s))
                if opts.counted and name in COUNTED:
                    cases.append((f"{name} +counted", str(seed), [*rec.cli_args, "--counted-velocity"],
                                  rec.truth.dc_gain, rec.truth.residence_time_s, rec.truth.sensor_lag_s))
        if not opts.no_real and REAL.is_dir():
            for f in sorted(REAL.glob("06_*.csv")):
                dc, res = HSLU_REFERENCE.get(f.name, (float("nan"), float("nan")))
                cases.append(("hslu:" + f.stem[3:], "—", ["--velocity", str(f)], dc, res, 0.0))
        for i, (name, seed, args, dc_true, res_true, lag) in enumerate(cases):
            out = work / f"model-{i}.json"
            code, model, wall, err = run_identify(args, out, opts.src)
            if model is None:
                rows.append((name, seed, code, float("nan"), float("nan"), "—", wall, "—", err, "—"))
                continue
            if counted(model):
                # the model is the motor's, the counting modelled (said, or read off the log): its own timing
                res_true -= lag
            dc = float(model["first_order"]["dc_gain"])
            truth_ci = truth_in_ci(model, dc_true, res_true) if not name.startswith("hslu:") else "—"
            rows.append((name, seed, code, pct(dc, dc_true), pct(residence_time(model), res_true),
                         inside_ci(model), wall, str(len(model.get("warnings") or [])), "", truth_ci))
    src = str(opts.src) if opts.src else "this checkout"
    print(f"# motorid identify, default options, fresh process each ({src})\n")
    print("truth: presets = their linearised plant (incremental gain; τ by moments + dead time + encoder lag; "
          "without the encoder's counting lag for a model that fitted the counting);")
    print("hslu = the authors' gain and 2·T1 + Td with their hand-refined T1, Td (a reference, not ground truth)")
    if opts.counted:
        print("RIG +counted = the same log with --counted-velocity, against the motor's own timing (the truth's "
              "residence time less the counting's lag, half the interval)")
    print()
    print("| setup | seed | exit | dc gain err % | residence err % | headline in ci95 | truth in ci95 | wall s |"
          " warnings |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, seed, code, edc, eres, ci, wall, nw, err, tci in rows:
        note = f" ({err[:70]})" if err else ""
        print(f"| {name} | {seed} | {code}{note} | {edc:+.2f} | {eres:+.2f} | {ci} | {tci} | {wall:.1f} | {nw} |")
    print("\n| setup | runs | exit 0 | dc gain abs err % median / worst | residence abs err % median / worst |"
          " headline in ci95 | truth in ci95 (gain and residence) | wall s median |")
    print("|---|---|---|---|---|---|---|---|")
    for name in dict.fromkeys(r[0] for r in rows):
        sub = [r for r in rows if r[0] == name]
        ok = [r for r in sub if r[2] == 0]
        edc = [abs(r[3]) for r in ok]
        eres = [abs(r[4]) for r in ok]

        def fmt(v: list[float]) -> str:
            return f"{statistics.median(v):.2f} / {max(v):.2f}" if v else "—"

        cis = [r[5] for r in ok if r[5] != "—"]
        ci = f"{sum(c == 'yes' for c in cis)}/{len(cis)}" if cis else "—"
        tcis = [r[9] for r in ok if r[9] != "—"]
        tci = f"{sum(c == 'yes' for c in tcis)}/{len(tcis)}" if tcis else "—"
        print(f"| {name} | {len(sub)} | {len(ok)} | {fmt(edc)} | {fmt(eres)} | {ci} | {tci} |"
              f" {statistics.median(r[6] for r in sub):.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
