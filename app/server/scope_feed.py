"""The live TDM-PWM oscilloscope feed: recent frames for `GET /api/scope` and fan-out to WebSockets.

The simulation thread calls `publish` once per 20 ms frame with the raw frame (OCR ticks and what
each servo decoded); that costs a deque append and, while anyone is watching, one
`call_soon_threadsafe`. Formatting happens on the event loop, once per frame for all clients.
Every client has a small queue of its own: a slow or stalled client loses its oldest frames
(counted) and never slows the simulation or the other clients.
"""

from __future__ import annotations

import asyncio
import json
import math
import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.core.frame_loop import FrameRecord
from hardware import SERVO_NAMES, TdmConfig, frame_to_dict

HISTORY_FRAMES = 250  # 5 s of frames for GET /api/scope
CLIENT_QUEUE_FRAMES = 10


def frame_message(record: FrameRecord, tdm: TdmConfig, params_version: int) -> dict[str, Any]:
    """One scope frame: frame_to_dict plus frame number, time, phase, the version of the
    parameters that produced it, and each slot's angle."""
    data = frame_to_dict(record.ocr, tdm, saturated=record.saturated_servos)
    angles = zip(SERVO_NAMES, record.setpoint.tolist(), strict=True)
    degrees = {name: math.degrees(a) for name, a in angles}
    for channel in data["channels"]:
        for slot in channel["slots"]:
            slot["deg"] = degrees.get(slot["servo"])
    return {
        "frame": record.index,
        "t_s": round(record.time_s, 6),
        "phase_rad": record.phase,
        "params_version": params_version,
        **data,
    }


@dataclass(eq=False)
class ScopeClient:
    queue: asyncio.Queue[str]
    dropped: int = 0


class ScopeFeed:
    def __init__(self, tdm: TdmConfig) -> None:
        self.tdm = tdm
        self._history: deque[tuple[FrameRecord, int]] = deque(maxlen=HISTORY_FRAMES)
        self._clients: set[ScopeClient] = set()
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
        self._clients.add(client)
        return client

    def disconnect(self, client: ScopeClient) -> None:
        if client in self._clients:
            self._clients.discard(client)
            self._dropped_gone += client.dropped

    @property
    def client_count(self) -> int:
        return len(self._clients)

    @property
    def dropped(self) -> int:
        """Frames lost by slow clients, over all clients connected now or before."""
        return self._dropped_gone + sum(c.dropped for c in self._clients)

    def _fan_out(self, record: FrameRecord, params_version: int) -> None:
        if not self._clients:
            return
        text = json.dumps(frame_message(record, self.tdm, params_version), default=_json_default)
        for client in list(self._clients):
            if client.queue.full():
                client.queue.get_nowait()  # lose the oldest frame, never wait
                client.dropped += 1
            client.queue.put_nowait(text)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
