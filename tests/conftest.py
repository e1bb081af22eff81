"""Shared test fixtures: the real recordings folder and an in-process CLI runner."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
REAL = REPO.parent / "shared" / "real"


@pytest.fixture
def real_dir() -> Path:
    """``../shared/real`` beside the clone; tests using it skip when it is absent."""
    if not REAL.is_dir():
        pytest.skip(f"real recordings not found at {REAL} (they live beside the repo, not in it)")
    return REAL


@dataclass
class CliResult:
    code: int
    out: str
    err: str


@pytest.fixture
def run_cli(capsys, monkeypatch):
    """Run ``motorid ARGS`` in-process through the real entry point (error mapping included)."""
    from motorid.cli.app import main

    def run(*args: str) -> CliResult:
        monkeypatch.setattr(sys, "argv", ["motorid", *map(str, args)])
        code = 0
        try:
            main()
        except SystemExit as exc:
            code = int(exc.code or 0)
        cap = capsys.readouterr()
        return CliResult(code, cap.out, cap.err)

    return run
