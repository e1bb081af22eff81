"""uvicorn's HTTP protocol with a deadline on the client's side of each request.

uvicorn closes an idle keep-alive connection, but a client that opens a connection and sends
its request line and headers a byte at a time, or its body at a trickle (the *slowloris*
pattern), holds the connection, and the upload's temporary files, for as long as it likes:
uvicorn has no header or body timeout (its ``timeout_keep_alive`` only starts after a
response).  This subclass of its h11 protocol, passed as ``uvicorn.run(http=…)`` (the extension
point uvicorn offers), gives each request :data:`HEADER_TIMEOUT_S` to send its headers and
:data:`BODY_TIMEOUT_S` more to send its body; a client that misses either is disconnected (the
app then sees ``http.disconnect`` and drops the request).
"""

from __future__ import annotations

import asyncio

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

__all__ = ["BODY_TIMEOUT_S", "HEADER_TIMEOUT_S", "DeadlineH11Protocol"]

#: Seconds from the connection (or the last response) to a request's complete headers.
HEADER_TIMEOUT_S = 10.0
#: Seconds from a request's headers to the end of its body (a 50 MB upload on loopback takes < 1 s).
BODY_TIMEOUT_S = 120.0

_REQUEST_IN = (h11.DONE, h11.MUST_CLOSE, h11.CLOSED, h11.ERROR)


class DeadlineH11Protocol(H11Protocol):
    """h11 protocol whose clients must send each request's headers and body in time."""

    header_timeout_s: float = HEADER_TIMEOUT_S
    body_timeout_s: float = BODY_TIMEOUT_S
    _receipt_timer: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        """Start the header deadline of the first request.

        Parameters
        ----------
        transport : asyncio.Transport
            The new connection.
        """
        super().connection_made(transport)
        self._arm(self.header_timeout_s)

    def handle_events(self) -> None:
        """When a request's headers are in, its body deadline starts."""
        before = self.cycle
        super().handle_events()
        if self.cycle is not None and self.cycle is not before:
            self._arm(self.body_timeout_s)

    def on_response_complete(self) -> None:
        """After a response, the next request's header deadline starts."""
        super().on_response_complete()
        if not self.transport.is_closing():
            self._arm(self.header_timeout_s)

    def connection_lost(self, exc: Exception | None) -> None:
        """Stop the deadline with the connection.

        Parameters
        ----------
        exc : Exception or None
            Why the connection ended (None: closed normally).
        """
        if self._receipt_timer is not None:
            self._receipt_timer.cancel()
        super().connection_lost(exc)

    def _arm(self, delay: float) -> None:
        if self._receipt_timer is not None:
            self._receipt_timer.cancel()
        self._receipt_timer = self.loop.call_later(delay, self._deadline)

    def _deadline(self) -> None:
        if self.transport.is_closing() or self.conn.their_state in _REQUEST_IN:
            return  # the request is in (the app is answering it) or the connection is going
        if self.cycle is not None and not self.cycle.response_complete:
            self.cycle.keep_alive = False
        self.transport.close()
