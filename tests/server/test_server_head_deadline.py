"""A client that never finishes a request's head is answered 408 and let go (uvicorn has no such
deadline: 20 000 such connections held the server's sockets for good); requests sent whole, kept
connections and WebSockets are untouched. The deadline is shortened here to 0.5 s."""

from __future__ import annotations

import socket

import httpx
import pytest
from websockets.sync.client import connect

from app.server.http import http_protocol

DEADLINE_S = 0.5


@pytest.fixture
def short_deadline(monkeypatch):
    monkeypatch.setattr(http_protocol, "HEAD_TIMEOUT_S", DEADLINE_S)


def open_socket(base_url: str) -> socket.socket:
    host, port = base_url.removeprefix("http://").split(":")
    return socket.create_connection((host, int(port)), timeout=30)


def read_until_closed(sock: socket.socket) -> bytes:
    """Everything the server sends until it closes the connection (30 s at most)."""
    got = b""
    while chunk := sock.recv(4096):
        got += chunk
    return got


def test_a_head_never_finished_is_answered_408_and_closed(server, short_deadline):
    base_url, _app = server
    with open_socket(base_url) as stalled:
        stalled.sendall(b"GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n")  # no blank line
        with httpx.Client(base_url=base_url, timeout=10) as http:
            assert http.get("/api/health").status_code == 200  # others are served meanwhile
        answer = read_until_closed(stalled)
    assert answer.startswith(b"HTTP/1.1 408 Request Timeout\r\n"), answer


def test_a_connection_that_sends_nothing_is_let_go(server, short_deadline):
    with open_socket(server[0]) as silent:
        assert read_until_closed(silent).startswith(b"HTTP/1.1 408 ")


def test_a_kept_connection_gets_the_deadline_for_its_next_head_only(server, short_deadline):
    with open_socket(server[0]) as kept:
        kept.sendall(b"GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        first = b""
        while b'"ok"' not in first:  # the whole first answer (a small JSON body)
            first += kept.recv(4096)
        assert first.startswith(b"HTTP/1.1 200 OK\r\n"), first
        kept.sendall(b"GET /api/health HTTP/1.1\r\n")  # the next head, never finished
        assert read_until_closed(kept).startswith(b"HTTP/1.1 408 ")


def test_a_websocket_outlives_the_deadline(server, short_deadline):
    url = server[0].replace("http://", "ws://") + "/ws/scope"
    with connect(url, open_timeout=10) as ws:
        # 50 frames a second: 100 frames span four deadlines, on the upgraded connection
        frames = [ws.recv(timeout=10) for _ in range(100)]
    assert len(frames) == 100
