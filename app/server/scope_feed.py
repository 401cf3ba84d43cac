"""The live oscilloscope feed: recent TDM-PWM frames for `GET /api/scope`, fan-out to WebSockets.

The simulation thread appends, the event loop formats once and feeds per-client queues that drop
their oldest frames; the client set is replaced, never changed in place (docs/DESIGN.md §8).
"""

from __future__ import annotations

import asyncio
import json
import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.core.frame_loop import FrameRecord
from app.server.scope_frames import frame_message
from hardware import TdmConfig

HISTORY_FRAMES = 250  # 5 s of frames for GET /api/scope
CLIENT_QUEUE_FRAMES = 10


@dataclass(eq=False)
class ScopeClient:
    queue: asyncio.Queue[str]
    dropped: int = 0


class ScopeFeed:
    def __init__(self, tdm: TdmConfig) -> None:
        self.tdm = tdm
        self._history: deque[tuple[FrameRecord, int]] = deque(maxlen=HISTORY_FRAMES)
        self._clients: frozenset[ScopeClient] = frozenset()  # replaced on the event loop
        self._loop: asyncio.AbstractEventLoop | None = None
        self._lock = threading.Lock()
        self.published = 0
        self._dropped_gone = 0

    def attach_loop(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = loop

    # --- simulation thread ----------------------------------------------------------------------

    def publish(self, record: FrameRecord, params_version: int) -> None:
        with self._lock:
            self._history.append((record, params_version))
            self.published += 1
        if self._clients and self._loop is not None and not self._loop.is_closed():
            try:
                self._loop.call_soon_threadsafe(self._fan_out, record, params_version)
            except RuntimeError:  # the loop closed between the check and the call
                pass

    def clear(self) -> None:
        with self._lock:
            self._history.clear()

    # --- event loop -----------------------------------------------------------------------------

    def recent(self, n: int) -> list[dict[str, Any]]:
        with self._lock:
            records = list(self._history)[-n:]
        return [frame_message(r, self.tdm, v) for r, v in records]

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

    def _fan_out(self, record: FrameRecord, params_version: int) -> None:
        clients = self._clients
        if not clients:
            return
        text = json.dumps(frame_message(record, self.tdm, params_version), default=_json_default)
        for client in clients:
            if client.queue.full():
                client.queue.get_nowait()  # lose the oldest frame, never wait
                client.dropped += 1
            client.queue.put_nowait(text)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
