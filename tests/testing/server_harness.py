"""What the tests and benchmarks share: a real uvicorn server running `create_app()` on a free
loopback port, and how to start Debian's Chromium for Playwright."""

from __future__ import annotations

import contextlib
import shutil
import socket
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import uvicorn

from app.server.http.app import UVICORN_OPTIONS, create_app
from app.server.services import ServerConfig

#: Debian's Chromium, driven by Playwright through `executable_path` (never Playwright's download)
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
#: headless as root on a closed network: no sandbox, no GPU, no background connections
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    # every origin its own renderer: the 3D view (viser, another port of the same host, drawn by
    # software WebGL here) must not share the dashboard's main thread, where on a busy machine it
    # held the page's state poll back for seconds (issue 33)
    "--enable-features=StrictOriginIsolation",
    "--disable-background-networking",
    "--disable-component-update",
    "--no-first-run",
    "--disable-sync",
]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class _Server(uvicorn.Server):
    """uvicorn.Server that tells us when it is listening (and the lifespan has run)."""

    def __init__(self, config: uvicorn.Config) -> None:
        super().__init__(config)
        self.ready = threading.Event()

    async def startup(self, sockets=None) -> None:
        await super().startup(sockets)
        self.ready.set()


@contextlib.contextmanager
def running_server(
    data_dir: Path, *, viewer: bool = False, drive: str = "model", **config: Any
) -> Iterator[tuple[str, object]]:
    """Yield (base_url, app) of a live server (`config`: more of `ServerConfig`); stop it (and
    its threads) afterwards."""
    port = free_port()
    config = ServerConfig(
        **{"viser_port": free_port(), **config},
        port=port, data_dir=data_dir, viewer=viewer, drive=drive,
    )  # fmt: skip
    app = create_app(config)
    server = _Server(
        uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning", **UVICORN_OPTIONS)
    )
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    if not server.ready.wait(30):
        raise RuntimeError("server did not start within 30 s")
    try:
        yield f"http://127.0.0.1:{port}", app
    finally:
        server.should_exit = True
        thread.join(30)


def client(base_url: str) -> httpx.Client:
    return httpx.Client(base_url=base_url, timeout=10)


def wait_for(condition, what: str, attempts: int = 600):
    """Poll `condition()` every 50 ms until it returns something truthy (about 30 s at most);
    the waiting is on a condition, never on the clock alone."""
    gate = threading.Event()
    for _ in range(attempts):
        result = condition()
        if result:
            return result
        gate.wait(0.05)
    raise AssertionError(f"never happened: {what}")
