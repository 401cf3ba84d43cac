"""What every robot's MuJoCo model gets, described or imported (docs/DESIGN.md §3, §7): the
collision groups, the servos as position actuators with their settings, the force sensor zones'
layout, and the sensors the studio reads (IMU, soles, each servo's torque)."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from app.robots.description import RobotDescription
from app.robots.description_parts import LEG_JOINTS
from app.robots.servos import ServoSettings, servo_settings

FLOOR_GROUP, BODY_GROUP = 0, 1


#: the force sensors under each sole: front/back, left/right, as signs of the sole's x and y
FSR_CORNERS = {"fl": (1, 1), "fr": (1, -1), "bl": (-1, 1), "br": (-1, -1)}
FSR_ZONE_M = 0.003  # a sensor's zone: its half height about the sole plane, its margin


def add_fsr_zones(
    foot: mujoco.MjsBody,
    side: str,
    sole_m: list[float],
    plate_m: tuple[float, float],
    sole_rot: np.ndarray | None = None,
    sole_quat: list[float] | None = None,
) -> None:
    """The four force sensors under a sole (docs/DESIGN.md §15), each a box site over its corner
    quadrant of the `plate_m` (length, width) plate whose centre is `sole_m` in the foot body,
    the sole's axes `sole_rot` (default the body's): each reads what a MuJoCo touch sensor on its
    site would, once per frame (`app.sim.sensors`); a zone reaches past the plate's edge, so the
    contacts at its corners lie inside it."""
    half_x, half_y = plate_m[0] / 4 + FSR_ZONE_M, plate_m[1] / 4 + FSR_ZONE_M
    for corner, (sx, sy) in FSR_CORNERS.items():
        offset = [sx * half_x, sy * half_y, 0.0]
        if sole_rot is not None:
            offset = list(sole_rot @ offset)
        site = foot.add_site(
            name=f"{side}_fsr_{corner}",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[a + b for a, b in zip(sole_m, offset, strict=True)],
            size=[half_x, half_y, FSR_ZONE_M],
        )
        if sole_quat is not None:
            site.quat = sole_quat


def joint_settings(robot: RobotDescription) -> dict[str, ServoSettings]:
    """Each joint's servo settings at the robot's supply voltage."""
    return {
        name: servo_settings(
            robot.joint_servo(name), robot.supply_voltage_v, robot.servo_catalogue()
        )
        for name in robot.joints
    }


def collide(geom: mujoco.MjsGeom, robot: RobotDescription, group: int) -> None:
    c = robot.contact
    geom.contype = geom.conaffinity = 1
    geom.condim = c.condim
    geom.friction = [c.friction, c.torsional_friction, c.rolling_friction]
    geom.group = group


def add_actuator(spec: mujoco.MjSpec, robot: RobotDescription, name: str) -> None:
    s = servo_settings(robot.joint_servo(name), robot.supply_voltage_v, robot.servo_catalogue())
    travel = min(math.radians(robot.joint_servo_spec(name).travel_deg) / 2, math.pi / 2)
    act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.set_to_position(kp=s.kp_nm_rad)
    act.forcerange = [-s.stall_torque_nm, s.stall_torque_nm]
    act.ctrlrange = [-travel, travel]


def add_sensors(spec: mujoco.MjSpec) -> None:
    site = mujoco.mjtObj.mjOBJ_SITE
    sensor = mujoco.mjtSensor
    spec.add_sensor(name="imu_gyro", type=sensor.mjSENS_GYRO, objtype=site, objname="imu")
    spec.add_sensor(name="imu_accel", type=sensor.mjSENS_ACCELEROMETER, objtype=site, objname="imu")
    for side in ("l", "r"):
        spec.add_sensor(
            name=f"{side}_sole_pos",
            type=sensor.mjSENS_FRAMEPOS,
            objtype=site,
            objname=f"{side}_sole",
        )
    # each servo's torque (the actuator's force after its limit): the servo budget and the
    # robustness report's servo advice read it from every run, the lanes' too (docs/DESIGN.md §7)
    for joint in (f"{side}_{j}" for side in ("l", "r") for j in LEG_JOINTS):
        spec.add_sensor(
            name=f"{joint}_torque",
            type=sensor.mjSENS_ACTUATORFRC,
            objtype=mujoco.mjtObj.mjOBJ_ACTUATOR,
            objname=joint,
        )
