"""Each heavy request runs in a worker the server can stop: bounded in time and memory, stopped
when its client leaves; a client that sends its request too slowly is disconnected."""

from __future__ import annotations

import asyncio
import os
import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from webhelpers import multipart

from motorid.errors import MotorIdError, OptionError
from motorid.web.work import RequestGoneError, WorkLimits, run_bounded


def _descendants(pid: int) -> set[int]:
    """Process ids below ``pid`` (read from /proc: the forkserver and its workers)."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    found, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, pp in parents.items() if pp in frontier} - found
        found |= frontier
    return found


def _forkserver_running() -> None:
    """Start the workers' forkserver first, so that the only new processes are workers."""
    from multiprocessing import forkserver

    from motorid.web.work import _context

    _context()
    forkserver.ensure_running()


def _alive(pids: set[int]) -> list[int]:
    """The processes of ``pids`` still running (not gone, not zombies)."""
    out = []
    for p in pids:
        try:
            if Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()[0] not in ("Z", "X"):
                out.append(p)
        except OSError:
            continue
    return out


class _LeavesAfter:
    """A request whose client disconnects after ``polls`` checks."""

    def __init__(self, polls: int) -> None:
        self.polls = polls

    async def is_disconnected(self) -> bool:
        self.polls -= 1
        return self.polls < 0


def test_a_runaway_request_is_stopped_at_its_time_limit():
    t0 = time.monotonic()
    with pytest.raises(OptionError, match=r"took longer than 0\.5 s and was stopped.*--max-seconds"):
        asyncio.run(run_bounded(None, WorkLimits(max_seconds=0.5), "the identification", time.sleep, 60))
    assert time.monotonic() - t0 < 15  # not the 60 s the work wanted


def test_a_request_that_needs_too_much_memory_is_a_one_line_error():
    # 16 GiB of ones against a 256 MB allowance: MemoryError in the worker, not in the server
    with pytest.raises(MotorIdError, match=r"the identification needed more than 256 MB.*--max-memory-mb"):
        asyncio.run(run_bounded(None, WorkLimits(max_memory_mb=256), "the identification", np.ones, 2**31))


def test_the_worker_stops_when_the_client_leaves():
    _forkserver_running()
    before = _descendants(os.getpid())
    t0 = time.monotonic()
    with pytest.raises(RequestGoneError):
        asyncio.run(run_bounded(_LeavesAfter(5), WorkLimits(), "the identification", time.sleep, 60))
    assert time.monotonic() - t0 < 15
    deadline = time.monotonic() + 5
    while (live := _alive(_descendants(os.getpid()) - before)) and time.monotonic() < deadline:
        time.sleep(0.05)
    # the forkserver stays (it serves the next request); the worker is gone
    assert not live, live


def test_a_user_error_in_the_worker_is_the_same_one_line_error():
    from motorid.io import read_capture

    with pytest.raises(MotorIdError) as err:
        asyncio.run(run_bounded(None, WorkLimits(), "the identification", read_capture, "/no/such/capture.csv"))
    assert "/no/such/capture.csv" in str(err.value) and "\n" not in str(err.value)


def test_limits_are_checked_in_one_line():
    with pytest.raises(OptionError, match="--max-seconds"):
        WorkLimits(max_seconds=0)
    with pytest.raises(OptionError, match="--max-memory-mb"):
        WorkLimits(max_memory_mb=float("nan"))


def test_api_identify_past_its_time_limit_is_a_422_line(make_client, demo_run):
    client = make_client(work=WorkLimits(max_seconds=0.01))
    d = demo_run.folder / "ALL0001"
    res = client.post("/api/identify", files=multipart("velocity", [d / "F0001CH1.CSV", d / "F0001CH2.CSV"]))
    assert res.status_code == 422, res.text
    assert res.json()["detail"].startswith("motorid: error: the identification took longer than 0.01 s")


def test_serve_result_is_the_same_through_the_worker(client, demo_run):
    """The worker's answer is the front door's (pickled across the process boundary)."""
    import motorid as mi

    d = demo_run.folder / "ALL0001"
    res = client.post("/api/identify", files=multipart("velocity", [d / "F0001CH1.CSV", d / "F0001CH2.CSV"]),
                      data={"method": "pinv"})
    assert res.status_code == 200, res.text
    want = mi.identify(mi.read_experiment(velocity=d), method="pinv").to_json()
    assert res.json()["first_order"] == pytest.approx(want["first_order"], rel=1e-12)


# ---------------------------------------------------------------- a real server, real sockets

@pytest.fixture
def live_server(web_root):
    """uvicorn in a thread with the deadline protocol at short timeouts: (host, port)."""
    import uvicorn

    from motorid.web import WebSettings, create_app
    from motorid.web.protocol import DeadlineH11Protocol

    class Quick(DeadlineH11Protocol):
        header_timeout_s = 0.5
        body_timeout_s = 1.0

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    config = uvicorn.Config(create_app(WebSettings(temp_root=web_root)), host="127.0.0.1", port=port,
                            log_level="error", http=Quick, timeout_graceful_shutdown=1)
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 20
    while not server.started:
        assert time.monotonic() < deadline, "the server did not start"
        time.sleep(0.02)
    yield "127.0.0.1", port
    server.should_exit = True
    thread.join(timeout=10)


def _closed_within(sock: socket.socket, seconds: float) -> float:
    sock.settimeout(seconds)
    t0 = time.monotonic()
    while True:
        if sock.recv(65536) == b"":
            return time.monotonic() - t0


def test_a_client_that_never_sends_its_headers_is_disconnected(live_server):
    with socket.create_connection(live_server) as sock:
        sock.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n")  # and never the blank line
        assert _closed_within(sock, 5.0) < 3.0


def test_a_client_that_trickles_its_body_is_disconnected(live_server):
    with socket.create_connection(live_server) as sock:
        sock.sendall(b"POST /api/design HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                     b"Content-Length: 1000\r\n\r\n{\"model\"")
        assert _closed_within(sock, 6.0) < 4.0


def test_a_prompt_client_is_served_by_the_same_server(live_server):
    with socket.create_connection(live_server) as sock:
        sock.sendall(b"GET /api/openapi.json HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n")
        sock.settimeout(10)
        data = b""
        while chunk := sock.recv(65536):
            data += chunk
    assert data.startswith(b"HTTP/1.1 200")


def test_the_identification_stops_when_its_client_hangs_up(live_server, demo_run):
    """A real upload through uvicorn; the client closes its socket while the worker runs."""
    import httpx

    d = demo_run.folder
    files = (multipart("position", [d / "ALL0000" / "F0000CH1.CSV", d / "ALL0000" / "F0000CH2.CSV"])
             + multipart("velocity", [d / "ALL0001" / "F0001CH1.CSV", d / "ALL0001" / "F0001CH2.CSV"])
             + multipart("current", [d / "ALL0002" / "F0002CH1.CSV", d / "ALL0002" / "F0002CH2.CSV"]))
    request = httpx.Request("POST", f"http://{live_server[0]}:{live_server[1]}/api/identify", files=files,
                            data={"method": "auto", "delay": "true"})
    body = b"".join(request.stream)
    head = f"POST /api/identify HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: {len(body)}\r\n"
    head += f"Content-Type: {request.headers['content-type']}\r\n\r\n"
    _forkserver_running()
    before = _descendants(os.getpid())
    with socket.create_connection(live_server) as sock:
        sock.sendall(head.encode() + body)
        deadline = time.monotonic() + 30
        while not _descendants(os.getpid()) - before:
            assert time.monotonic() < deadline, "no worker started"
            time.sleep(0.01)
        time.sleep(0.2)
    hung_up = time.monotonic()  # the socket is closed here
    deadline = hung_up + 5
    while (alive := _alive(_descendants(os.getpid()) - before)) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert not alive, "the worker kept running after its client left"
    assert time.monotonic() - hung_up < 2.0
