"""Shared test fixtures: the real recordings folder, the demo captures (built once per test run)
and an in-process CLI runner."""

from __future__ import annotations

import os
import types
from dataclasses import dataclass
from pathlib import Path

import pytest
from clihelpers import run_motorid

REPO = Path(__file__).resolve().parents[1]
REAL = REPO.parent / "shared" / "real"
REAL_ABS = Path(os.path.abspath(REAL))
TESTS = REPO / "tests"


@pytest.fixture
def real_dir() -> Path:
    """``../shared/real`` beside the clone; tests using it skip when it is absent."""
    if not REAL.is_dir():
        pytest.skip(f"real recordings not found at {REAL} (they live beside the repo, not in it)")
    return REAL


@pytest.fixture
def run_cli():
    """Run ``motorid ARGS`` in-process through the real entry point (error mapping included)."""
    return run_motorid


@dataclass(frozen=True)
class DemoRun:
    """The bundled demo experiment, written once per test run (read-only for the tests)."""

    folder: Path
    result: object  # motorid.cli.demo.DemoResult
    truth: dict


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory, request) -> DemoRun:
    """``motorid demo`` (seed 0) into a session folder: every test reading the demo captures
    shares this one run instead of simulating, writing and identifying its own. Under
    ``pytest -n`` the workers share it too: the first one runs it, the others read its result.

    A worker is known by its ``workerinput``, not by ``PYTEST_XDIST_WORKER``: a pytest run started
    from inside a worker (the other Pythons' test) inherits that variable, and its temporary
    folder's parent is the one every run shares, where a result pickled by older code waited."""
    import json

    from motorid.cli.demo import run_demo

    try:
        import fcntl
    except ImportError:  # not POSIX: each worker runs its own
        fcntl = None
    if fcntl is None or getattr(request.config, "workerinput", None) is None:
        out = tmp_path_factory.mktemp("demo") / "D"
        result = run_demo(out, seed=0)
    else:
        import pickle

        shared = tmp_path_factory.getbasetemp().parent / "demo"  # this test run's, common to its workers
        shared.mkdir(exist_ok=True)
        out, done = shared / "D", shared / "result.pickle"
        with open(shared / "lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if done.is_file():
                result = pickle.loads(done.read_bytes())
            else:
                result = run_demo(out, seed=0)
                done.write_bytes(pickle.dumps(result))
    return DemoRun(out, result, json.loads(result.truth_path.read_text()))



def _names_used(func, depth: int = 2) -> dict[str, object]:
    """The globals a function (its nested functions and lambdas included) reads by name, and
    those read by the test-tree functions it calls, ``depth`` calls deep."""
    seen: dict[str, object] = {}
    stack = [(func, depth)]
    while stack:
        fn, left = stack.pop()
        codes, names = [fn.__code__], set()
        while codes:
            code = codes.pop()
            names.update(code.co_names)
            codes.extend(c for c in code.co_consts if isinstance(c, types.CodeType))
        for name in names - seen.keys():
            value = fn.__globals__.get(name)
            seen[name] = value
            if left and isinstance(value, types.FunctionType) and _in_tests(value):
                stack.append((value, left - 1))
    return seen


def _in_tests(func) -> bool:
    return Path(func.__code__.co_filename).resolve().is_relative_to(TESTS)


def _is_real(value) -> bool:
    """A path into the real recordings, or a list of such paths."""
    if isinstance(value, (list, tuple)):
        return any(_is_real(v) for v in value)
    return isinstance(value, Path) and Path(os.path.abspath(value)).is_relative_to(REAL_ABS)


def _reads_real(item) -> bool:
    """Whether the test names the real recordings: the ``real_dir`` fixture, or a path under
    ``../shared/real`` in a parameter, a global it reads (``REAL``, ``HSLU``, ``TDS2012B``…) or one
    read by the test-tree helpers and fixtures it uses."""
    if "real_dir" in getattr(item, "fixturenames", ()):
        return True
    callspec = getattr(item, "callspec", None)
    if callspec is not None and any(_is_real(v) for v in callspec.params.values()):
        return True
    test = getattr(item, "function", None)
    test = getattr(getattr(test, "hypothesis", None), "inner_test", test)  # a @given test: the test itself
    funcs = [test] if isinstance(test, types.FunctionType) else []
    fixtureinfo = getattr(item, "_fixtureinfo", None)
    for defs in (fixtureinfo.name2fixturedefs.values() if fixtureinfo is not None else ()):
        funcs += [d.func for d in defs if isinstance(d.func, types.FunctionType) and _in_tests(d.func)]
    return any(_is_real(v) for f in funcs for v in _names_used(f).values())


def pytest_collection_modifyitems(config, items):
    """Markers from what a test uses: ``corpus`` for the real recordings, ``browser`` for a
    real browser (the ``*_browser.py`` files; a browser test elsewhere carries the marker
    itself). ``pytest -m "not corpus"`` / ``-m "not browser"`` select without them."""
    for item in items:
        path = str(item.fspath)
        if "/robustness/" in path or _reads_real(item):
            item.add_marker(pytest.mark.corpus)
        if path.endswith("_browser.py"):
            item.add_marker(pytest.mark.browser)
