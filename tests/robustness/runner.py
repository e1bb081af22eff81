"""Run corpus cases through ``motorid.cli.app:main`` in one process, each under a time limit.

``python runner.py CASES.json RESULTS.json [TIMEOUT_S]``: CASES is a list of ``{id, dir,
argv}``; for each case the real entry point runs with that argv (stdout/stderr captured, exit
code from ``SystemExit``), the case folder is snapshotted before and after, and the result is
written to RESULTS as ``{id: {code, out, err, seconds, changed}}``.  The parent sets the
memory limit (``RLIMIT_AS``) before this process starts.  A case that runs past the limit is
recorded with code ``"timeout"`` (SIGALRM).
"""

from __future__ import annotations

import io
import json
import signal
import sys
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corpus import snapshot


class _Timeout(BaseException):
    pass


def _alarm(signum, frame):
    raise _Timeout()


def run_case(argv: list[str], timeout_s: float) -> tuple[object, str, str, float]:
    from motorid.cli.app import _state, main

    _state["debug"] = False
    out, err = io.StringIO(), io.StringIO()
    sys.argv = ["motorid", *argv]
    code: object = 0
    t0 = time.perf_counter()
    signal.setitimer(signal.ITIMER_REAL, timeout_s)
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                main()
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except _Timeout:
        code = "timeout"
    except MemoryError:
        code = "memory"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    return code, out.getvalue(), err.getvalue(), time.perf_counter() - t0


def main() -> None:
    spec, dest = Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()
    cases = json.loads(spec.read_text())
    timeout_s = float(sys.argv[3]) if len(sys.argv) > 3 else 60.0
    signal.signal(signal.SIGALRM, _alarm)
    import matplotlib

    matplotlib.use("Agg")
    results = {}
    for c in cases:
        folder = Path(c["dir"])
        before = snapshot(folder)
        code, out, err, secs = run_case(c["argv"], timeout_s)
        after = snapshot(folder)
        changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
        results[c["id"]] = {"code": code, "out": out[-4000:], "err": err[-4000:], "seconds": secs,
                            "changed": changed}
        dest.write_text(json.dumps(results))  # partial results survive a crash


if __name__ == "__main__":
    main()
