"""Capture readers on large files: rows, MB, CPU seconds and peak memory, against pandas.read_csv.

Run: ``python3 bench/read_speed.py [--rows 10000,100000,1000000,2500000,10000000] [--tds 1000000]
[--src DIR] [--timeout 60] [--dir /tmp/motorid-read-bench]``.

Each read runs in a fresh child process (``python -c``); its CPU time (``time.process_time``,
from the interpreter's start: the imports are counted, pyarrow's or pandas' too when a reader imports
it) and its peak resident memory
(``resource.getrusage(RUSAGE_SELF).ru_maxrss`` of the child, includes the interpreter and
numpy, about 30 MB) are its own.  The files are plain CSVs ``time,input,velocity`` of about 26
bytes a row (a DAQ log) and one Tektronix "Save All" pair (``ALL0000/F0000CH1.CSV`` +
``F0000CH2.CSV``) written by :func:`motorid.io.write_tds_capture`; they are generated once and
kept in ``--dir``.  ``pandas.read_csv`` (its C engine, the same columns) is the peer when
pandas imports (``PYTHONPATH`` may point at a private install); ``ratio`` is motorid's time
over pandas's.  ``--src DIR`` reads with another checkout's ``DIR/src`` (the before/after
table); a read that exceeds ``--timeout`` seconds or the ``--mem`` limit is reported as such.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, time
t0 = time.process_time()
kind, path = sys.argv[1], sys.argv[2]
if kind == "pandas":
    import pandas as pd
    df = pd.read_csv(path)
    n = len(df)
elif kind == "pandas-tds":
    import pandas as pd
    n = 0
    for f in sorted(__import__("pathlib").Path(path).glob("*.CSV")):
        df = pd.read_csv(f, header=None, usecols=[3, 4])
        n = len(df)
else:
    from motorid.io import read_capture
    n = read_capture(path).n_samples
dt = time.process_time() - t0
print(json.dumps({"n": n, "s": dt, "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def make_plain(path: Path, rows: int) -> None:
    """A DAQ-style log: time (s), a 0 → 5.92 V step, a first-order velocity with noise."""
    import numpy as np

    rng = np.random.default_rng(1)
    with open(path, "w") as fh:
        fh.write("time,input,velocity\n")
        block = 1_000_000
        for start in range(0, rows, block):
            i = np.arange(start, min(rows, start + block))
            t = i * 1e-4
            u = np.where(i >= rows // 10, 5.92, 0.0)
            y = np.where(i >= rows // 10, 1.5 * (1 - np.exp(-(i - rows // 10) * 1e-4 / 0.4)), 0.0)
            y = y + rng.normal(0, 0.002, i.size)
            block_rows = zip(t.tolist(), u.tolist(), y.tolist(), strict=True)
            fh.write("".join(f"{a:.4f},{b:.2f},{c:.6f}\n" for a, b, c in block_rows))


def make_tds(folder: Path, n: int) -> Path:
    """A Save-All pair of ``n`` samples per channel (the TDS layout, a long record)."""
    import numpy as np

    from motorid.capture import Capture, ChannelInfo, ScopeInfo
    from motorid.io import write_tds_capture

    dt = 1e-5
    t = (np.arange(n) - n // 10) * dt
    lsb_in, lsb_out = 2.0 / 25, 0.5 / 25
    u = np.where(t >= 0, np.round(5.92 / lsb_in), 0.0) * lsb_in
    y = np.round(np.where(t >= 0, 1.5 * (1 - np.exp(-np.maximum(t, 0) / 0.4)), 0.0) / lsb_out) * lsb_out
    cap = Capture(source="<bench>", format="trainer", time_s=t, output_v=y,
                  output_info=ChannelInfo("CH2", "V", 0.5, 0.0, 1.0, 0.0), input_v=u,
                  input_info=ChannelInfo("CH1", "V", 2.0, 0.0, 10.0, 0.0),
                  scope=ScopeInfo("TDS2012C", "C0", "FV", n, n * dt / 10, n // 10))
    return write_tds_capture(folder, cap, force=True)


def child(kind: str, path: Path, env: dict[str, str], timeout: float, mem_mb: int) -> dict:
    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (mem_mb << 20, mem_mb << 20))

    try:
        proc = subprocess.run([sys.executable, "-c", CHILD, kind, str(path)], env=env, capture_output=True,
                              text=True, timeout=timeout, preexec_fn=limit)
    except subprocess.TimeoutExpired:
        return {"error": f"> {timeout:g} s"}
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["?"])[-1]
        return {"error": "MemoryError" if "MemoryError" in proc.stderr else last[:40]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", default="10000,100000,1000000,2500000,10000000")
    ap.add_argument("--tds", type=int, default=1_000_000, help="samples per channel of the TDS pair (0: none)")
    ap.add_argument("--src", type=Path, default=REPO, help="checkout whose src/ is read with")
    ap.add_argument("--timeout", type=float, default=60.0)
    ap.add_argument("--mem", type=int, default=4096, help="address-space limit of a child, MB")
    ap.add_argument("--dir", type=Path, default=Path("/tmp/motorid-read-bench"))
    ap.add_argument("--no-pandas", action="store_true")
    args = ap.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    extra = os.environ.get("PYTHONPATH", "")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(args.src / "src"), extra) if p)
    gen_env_path = str(REPO / "src")
    sys.path.insert(0, gen_env_path)
    have_pandas = not args.no_pandas and subprocess.run(
        [sys.executable, "-c", "import pandas"], env=env, capture_output=True).returncode == 0

    cases: list[tuple[str, Path, str]] = []
    for rows in (int(r) for r in args.rows.split(",") if r):
        f = args.dir / f"plain_{rows}.csv"
        if not f.exists():
            t0 = time.perf_counter()
            make_plain(f, rows)
            print(f"# wrote {f} in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
        cases.append((f"plain {rows}", f, "pandas"))
    if args.tds:
        folder = args.dir / f"tds_{args.tds}" / "ALL0000"
        if not folder.exists():
            make_tds(folder.parent, args.tds)
        cases.append((f"tds pair {args.tds}", folder, "pandas-tds"))

    print(f"reader: {args.src / 'src'}   pandas: {'yes' if have_pandas else 'not installed'}")
    head = f"{'file':<20} {'rows':>9} {'MB':>7} {'motorid CPU s':>13} {'RSS MB':>8}"
    if have_pandas:
        head += f" {'pandas CPU s':>12} {'RSS MB':>8} {'ratio':>6}"
    print(head)
    for name, path, peer in cases:
        mb = sum(p.stat().st_size for p in ([path] if path.is_file() else path.iterdir())) / 1e6
        ours = child("motorid", path, env, args.timeout, args.mem)
        rows = ours.get("n", "")
        line = f"{name:<20} {rows!s:>9} {mb:7.1f} "
        line += (f"{ours['s']:13.2f} {ours['rss_mb']:8.0f}" if "s" in ours else f"{ours['error']:>22}")
        if have_pandas:
            theirs = child(peer, path, env, args.timeout, args.mem)
            if "s" in theirs:
                ratio = f"{ours['s'] / theirs['s']:6.2f}" if "s" in ours else "     -"
                line += f" {theirs['s']:12.2f} {theirs['rss_mb']:8.0f} {ratio}"
            else:
                line += f" {theirs['error']:>21}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
