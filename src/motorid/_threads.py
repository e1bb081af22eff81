"""One BLAS thread around the fitting code, whoever calls it (CLI, notebook, batch worker).

The matrices motorid factorises are tiny (at most a few thousand × a dozen): a multithreaded
BLAS only adds synchronisation, and on a loaded 2-core machine it made one output-error fit
take 35 s instead of 0.1 s.  ``threadpoolctl`` limits only the libraries loaded when its
context is entered, and numpy and scipy each ship their own OpenBLAS (``libscipy_openblas``
is loaded by ``scipy.linalg`` on first import): so the limit is entered here, after both are
loaded, around each public entry point of the library — not once at CLI start-up, where
scipy's copy was not loaded yet and ran two threads.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

__all__ = ["blas_threads", "single_blas_thread"]

P = ParamSpec("P")
R = TypeVar("R")


def blas_threads() -> dict[str, int]:
    """Threads of every loaded BLAS library, keyed by its file name (for tests and benches)."""
    from threadpoolctl import threadpool_info

    return {info["filepath"].rsplit("/", 1)[-1]: int(info["num_threads"])
            for info in threadpool_info() if info.get("user_api") == "blas"}


def single_blas_thread(func: Callable[P, R]) -> Callable[P, R]:
    """Run ``func`` with every BLAS library (numpy's and scipy's) limited to one thread.

    The libraries are imported first so that both OpenBLAS copies are loaded when the limit
    is applied; nested calls are cheap (threadpoolctl only sets the count again).  With
    ``OPENBLAS_NUM_THREADS=1`` in the environment (the CLI sets it before anything loads) an
    OpenBLAS loaded later starts with one thread anyway, so scipy is not imported for
    functions that do not use it (``motorid inspect``: start-up).

    Parameters
    ----------
    func : callable
        The function to wrap.

    Returns
    -------
    callable
        ``func`` run under a one-thread BLAS limit.
    """

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        import os

        import numpy  # noqa: F401 - loads numpy's OpenBLAS
        from threadpoolctl import threadpool_limits

        if os.environ.get("OPENBLAS_NUM_THREADS") != "1":
            import scipy.linalg  # noqa: F401 - loads scipy's own OpenBLAS

        with threadpool_limits(limits=1, user_api="blas"):
            return func(*args, **kwargs)

    return wrapper
