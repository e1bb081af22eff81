"""The parallel engine: joblib on this machine (``loky`` processes), or a Dask cluster unchanged.

Why joblib: its ``loky`` executor keeps its worker processes alive between calls (each
worker imports motorid once: a command-line call per experiment costs ~11 s of CPU in
imports and oversubscribed BLAS, against ~1 s identified in a warm process), it limits the
BLAS and OpenMP thread pools of its workers (``inner_max_num_threads``), and
``joblib.parallel_config(backend="dask")`` runs the very same ``Parallel`` call on a
``distributed.Client``.  What is written here is only what joblib does not do: a seed per
task derived from the task's key (not from the worker or the order, so a result is the same
on one core or on a cluster, on a first run or a resumed one), and one BLAS thread inside
every task (a Dask worker does not get loky's environment variables).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import random
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

from motorid._process import end_with_parent
from motorid._threads import single_blas_thread
from motorid.errors import OptionError

__all__ = ["parallel_map", "task_seed"]

R = TypeVar("R")

#: Seconds to wait for a Dask scheduler to answer before giving up.
CONNECT_TIMEOUT_S = 20


def task_seed(base_seed: int, key: str) -> int:
    """The seed of one task: a hash of the batch's seed and the task's key (32 bits).

    Parameters
    ----------
    base_seed : int
        The batch's seed.
    key : str
        The task's key (an experiment's name).

    Returns
    -------
    int
        In ``[0, 2**32)``, the same on every machine and in every order of execution.
    """
    digest = hashlib.sha256(f"{int(base_seed)}:{key}".encode()).digest()
    return int.from_bytes(digest[:4], "little")


@single_blas_thread
def _seeded_call(func: Callable[[Any], R], key: str, item: Any, seed: int,
                 parent_pid: int | None = None) -> tuple[str, R]:
    """Run one task with the global random generators seeded (numpy's legacy one and Python's).

    In a worker process of this machine's pool (``parent_pid``: the batch's process), a watcher
    ends the worker when the batch is gone (killed by SIGKILL, or ended while this worker was
    busy): a worker left running held the batch's output open, so a ``| tee`` never ended.
    """
    import numpy as np

    if parent_pid is not None and os.getpid() != parent_pid:
        end_with_parent(parent_pid)
    np.random.seed(seed)  # legacy global-RNG use in any library the task calls
    random.seed(seed)
    return key, func(item)


@contextlib.contextmanager
def _dask_client(scheduler: str, timeout_s: float) -> Iterator[Any]:
    """A ``distributed.Client`` on ``scheduler``, closed afterwards (the cluster keeps running).

    Raises
    ------
    OptionError
        Dask is not installed, or the scheduler does not answer.
    """
    try:
        from distributed import Client
    except ImportError:
        raise OptionError(f"--scheduler {scheduler}: Dask is not installed; pip install 'motorid[dask]' "
                          "or leave --scheduler out to run on this machine") from None
    try:
        client = Client(scheduler, timeout=timeout_s)
    except (OSError, TimeoutError, ValueError) as exc:
        raise OptionError(f"--scheduler {scheduler}: cannot connect ({type(exc).__name__}: "
                          f"{str(exc).splitlines()[0] if str(exc) else 'no answer'}); start one with "
                          "'dask scheduler' or leave --scheduler out to run on this machine") from None
    try:
        yield client
    finally:
        client.close()


def parallel_map(
    func: Callable[[Any], R],
    items: Sequence[tuple[str, Any]],
    *,
    jobs: int = 1,
    scheduler: str | None = None,
    seed: int = 0,
    ordered: bool = False,
    batch_size: int | str = 1,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
) -> Iterator[tuple[str, R]]:
    """Run ``func(item)`` for every ``(key, item)``, in parallel, yielding ``(key, result)``.

    Results are yielded as they come (``ordered=False``), so a caller can write each one at
    once: an interrupted run keeps everything finished before the interruption.

    Parameters
    ----------
    func : callable
        A picklable function of one item (module-level; a script's own functions are sent
        by value).  Exceptions it raises stop the run: catch them inside for a batch that
        must go on.
    items : sequence of (str, object)
        Each task's key (its seed comes from it) and argument.
    jobs : int
        Worker processes on this machine (``1``: in this process, no pool; ``-1``: one per
        core).  Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``): the tasks run on its workers.
    seed : int
        The batch's seed (see :func:`task_seed`).
    ordered : bool
        Yield in the order of ``items`` (else as tasks finish).
    batch_size : int or "auto"
        Tasks sent to a worker at a time (``"auto"`` for many very short tasks).
    connect_timeout_s : float
        How long to wait for the scheduler [s].

    Yields
    ------
    tuple of (str, object)
        A task's key and ``func``'s result.

    Raises
    ------
    OptionError
        ``jobs`` of 0 or below −1; a scheduler that cannot be reached.
    """
    import joblib

    if not isinstance(jobs, int) or jobs == 0 or jobs < -1:
        raise OptionError(f"--jobs {jobs!r}: give a number of worker processes ≥ 1 (or -1 for one per core)")
    parent = os.getpid() if scheduler is None else None  # loky workers are this process's children
    tasks = [joblib.delayed(_seeded_call)(func, key, item, task_seed(seed, key), parent) for key, item in items]
    if not tasks:
        return
    return_as = "generator" if ordered else "generator_unordered"
    with contextlib.ExitStack() as stack:
        if scheduler is not None:
            stack.enter_context(_dask_client(scheduler, connect_timeout_s))
            stack.enter_context(joblib.parallel_config(backend="dask"))
            parallel = joblib.Parallel(n_jobs=-1, return_as=return_as, batch_size=batch_size)
        else:
            stack.enter_context(joblib.parallel_config(backend="loky", inner_max_num_threads=1))
            parallel = joblib.Parallel(n_jobs=jobs, return_as=return_as, batch_size=batch_size)
        yield from parallel(tasks)
