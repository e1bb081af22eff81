"""``motorid serve``: the local web page of the lab (:mod:`motorid.web`) under uvicorn."""

from __future__ import annotations

import ipaddress
import socket
import sys
from typing import Annotated

import typer

from motorid.errors import OptionError

__all__ = ["CONNECTIONS", "KEEP_ALIVE_S", "SHUTDOWN_GRACE_S", "is_loopback", "register", "serve"]

#: Seconds in-flight requests get after SIGTERM or Ctrl+C before the server stops anyway.
SHUTDOWN_GRACE_S = 3
#: Seconds an idle keep-alive connection is kept.
KEEP_ALIVE_S = 5
#: Connections and requests served at once; beyond, uvicorn answers 503.
CONNECTIONS = 64


def is_loopback(host: str) -> bool:
    """Whether ``host`` only accepts connections from this computer.

    Parameters
    ----------
    host : str
        An address or ``localhost``.

    Returns
    -------
    bool
        True for ``localhost`` and the loopback addresses (127.0.0.0/8, ::1).
    """
    if host.strip().lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _check_port(host: str, port: int) -> None:
    if not 0 < port < 65536:
        raise OptionError(f"--port {port}: give a port number 1..65535")
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as sock:
        try:
            sock.bind((host.strip("[]"), port))
        except OSError as exc:
            raise OptionError(f"--host {host} --port {port}: cannot listen there ({exc.strerror}); "
                              "choose another --port, or stop the program using it") from None


def serve(
    host: Annotated[str, typer.Option(help="Address to listen on (default: this computer only).")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port to listen on.")] = 8765,
    max_upload_mb: Annotated[float, typer.Option("--max-upload-mb", help="Largest upload, MB.")] = 50.0,
    open_browser: Annotated[bool, typer.Option("--open/--no-open", help="Open the page in a browser.")] = False,
    token: Annotated[bool, typer.Option(
        "--token/--no-token",
        help="Require the random token printed on the first line (as Jupyter does); --no-token only for "
             "scripts on a machine you trust.")] = True,
    max_seconds: Annotated[float, typer.Option(
        "--max-seconds", help="Longest identification or report; it is stopped after this many seconds.")] = 300.0,
    max_memory_mb: Annotated[float, typer.Option(
        "--max-memory-mb", help="Memory one identification or report may take, MB.")] = 2048.0,
) -> None:
    """Start the local web page: drop captures, identify, tune the controller with sliders."""
    try:
        import uvicorn

        from motorid.web import WebSettings, create_app
        from motorid.web.protocol import DeadlineH11Protocol
        from motorid.web.work import WorkLimits
    except ImportError as exc:
        raise OptionError(f"motorid serve needs the web extra ({exc.name} is missing): "
                          "pip install 'motorid[web]'") from None
    import secrets

    from motorid.web.guard import LOCAL_HOSTS

    secret = secrets.token_urlsafe(24) if token else None
    bound = host.strip("[]")
    hosts = LOCAL_HOSTS + (() if bound in ("0.0.0.0", "::") or bound in LOCAL_HOSTS else (bound,))
    settings = WebSettings(max_upload_mb=max_upload_mb, token=secret, hosts=hosts,
                           work=WorkLimits(max_seconds=max_seconds, max_memory_mb=max_memory_mb))
    _check_port(host, port)
    if secret is None:
        print("motorid: warning: --no-token: any program or web page on this computer that finds the port can "
              "use the server", file=sys.stderr)
    if not is_loopback(host):
        print(f"motorid: warning: listening on {host}: anyone who can reach this computer on port {port} can "
              "use the page and upload files (there is no password); use --host 127.0.0.1 to keep it local",
              file=sys.stderr)
    shown = "localhost" if host in ("0.0.0.0", "::") else host  # a name the browser can open
    url = f"http://{shown if ':' not in shown else '[' + shown + ']'}:{port}/"
    if secret is not None:
        url += f"?token={secret}"
    typer.echo(f"motorid serve: {url}  (Ctrl+C stops it; uploads are deleted when it stops)")
    if open_browser:
        import threading
        import webbrowser

        # the browser asks once; give uvicorn a moment to bind first
        threading.Timer(1.0, webbrowser.open, [url]).start()
    # SIGTERM or Ctrl+C: in-flight requests get a few seconds, then the server stops and its
    # temporary folder goes (it used to wait for a long request for over a minute); an idle
    # connection is closed after a few seconds, a client that sends its request too slowly is
    # disconnected, and past CONNECTIONS open connections new ones get 503
    uvicorn.run(create_app(settings), host=host.strip("[]"), port=port, log_level="warning",
                timeout_graceful_shutdown=SHUTDOWN_GRACE_S, timeout_keep_alive=KEEP_ALIVE_S,
                http=DeadlineH11Protocol, limit_concurrency=CONNECTIONS)


def register(app: typer.Typer) -> None:
    """Add ``serve`` to the main app."""
    app.command()(serve)
