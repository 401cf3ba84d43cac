"""Eq (1) of seed 000 on a robot description: each joint's static load, swing and stance,
standing and over the gait's poses, times (1 + sf) against its servo's stall torque; a servo too
weak gets a warning with the numbers (docs/DESIGN.md §7 says how the load is computed)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from app.robots.builder import build_model, joint_settings
from app.robots.description import RobotDescription, mass_tolerance_kg
from gait import JOINT_NAMES, GaitParams, LegGeometry, Motion, joint_angles_with_flags
from hardware import SAFETY_FACTOR

GAIT_CASES = (Motion(), Motion(a_p=0.07), Motion(a_r=0.1), Motion(a_y=0.2))  # seed 000's table
PHASES = 64  # poses per gait cycle


@dataclass(frozen=True)
class JointTorque:
    """Eq (1) for one joint: the load torque standing and at the gait's worst pose."""

    joint: str
    servo: str
    stall_torque_nm: float
    standing_nm: float  # gravity torque of the worse of stance and swing, standing
    gait_worst_nm: float  # the same at the gait's worst pose
    required_nm: float  # (1 + sf) x the larger of the two
    margin: float  # 1 - required / stall: < 0 means the servo is too weak

    def to_dict(self) -> dict[str, float | str]:
        return dict(self.__dict__)

    def warning(self) -> str | None:
        if self.margin >= 0:
            return None
        return (
            f"{self.joint}: the {self.servo} stalls at {self.stall_torque_nm:.3f} N·m, eq (1) "
            f"asks {self.required_nm:.3f} N·m ((1 + {SAFETY_FACTOR:g}) x "
            f"{max(self.standing_nm, self.gait_worst_nm):.3f} N·m of load, "
            f"{'standing' if self.standing_nm >= self.gait_worst_nm else 'walking'}): "
            f"{-self.margin:.0%} short"
        )


def _gravity_torques(
    model: mujoco.MjModel, data: mujoco.MjData, half_foot_m: tuple[float, float]
) -> np.ndarray:
    """Per leg joint, the larger of its swing and stance load about its axis, N·m (see the
    module docstring); `data` has kinematics and subtree COMs computed."""
    g = -model.opt.gravity[2]
    trunk = model.body("trunk").id
    weight = np.array([0.0, 0.0, float(model.body_subtreemass[trunk]) * g])
    com = data.subtree_com[trunk]
    out = np.empty(len(JOINT_NAMES))
    for i, name in enumerate(JOINT_NAMES):
        joint = model.joint(name)
        body = int(joint.bodyid[0])
        axis, anchor = data.xaxis[joint.id], data.xanchor[joint.id]
        below = float(model.body_subtreemass[body]) * np.array([0.0, 0.0, -g])
        swing = axis @ np.cross(data.subtree_com[body] - anchor, below)
        sole = data.site(f"{name[0]}_sole")
        frame = sole.xmat.reshape(3, 3)
        local = frame[:, :2].T @ (com - sole.xpos)  # the COM over the sole, in the sole's x, y
        held = np.clip(local, -np.asarray(half_foot_m), np.asarray(half_foot_m))
        pressure = sole.xpos + frame[:, :2] @ held
        stance = abs(axis @ np.cross(pressure - anchor, weight) + swing)
        out[i] = max(abs(swing), stance)
    return out


def eq1_torques(robot: RobotDescription, params: GaitParams | None = None) -> list[JointTorque]:
    """Eq (1) on every joint of `robot` for the gait `params` (default: the worse of the gaits
    the robot is checked for, the paper's and its default preset's: `walked_gaits`)."""
    gaits = [params] if params is not None else [g for _, g in robot.walked_gaits()]
    model = build_model(robot)
    data = mujoco.MjData(model)
    geometry = LegGeometry(upper_m=robot.geometry.thigh_m, lower_m=robot.geometry.shank_m)
    qpos_adr = [int(model.joint(n).qposadr[0]) for n in JOINT_NAMES]
    half_foot = (robot.geometry.foot_length_m / 2, robot.geometry.foot_width_m / 2)

    def load_at(pose: np.ndarray) -> np.ndarray:
        data.qpos[:] = model.qpos0
        data.qpos[qpos_adr] = pose
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        return _gravity_torques(model, data, half_foot)

    standing = load_at(np.zeros(len(JOINT_NAMES)))
    phases = np.linspace(-np.pi, np.pi, PHASES, endpoint=False)
    walking = np.zeros(len(JOINT_NAMES))
    for gait in gaits:
        for motion in GAIT_CASES:
            for pose in joint_angles_with_flags(gait, motion, phases, geometry).values:
                walking = np.maximum(walking, load_at(pose))
    settings = joint_settings(robot)
    out = []
    for i, name in enumerate(JOINT_NAMES):
        stall = settings[name].stall_torque_nm
        required = (1 + SAFETY_FACTOR) * max(standing[i], walking[i])
        out.append(
            JointTorque(
                joint=name,
                servo=settings[name].name,
                stall_torque_nm=stall,
                standing_nm=float(standing[i]),
                gait_worst_nm=float(walking[i]),
                required_nm=float(required),
                margin=float(1.0 - required / stall),
            )
        )
    return out


def robot_warnings(
    robot: RobotDescription,
    params: GaitParams | None = None,
    torques: Sequence[JointTorque] | None = None,
) -> list[str]:
    """What a builder should know before walking `robot` (it walks all the same): servos too
    weak by eq (1), figures interpolated between datasheet voltages, a stated total mass that
    differs from the parts' (within the tolerance, or it would be refused). `params`: as for
    `eq1_torques`; `torques`: its result, where the caller has it (~0.6 s a robot)."""
    torques = eq1_torques(robot, params) if torques is None else torques
    warnings = [w for t in torques if (w := t.warning())]
    parts = robot.parts_mass_kg()
    if robot.total_mass_kg is not None and abs(robot.total_mass_kg - parts) >= 0.0005:
        warnings.append(
            f"total_mass_kg: the stated {robot.total_mass_kg:.3f} kg is "
            f"{1000 * (robot.total_mass_kg - parts):+.0f} g from the parts' {parts:.3f} kg "
            f"(allowed ±{1000 * mass_tolerance_kg(parts):.0f} g); the model carries the parts: "
            f"add what is missing (wires, screws) to a link's parts to carry it where it is"
        )
    interpolated: dict[tuple[str, float], list[str]] = {}
    for name, s in joint_settings(robot).items():
        if s.interpolated:
            interpolated.setdefault((s.name, s.voltage_v), []).append(name)
    for (servo, volts), joints in interpolated.items():  # every joint named, once per servo
        warnings.append(
            f"joints {', '.join(joints)}: the {servo}'s figures at {volts:g} V are "
            f"interpolated between the datasheet's voltages"
        )
    return warnings
