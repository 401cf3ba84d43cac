"""The identification routine played in simulation (docs/FIT.md): each frame's commanded
set-points and what the sensors read after it, on a robot varied by a `Variation`; what
`artro run --script identify --record` writes and what the fit compares with a recording."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from app.analysis.identify_routine import Segment, segment_params
from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.worlds.variations import NOMINAL, Variation
from gait import GaitParams, Motion


@dataclass
class Traces:
    """Per frame (n frames): commanded set-points (n, 12) rad, gyro (n, 3) rad/s and
    accelerometer (n, 3) m/s² in the IMU's axes, foot forces (n, 8) N (left then right, front-
    left, front-right, back-left, back-right), the joints' angles (n, 12) rad, the trunk's x, y
    (m) and yaw (rad) (n, 3); `fell_frame` the frame the robot fell in (None: it stood);
    `index` each row's frame in the routine (None: every frame, in order; a recording from the
    link may lack some, docs/FIT.md); `effort` each servo's |torque| over its limit (n, 12), a
    simulated replay's only (None: a recording's)."""

    commanded: NDArray[np.float64]
    gyro: NDArray[np.float64]
    accel: NDArray[np.float64]
    fsr: NDArray[np.float64]
    joints: NDArray[np.float64]
    pose: NDArray[np.float64]
    fell_frame: int | None = None
    index: NDArray[np.int64] | None = None
    effort: NDArray[np.float64] | None = None

    @property
    def frames(self) -> int:
        return len(self.gyro)

    @property
    def positions(self) -> NDArray[np.int64]:
        """Each row's frame in the routine."""
        return np.arange(self.frames) if self.index is None else self.index

    def at(self, rows: NDArray[np.int64]) -> Traces:
        """The rows `rows` (positions into these traces), their frames kept in `index`."""
        cut = {f: getattr(self, f)[rows] for f in CHANNELS}
        effort = None if self.effort is None else self.effort[rows]
        return dataclasses.replace(self, **cut, index=self.positions[rows], effort=effort)


CHANNELS = ("commanded", "gyro", "accel", "fsr", "joints", "pose")


def play(
    robot: RobotModel,
    params: GaitParams,
    routine: tuple[Segment, ...],
    variation: Variation = NOMINAL,
    *,
    sensor_errors: bool = True,
    lengths: list[int] | None = None,
) -> Traces:
    """Play `routine` from standing on `robot` varied by `variation`; the sensors read with the
    variation's errors (bias, noise, delay) unless `sensor_errors` is False (the fit's replay:
    it fits those in closed form, `app.analysis.fit_sensors`). `lengths`: each segment's frames
    as a recording has them (a robot on the link switches where its ACK said; default the
    routine's). A fall ends the physics; the frames after it repeat the last reading, as a robot
    lying still would."""
    lengths = lengths or [s.frames for s in routine]
    n = sum(lengths)
    sim = FrameLoop(
        robot,
        params=segment_params(params, routine[0]),
        motion=routine[0].motion,
        start_motion=Motion(),
        variation=variation if sensor_errors else variation.physics,
    )
    sim.watch_sensors = True
    commanded, gyro, accel, fsr, joints, pose = (np.zeros((n, k)) for k in (12, 3, 3, 8, 12, 3))
    effort = np.zeros((n, 12))
    out = Traces(commanded, gyro, accel, fsr, joints, pose, effort=effort)
    actuators = robot.actuator_ids
    limit = np.abs(sim.model.actuator_forcerange[actuators, 1])
    frame = 0
    for segment, length in zip(routine, lengths, strict=True):
        if frame:
            sim.set_gait(params=segment_params(params, segment), motion=segment.motion)
        for _ in range(length):
            if out.fell_frame is None:
                record = sim.step_frame()
                reading = record.reading
                assert reading is not None  # watch_sensors
                out.commanded[frame] = record.setpoint
                out.gyro[frame] = reading.gyro_rad_s
                out.accel[frame] = reading.accel_m_s2
                out.fsr[frame] = np.asarray(reading.fsr_n).reshape(8)
                out.joints[frame] = sim.data.qpos[robot.qpos_adr]
                out.pose[frame] = sim.trunk_pose()
                effort[frame] = np.abs(sim.data.actuator_force[actuators]) / limit
                if sim.fell:
                    out.fell_frame = frame
            else:
                for trace in (out.commanded, out.gyro, out.accel, out.fsr, out.joints, out.pose):
                    trace[frame] = trace[frame - 1]
                effort[frame] = 0.0  # lying still
            frame += 1
    return out
