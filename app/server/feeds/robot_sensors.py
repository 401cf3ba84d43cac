"""A linked robot's balance sensors beside the simulation's (docs/DESIGN.md §15): the SENSORS
frames that `artro link` reads off the robot's port, decodes and forwards (`POST
/api/sensors/robot`), kept for 5 s in a ring of their own with when they last arrived. Data
from outside: the simulation thread never sees it; any thread may add or read, under a lock."""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.server.recording.sensor_trace import WINDOW_FRAMES
from app.sim.planning import FRAME_S
from app.sim.sensor_channels import ROBOT_CHANNELS, ROBOT_OUTPUT_FIELDS, robot_sample
from app.sim.sensors import SensorReading

FRESH_S = 2.0  # frames older than this: no robot linked
#: the columns of the robot's view: the channels its frames carry (app/sim/sensor_channels.py),
#: named as the simulation's, its own frame number after the time
COLUMNS: tuple[str, ...] = (
    ROBOT_CHANNELS[0].key,
    "frame",
    *(channel.key for channel in ROBOT_CHANNELS[1:]),
)


@dataclass(frozen=True)
class RobotFrame:
    """One SENSORS frame as the link decoded it (app/firmware/sensor_feed.py `decoded`)."""

    frame: int  # the robot's frame (20 ms each since its reset) the laws corrected
    status: tuple[str, ...]  # the names of protocol.STATUS_BITS set
    imu_failures: int  # failed IMU reads since boot (255: at least)
    laws: tuple[str, ...]  # the names of protocol.LAW_BITS set
    support: int  # 0 left, 1 right, -1 neither
    attitude_rad: tuple[float, float]  # pitch, roll estimate
    gyro_rad_s: tuple[float, float, float]  # after the boot calibration
    accel_m_s2: tuple[float, float, float]
    fsr_n: tuple[tuple[float, ...], tuple[float, ...]]  # left sole fl, fr, bl, br; right sole
    tilt_rad: tuple[float, float]
    a_y_delta: float
    cop_rad: tuple[float, float]


def frame_row(frame: RobotFrame, positions_m: NDArray[np.float64]) -> tuple[float | None, ...]:
    """`frame` as a row of COLUMNS, each channel taken as the trace takes it; each sole's centre
    of pressure from the force sensors' places `positions_m` (4, 2: the dashboard's robot), None
    for a sole that carries nothing."""
    reading = SensorReading(
        np.asarray(frame.gyro_rad_s), np.asarray(frame.accel_m_s2), np.asarray(frame.fsr_n)
    )
    sent = {name: getattr(frame, name) for name in ROBOT_OUTPUT_FIELDS}
    cop_mm = reading.centre_of_pressure_m(positions_m) * 1e3
    sample = robot_sample(frame.frame * FRAME_S, reading, sent, cop_mm)
    time_s, *values = (channel.take(sample) for channel in ROBOT_CHANNELS)
    return (time_s, float(frame.frame), *(None if math.isnan(v) else v for v in values))


class RobotSensors:
    """The last WINDOW_FRAMES frames of the linked robot, oldest first, in its frame order."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._rows: deque[tuple[float | None, ...]] = deque(maxlen=WINDOW_FRAMES)
        self._last: RobotFrame | None = None
        self._arrived = -np.inf  # time.monotonic() of the last frame taken
        self._received = 0

    def add(
        self,
        frames: list[RobotFrame],
        positions_m: NDArray[np.float64],
        now: float | None = None,
    ) -> int:
        """Take `frames` (in the robot's order); how many were new. A frame the ring holds
        already (a batch posted again) is skipped; one far behind the last (the robot started
        over) empties the ring first."""
        rows = [(f, frame_row(f, positions_m)) for f in frames]  # outside the lock
        taken = 0
        with self._lock:
            for frame, row in rows:
                last = None if self._last is None else self._last.frame
                if last is not None and frame.frame <= last:
                    if frame.frame > last - WINDOW_FRAMES:
                        continue  # held already
                    self._rows.clear()  # started over
                self._rows.append(row)
                self._last = frame
                taken += 1
            if taken:
                self._arrived = time.monotonic() if now is None else now
                self._received += taken
        return taken

    def view(self, now: float | None = None) -> dict[str, Any] | None:
        """The window's columns and the last frame's status, or None when no frame arrived in
        the last FRESH_S (no robot linked)."""
        now = time.monotonic() if now is None else now
        with self._lock:
            age = now - self._arrived
            if age > FRESH_S or self._last is None:
                return None
            rows, last, received = tuple(self._rows), self._last, self._received
        return {
            "columns": {name: [row[i] for row in rows] for i, name in enumerate(COLUMNS)},
            "received_s_ago": round(age, 3),
            "frames_received": received,
            "frame": last.frame,
            "status": list(last.status),
            "imu_failures": last.imu_failures,
            "laws": list(last.laws),
            "support": last.support,
        }
