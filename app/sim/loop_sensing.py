"""A frame loop's sensors and laws (docs/DESIGN.md §15): the variation's sensors, the sensor rows
of the last physics steps their delay reaches back to, and the laws' state carried from frame to
frame; read and stepped once a frame by `app.sim.frame_loop.FrameLoop`."""

from __future__ import annotations

from collections import deque

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots.model import RobotModel
from app.sim.planning import FRAME_S
from app.sim.sensors import SensorReading, Sensors
from app.worlds.variations import Variation
from gait import GaitParams, Motion, feedback


class LoopSensing:
    """`robot`'s sensors with `variation`'s errors, read anew from here (their noise too), the
    rows they need filled with `data` as it is; the laws' `state` carried on (a fresh one by
    default)."""

    def __init__(
        self,
        robot: RobotModel,
        variation: Variation,
        data: mujoco.MjData,
        state: feedback.State | None = None,
    ) -> None:
        self.sensors = Sensors(robot, variation)
        self.state = feedback.State() if state is None else state
        self._data = data
        self.rows: deque[NDArray[np.float64]] = deque(maxlen=self.sensors.steps_needed)
        self.rows_as_now()

    def rows_as_now(self) -> None:
        """Every sensor row the IMU's delay reaches back to: the sensors as they read now."""
        self.rows.extend([self._data.sensordata.copy()] * self.sensors.steps_needed)

    def keep_row(self) -> None:
        """The sensor row of the physics step just done."""
        self.rows.append(self._data.sensordata.copy())

    def restart(self, current: bool) -> None:
        """Another set of laws is on from the next frame: they start anew, as the firmware's
        (`feedback.restarted`). The attitude estimate is kept where it is `current` (a law was
        on or the sensors watched); else the rows, not read meanwhile, are filled with the state
        as it is and the estimate starts from them."""
        if current:
            self.state = feedback.restarted(self.state)
            return
        self.rows_as_now()
        self.state = feedback.State()

    def read_and_step(
        self,
        params: GaitParams,
        motion_now: Motion,
        fsr_positions_m: NDArray[np.float32],
        phase_rad: float,
    ) -> tuple[SensorReading, feedback.Output]:
        """The sensors read now, and the laws' step on that reading (their state carried on)."""
        reading = self.sensors.read(np.array(self.rows), self._data)
        self.state, out = feedback.step(
            params, self.state, reading.for_laws(), motion_now, fsr_positions_m, FRAME_S,
            phase_rad=phase_rad,
        )  # fmt: skip
        return reading, out
