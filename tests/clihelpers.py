"""Helpers of the tests (imported by name: the test folder is on sys.path): ``motorid`` in-process."""

from __future__ import annotations

import contextlib
import io
import sys
from dataclasses import dataclass


@dataclass
class CliResult:
    code: int
    out: str
    err: str


def run_motorid(*args: object) -> CliResult:
    """``motorid ARGS`` in this process through the real entry point (error mapping included)."""
    from motorid.cli.app import main

    argv, out, err = sys.argv, io.StringIO(), io.StringIO()
    sys.argv = ["motorid", *map(str, args)]
    code = 0
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            main()
    except SystemExit as exc:
        code = int(exc.code or 0)
    finally:
        sys.argv = argv
    return CliResult(code, out.getvalue(), err.getvalue())


def motorid_ok(*args: object) -> CliResult:
    """:func:`run_motorid`, which must exit 0 (the message shows the command and its stderr)."""
    res = run_motorid(*args)
    assert res.code == 0, f"motorid {' '.join(map(str, args))}: exit {res.code}: {res.err[-500:]}"
    return res
