"""Helpers of the tests (imported by name: the test folder is on sys.path): ``motorid`` in-process."""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
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


def motorid_fresh(*args: object, cwd: object) -> subprocess.CompletedProcess[str]:
    """``python -m motorid ARGS`` in a new process with the default environment, as a user runs it.

    The BLAS thread variables the test run may have set are left out (the tool sets its own);
    the call must exit 0 (the message shows the command and its stderr).
    """
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMP_", "OPENBLAS_NUM", "MKL_"))}
    proc = subprocess.run([sys.executable, "-m", "motorid", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=300)
    assert proc.returncode == 0, f"motorid {' '.join(map(str, args))}: exit {proc.returncode}: {proc.stderr[-500:]}"
    return proc
