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
    process has exited: a complete, confirmed run is a success. An interrupted command ends
    without the interpreter's teardown (:func:`_end_interrupted`).
    """
    import signal

    _raise_swallowed_interrupts()
    code: str | int | None = 0  # the exit code, as SystemExit carries it
    try:
        from motorid.cli.app import main

        main()
    except KeyboardInterrupt:  # during the imports, before main's own handling was in place
        print("motorid: interrupted", file=sys.stderr)
        code = 130
        raise SystemExit(130) from None
    except ImportError as exc:  # an extension module interrupted while it was initialised
        if not isinstance(exc.__cause__ or exc.__context__, KeyboardInterrupt):
            raise
        print("motorid: interrupted", file=sys.stderr)
        code = 130
        raise SystemExit(130) from None
    except SystemExit as exc:
        code = exc.code
        raise
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        _forget_handled_interrupts()
        if isinstance(code, int) and code in _INTERRUPTED_EXITS:
            _end_interrupted(code)


def _raise_swallowed_interrupts() -> None:
    """Raise again, in the main thread, a Ctrl-C that landed where Python cannot raise it.

    Python raises Ctrl-C's KeyboardInterrupt at the next instruction of the main thread. When that
    instruction is inside a callback the interpreter calls on its own, it cannot propagate. Such
    callbacks include the import system's lock clean-up, a weak reference's callback and a
    finaliser. The interrupt is then printed as "Exception ignored in: …" and dropped, and the
    command ran on to exit 0. This was seen on a loaded machine, in a Ctrl-C 1.5 s into
    ``motorid demo``.

    The hook hands such an interrupt back to the main thread as a fresh SIGINT
    (``_thread.interrupt_main``), which then ends the command like any other Ctrl-C. The SIGINT
    is sent from a timer thread 20 ms later: sent at once it would be raised inside the hook (or
    inside the thread's start, which waits) and dropped again. If it lands in another such
    callback, the hook sends it again. Other unraisable exceptions go to the default hook. Once
    SIGINT is ignored, which happens after the command has finished, the re-sent signal does
    nothing. The standard library offers nothing narrower than ``sys.unraisablehook`` for this.
    """
    import _thread
    import threading

    default = sys.unraisablehook

    def hook(unraisable: Any) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            # a moment later: the hook (and the thread's own start, which waits for it) must have returned
            resend = threading.Timer(0.02, _thread.interrupt_main)
            resend.daemon = True
            resend.start()
            return
        default(unraisable)

    sys.unraisablehook = hook


#: The exit codes of a command ended by Ctrl-C (130) or SIGTERM (143).
_INTERRUPTED_EXITS = frozenset({130, 143})


def _end_interrupted(code: int) -> None:
    """End an interrupted command now: its streams flushed and exit handlers run, no teardown.

    The interruption has been handled by then (outputs discarded or put back, its line printed),
    but a signal can land anywhere, inside a compiled extension's initialisation or its call back
    into Python, and leave that extension's state half made. Tearing the interpreter down then
    runs the extension's own clean-up on that state, which can abort the process ("Fatal Python
    error: PyThreadState_Get ... finalizing", exit -6, seen once on a loaded machine after a
    SIGTERM) instead of returning the exit code the caller waits for. The teardown frees memory
    the system frees anyway, so it is skipped: ``atexit`` handlers still run (a library's own
    clean-up, coverage data), then ``os._exit``.
    """
    import atexit
    import contextlib
    import os

    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a closed pipe or stream: nothing more reaches the caller
            stream.flush()
    atexit._run_exitfuncs()
    os._exit(code)


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
