"""The live oscilloscope feed: recent TDM-PWM frames for `GET /api/scope`, fan-out to WebSockets.

The simulation thread appends; each frame's JSON is made once, when first wanted, and shared by
every WebSocket and `GET /api/scope`; per-client queues drop their oldest frames; the client set is
replaced, never changed in place (docs/DESIGN.md §10)."""

from __future__ import annotations

import asyncio
import json
import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.firmware.mega_pulses import BoardFrame
from app.server.feeds.scope_frames import frame_message
from app.sim.frame_record import FrameRecord
from hardware import TdmConfig
from hardware.servo_bus import BusLink

HISTORY_FRAMES = 250  # 5 s of frames for GET /api/scope
CLIENT_QUEUE_FRAMES = 10


@dataclass(eq=False)
class _Frame:
    record: FrameRecord
    params_version: int
    tdm: TdmConfig  # the robot's wiring when it was published (a switch of robots changes it)
    bus: BusLink | None = None  # its bus, for a robot of bus servos
    board: BoardFrame | None = None  # the Mega board's PCA9685 channels and I2C transactions
    text: str | None = None  # the JSON message, made once (a race makes it twice, both equal)

    def json(self) -> str:
        if self.text is None:
            message = frame_message(
                self.record, self.tdm, self.params_version, self.bus, self.board
            )
            self.text = json.dumps(message, default=_json_default)
        return self.text


@dataclass(eq=False)
class ScopeClient:
    queue: asyncio.Queue[str]
    dropped: int = 0


class ScopeFeed:
    def __init__(self, tdm: TdmConfig, bus: BusLink | None = None) -> None:
        self.tdm = tdm
        self.bus = bus  # set with `tdm` by the simulation thread when the robot changes
        self._history: deque[_Frame] = deque(maxlen=HISTORY_FRAMES)
        self._recent: tuple[int, int, bytes] = (-1, 0, b"")  # (published, n, the JSON answer)
        self._clients: frozenset[ScopeClient] = frozenset()  # replaced on the event loop
        self._loop: asyncio.AbstractEventLoop | None = None
        self._lock = threading.Lock()
        self.published = 0
        self._dropped_gone = 0

    def attach_loop(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = loop

    # --- simulation thread ----------------------------------------------------------------------

    def publish(
        self, record: FrameRecord, params_version: int, board: BoardFrame | None = None
    ) -> None:
        frame = _Frame(record, params_version, self.tdm, self.bus, board)
        with self._lock:
            self._history.append(frame)
            self.published += 1
        if self._clients and self._loop is not None and not self._loop.is_closed():
            try:
                self._loop.call_soon_threadsafe(self._fan_out, frame)
            except RuntimeError:  # the loop closed between the check and the call
                pass

    def clear(self) -> None:
        with self._lock:
            self._history.clear()

    # --- event loop -----------------------------------------------------------------------------

    def recent_json(self, n: int) -> bytes:
        """`{"frames": [the last n frames]}` as UTF-8 JSON: each frame serialised once, and the
        whole answer shared by every client asking for the same n before the next frame."""
        with self._lock:
            published, frames = self.published, list(self._history)[-n:]
        cached = self._recent
        if cached[0] == published and cached[1] == n:
            return cached[2]
        text = ('{"frames": [' + ", ".join(f.json() for f in frames) + "]}").encode()
        self._recent = (published, n, text)
        return text

    def unformatted(self, n: int) -> int:
        """How many of the last n frames have no JSON text yet (the work `recent_json` would do)."""
        with self._lock:
            frames = list(self._history)[-n:]
        return sum(f.text is None for f in frames)

    def recent(self, n: int) -> list[dict[str, Any]]:
        return json.loads(self.recent_json(n))["frames"]

    def connect(self) -> ScopeClient:
        client = ScopeClient(asyncio.Queue(maxsize=CLIENT_QUEUE_FRAMES))
        self._clients = self._clients | {client}
        return client

    def disconnect(self, client: ScopeClient) -> None:
        if client in self._clients:
            self._dropped_gone += client.dropped
            self._clients = self._clients - {client}

    @property
    def client_count(self) -> int:
        return len(self._clients)

    @property
    def dropped(self) -> int:
        """Frames lost by slow clients, over all clients connected now or before."""
        clients = self._clients
        return self._dropped_gone + sum(c.dropped for c in clients)

    def _fan_out(self, frame: _Frame) -> None:
        clients = self._clients
        if not clients:
            return
        text = frame.json()
        for client in clients:
            if client.queue.full():
                client.queue.get_nowait()  # lose the oldest frame, never wait
                client.dropped += 1
            client.queue.put_nowait(text)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
