"""A WebSocket client that stops reading loses frames; the simulation and other clients don't."""

import base64
import json
import os
import socket

import httpx
import pytest
from websockets.sync.client import connect

SPEED = 2.0  # times real time


def stalled_scope_client(host: str, port: int) -> socket.socket:
    """Open /ws/scope by hand with a tiny receive buffer, then never read again."""
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 2048)
    sock.connect((host, port))
    key = base64.b64encode(os.urandom(16)).decode()
    request = (
        f"GET /ws/scope HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
        f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
    )
    sock.sendall(request.encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    assert b" 101 " in head.split(b"\r\n", 1)[0], head
    return sock


@pytest.mark.slow
def test_a_stalled_client_does_not_slow_the_simulation_or_other_clients(server):
    base_url, _app = server
    host, port = base_url.removeprefix("http://").split(":")
    http = httpx.Client(base_url=base_url, timeout=10)
    # 2x real time fills the stalled connection's buffers within seconds and leaves the
    # simulation thread 40 ms a frame, so the pacing keeps up on a busy 2-core VM
    assert http.put("/api/sim/speed", json={"speed": SPEED}).status_code == 200
    before = http.get("/api/state").json()
    stalled = stalled_scope_client(host, int(port))
    try:
        with connect(base_url.replace("http://", "ws://") + "/ws/scope", open_timeout=10) as ws:
            # read until the server reports the stalled client losing frames (<= 60 s)
            received = 0
            while http.get("/api/state").json()["scope"]["dropped"] == 0:
                for _ in range(100):
                    ws.recv(timeout=10)
                received += 100
                assert received < 60 * 50 * SPEED, "the stalled client never lost a frame"
            # from now on the stalled client is losing frames: this client must lose none
            numbers = [json.loads(ws.recv(timeout=10))["frame"] for _ in range(300)]
        state = http.get("/api/state").json()
    finally:
        stalled.close()
        http.put("/api/sim/speed", json={"speed": 1.0})
    assert numbers == list(range(numbers[0], numbers[0] + 300))
    assert abs(state["rtf"] - SPEED) < 0.05 * SPEED  # the simulation kept its pace
    assert state["scope"]["dropped"] > 0  # the stalled client did lose frames
    # pacing on a busy 2-core VM skips a few frames now and then; a stalled client that held up
    # the simulation thread would skip a large share of them
    ran = state["frame"] - before["frame"]
    skipped = state["frames_dropped"] - before["frames_dropped"]
    assert ran > 300
    assert skipped <= 0.05 * (ran + skipped), (skipped, ran)
