"""Shared test fixtures: the real recordings folder, the demo captures (built once per test run)
and an in-process CLI runner."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest
from clihelpers import run_motorid

REPO = Path(__file__).resolve().parents[1]
REAL = REPO.parent / "shared" / "real"


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
def demo_run(tmp_path_factory) -> DemoRun:
    """``motorid demo`` (seed 0) into a session folder: every test reading the demo captures
    shares this one run instead of simulating, writing and identifying its own."""
    import json

    from motorid.cli.demo import run_demo

    out = tmp_path_factory.mktemp("demo") / "D"
    result = run_demo(out, seed=0)
    return DemoRun(out, result, json.loads(result.truth_path.read_text()))



def pytest_collection_modifyitems(config, items):
    """Markers from what a test uses: ``corpus`` for the real recordings, ``browser`` for a
    real browser (``pytest -m "not corpus"`` / ``-m "not browser"`` select without them)."""
    for item in items:
        path = str(item.fspath)
        if "real_dir" in getattr(item, "fixturenames", ()) or "/robustness/" in path:
            item.add_marker(pytest.mark.corpus)
        if path.endswith("_browser.py"):
            item.add_marker(pytest.mark.browser)
