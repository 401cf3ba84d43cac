"""What the simulation thread publishes for every other thread: a `SimStatus`, copies of the
body poses (`BodyPoses`), the A/B ghost's `GhostStatus`, the servo load report and the sensors'
last frames (`SensorView`); each a frozen snapshot replaced whole, never the live MjData
(docs/DESIGN.md §10)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots.model import RobotModel
from app.server.recording.sensor_trace import SensorView
from app.server.sim.emulated_controller import FirmwareStatus
from app.server.sim.ghost import GhostStatus
from app.server.sim.live_robot import Drive
from app.sim.servo_load import ServoLoadMeter, ServoLoadReport

LOAD_PUBLISH_FRAMES = 25  # the servo load budget is published twice a second
GHOST_PUBLISH_FRAMES = 10  # the ghost's metrics five times a second
SENSORS_PUBLISH_FRAMES = 10  # the Sensors panel's window five times a second
SENSORS_WATCHED_S = 2.0  # the live loop reads its sensors this long after they were asked for


@dataclass(frozen=True)
class TrunkPose:
    x_m: float
    y_m: float
    z_m: float
    yaw_rad: float  # counter-clockwise


@dataclass(frozen=True)
class PushMark:
    """The last push (the dashboard's Push): when, how hard, which way in the world, where."""

    sim_time_s: float
    impulse_n_s: float
    direction_deg: float  # in the world, counter-clockwise from +x
    x_m: float
    y_m: float
    z_m: float
    #: as the Push control gives it: counter-clockwise from where the robot faced (0 forward,
    #: 90 to its left), over -180 to 180 (the fall notice names the push by it: issue 56, item 17)
    toward_deg: float = 0.0


@dataclass(frozen=True)
class LatencySummary:
    """Frames from a change entering the store to the first frame built with it."""

    count: int = 0
    median: int | None = None
    max: int | None = None

    @classmethod
    def of(cls, frames: Iterable[int]) -> LatencySummary:
        ordered = sorted(frames)
        if not ordered:
            return cls()
        return cls(len(ordered), ordered[len(ordered) // 2], ordered[-1])


@dataclass(frozen=True)
class SimStatus:
    """What the simulation thread published last; any thread may read it (immutable)."""

    sim_time_s: float = 0.0
    frame: int = 0
    rtf: float | None = None  # simulated / wall time over the last RTF_WINDOW_S, None: no window
    speed: float = 1.0
    paused: bool = False
    fell: bool = False
    behind: bool = False
    frames_dropped: int = 0
    trunk: TrunkPose = TrunkPose(0.0, 0.0, 0.0, 0.0)
    params_version_applied: int = 0
    param_latency_frames: LatencySummary = LatencySummary()
    resets: int = 0
    errors: tuple[str, ...] = ()
    drive: str = Drive.MODEL.value  # which pulses move the servos
    firmware: FirmwareStatus | None = None  # while the firmware drive is on
    gait_ramp: float | None = None  # how far a change of gait constants has come (0..1), if so
    world: str = "nominal"  # the variation the robot walks in, as `artro run --vary` takes it
    robot: str = ""  # the robot simulated (the store's version in use names it)
    push: PushMark | None = None  # the last push since the last reset

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self) | {"errors": list(self.errors)}


@dataclass(frozen=True)
class BodyPoses:
    """A copy of the bodies' world poses for the 3D view (never the live MjData)."""

    serial: int
    xpos: np.ndarray
    xmat: np.ndarray
    ghost_xpos: np.ndarray | None = None  # the A/B ghost's bodies, when there is one
    ghost_xmat: np.ndarray | None = None
    model: mujoco.MjModel | None = None  # the robot's model they are poses of


class Bulletin:
    """The snapshots last published. Only the simulation thread writes, each replaced whole by
    one assignment; any thread reads."""

    def __init__(self, status: SimStatus, robot: RobotModel) -> None:
        self.status = status
        self.poses: BodyPoses | None = None
        self.ghost: GhostStatus | None = None  # None: no ghost
        self.sensors: SensorView | None = None  # the Sensors panel's last frames
        self.sensors_asked_at = -1e9  # monotonic time a reader last asked for them
        self.publish_poses = False  # set by the 3D view, the only reader of body poses
        self._pose_serial = 0
        self._load_meter = ServoLoadMeter(robot)  # the servo budget of the current gait
        self.servo_load: ServoLoadReport = self._load_meter.report()

    def publish_body_poses(
        self, model: mujoco.MjModel, live: mujoco.MjData, ghost: mujoco.MjData | None
    ) -> None:
        """Copies of the live robot's (and the ghost's) body poses, with the `model` they are
        poses of: made only when a view exists."""
        if not self.publish_poses:
            return
        self._pose_serial += 1
        self.poses = BodyPoses(
            self._pose_serial,
            live.xpos.copy(),
            live.xmat.copy(),
            None if ghost is None else ghost.xpos.copy(),
            None if ghost is None else ghost.xmat.copy(),
            model,
        )

    # --- the servo load: measured every frame, published twice a second ---------------------------

    def measure_load_of(self, robot: RobotModel) -> None:
        """Measure `robot`'s servos from now (a switch of robots)."""
        self._load_meter = ServoLoadMeter(robot)
        self.servo_load = self._load_meter.report()

    def clear_load(self) -> None:
        """The budget belongs to one gait, from a reset on."""
        self._load_meter.clear()

    def add_load(
        self, data: mujoco.MjData, saturated_servos: NDArray[np.bool_], frame_index: int
    ) -> None:
        self._load_meter.add(data, saturated_servos)
        if frame_index % LOAD_PUBLISH_FRAMES == 0:
            self.servo_load = self._load_meter.report()
