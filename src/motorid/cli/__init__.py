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
    """The ``motorid`` process: the commands' imports and :func:`motorid.cli.app.main`.

    Ctrl-C during the imports is an interruption like Ctrl-C during the command (exit 130, one
    line). Once the command has finished and said so, SIGINT and SIGTERM are ignored until the
    process has exited: a complete, confirmed run is a success.
    """
    import signal

    try:
        from motorid.cli.app import main

        main()
    except KeyboardInterrupt:  # during the imports, before main's own handling was in place
        print("motorid: interrupted", file=sys.stderr)
        raise SystemExit(130) from None
    except ImportError as exc:  # an extension module interrupted while it was initialised
        if not isinstance(exc.__cause__ or exc.__context__, KeyboardInterrupt):
            raise
        print("motorid: interrupted", file=sys.stderr)
        raise SystemExit(130) from None
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        _forget_handled_interrupts()


def _forget_handled_interrupts() -> None:
    """Clear CPython's record of a Ctrl-C that ended an ``exec`` or ``eval`` of a string.

    Under ``python -m motorid`` the interpreter kills itself with SIGINT at exit (instead of
    returning the command's exit code) when a KeyboardInterrupt ever ended the evaluation of
    a source string, even one that was caught and handled: ``dataclasses`` and
    ``collections.namedtuple`` build their methods that way, so a Ctrl-C while a module
    defining them is imported left the process "killed by SIGINT" after it had printed
    "interrupted" and chosen 130. Each evaluation of a source string resets that record first
    (CPython's ``run_eval_code_obj``), and no interrupt can follow once SIGINT is ignored, so
    evaluating an empty string here clears it for good. There is no public API for this.
    """
    exec("")  # a constant empty source; see the docstring


def __getattr__(name: str) -> Any:
    # ``main`` loads the commands when asked for; the typer application is ``motorid.cli.app.app``
    # (``motorid.cli.app`` is the module of that name)
    if name == "main":
        import importlib

        return importlib.import_module("motorid.cli.app").main
    raise AttributeError(f"module 'motorid.cli' has no attribute {name!r}")
