"""The ``motorid`` command line (typer).

:mod:`.app` holds the commands of the identification half, :mod:`.control` those of the control
half, :mod:`.demo` the bundled example; the typer application is ``motorid.cli.app.app``.

This package's own module is light: :func:`entry` (the console script) imports the commands
inside a guard, so that Ctrl-C during the start-up is an interruption (exit 130, one line) like
Ctrl-C during the command, not a traceback.

The library never imports this package (checked by import-linter in CI).
"""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["entry", "main"]


def entry() -> None:
    """The ``motorid`` console script: :func:`motorid.cli.app.entry`, Ctrl-C during its imports included."""
    try:
        from motorid.cli.app import entry as run
    except KeyboardInterrupt:
        print("motorid: interrupted", file=sys.stderr)
        raise SystemExit(130) from None
    run()


def __getattr__(name: str) -> Any:
    # ``main`` loads the commands when asked for; the typer application is ``motorid.cli.app.app``
    # (``motorid.cli.app`` is the module of that name)
    if name == "main":
        import importlib

        return importlib.import_module("motorid.cli.app").main
    raise AttributeError(f"module 'motorid.cli' has no attribute {name!r}")
