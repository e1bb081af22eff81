"""A worker process that ends when the process that started it is gone.

The batch's loky workers and the web page's bounded workers run tasks for a parent that may be
killed with SIGKILL, which gives no one the chance to stop them: a worker left running held
the batch's output open (a ``| tee`` never ended) or a core of the machine.  The standard
library has no "die with the parent" option (Linux's ``PR_SET_PDEATHSIG`` needs ctypes and
fires on the parent *thread's* exit), so a daemon thread polls the parent's pid.
"""

from __future__ import annotations

import functools
import os
import threading
import time

__all__ = ["PARENT_POLL_S", "end_with_parent"]

#: How often a worker looks whether its parent is still there [s].
PARENT_POLL_S = 1.0


@functools.cache
def end_with_parent(parent_pid: int) -> None:
    """Start, once per process, a thread that ends the process when ``parent_pid`` is no longer its parent.

    Parameters
    ----------
    parent_pid : int
        The process whose end ends this one (the batch's process; for the web page's workers
        the forkserver, which exits with the server).
    """

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(PARENT_POLL_S)
        os._exit(1)  # the parent is gone: nobody reads this worker's result

    threading.Thread(target=watch, name="motorid-parent-watch", daemon=True).start()
