"""The server's heavy requests in a worker process it can stop.

An identification or a report can take seconds to minutes on a large upload, and a thread
cannot be stopped: a request whose client has gone, or that runs away, would hold a core and
its memory until it ends on its own.  Each such request therefore runs in a process of its own,
forked from a *forkserver* that has motorid imported (a few milliseconds, not the 1–2 s of a
fresh interpreter, and never a fork of the threaded server itself).  The worker has an
address-space limit (``RLIMIT_AS``: the request's memory), a CPU-time limit a little above the
request's time limit (the kernel ends it even if the server died), and the server kills it when
the time limit passes or the client disconnects.  The standard library's
:mod:`concurrent.futures` pools cannot cancel a task that has started, hence this small module.
"""

from __future__ import annotations

import asyncio
import math
import multiprocessing
import os
import resource
import time
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any, Protocol, TypeVar

from starlette.concurrency import run_in_threadpool

from motorid._process import end_with_parent
from motorid.errors import MotorIdError, OptionError

__all__ = ["RequestGoneError", "WorkLimits", "run_bounded"]

T = TypeVar("T")

#: Modules the forkserver imports once, so that each worker starts with them loaded.
PRELOAD = ["motorid.frontdoor", "motorid.report", "motorid.web.pages", "motorid.web.api"]
_POLL_S = 0.02


@dataclass(frozen=True, slots=True)
class WorkLimits:
    """Bounds of one heavy request.

    Attributes
    ----------
    max_seconds : float
        Wall-clock time before the worker is stopped (``motorid serve --max-seconds``).
    max_memory_mb : float
        Memory the worker may allocate beyond what it starts with (``motorid serve --max-memory-mb``).
    """

    max_seconds: float = 300.0
    max_memory_mb: float = 2048.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.max_seconds) and 0 < self.max_seconds <= 86400):
            raise OptionError(f"--max-seconds must be in (0, 86400], got {self.max_seconds!r}")
        if not (math.isfinite(self.max_memory_mb) and 64 <= self.max_memory_mb <= 1 << 20):
            raise OptionError(f"--max-memory-mb must be in [64, 1048576], got {self.max_memory_mb!r}")


class RequestGoneError(Exception):
    """The client disconnected while its request ran (nobody is left to answer)."""


class _Disconnectable(Protocol):
    async def is_disconnected(self) -> bool: ...


def _address_space_bytes() -> int | None:
    try:
        with open("/proc/self/statm", encoding="ascii") as fh:
            return int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def _child(conn: Connection, limits: WorkLimits, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
    # the parent is the forkserver, which exits with the server (SIGKILL leaves no one to stop us)
    end_with_parent(os.getppid())
    now = _address_space_bytes()
    if now is not None:
        cap = now + int(limits.max_memory_mb * 2**20)
        resource.setrlimit(resource.RLIMIT_AS, (cap, resource.getrlimit(resource.RLIMIT_AS)[1]))
    cpu = math.ceil(limits.max_seconds) + 5
    hard = resource.getrlimit(resource.RLIMIT_CPU)[1]
    if hard == resource.RLIM_INFINITY or cpu < hard:
        resource.setrlimit(resource.RLIMIT_CPU, (cpu, hard))
    try:
        out: tuple[str, Any] = ("ok", fn(*args))
    except MotorIdError as exc:
        out = ("user", exc)
    except MemoryError:
        out = ("memory", None)
    except BaseException as exc:  # reported to the server as one line
        out = ("internal", f"{type(exc).__name__}: {exc}")
    try:
        conn.send(out)
    except Exception as exc:  # an answer that does not pickle
        conn.send(("internal", f"the answer could not be sent back: {type(exc).__name__}: {exc}"))
    conn.close()


def _context() -> Any:
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(PRELOAD)
    return ctx


def _memory_line(what: str, limits: WorkLimits) -> str:
    return (f"{what} needed more than {limits.max_memory_mb:g} MB and was stopped: send a shorter record, "
            "or start the server with a larger --max-memory-mb")


async def run_bounded(request: _Disconnectable | None, limits: WorkLimits, what: str,
                      fn: Callable[..., T], *args: Any) -> T:
    """Run ``fn(*args)`` in a worker process bounded by ``limits``; stop it if the client leaves.

    Parameters
    ----------
    request : Request or None
        The request whose client is watched (``None``: no one to watch).
    limits : WorkLimits
        Time and memory bounds.
    what : str
        What the work is, for messages ("the identification").
    fn : callable
        A module-level function (it is pickled to the worker), and picklable arguments.
    *args
        Its arguments.

    Returns
    -------
    object
        ``fn``'s result (pickled back).

    Raises
    ------
    MotorIdError
        The worker's own user error, or a one-line error when it ran out of time or memory.
    RequestGoneError
        The client disconnected; the worker was stopped.
    """
    ctx = _context()
    receiver, sender = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(sender, limits, fn, args), daemon=True)
    await run_in_threadpool(proc.start)
    sender.close()
    deadline = time.monotonic() + limits.max_seconds
    try:
        while not receiver.poll():
            if not proc.is_alive() and not receiver.poll():
                if proc.exitcode in (-9, -24):  # SIGKILL (the kernel's OOM killer), SIGXCPU
                    raise MotorIdError(_memory_line(what, limits) if proc.exitcode == -9 else
                                       f"{what} used more CPU time than --max-seconds allows and was stopped")
                raise MotorIdError(f"{what} stopped: its worker process ended with exit code {proc.exitcode}")
            if time.monotonic() > deadline:
                raise OptionError(f"{what} took longer than {limits.max_seconds:g} s and was stopped: send a "
                                  "shorter record, or start the server with a larger --max-seconds")
            if request is not None and await request.is_disconnected():
                raise RequestGoneError(what)
            await asyncio.sleep(_POLL_S)
        try:
            kind, payload = await run_in_threadpool(receiver.recv)
        except EOFError:
            raise MotorIdError(f"{what} stopped: its worker process ended before answering") from None
    finally:
        # no await here: a request cancelled by the server's shutdown must still stop its worker
        # (the forkserver, its parent, reaps it)
        if proc.is_alive():
            proc.kill()
        receiver.close()
    if kind == "ok":
        return payload
    if kind == "user":
        raise payload
    if kind == "memory":
        raise MotorIdError(_memory_line(what, limits))
    raise RuntimeError(f"{what}: {payload}")
