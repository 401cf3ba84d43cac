"""The request gate of app/server/http/request_gate.py for the viser port (docs/DESIGN.md §14).

viser 1.1 has no origin option: its WebsockServer runs our check as the first connect callback,
where the handshake's Host and Origin are known and nothing has been sent or received yet; a foreign
socket is closed with 1008. Its static client files stay public (they hold no state)."""

from __future__ import annotations

import logging
from typing import Any

from app.server.http.request_gate import host_allowed, same_origin

log = logging.getLogger(__name__)


def gate_viser(server: Any, hosts: frozenset[str]) -> bool:
    """Refuse viser WebSockets from other sites or Host names; False if viser has no hook."""
    websock = getattr(server, "_websock_server", None)
    live = getattr(websock, "_live_connections", None)
    callbacks = getattr(websock, "_client_connect_cb", None)
    if not isinstance(live, dict) or not isinstance(callbacks, list):
        log.warning("viser has no connection hook: its port accepts every origin")
        return False

    async def check(client: Any) -> None:
        connection = live.get(client.client_id)
        if connection is None:
            return
        headers = connection.request.headers
        host, origin = headers.get("Host"), headers.get("Origin")
        foreign = origin is not None and not same_origin(origin, host or "")
        if foreign or not host_allowed(host, hosts):
            log.warning("viser: refused a socket from Origin %.80r, Host %.80r", origin, host)
            await connection.close(1008, "cross-site connections are refused")

    callbacks.insert(0, check)  # before viser's own: a refused client is never set up
    return True
