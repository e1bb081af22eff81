"""The robustness corpus through the real CLI entry point.

Each case of :mod:`corpus` must end in exit 2 with 1–3 lines naming the file or option, or
exit 0 (with the expected warning); never an internal error or a traceback; nothing in its
folder written or changed on a failure; within the time limit, under a 2 GiB address-space
limit.  The cases run grouped, several hundred in a few subprocesses (``runner.py``, in-process
``motorid.cli.app:main`` per case with a timer); the ones that could hang (FIFOs, devices) run one
per subprocess with a hard timeout.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import corpus

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow

CASES = corpus.all_cases()
RUNNER = Path(__file__).resolve().parent / "runner.py"
#: Address-space limit of every subprocess.
MEMORY_LIMIT = 2 * 1024**3
#: Seconds a single case may take (the slowest valid case identifies in about 2 s).
CASE_TIMEOUT_S = 30.0


def _limits() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def _env() -> dict[str, str]:
    return {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg"}


def _run_hang_case(case: corpus.Case, folder: Path, base: Path) -> dict:
    before = corpus.snapshot(folder)
    try:
        proc = subprocess.run([sys.executable, "-m", "motorid", *case.args(folder, base)], capture_output=True,
                              text=True, timeout=CASE_TIMEOUT_S, preexec_fn=_limits, env=_env())
        code, out, err = proc.returncode, proc.stdout, proc.stderr
    except subprocess.TimeoutExpired:
        code, out, err = "timeout", "", ""
    after = corpus.snapshot(folder)
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    return {"code": code, "out": out, "err": err, "seconds": 0.0, "changed": changed}


@pytest.fixture(scope="session")
def results(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("corpus")
    base = corpus.build(root, CASES)
    grouped = [c for c in CASES if not c.hang]
    # two subprocesses side by side (2 cores), each running half of the cases in-process
    halves = [grouped[0::2], grouped[1::2]]
    procs = []
    for i, part in enumerate(halves):
        spec = root / f"cases{i}.json"
        spec.write_text(corpus.to_json(part, root, base))
        out = root / f"results{i}.json"
        procs.append((subprocess.Popen([sys.executable, str(RUNNER), str(spec), str(out), str(CASE_TIMEOUT_S)],
                                       preexec_fn=_limits, env=_env(), stdout=subprocess.PIPE,
                                       stderr=subprocess.PIPE, text=True), out))
    res: dict = {}
    for c in CASES:
        if c.hang:
            res[c.id] = _run_hang_case(c, root / c.id, base)
    for proc, out in procs:
        _stdout, stderr = proc.communicate(timeout=900)
        if out.exists():
            res.update(json.loads(out.read_text()))
        if proc.returncode != 0:
            res["_runner"] = f"runner exited {proc.returncode}: {stderr[-2000:]}"
    return res


def test_corpus_size():
    """The aim: well over 150 cases, every class represented."""
    groups = {c.group for c in CASES}
    assert groups == {"file", "signal", "option", "output"}
    assert len(CASES) >= 150, len(CASES)


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_case(case: corpus.Case, results: dict) -> None:
    assert "_runner" not in results, results.get("_runner")
    r = results.get(case.id)
    assert r is not None, f"{case.id} did not run (runner crashed?)"
    code, out, err = r["code"], r["out"], r["err"]
    shown = f"exit {code}\nstderr: {err[-1500:]}\nstdout: {out[-800:]}"
    assert code not in ("timeout", "memory"), f"{case.id}: {code}"
    assert "Traceback" not in err and "internal error" not in err, shown
    assert code in (0, 2), shown
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if code == 2:
        assert 1 <= len(lines) <= 3, shown
        # nothing written or changed in the case's folder on a failure
        assert r["changed"] == [], f"{case.id}: files changed on failure: {r['changed']}"
    if case.expect == "refuse":
        assert code == 2, shown
        for name in case.names:
            assert name in err, f"{name!r} not in: {err}"
    elif case.expect == "ok":
        assert code == 0, shown
        said = " ".join((out + err).split())  # the printout wraps long lines where the paths' lengths put them
        for w in case.warns:
            assert w in said, f"warning {w!r} missing: {out[-1500:]}"
    assert r["seconds"] < CASE_TIMEOUT_S
