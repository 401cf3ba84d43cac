"""uvicorn's HTTP/1.1 protocol (h11) with a deadline for each request's head (docs/DESIGN.md
§14): a connection that opens, or starts its next request, and has not sent the whole head
within HEAD_TIMEOUT_S is answered 408 and closed. uvicorn has no such deadline of its own, so
20 000 connections that never finished their headers held the server's sockets for good."""

from __future__ import annotations

import asyncio

from uvicorn.protocols.http.h11_impl import H11Protocol

HEAD_TIMEOUT_S = 10.0  # a browser sends its head at once; only a stalled client waits this long
TIMED_OUT = b"HTTP/1.1 408 Request Timeout\r\nconnection: close\r\ncontent-length: 0\r\n\r\n"


class HeadDeadlineProtocol(H11Protocol):
    """H11Protocol whose wait for a request's head ends after HEAD_TIMEOUT_S."""

    _head_deadline: asyncio.TimerHandle | None = None
    _waited_cycle: object = None  # the request cycle before the head being waited for

    # H11Protocol's own signature: it narrows asyncio's BaseTransport to a Transport, as uvicorn
    # does (with the same ignore)
    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._arm_head_deadline()

    def data_received(self, data: bytes) -> None:
        if self._waiting_for_head() and (
            self._head_deadline is None or self._waited_cycle is not self.cycle
        ):  # the first bytes of a next request on a kept connection
            self._disarm_head_deadline()
            self._arm_head_deadline()
        super().data_received(data)

    def connection_lost(self, exc: Exception | None) -> None:
        self._disarm_head_deadline()
        super().connection_lost(exc)

    def _waiting_for_head(self) -> bool:
        return self.cycle is None or self.cycle.response_complete

    def _arm_head_deadline(self) -> None:
        self._waited_cycle = self.cycle
        self._head_deadline = self.loop.call_later(HEAD_TIMEOUT_S, self._head_timed_out)

    def _disarm_head_deadline(self) -> None:
        if self._head_deadline is not None:
            self._head_deadline.cancel()
            self._head_deadline = None

    def _head_timed_out(self) -> None:
        self._head_deadline = None
        upgraded = self.transport.get_protocol() is not self  # a WebSocket now: not ours
        if upgraded or self.transport.is_closing() or self.cycle is not self._waited_cycle:
            return  # the head came (a request began) or the connection ended
        self.transport.write(TIMED_OUT)
        self.transport.close()
