"""The request gate in front of the app, a pure ASGI middleware (docs/DESIGN.md §14):
a Host allow-list against DNS rebinding; API and WebSocket requests from other sites refused
(Origin, Sec-Fetch-Site); state-changing requests only as JSON (or YAML for the import, bytes
for a robot's upload); bodies counted, a 413 as soon as one is too large; a client gone
mid-upload ends quietly."""

from __future__ import annotations

import asyncio
import ipaddress
import json
import logging
import socket
from collections.abc import Iterable
from typing import Any
from urllib.parse import urlsplit

from starlette.datastructures import Headers
from starlette.requests import ClientDisconnect
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.params.formats import MAX_IMPORT_BYTES
from app.server.http.errors import error_content
from app.server.http.robot_upload import MAX_UPLOAD_BYTES

log = logging.getLogger(__name__)

SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
JSON_TYPES = frozenset({"application/json"})
YAML_TYPES = frozenset({"application/yaml", "application/x-yaml", "text/yaml"})
IMPORT_PATH = "/api/import"
#: a robot's file or zip, as bytes: no form a page of another site can send (no CORS-safe type)
ROBOT_IMPORT_PATH = "/api/robot/import"
UPLOAD_TYPES = frozenset({"application/octet-stream"})
RECORDING_IMPORT_PATH = "/api/recording/import"
FIT_PATH = "/api/fit"  # a recording of the identify routine (docs/FIT.md), about 1 MB
MAX_BODY_BYTES = 16 * 1024  # a parameter set is about 4 KiB
MAX_IMPORT_BODY_BYTES = MAX_IMPORT_BYTES
MAX_RECORDING_BODY_BYTES = 16 * 1024 * 1024  # a 60 s recording file is about 2 MB
BODY_LIMITS = {
    IMPORT_PATH: MAX_IMPORT_BODY_BYTES,
    RECORDING_IMPORT_PATH: MAX_RECORDING_BODY_BYTES,
    FIT_PATH: MAX_RECORDING_BODY_BYTES,
    ROBOT_IMPORT_PATH: MAX_UPLOAD_BYTES,
}
GATED_PREFIXES = ("/api/", "/ws/")
LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})
WILDCARD_HOSTS = frozenset({"0.0.0.0", "::", ""})


def served_hosts(bind_host: str, extra: Iterable[str] = ()) -> frozenset[str]:
    """Host names a browser may use for this server: loopback, the bind address (or, bound to
    all interfaces, this machine's name) and any configured extra names. IP literals are always
    allowed (they cannot be rebound); see `host_allowed`."""
    names = set(LOOPBACK_NAMES) | {h.lower().strip("[]") for h in extra}
    if bind_host in WILDCARD_HOSTS:
        hostname = socket.gethostname().lower()
        names |= {hostname, f"{hostname}.local"}
    else:
        names.add(bind_host.lower().strip("[]"))
    return frozenset(names)


def split_host(host: str) -> str:
    """'Example.org:8000' -> 'example.org'; '[::1]:8000' -> '::1'."""
    host = host.strip().lower()
    if host.startswith("["):
        return host[1 : host.find("]")] if "]" in host else host
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


def host_allowed(host: str | None, names: frozenset[str]) -> bool:
    if not host:
        return False
    name = split_host(host)
    if name in names:
        return True
    try:
        ipaddress.ip_address(name)  # a DNS-rebinding page always uses a name, never an address
    except ValueError:
        return False
    return True


def same_origin(origin: str, host: str) -> bool:
    """The Origin header names the server the request was sent to (scheme http/https)."""
    try:
        parts = urlsplit(origin)
    except ValueError:
        return False
    return parts.scheme in ("http", "https") and parts.netloc.lower() == host.strip().lower()


class _TooLarge(Exception):
    pass


class RequestGate:
    def __init__(self, app: ASGIApp, *, hosts: frozenset[str]) -> None:
        self.app = app
        self.hosts = hosts

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        refusal = self._refusal(scope, headers)
        if refusal is not None:
            await _refuse(scope, receive, send, *refusal)
            return
        if scope["type"] == "websocket":
            await self.app(scope, receive, send)
            return
        limit = BODY_LIMITS.get(scope["path"], MAX_BODY_BYTES)
        length = headers.get("content-length")
        if length is not None and (not length.isdigit() or int(length) > limit):
            await _refuse(scope, receive, send, *_too_large(limit))
            return
        await self._counted(scope, receive, send, limit)

    def _refusal(self, scope: Scope, headers: Headers) -> tuple[int, str, str, list[str]] | None:
        host = headers.get("host")
        if not host_allowed(host, self.hosts):
            allowed = ", ".join(sorted(self.hosts))
            msg = f"this server does not answer to Host {host!r:.80}; allowed: {allowed}"
            return 400, msg, "host_not_allowed", ["header", "host"]
        path: str = scope["path"]
        if not path.startswith(GATED_PREFIXES):
            return None  # the page itself may be opened from a link on any site
        origin = headers.get("origin")
        if origin is not None and not same_origin(origin, host or ""):
            msg = f"requests from {origin!r:.80} are refused; only pages of this server may call"
            return 403, msg, "cross_origin", ["header", "origin"]
        if headers.get("sec-fetch-site", "same-origin") not in ("same-origin", "none"):
            msg = "cross-site requests are refused; only pages of this server may call"
            return 403, msg, "cross_site", ["header", "sec-fetch-site"]
        if scope["type"] == "http" and scope["method"] not in SAFE_METHODS:
            media = headers.get("content-type", "").split(";")[0].strip().lower()
            types = JSON_TYPES | (YAML_TYPES if path == IMPORT_PATH else frozenset())
            types = UPLOAD_TYPES if path == ROBOT_IMPORT_PATH else types
            has_body = headers.get("content-length", "0") != "0" or "transfer-encoding" in headers
            if (media or has_body) and media not in types:
                shown = media[:60] or "missing"
                msg = f"Content-Type {shown!r}; allowed: {', '.join(sorted(types))}"
                return 415, msg, "unsupported_media_type", ["header", "content-type"]
        return None

    async def _counted(self, scope: Scope, receive: Receive, send: Send, limit: int) -> None:
        state = {"count": 0, "over": False, "started": False}

        async def counting_receive() -> Message:
            message = await receive()
            if message["type"] == "http.request":
                state["count"] += len(message.get("body", b""))
                if state["count"] > limit:
                    state["over"] = True
                    raise _TooLarge
            return message

        async def gated_send(message: Message) -> None:
            if state["over"]:
                return  # the app's answer to a body it could not read; ours goes out instead
            state["started"] = True
            await send(message)

        try:
            await self.app(scope, counting_receive, gated_send)
        except _TooLarge:
            pass
        except ClientDisconnect:  # left mid-upload: no one to answer, nothing to report
            log.debug(
                "%s %s: the client left before its body arrived", scope["method"], scope["path"]
            )
            return
        except asyncio.CancelledError:  # the server stops, and this request outlasted its wait
            log.warning("%s %s: cut short, the server stops", scope["method"], scope["path"])
            if not state["started"]:  # answered in a line, not a traceback in the server's log
                await _send_json(send, 503, "the server is stopping", "server_stopping", [])
            return
        if state["over"] and not state["started"]:
            await _send_json(send, *_too_large(limit))


def _too_large(limit: int) -> tuple[int, str, str, list[str]]:
    return 413, f"request body larger than {limit} bytes", "body_too_large", ["body"]


async def _refuse(
    scope: Scope, receive: Receive, send: Send, status: int, msg: str, kind: str, loc: list[str]
) -> None:
    if scope["type"] == "websocket":
        await receive()  # websocket.connect
        await send({"type": "websocket.close", "code": 1008, "reason": msg[:120]})
        return
    await _send_json(send, status, msg, kind, loc)


async def _send_json(send: Send, status: int, msg: str, kind: str, loc: list[Any]) -> None:
    body = json.dumps(error_content([{"loc": loc, "msg": msg, "type": kind}])).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    if status == 413:
        headers.append((b"connection", b"close"))
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})
