"""Start-up: what a fresh ``motorid`` process imports for ``--help`` and ``inspect``.

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

HEAVY = ("numpy", "scipy", "control", "matplotlib", "pandas", "pyarrow")


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
    # typer's rich_utils imports rich.markdown (markdown-it, pygments) and rich.traceback: not for help
    assert [m for m in ("rich.markdown", "rich.traceback", "typer.rich_utils") if _loaded(mods, m)] == []


def test_help_formatter_writes_what_typers_writes() -> None:
    """motorid.cli._richhelp (typer's help code without its heavy imports) against typer's own module."""
    code = textwrap.dedent(
        """
        import contextlib, io, json
        import typer._click as click
        import typer.main
        import typer.rich_utils
        from motorid.cli import _richhelp
        from motorid.cli.app import _conventional_help, app

        root = _conventional_help(typer.main.get_command(app))
        todo, pairs = [(root, "motorid", None)], []
        while todo:
            cmd, name, parent = todo.pop()
            ctx = click.Context(cmd, info_name=name, parent=parent)
            texts = []
            for module in (typer.rich_utils, _richhelp):
                out = io.StringIO()
                with contextlib.redirect_stdout(out):
                    module.rich_format_help(obj=cmd, ctx=ctx, markup_mode="rich")
                texts.append(out.getvalue())
            pairs.append([name, *texts])
            todo.extend((sub, n, ctx) for n, sub in getattr(cmd, "commands", {}).items())
        print("@@" + json.dumps(pairs))
        """
    )
    env = {**os.environ, "COLUMNS": "100"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    pairs = json.loads(out.stdout.rsplit("@@", 1)[1])
    assert len(pairs) > 15  # every command and group, nested ones too
    for name, theirs, ours in pairs:
        assert "Usage:" in ours, name
        assert ours == theirs, name


def test_import_motorid_loads_no_numpy() -> None:
    out = subprocess.run([sys.executable, "-c", "import sys, motorid; print('numpy' in sys.modules)"],
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_inspect_loads_numpy_but_not_scipy_control_or_matplotlib(demo_run) -> None:
    mods, rc = _modules_after(["inspect", str(demo_run.folder / "ALL0001")])
    assert rc == 0
    assert _loaded(mods, "numpy")
    assert [h for h in ("scipy", "control", "matplotlib") if _loaded(mods, h)] == []


def test_identify_loads_neither_python_control_nor_matplotlib(demo_run, tmp_path) -> None:
    """``identify`` (auto, printout, model JSON) needs no python-control object, no figure, no scipy.signal.

    ``scipy.signal`` would bring ``scipy.stats`` (half a second of start-up) for three small
    functions (``motorid.model.lti``); ``rich.markdown`` is only for help texts.
    """
    d = demo_run.folder
    mods, rc = _modules_after(["identify", "--position", str(d / "ALL0000"), "--velocity", str(d / "ALL0001"),
                               "--current", str(d / "ALL0002"), "--json", str(tmp_path / "m.json")])
    assert rc == 0 and (tmp_path / "m.json").is_file()
    heavy = ("control", "matplotlib", "scipy.signal", "scipy.stats", "rich.markdown")
    assert [h for h in heavy if _loaded(mods, h)] == []


def test_one_blas_thread_without_importing_scipy_up_front() -> None:
    # with OPENBLAS_NUM_THREADS=1 (what the CLI sets) the wrapper no longer imports scipy.linalg;
    # a scipy loaded later inside the wrapped function must still run one BLAS thread
    code = textwrap.dedent(
        """
        import json, sys
        from motorid._threads import blas_threads, single_blas_thread

        @single_blas_thread
        def light():
            return "scipy" in sys.modules

        @single_blas_thread
        def heavy():
            import scipy.linalg  # noqa: F401
            return blas_threads()

        print(json.dumps([light(), heavy()]))
        """
    )
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    env["OPENBLAS_NUM_THREADS"] = "1"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    scipy_loaded, threads = json.loads(out.stdout.strip().splitlines()[-1])
    assert scipy_loaded is False
    assert len(threads) >= 2 and all(n == 1 for n in threads.values()), threads  # numpy's and scipy's OpenBLAS


def test_demo_help_lists_every_trainer_preset_without_importing_the_trainer(run_cli) -> None:
    """``motorid demo --help`` said only "Virtual trainer preset." (a newcomer had to provoke an
    error to learn the names); it lists them now, read from the options, not from the trainer."""
    from motorid.trainer import PRESET_NAMES, preset

    res = run_cli("demo", "--help")
    assert res.code == 0
    flat = " ".join(res.out.replace("│", " ").split())
    assert f"Virtual trainer preset: {', '.join(PRESET_NAMES)}." in flat
    assert all(preset(name) is not None for name in PRESET_NAMES)  # every name listed is one the trainer has
    mods, rc = _modules_after(["demo", "--help"])
    assert rc == 0 and not _loaded(mods, "motorid.trainer")
