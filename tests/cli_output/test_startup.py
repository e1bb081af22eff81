"""Start-up (issue 16): what a fresh ``motorid`` process imports for ``--help`` and ``inspect``.

Checked by module presence in ``sys.modules`` of a fresh interpreter, not by time (the machine
is shared; bench/startup.py measures the time).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

HEAVY = ("numpy", "scipy", "control", "matplotlib", "pandas")


def _modules_after(args: list[str], env_extra: dict[str, str] | None = None) -> tuple[list[str], int]:
    code = textwrap.dedent(
        f"""
        import json, sys
        sys.argv = ["motorid", *{args!r}]
        from motorid.cli.app import main
        try:
            main()
        except SystemExit as exc:
            code = exc.code
        else:
            code = 0
        print("@@" + json.dumps([sorted(m for m in sys.modules), code]))
        """
    )
    env = {**os.environ, **(env_extra or {})}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    mods, rc = json.loads(out.stdout.rsplit("@@", 1)[1])
    return mods, rc


def _loaded(mods: list[str], root: str) -> bool:
    return any(m == root or m.startswith(root + ".") for m in mods)


@pytest.mark.parametrize("args", [["--help"], ["identify", "--help"]])
def test_help_loads_no_numerical_library(args: list[str]) -> None:
    mods, rc = _modules_after(args)
    assert rc == 0
    assert [h for h in HEAVY if _loaded(mods, h)] == []


def test_import_motorid_loads_no_numpy() -> None:
    out = subprocess.run([sys.executable, "-c", "import sys, motorid; print('numpy' in sys.modules)"],
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_inspect_loads_numpy_but_not_scipy_control_or_matplotlib(demo_run) -> None:
    mods, rc = _modules_after(["inspect", str(demo_run.folder / "ALL0001")])
    assert rc == 0
    assert _loaded(mods, "numpy")
    assert [h for h in ("scipy", "control", "matplotlib") if _loaded(mods, h)] == []
