"""The local server answers the local user only: Host, Origin, content type and a token.

A page the student visits in the same browser can send requests to ``127.0.0.1``: through DNS
rebinding it can even read the answers (its own name resolving to 127.0.0.1: the ``Host``
header then carries that name), and any page can post a form or a ``text/plain`` body without a
preflight.  Jupyter, the server students already run on localhost, refuses such requests the
same way: the ``Host`` must be a local name (or the address the server was bound to), a
state-changing request must come from the page itself (``Origin``, or ``Sec-Fetch-Site``), a
JSON endpoint only takes ``application/json``, and every request carries a random token that
``motorid serve`` prints and opens (``?token=…`` once, then a same-site cookie; scripts send
``?token=`` or ``Authorization: Bearer``).  Starlette's ``TrustedHostMiddleware`` checks the
host; this module adds the rest as one small ASGI middleware (Starlette has no Origin or token
check of its own).
"""

from __future__ import annotations

import hmac
import json
from collections.abc import Awaitable, Callable, MutableMapping
from http.cookies import SimpleCookie
from typing import Any
from urllib.parse import parse_qs, urlsplit

__all__ = ["LOCAL_HOSTS", "TOKEN_COOKIE", "LocalOnly"]

#: The names a browser on this computer uses for it.
LOCAL_HOSTS: tuple[str, ...] = ("127.0.0.1", "localhost", "::1", "[::1]")
#: The cookie that keeps the token for the page's own requests.
TOKEN_COOKIE = "motorid_token"
#: Endpoints whose body is JSON (a form or text/plain body there is a cross-site trick).
JSON_ENDPOINTS: tuple[str, ...] = ("/api/design", "/api/simulate")
#: Methods that change something on the server.
UNSAFE_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]


class LocalOnly:
    """ASGI middleware: same-origin state changes, JSON where JSON is due, and the token.

    Parameters
    ----------
    app : ASGI app
        The wrapped app.
    token : str or None
        The secret every request must carry (None: no token, ``motorid serve --no-token``).
    hosts : tuple of str
        The ``Host`` names answered (without port): :data:`LOCAL_HOSTS` and the bound address.
    """

    def __init__(self, app: ASGIApp, token: str | None, hosts: tuple[str, ...] = LOCAL_HOSTS) -> None:
        self.app = app
        self.token = token
        self.hosts = frozenset(h.lower() for h in hosts) | frozenset(f"[{h}]" for h in hosts if ":" in h)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Answer the request, or refuse it in one line (400 host, 403 site or token, 415 body type).

        Parameters
        ----------
        scope, receive, send :
            The ASGI triple.
        """
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        path, method = scope.get("path", ""), scope.get("method", "GET")
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        refusal = self._refusal(headers, path, method, query)
        if refusal is not None:
            status, line = refusal
            await _plain(send, status, line, path)
            return
        if self.token is not None and query.get("token") and method == "GET" and path == "/":
            await self.app(scope, receive, _with_cookie(send, self.token))
            return
        await self.app(scope, receive, send)

    def _refusal(self, headers: dict[str, str], path: str, method: str,
                 query: dict[str, list[str]]) -> tuple[int, str] | None:
        name = _host_name(headers.get("host", ""))
        if name not in self.hosts:
            return 400, (f"motorid: error: this server answers {', '.join(sorted(self.hosts))} only, not {name!r} "
                         "(a page under another name is refused)")
        if method in UNSAFE_METHODS:
            origin = headers.get("origin")
            host = headers.get("host", "")
            if origin is not None and origin != "null" and urlsplit(origin).netloc.lower() != host.lower():
                return 403, f"motorid: error: a request from another site ({origin}) is refused"
            if origin == "null" or headers.get("sec-fetch-site", "same-origin") not in ("same-origin", "none"):
                return 403, "motorid: error: a request from another site is refused"
            if path in JSON_ENDPOINTS:
                kind = headers.get("content-type", "").split(";")[0].strip().lower()
                if kind != "application/json":
                    return 415, f"motorid: error: {path} takes a JSON body (Content-Type: application/json)"
        if self.token is None or path.startswith("/static/"):
            return None
        given = query.get("token", [""])[0]
        if not given:
            auth = headers.get("authorization", "")
            given = auth[7:].strip() if auth.lower().startswith("bearer ") else ""
        if not given:
            cookie: SimpleCookie = SimpleCookie()
            try:
                cookie.load(headers.get("cookie", ""))
            except Exception:  # a malformed Cookie header is no token
                cookie = SimpleCookie()
            given = cookie[TOKEN_COOKIE].value if TOKEN_COOKIE in cookie else ""
        if not hmac.compare_digest(given.encode(), self.token.encode()):
            return 403, ("motorid: error: this server needs its token: open the address motorid serve printed "
                         "(…/?token=…), or send ?token= or Authorization: Bearer")
        return None


def _host_name(host: str) -> str:
    """The ``Host`` header without its port (``[::1]:8765`` → ``[::1]``), lower case."""
    host = host.strip().lower()
    if host.startswith("["):
        return host[: host.find("]") + 1] if "]" in host else host
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


async def _plain(send: Send, status: int, line: str, path: str) -> None:
    """One line: JSON ``{"detail": …}`` for the API, text for the page."""
    if path.startswith("/api/"):
        body, kind = json.dumps({"detail": line}).encode(), b"application/json"
    else:
        body, kind = (line + "\n").encode(), b"text/plain; charset=utf-8"
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", kind), (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


def _with_cookie(send: Send, token: str) -> Send:
    """``send`` that adds the token cookie to the response (the page's own requests carry it)."""

    async def wrapped(message: Message) -> None:
        if message["type"] == "http.response.start":
            cookie = f"{TOKEN_COOKIE}={token}; Path=/; HttpOnly; SameSite=Strict".encode()
            message = dict(message)
            message["headers"] = [*message.get("headers", []), (b"set-cookie", cookie)]
        await send(message)

    return wrapped
