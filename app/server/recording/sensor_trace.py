"""The Sensors panel's data (docs/DESIGN.md §15): per frame, what the modelled sensors read and
what the feedback laws made of it -- the columns of `app.sim.sensor_channels.CHANNELS` -- over
the last seconds. Fed by the simulation thread; `view()` is an immutable copy for any thread."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import mujoco
import numpy as np

from app.robots.model import RobotModel
from app.sim.frame_record import FrameRecord
from app.sim.sensor_channels import CHANNELS, COLUMNS, FrameSample
from gait.attitude import accel_tilt

WINDOW_FRAMES = 250  # 5 s of 20 ms frames


@dataclass(frozen=True)
class SensorView:
    """The last frames (rows of `COLUMNS`: `CHANNELS`' keys, oldest first), the sole outline and
    the force sensors' places (mm, x forward, y left, from each sole's centre) to draw the CoP
    in. Its columns are made when asked for, in the asker's thread."""

    rows: tuple[tuple[float, ...], ...]
    sole_mm: tuple[float, float]  # half length, half width
    fsr_mm: tuple[tuple[float, float], ...]

    @property
    def columns(self) -> dict[str, list[float | None]]:
        return {name: [_finite(row[i]) for row in self.rows] for i, name in enumerate(COLUMNS)}

    def to_dict(self) -> dict:
        return {"columns": self.columns, "sole_mm": self.sole_mm, "fsr_mm": self.fsr_mm}


def true_tilt_deg(data: mujoco.MjData, imu_site: int) -> tuple[float, float]:
    """(pitch, roll) of the IMU's site as the simulator has it, degrees (what an ideal, level
    mounted accelerometer at rest would give): for the panel only, never for a law."""
    up_in_site = data.site_xmat[imu_site].reshape(3, 3).T @ np.array([0.0, 0.0, 1.0])
    pitch, roll = accel_tilt(up_in_site)
    return float(np.degrees(pitch)), float(np.degrees(roll))


def _finite(value: float) -> float | None:
    return value if np.isfinite(value) else None  # JSON has no NaN


class SensorTrace:
    """The last `WINDOW_FRAMES` frames of sensor readings and law outputs. The simulation
    thread's: `add` and `clear`; `view` makes the copy it publishes."""

    def __init__(self, robot: RobotModel) -> None:
        self.measure(robot)

    def measure(self, robot: RobotModel) -> None:
        """Trace `robot` from now (a switch of robots)."""
        self._imu_site = int(robot.model.site("imu").id)
        geo = robot.description.geometry
        self._sole_mm = (geo.foot_length_m * 500.0, geo.foot_width_m * 500.0)
        self._positions_m = robot.fsr_positions_m.astype(np.float64)
        self._fsr_mm = tuple((float(x * 1e3), float(y * 1e3)) for x, y in self._positions_m)
        self._rows: deque[tuple[float, ...]] = deque(maxlen=WINDOW_FRAMES)

    def clear(self) -> None:
        self._rows.clear()

    def add(self, record: FrameRecord, data: mujoco.MjData) -> None:
        """One frame; a frame without a reading (the loop not watching) adds nothing."""
        reading, out = record.reading, record.feedback
        if reading is None or out is None:
            return
        sample = FrameSample(
            time_s=record.time_s + 0.02,  # read after the frame
            reading=reading,
            out=out,
            true_tilt_deg=true_tilt_deg(data, self._imu_site),
            cop_mm=reading.centre_of_pressure_m(self._positions_m) * 1e3,
        )
        self._rows.append(tuple(channel.take(sample) for channel in CHANNELS))

    def view(self) -> SensorView:
        """A copy of the window (a tuple of the rows: cheap for the simulation thread)."""
        return SensorView(tuple(self._rows), self._sole_mm, self._fsr_mm)
