"""How a CAD biped's joints map onto the gait, from its zero pose's geometry, never from names
or frames (docs/DESIGN.md §16): the legs end farthest below the centre of mass, up runs from
soles to hips, forward is where the toes (or knees) say; each leg's six hinges classified by
axis in chain order, with the sign and zero offset of docs/DESIGN.md §3's angles. What the
gait cannot drive is refused (`ImportRefused`), naming the joint and the number."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from app.robots.cad_geometry import (
    Frame,
    Vec,
    axis_line,
    element_name,
    joint_name,
    lowest,
    quat_of,
    unit,
)
from app.robots.cad_leg_joints import (
    SOLE_BAND_M,
    FootMap,
    JointMap,
    crossing,
    foot_map,
    leg_joints,
)
from app.robots.cad_legs import (
    ImportRefused,
    Leg,
    body_name,
    check_closed_chains,
    check_mirror,
    check_third_leg,
    find_legs,
    foot_points,
    link_masses,
)
from app.robots.description_parts import LEG_JOINTS

#: the sole's centre this far ahead of (or behind) the ankle tells where the toes are
TOE_OFFSET_MIN_M = 0.003
#: a knee bends one way when one end of its range is this many times the other's magnitude
KNEE_BEND_RATIO = 1.5


@dataclass
class Mapping:
    """What the import found: the root body and how it turns into the trunk's frame, the 12
    joints, the feet, what is held rigid and the leg geometry."""

    root_body: str
    trunk_quat: tuple[float, float, float, float]  # the root body's frame in the trunk's
    joints: dict[str, JointMap]
    feet: dict[str, FootMap]
    held: list[str]
    geometry: dict[str, float]
    link_masses_kg: dict[str, float]
    forward_from: str  # what told the front: "toes", "knees" or "given" (--forward)
    sites: dict[str, tuple[str, tuple[float, float, float]]]  # l_hip, l_ankle, ...: body, pos
    notes: list[str] = field(default_factory=list)


def map_model(model: mujoco.MjModel, root: int, forward: str | None = None) -> Mapping:
    """The mapping of the compiled file `model` (its root body `root` welded where the file put
    it, every joint at its reference), or ImportRefused."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    frame = Frame(data.xpos[root].copy(), data.xmat[root].reshape(3, 3).copy())
    legs = find_legs(model, data, root, frame)
    feet_points = {id(leg): foot_points(model, data, leg.foot, frame) for leg in legs}
    com = frame.point(data.subtree_com[root])
    hips = [crossing(model, data, frame, leg, 1, 2, "hip roll", "hip pitch") for leg in legs]
    down0 = unit(np.mean([feet_points[id(leg)].mean(axis=0) for leg in legs], axis=0) - com)
    soles = [lowest(feet_points[id(leg)], -down0, SOLE_BAND_M) for leg in legs]
    up = unit(np.mean(hips, axis=0) - np.mean(soles, axis=0))
    across = hips[0] - hips[1]
    across = unit(across - up * (across @ up))
    ankles = [crossing(model, data, frame, leg, 4, 5, "ankle pitch", "ankle roll") for leg in legs]
    ahead, told_by = _forward(model, data, frame, legs, up, across, ankles, feet_points, forward)
    left = np.cross(up, ahead)
    if (hips[0] - hips[1]) @ left < 0:
        legs, hips, ankles = legs[::-1], hips[::-1], ankles[::-1]
    legs[0].side, legs[1].side = "l", "r"
    to_trunk = np.array([ahead, left, up])  # root-frame vector -> trunk-frame vector
    joints: dict[str, JointMap] = {}
    lengths: dict[str, list[float]] = {}
    feet: dict[str, FootMap] = {}
    for leg, hip, ankle in zip(legs, hips, ankles, strict=True):
        found = leg_joints(model, data, frame, leg, to_trunk, hip, ankle, lengths)
        joints |= found
        feet[leg.side] = foot_map(model, data, frame, leg, to_trunk, feet_points[id(leg)], ankle)
    check_mirror(lengths, hips, to_trunk)
    geometry = _geometry(model, data, frame, legs, to_trunk, hips, ankles, feet, lengths)
    in_legs = {int(j) for leg in legs for j in leg.joints}
    held = [
        element_name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        for j in range(model.njnt)
        if j not in in_legs and model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE
    ]
    check_closed_chains(model, legs)
    check_third_leg(model, data, frame, root, legs, up, soles, geometry)
    sites: dict[str, tuple[str, tuple[float, float, float]]] = {}
    for leg, hip, ankle in zip(legs, hips, ankles, strict=True):
        for what, point, j in (("hip", hip, leg.joints[2]), ("ankle", ankle, leg.joints[4])):
            body = int(model.jnt_bodyid[j])
            rot = frame.rotation.T @ data.xmat[body].reshape(3, 3)
            local = rot.T @ (point - frame.point(data.xpos[body]))
            sites[f"{leg.side}_{what}"] = (
                body_name(model, body),
                (float(local[0]), float(local[1]), float(local[2])),
            )
    return Mapping(
        root_body=body_name(model, root),
        trunk_quat=quat_of(to_trunk),
        joints={
            name: joints[name] for side in "lr" for name in (f"{side}_{j}" for j in LEG_JOINTS)
        },
        feet=feet,
        held=held,
        geometry=geometry,
        link_masses_kg=link_masses(model, legs[0]),
        forward_from=told_by,
        sites=sites,
    )


def _forward(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    frame: Frame,
    legs: list[Leg],
    up: Vec,
    across: Vec,
    ankles: list[Vec],
    feet_points: dict[int, Vec],
    given: str | None,
) -> tuple[Vec, str]:
    """Forward: as `given` (an axis of the file's root frame, "+x" ... "-z"), else from the
    toes (the soles' centres ahead of the ankles), else the knees (the side a bending knee moves
    the ankle away from)."""
    candidate = np.cross(across, up)
    if given is not None:
        axis = np.zeros(3)
        axis["xyz".index(given[1])] = 1.0 if given[0] == "+" else -1.0
        if abs(axis @ candidate) < math.cos(math.radians(45)):
            raise ImportRefused(
                f"--forward {given}: that axis of the file's root frame is "
                f"{math.degrees(math.acos(min(1.0, float(abs(axis @ candidate))))):.0f}° from the "
                "robot's front-back line (at most 45°); give the axis the toes point along"
            )
        return candidate * np.sign(axis @ candidate), "given"
    ahead = [
        float((lowest(feet_points[id(leg)], up, SOLE_BAND_M) - a) @ candidate)
        for leg, a in zip(legs, ankles, strict=True)
    ]
    if abs(np.mean(ahead)) >= TOE_OFFSET_MIN_M:
        return candidate * np.sign(np.mean(ahead)), "toes"
    knee = legs[0].joints[3]
    lo, hi = model.jnt_range[knee] if model.jnt_limited[knee] else (0.0, 0.0)
    bend = (
        -1.0
        if abs(lo) > KNEE_BEND_RATIO * abs(hi)
        else 1.0
        if abs(hi) > KNEE_BEND_RATIO * abs(lo)
        else 0.0
    )
    if bend:
        k, axis = axis_line(model, data, frame, knee)
        ankle_moves = bend * np.cross(axis, ankles[0] - k)
        return -candidate * np.sign(ankle_moves @ candidate), "knees"
    raise ImportRefused(
        f"cannot tell the robot's front from its back: the soles are centred under the ankles "
        f"(within {1000 * TOE_OFFSET_MIN_M:g} mm) and the knee {joint_name(model, knee)!r} bends "
        f"both ways ({lo:.2f}..{hi:.2f} rad); say where the toes point with --forward (an axis "
        "of the file's root frame, e.g. --forward +x), or give the knee its range"
    )


# --- checks across the legs -------------------------------------------------------------------


def _geometry(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    frame: Frame,
    legs: list[Leg],
    to_trunk: Vec,
    hips: list[Vec],
    ankles: list[Vec],
    feet: dict[str, FootMap],
    lengths: dict[str, list[float]],
) -> dict[str, float]:
    hips_t = [to_trunk @ h for h in hips]
    yaw_t = [to_trunk @ frame.point(data.xanchor[leg.joints[0]]) for leg in legs]
    ankles_t = [to_trunk @ a for a in ankles]
    sole_z = []
    for leg, ankle in zip(legs, ankles_t, strict=True):
        foot = feet[leg.side]
        body_pos = to_trunk @ frame.point(data.xpos[leg.foot])
        rot = to_trunk @ frame.rotation.T @ data.xmat[leg.foot].reshape(3, 3)
        sole_z.append(ankle[2] - (body_pos + rot @ np.array(foot.sole_pos_m))[2])
    hip_roll_offset = float(np.mean([y[2] - h[2] for y, h in zip(yaw_t, hips_t, strict=True)]))
    return {
        "hip_spacing_m": float(hips_t[0][1] - hips_t[1][1]),
        "hip_yaw_offset_m": max(0.0, float(-np.mean([y[2] for y in yaw_t]))),
        "hip_roll_offset_m": max(1e-4, hip_roll_offset),
        "thigh_m": float(np.mean(lengths["thigh"])),
        "shank_m": float(np.mean(lengths["shank"])),
        "ankle_to_sole_m": float(np.mean(sole_z)),
        "foot_length_m": float(np.mean([f.length_m for f in feet.values()])),
        "foot_width_m": float(np.mean([f.width_m for f in feet.values()])),
        "foot_thickness_m": float(np.mean([f.thickness_m for f in feet.values()])),
    }
