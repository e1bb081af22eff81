"""Progress bars of the command line: rich, on stderr, only when someone watches.

The library never prints: a long function takes a ``progress`` callback (``progress(done,
total)``, optionally with a ``label`` naming the step) and the command line passes the one
:func:`progress_bar` yields.  The bar is drawn on stderr when stderr is a terminal or the
global ``--progress`` flag is given; otherwise the callback does nothing, so scripts and tests
see exactly the output they saw before (and an error stays the only line on stderr).
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rich.progress import Progress, TaskID

__all__ = ["ProgressCallback", "progress_bar", "wanted"]


def wanted(flag: bool) -> bool:
    """Whether to draw progress bars: ``--progress`` given, or stderr is a terminal.

    Parameters
    ----------
    flag : bool
        The global ``--progress`` flag.

    Returns
    -------
    bool
        True to draw the bars.
    """
    return bool(flag) or sys.stderr.isatty()


class ProgressCallback:
    """The callback a command passes to the library: ``cb(done, total, label=None)``.

    ``total`` may change between calls (a stage count known only once the data are read);
    ``label`` replaces the bar's description (the stage running now).  A disabled callback
    (no bar) ignores every call.
    """

    def __init__(self, bar: Progress | None, task: TaskID | None, description: str) -> None:
        self._bar = bar
        self._task = task
        self._description = description

    def __call__(self, done: float, total: float | None = None, label: str | None = None) -> None:
        """Report ``done`` of ``total`` steps.

        Parameters
        ----------
        done : float
            Steps finished.
        total : float, optional
            Steps in all (``None``: keep the last total; a spinner without one).
        label : str, optional
            What runs now; shown after the command's own description.
        """
        if self._bar is None or self._task is None:
            return
        text = self._description if label is None else f"{self._description}: {label}"
        if total is None:
            self._bar.update(self._task, completed=done, description=text)
        else:
            self._bar.update(self._task, completed=done, total=total, description=text)

    @property
    def enabled(self) -> bool:
        """Whether a bar is drawn."""
        return self._bar is not None


@contextmanager
def progress_bar(description: str, *, total: float | None = None, enabled: bool,
                 force_terminal: bool = False) -> Iterator[ProgressCallback]:
    """A transient progress bar on stderr for the duration of a ``with`` block.

    Parameters
    ----------
    description : str
        What the command does ("identifying", "sweep").
    total : float, optional
        Steps in all; ``None`` draws a spinner with the elapsed time until a total is reported.
    enabled : bool
        Draw the bar (see :func:`wanted`); otherwise the callback does nothing.
    force_terminal : bool
        Draw it live even when stderr is not a terminal (``--progress``: rich would otherwise
        only print the final state there).

    Yields
    ------
    ProgressCallback
        The callback to pass to the library.
    """
    if not enabled:
        yield ProgressCallback(None, None, description)
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn())
    console = Console(stderr=True, force_terminal=True if force_terminal else None)
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task(description, total=total)
        yield ProgressCallback(bar, task, description)
