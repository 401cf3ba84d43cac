"""Record the session: per frame the robot's pose (qpos) and the pulses (OCR), plus parameter
changes with their sources, resets and falls, in a 60 s ring buffer (docs/DESIGN.md §10). The
simulation thread writes; others take an immutable `Recording` copy.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.firmware.mega_pulses import BoardFrame
from app.sim.frame_record import FrameRecord
from app.sim.planning import FRAME_S
from hardware import CHANNELS, SLOTS_PER_FRAME

RECORD_SECONDS = 60.0
RECORD_FRAMES = round(RECORD_SECONDS / FRAME_S)  # 3000 frames, about 0.6 MB
MAX_EVENTS = 1000
MAX_PARAM_DOCUMENTS = 200  # as many versions as the store's undo history keeps
FORMAT = "artro-recording"
FORMAT_VERSION = 1


@dataclass(frozen=True)
class Recording:
    """Frames oldest first (arrays with a leading frame axis) and the events among them."""

    frame: NDArray[np.int64]  # frame index since the last reset
    t_s: NDArray[np.float64]  # session time: seconds since recording began
    sim_t_s: NDArray[np.float64]  # simulated time since the last reset
    phase: NDArray[np.float32]
    qpos: NDArray[np.float32]  # (n, nq)
    ocr: NDArray[np.int16]  # (n, 6, 8)
    version: NDArray[np.int32]  # the parameter version that made the frame
    drive: NDArray[np.int8]  # 0: the model made the pulses, 1: the emulated firmware
    events: tuple[dict[str, Any], ...] = ()  # {"t_s", "kind", ...}: params, reset, fall, drive
    params: dict[int, dict[str, Any]] = field(default_factory=dict)  # version -> document
    model: str = ""
    #: per frame, what the Mega board showed (its PCA9685's edges, its I2C bus; None: another
    #: drive); kept in memory for the VCD download, not written to the file
    boards: tuple[BoardFrame | None, ...] = ()

    def __len__(self) -> int:
        return len(self.frame)

    def to_json(self) -> dict[str, Any]:
        """The file format: one JSON document (arrays as lists, floats as written)."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "model": self.model,
            "frame_s": FRAME_S,
            "frames": len(self),
            "columns": {
                "frame": self.frame.tolist(),
                "t_s": self.t_s.tolist(),
                "sim_t_s": self.sim_t_s.tolist(),
                "phase": self.phase.tolist(),
                "qpos": self.qpos.tolist(),
                "ocr": self.ocr.tolist(),
                "version": self.version.tolist(),
                "drive": self.drive.tolist(),
            },
            "events": list(self.events),
            "params": {str(v): doc for v, doc in sorted(self.params.items())},
        }


class Recorder:
    """The ring buffer. `add` and `event` are cheap; `recording()` copies under the lock."""

    def __init__(self, nq: int, model: str, capacity: int = RECORD_FRAMES) -> None:
        self.capacity, self.model = capacity, model
        self._lock = threading.Lock()
        self._frame = np.zeros(capacity, np.int64)
        self._t = np.zeros(capacity, np.float64)
        self._sim_t = np.zeros(capacity, np.float64)
        self._phase = np.zeros(capacity, np.float32)
        self._qpos = np.zeros((capacity, nq), np.float32)
        self._ocr = np.zeros((capacity, len(CHANNELS), SLOTS_PER_FRAME), np.int16)
        self._version = np.zeros(capacity, np.int32)
        self._drive = np.zeros(capacity, np.int8)
        self._boards: list[BoardFrame | None] = [None] * capacity
        self._written = 0  # frames since the start; the ring holds the last `capacity`
        self._events: list[dict[str, Any]] = []
        self._params: dict[int, dict[str, Any]] = {}

    def restart(self, model: str) -> None:
        """Forget the frames and events: what follows is another robot's (`model`), and a
        replay must not draw one robot's poses with the other's bodies."""
        with self._lock:
            self.model, self._written = model, 0
            self._events.clear()

    @property
    def session_s(self) -> float:
        return self._written * FRAME_S

    def add(
        self,
        record: FrameRecord,
        qpos: NDArray[np.float64],
        version: int,
        board: BoardFrame | None = None,
    ) -> None:
        """One frame (the simulation thread, after the frame); `board`: the Mega board's."""
        with self._lock:
            i = self._written % self.capacity
            self._frame[i] = record.index
            self._t[i] = self._written * FRAME_S
            self._sim_t[i] = record.time_s
            self._phase[i] = record.phase
            self._qpos[i] = qpos
            self._ocr[i] = record.ocr
            self._version[i] = version
            self._drive[i] = record.pin_edges is not None
            self._boards[i] = board
            self._written += 1

    def event(self, kind: str, **fields: Any) -> None:
        """Something that happened now: "params" (version, source, changed), "reset", "fall",
        "drive"; the oldest go when there are more than MAX_EVENTS."""
        with self._lock:
            self._events.append({"t_s": round(self._written * FRAME_S, 3), "kind": kind, **fields})
            del self._events[:-MAX_EVENTS]

    def keep_params(self, version: int, document: dict[str, Any]) -> None:
        """The document of a parameter version, so that a recording names what made its frames."""
        with self._lock:
            self._params[version] = document
            for old in sorted(self._params)[:-MAX_PARAM_DOCUMENTS]:
                del self._params[old]

    def summary(self, last_events: int = 50) -> dict[str, Any]:
        """Frames held, their session times and the newest events, without copying the ring
        (what the pages poll once a second)."""
        with self._lock:
            n = min(self._written, self.capacity)
            first_t = (self._written - n) * FRAME_S
            return {
                "frames": n,
                "capacity": self.capacity,
                "first_t_s": first_t if n else None,
                "last_t_s": (self._written - 1) * FRAME_S if n else None,
                "events": [e for e in self._events[-last_events:] if e["t_s"] >= first_t],
            }

    def recording(self) -> Recording:
        """A copy of what the ring holds, oldest frame first."""
        with self._lock:
            n = min(self._written, self.capacity)
            order = (np.arange(n) + self._written - n) % self.capacity
            first_t = (self._written - n) * FRAME_S
            versions = set(self._version[order].tolist())
            return Recording(
                frame=self._frame[order],
                t_s=self._t[order],
                sim_t_s=self._sim_t[order],
                phase=self._phase[order],
                qpos=self._qpos[order],
                ocr=self._ocr[order],
                version=self._version[order],
                drive=self._drive[order],
                events=tuple(e for e in self._events if e["t_s"] >= first_t),
                params={v: d for v, d in self._params.items() if v in versions},
                model=self.model,
                boards=tuple(self._boards[i] for i in order.tolist()),
            )
