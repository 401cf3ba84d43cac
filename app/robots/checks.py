"""Eq (1) of seed 000 on a robot description: each joint's static load, swing and stance,
standing and over the gait's poses, times (1 + sf) against its servo's stall torque; a servo too
weak gets a warning with the numbers (docs/DESIGN.md §7 says how the load is computed)."""

from __future__ import annotations

import math
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


def _walking_poses(robot: RobotDescription, gaits: Sequence[GaitParams]) -> np.ndarray:
    """Every pose (poses x 12 joint angles) of each paper case in each of `gaits`, PHASES a
    cycle."""
    geometry = LegGeometry(upper_m=robot.geometry.thigh_m, lower_m=robot.geometry.shank_m)
    phases = np.linspace(-np.pi, np.pi, PHASES, endpoint=False)
    return np.concatenate(
        [
            np.asarray(joint_angles_with_flags(gait, motion, phases, geometry).values)
            for gait in gaits
            for motion in GAIT_CASES
        ]
    )


def _loads(robot: RobotDescription, model: mujoco.MjModel, poses: np.ndarray) -> np.ndarray:
    """Each joint's static load (the larger of swing and stance) at each of `poses`, N·m."""
    data = mujoco.MjData(model)
    qpos_adr = [int(model.joint(n).qposadr[0]) for n in JOINT_NAMES]
    half_foot = (robot.geometry.foot_length_m / 2, robot.geometry.foot_width_m / 2)
    out = np.empty((len(poses), len(JOINT_NAMES)))
    for k, pose in enumerate(poses):
        data.qpos[:] = model.qpos0
        data.qpos[qpos_adr] = pose
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        out[k] = _gravity_torques(model, data, half_foot)
    return out


def eq1_torques(robot: RobotDescription, params: GaitParams | None = None) -> list[JointTorque]:
    """Eq (1) on every joint of `robot` for the gait `params` (default: the worse of the gaits
    the robot is checked for, the paper's and its default preset's: `walked_gaits`)."""
    gaits = [params] if params is not None else [g for _, g in robot.walked_gaits()]
    model = build_model(robot)
    standing = _loads(robot, model, np.zeros((1, len(JOINT_NAMES))))[0]
    walking = np.maximum(_loads(robot, model, _walking_poses(robot, gaits)).max(axis=0), 0.0)
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


@dataclass(frozen=True)
class Lighter:
    """`lighter_parts`' answer: which parts are scaled ("trunk", or "trunk and links": every
    part but the servos), their mass now and at most, kg, and the robot's mass then."""

    parts: str
    now_kg: float
    most_kg: float
    robot_kg: float


def parts_mass(robot: RobotDescription, links: bool) -> float:
    """The mass of the trunk's parts (and with `links` the links' parts of both legs), kg."""
    trunk = sum(p.mass_kg for p in robot.trunk)
    return trunk + (2 * sum(p.mass_kg for ps in robot.links.values() for p in ps) if links else 0)


def with_parts_mass(robot: RobotDescription, kg: float, links: bool) -> RobotDescription:
    """`robot` with its trunk's parts (and with `links` its links' too) scaled alike to `kg`
    in all (`parts_mass`); a stated total mass moved with them."""
    now = parts_mass(robot, links)
    scale = kg / now
    data = robot.model_dump(mode="json")
    for part in data["trunk"]:
        part["mass_kg"] *= scale
    for parts in data["links"].values() if links else ():
        for part in parts:
            part["mass_kg"] *= scale
    if robot.total_mass_kg is not None:
        data["total_mass_kg"] = robot.total_mass_kg + kg - now
    return RobotDescription.model_validate(data)


def _carried(
    robot: RobotDescription, kg: float, links: bool, poses: np.ndarray, stall: np.ndarray
) -> bool:
    """Whether eq (1) holds at `poses` on every joint (`stall`) with the parts at `kg`."""
    r = with_parts_mass(robot, kg, links)
    need = (1 + SAFETY_FACTOR) * _loads(r, build_model(r), poses).max(axis=0)
    return bool((need <= stall).all())


def lighter_parts(robot: RobotDescription, torques: Sequence[JointTorque]) -> Lighter | None:
    """How light the robot would have to be for eq (1) to hold on every joint with the servos
    it has (`torques`: its `eq1_torques`): its trunk's parts scaled alike (the upper body, the
    boards, the battery), or where a trunk of no mass is not enough, every part but the servos,
    to the gram below; None where none is short or where the servos' own mass alone leaves a
    joint short. The search takes the worst poses; the answer is checked on every pose."""
    if all(t.margin >= 0 for t in torques):
        return None
    stall = np.array([t.stall_torque_nm for t in torques])
    gaits = [g for _, g in robot.walked_gaits()]
    every = np.concatenate([np.zeros((1, len(JOINT_NAMES))), _walking_poses(robot, gaits)])

    def worst(r: RobotDescription) -> np.ndarray:
        return every[np.unique(_loads(r, build_model(r), every).argmax(axis=0))]

    for links in (False, True):
        now = parts_mass(robot, links)
        least = now / 1000 if links else 0.0  # a foot weighs something (MuJoCo's bodies do)
        poses = np.concatenate([worst(robot), worst(with_parts_mass(robot, least, links))])

        if not _carried(robot, least, links, poses, stall):
            continue  # short at the worst poses with none of these parts' mass: at every pose
        low, high = least, now  # carried at low, not at high (a joint is short now)
        for _ in range(4):  # the worst poses move a little with the mass: check on all
            while high - low > 0.0005:
                middle = (low + high) / 2
                low, high = (
                    (middle, high)
                    if _carried(robot, middle, links, poses, stall)
                    else (low, middle)
                )
            grams = math.floor(low * 1000) / 1000
            found = with_parts_mass(robot, grams, links)
            if all(t.margin >= 0 for t in eq1_torques(found)):
                what = "trunk and links" if links else "trunk"
                return Lighter(what, now, grams, found.parts_mass_kg())
            poses = np.concatenate([poses, worst(found)])
            low, high = least, grams
    return None


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
