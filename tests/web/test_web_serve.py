"""``motorid serve`` — loopback by default, a warning otherwise, options checked."""

from __future__ import annotations

import socket

import pytest

from motorid.cli.serve import is_loopback


@pytest.mark.parametrize(("host", "local"), [
    ("127.0.0.1", True), ("127.8.9.1", True), ("localhost", True), ("::1", True), ("[::1]", True),
    ("0.0.0.0", False), ("192.168.1.20", False), ("::", False), ("lab-pc.example.org", False),
])
def test_is_loopback(host, local):
    assert is_loopback(host) is local


@pytest.fixture
def fake_uvicorn(monkeypatch):
    """Record what ``serve`` would run instead of running it."""
    import uvicorn

    calls = []
    monkeypatch.setattr(uvicorn, "run", lambda app, **kw: calls.append((app, kw)))
    return calls


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_serve_defaults_to_this_computer_only(run_cli, fake_uvicorn):
    port = _free_port()
    res = run_cli("serve", "--port", str(port), "--max-upload-mb", "7")
    assert res.code == 0, res.err
    app, kw = fake_uvicorn[0]
    assert kw["host"] == "127.0.0.1" and kw["port"] == port
    assert app.state.settings.max_upload_mb == 7
    assert "warning" not in res.err
    assert f"http://127.0.0.1:{port}/" in res.out


def test_serve_warns_when_listening_beyond_loopback(run_cli, fake_uvicorn):
    res = run_cli("serve", "--host", "0.0.0.0", "--port", str(_free_port()))
    assert res.code == 0, res.err
    assert fake_uvicorn[0][1]["host"] == "0.0.0.0"
    assert res.err.startswith("motorid: warning: listening on 0.0.0.0") and res.err.count("\n") == 1


def test_serve_refuses_bad_options_in_one_line(run_cli, fake_uvicorn):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        res = run_cli("serve", "--port", str(busy.getsockname()[1]))
    assert res.code == 2 and res.err.startswith("motorid: error: --host 127.0.0.1 --port") and res.err.count("\n") == 1
    res = run_cli("serve", "--max-upload-mb", "0")
    assert res.code == 2 and "--max-upload-mb" in res.err
    for flag, value in (("--max-seconds", "0"), ("--max-seconds", "inf"), ("--max-memory-mb", "10"),
                        ("--max-memory-mb", "nan")):
        res = run_cli("serve", flag, value)
        assert res.code == 2 and res.err.startswith(f"motorid: error: {flag} must be") and res.err.count("\n") == 1
    assert fake_uvicorn == []


def test_serve_passes_its_bounds_and_the_deadline_protocol_to_uvicorn(run_cli, fake_uvicorn):
    from motorid.web.protocol import DeadlineH11Protocol

    res = run_cli("serve", "--no-token", "--max-seconds", "30", "--max-memory-mb", "512")
    assert res.code == 0, res.err
    app, kw = fake_uvicorn[0]
    assert kw["http"] is DeadlineH11Protocol and kw["limit_concurrency"] == 64
    work = app.state.settings.work
    assert (work.max_seconds, work.max_memory_mb) == (30.0, 512.0)


@pytest.mark.slow
def test_serve_prints_its_token_and_stops_on_sigterm_within_seconds(tmp_path):
    """As a user runs it: the first line is the address with the token; the page needs it; SIGTERM
    stops the server within seconds and its temporary folder goes with it."""
    import os
    import signal
    import subprocess
    import sys
    import time
    import urllib.error
    import urllib.request

    port = _free_port()
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    proc = subprocess.Popen([sys.executable, "-m", "motorid", "serve", "--port", str(port)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = proc.stdout.readline()
        url = first.split()[2]
        assert url.startswith(f"http://127.0.0.1:{port}/?token="), first
        deadline = time.monotonic() + 30
        while True:
            try:
                with urllib.request.urlopen(url, timeout=5) as res:
                    assert res.status == 200
                break
            except (urllib.error.URLError, ConnectionError):
                assert time.monotonic() < deadline, "the server did not answer"
                time.sleep(0.2)
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=5)
        assert refused.value.code == 403  # no token, no page
        assert list(tmp_path.glob("motorid-web-*"))
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=15)
        assert time.monotonic() - t0 < 10
        assert not list(tmp_path.glob("motorid-web-*"))  # its temporary folder went with it
    finally:
        if proc.poll() is None:
            proc.kill()
