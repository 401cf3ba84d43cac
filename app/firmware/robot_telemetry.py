"""A linked robot's SENSORS stream to the dashboard (docs/DESIGN.md §15): each frame's fields
that hardware/firmware/wire.py marks, its counts decoded as the firmware decodes them, posted in
batches (`POST /api/sensors/robot`, every FORWARD_S) from a thread of its own, so neither the
port nor the parameter sending waits on the dashboard. A dashboard that does not answer costs
frames (the last WINDOW_FRAMES wait), never the link."""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from app.firmware import protocol as proto
from app.firmware.sensor_feed import RawSample, decoded
from hardware.firmware.wire import SENSORS

FORWARD_S = 0.15  # a batch of about 7 frames
POST_FRAMES = 16  # at most per request (about 7 KiB; the server takes 16)
WINDOW_FRAMES = 250  # what waits while the dashboard does not answer: the last 5 s
POST_TIMEOUT_S = 2.0


def _f32(values: Any) -> list[float]:
    """float32 values as the shortest decimals that read back to them (short JSON)."""
    return [float(str(np.float32(v))) for v in np.ravel(values)]


#: the names of the bits of each SENSORS field the layout marks "bits"
BIT_NAMES = {"status": proto.STATUS_BITS, "laws": proto.LAW_BITS}


def frame_json(sensors: proto.Sensors) -> dict[str, Any] | None:
    """One SENSORS frame as the dashboard takes it, or None if a value is not finite: the fields
    hardware/firmware/wire.py marks for the dashboard, and the raw counts decoded."""
    raw = RawSample(sensors.accel_raw, sensors.gyro_raw, sensors.adc)
    reading = decoded(raw, sensors.gyro_offset)
    frame: dict[str, Any] = {
        "gyro_rad_s": _f32(reading.gyro_rad_s),
        "accel_m_s2": _f32(reading.accel_m_s2),
        "fsr_n": [_f32(sole) for sole in reading.fsr_n],
    }
    numbers: list[float] = []
    for field in SENSORS.fields:
        value = getattr(sensors, field.name)
        if field.dashboard == "value":
            frame[field.name] = value
        elif field.dashboard == "bits":
            frame[field.name] = [name for name, bit in BIT_NAMES[field.name].items() if value & bit]
        elif field.dashboard == "float32":
            frame[field.name] = _f32(value) if field.count > 1 else _f32(value)[0]
            numbers.extend(np.ravel(value))
    return frame if all(math.isfinite(v) for v in numbers) else None


class SensorForwarder:
    """Posts the frames `put` to it to `server` every FORWARD_S on its own thread: `start`,
    `put` (from the port's reader, never blocking), `stop`. Says once when the dashboard stops
    taking them and once when it takes them again."""

    def __init__(self, server: str, log: Callable[[str], None] = print) -> None:
        self.server = server
        self.log = log
        self._pending: deque[dict[str, Any]] = deque(maxlen=WINDOW_FRAMES)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="robot-sensors", daemon=True)
        self._failing: str | None = None
        self.posted = 0  # frames the dashboard took
        self.skipped = 0  # frames with a value that is not finite
        self.refused = 0  # frames the dashboard refused (a 422: not worth sending again)

    def put(self, sensors: proto.Sensors) -> None:
        frame = frame_json(sensors)
        with self._lock:
            if frame is None:
                self.skipped += 1
            else:
                self._pending.append(frame)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def _run(self) -> None:
        import httpx  # ~0.5 s: only to follow a dashboard

        with httpx.Client(base_url=self.server, timeout=POST_TIMEOUT_S) as http:
            while not self._stop.wait(FORWARD_S):
                while self._post_batch(http) and not self._stop.is_set():
                    pass

    def _post_batch(self, http: Any) -> bool:
        """One request of the oldest waiting frames; whether a full batch went (more may wait)."""
        import httpx

        with self._lock:
            batch = [self._pending[i] for i in range(min(POST_FRAMES, len(self._pending)))]
        if not batch:
            return False
        try:
            answer = http.post("/api/sensors/robot", json={"frames": batch})
        except httpx.HTTPError as exc:
            self._say_failing(f"{type(exc).__name__}: {exc}")
            return False
        if answer.status_code not in (200, 422):
            self._say_failing(f"HTTP {answer.status_code}")
            return False
        if answer.status_code == 422:
            named = _frames_named(answer, len(batch))
            if not named:
                self._drop(batch)
                self.refused += len(batch)
                self._say_failing(f"refused: {_message(answer)[:200]}")
                return False
            self._drop([batch[i] for i in named])  # the others go again at once
            if self.refused == 0:
                self.log(
                    f"the dashboard refused the robot's sensor frame {batch[named[0]]['frame']} "
                    f"({_message(answer)[:200]}); such frames are left out and counted"
                )
            self.refused += len(named)
            return True
        self._drop(batch)
        self.posted += len(batch)
        if self._failing is not None:
            self._failing = None
            self.log("the dashboard takes the robot's sensors again")
        return len(batch) == POST_FRAMES

    def _drop(self, frames: list[dict[str, Any]]) -> None:
        """Forget these frames (sent, or refused) wherever they still wait: the reader may have
        pushed some out meanwhile."""
        gone = {id(frame) for frame in frames}
        with self._lock:
            kept = [frame for frame in self._pending if id(frame) not in gone]
            self._pending.clear()
            self._pending.extend(kept)

    def _say_failing(self, why: str) -> None:
        if self._failing is None:
            self.log(
                f"the dashboard at {self.server} did not take the robot's sensors ({why}); "
                "the link goes on and tries again"
            )
        self._failing = why


def _message(answer: Any) -> str:
    try:
        return str(answer.json().get("message", answer.text))
    except (ValueError, AttributeError):
        return answer.text


def _frames_named(answer: Any, count: int) -> list[int]:
    """The frames of a batch of `count` that a 422 names (its items' loc: body, frames, i, ...);
    [] when it names none (then the batch as a whole was refused)."""
    try:
        items = answer.json()["detail"]
        named = {
            item["loc"][2]
            for item in items
            if list(item["loc"][:2]) == ["body", "frames"] and len(item["loc"]) > 2
        }
    except (ValueError, KeyError, TypeError, IndexError):
        return []
    if not all(isinstance(i, int) and 0 <= i < count for i in named):
        return []
    return sorted(named)
