"""What every robot's MuJoCo model gets, described or imported (docs/DESIGN.md §3, §7): the
collision groups, the servos as position actuators with their settings, the force sensor zones'
layout, and the sensors the studio reads (IMU, soles, each servo's torque)."""

from __future__ import annotations

import math

import mujoco

from app.robots.description import LEG_JOINTS, RobotDescription
from app.robots.servos import ServoSettings, servo_settings

FLOOR_GROUP, BODY_GROUP = 0, 1


#: the force sensors under each sole: front/back, left/right, as signs of the sole's x and y
FSR_CORNERS = {"fl": (1, 1), "fr": (1, -1), "bl": (-1, 1), "br": (-1, -1)}
FSR_ZONE_M = 0.003  # a sensor's zone: its half height about the sole plane, its margin


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
