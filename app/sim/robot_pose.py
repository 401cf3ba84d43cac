"""The robot's pose as the frame loop and the evaluators read and set it (docs/DESIGN.md §2):
standing it on the floor (`stand`), the trunk's heading, the distance between the soles and the
fall test, each one state or many with the same arithmetic."""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots.model import RobotModel
from app.sim.sensors import rest_accelerometers
from gait import GaitParams, Motion, joint_angles_with_flags, startup_gain

FALL_HEIGHT_FRACTION = 0.6  # fallen: trunk below 60 % of its standing height ...
FALL_TILT_RAD = math.radians(50.0)  # ... or tilted more than 50 degrees


def trunk_yaw(quat_wxyz: NDArray[np.float64]) -> float:
    """Heading of the trunk (counter-clockwise) from its orientation quaternion."""
    w, x, y, z = quat_wxyz
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def trunk_yaws(quats_wxyz: NDArray[np.float64]) -> list[float]:
    """`trunk_yaw` of each row of (n, 4) quaternions, to the bit: the same float arithmetic in
    whole arrays, then `math.atan2` per row."""
    w, x, y, z = quats_wxyz.T
    along = 2.0 * (w * z + x * y)
    across = 1.0 - 2.0 * (y * y + z * z)
    return list(map(math.atan2, along.tolist(), across.tolist()))


def has_fallen(
    qpos: NDArray[np.float64], standing_height_m: float | NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Trunk below 60 % of its standing height, or tilted more than 50 degrees; qpos may be one
    state (nq,) or many (..., nq), with the same arithmetic either way."""
    up_z = 1.0 - 2.0 * (qpos[..., 4] ** 2 + qpos[..., 5] ** 2)  # trunk z axis, world z part
    return (qpos[..., 2] < FALL_HEIGHT_FRACTION * standing_height_m) | (
        up_z < math.cos(FALL_TILT_RAD)
    )


def planar_distance_m(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance in the ground plane between points (..., >= 2), elementwise arithmetic only, so
    one point pair and many give the same bits."""
    dx, dy = a[..., 0] - b[..., 0], a[..., 1] - b[..., 1]
    return np.sqrt(dx * dx + dy * dy)


def sole_distance_m(data: mujoco.MjData) -> float:
    """Distance between the sole centres in the ground plane (the differential drive's b), from
    the site positions MuJoCo last computed."""
    return float(planar_distance_m(data.site("l_sole").xpos, data.site("r_sole").xpos))


def stand(
    robot: RobotModel, data: mujoco.MjData, params: GaitParams, motion: Motion, phase: float
) -> NDArray[np.float64]:
    """Reset `data` and stand the robot on the floor in the gait's pose of `motion` at `phase`
    (start-up gain at time 0), feet flat, at rest, each servo's set-point on its angle, the IMU
    reading as at rest there (`rest_accelerometers`); returns the pose. `data` is the scratch
    for the standing height first: no MjData is made."""
    pose = joint_angles_with_flags(
        params, motion, phase, robot.geometry, startup=startup_gain(params, 0.0)
    ).values
    height = robot.standing_height_m(pose, scratch=data)
    mujoco.mj_resetData(robot.model, data)
    data.qpos[robot.qpos_adr] = pose
    data.qpos[2] = height + 1e-4
    data.ctrl[robot.actuator_ids] = pose
    mujoco.mj_forward(robot.model, data)
    rest_accelerometers(robot.model, data)
    return pose
