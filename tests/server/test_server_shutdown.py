"""`artro serve` ends on SIGTERM though a client holds a request half sent: uvicorn waits at
most `timeout_graceful_shutdown` for requests in flight (`UVICORN_OPTIONS`), then the app stops
its jobs, simulation and 3D view. Before, the process lived as long as the client liked. A second
Ctrl-C while it waits ends it at once, quietly."""

from __future__ import annotations

import contextlib
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from tests.testing.server_harness import free_port, wait_for
from tests.testing.signal_support import with_sigint_default

ROOT = Path(__file__).resolve().parents[2]


def healthy(base_url: str) -> bool:
    try:
        return httpx.get(f"{base_url}/api/health", timeout=5).status_code == 200
    except httpx.HTTPError:
        return False


@contextlib.contextmanager
def serving_with_a_request_held(tmp_path: Path, *flags: str) -> Iterator[tuple]:
    """`artro serve FLAGS` as a process, answering, and a connection holding a PUT whose body
    stays half sent: (the process, its URL, that socket). Killed at the end if still running."""
    port = free_port()
    server = subprocess.Popen(  # Ctrl-C as from a terminal, though the suite runs in background
        with_sigint_default([sys.executable, "-m", "app.cli", "serve", "--port", str(port),
                             *flags, "--data-dir", str(tmp_path)]),
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
    )  # fmt: skip
    held = None
    try:
        base_url = f"http://127.0.0.1:{port}"
        wait_for(lambda: healthy(base_url), "the server answers", 1200)
        held = socket.create_connection(("127.0.0.1", port), timeout=10)
        held.sendall(
            b"PUT /api/params HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
            b"Content-Length: 5000\r\n\r\n{"
        )  # and nothing more: the body stays half sent while the server is asked to stop
        # a request sent after it answered: the loop has read the held one's head by then (on a
        # loaded machine a SIGTERM at once could come before it, and nothing was in flight)
        assert healthy(base_url)
        yield server, base_url, held
    finally:
        if held is not None:
            held.close()
        if server.poll() is None:
            server.kill()
            server.wait(30)


def ended(server: subprocess.Popen, what: str) -> str:
    """What the server said, once it ended (within 60 s of `what`, else the test fails)."""
    try:
        return server.communicate(timeout=60)[0].decode()
    except subprocess.TimeoutExpired:
        server.kill()
        pytest.fail(f"the server still ran 60 s after {what}")


@pytest.mark.slow
def test_sigterm_ends_the_server_though_a_client_holds_a_request_half_sent(tmp_path):
    flags = ("--viser-port", str(free_port()))
    with serving_with_a_request_held(tmp_path, *flags) as (server, _url, held):
        server.send_signal(signal.SIGTERM)
        said = ended(server, "SIGTERM while a request was half sent")
        assert server.returncode in (0, -signal.SIGTERM), said[-2000:]  # uvicorn re-raises it
        assert "Traceback" not in said
        assert "PUT /api/params: cut short, the server stops" in said
        assert held.recv(65536).startswith(b"HTTP/1.1 503 ")  # told, not left hanging


@pytest.mark.slow
def test_a_second_ctrl_c_while_stopping_ends_the_server_quietly(tmp_path):
    """uvicorn takes a second Ctrl-C as "force quit": it skips the app's end and cancels it as the
    loop closes, which it logged as a traceback; the services stop all the same, quietly."""
    with serving_with_a_request_held(tmp_path, "--no-viewer") as (server, base_url, _held):
        assert httpx.post(f"{base_url}/api/jobs/robustness", json={}).status_code == 202
        server.send_signal(signal.SIGINT)  # the first: it waits up to 5 s for the held request
        wait_for(lambda: not healthy(base_url), "the server stops listening", 1200)
        server.send_signal(signal.SIGINT)  # the second, while it waits
        said = ended(server, "a second Ctrl-C")
    assert "Traceback" not in said and "ERROR" not in said, said[-3000:]
    assert server.returncode == 0, said[-2000:]  # uvicorn ends a Ctrl-C'd server with 0
