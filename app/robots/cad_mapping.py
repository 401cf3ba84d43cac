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
    closest,
    collides,
    element_name,
    geom_points,
    joint_name,
    lowest,
    quat_of,
    subtree_of,
    unit,
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

#: a hinge's axis may lie this far from what its place in the chain needs: the gait's inverse
#: kinematics (eqs 2–9) assumes exact axes; 5° tilts a 0.3 rad swing's foot by under 0.03 rad
AXIS_TOLERANCE_DEG = 5.0
#: axes that must cross (hip roll/pitch, ankle pitch/roll, the hip yaw through the hip's
#: crossing) may pass this far apart: a CAD export places them to a tenth of a millimetre, and
#: 2 mm moves the foot by less than the servos' play does
AXES_MEET_TOLERANCE_M = 0.002
#: the sole's centre this far ahead of (or behind) the ankle tells where the toes are
TOE_OFFSET_MIN_M = 0.003
#: a knee bends one way when one end of its range is this many times the other's magnitude
KNEE_BEND_RATIO = 1.5
#: the foot's collision points within this height of its lowest make its sole's outline
SOLE_BAND_M = 0.01
#: the thickness of a sole plate added under a foot whose lowest geometry is no aligned box
ADDED_PLATE_THICKNESS_M = 0.002


#: what each joint's axis must be along, in the studio's trunk frame (x forward, y left, z up),
#: on the left leg; the right leg's roll and yaw axes are reversed (docs/DESIGN.md §3)
EXPECTED_AXIS = {
    "hip_yaw": (0.0, 0.0, 1.0),
    "hip_roll": (1.0, 0.0, 0.0),
    "hip_pitch": (0.0, -1.0, 0.0),
    "knee": (0.0, -1.0, 0.0),
    "ankle_pitch": (0.0, -1.0, 0.0),
    "ankle_roll": (1.0, 0.0, 0.0),
}
MIRRORED = {"hip_yaw", "hip_roll", "ankle_roll"}
AXIS_WORD = {0: "forward", 1: "sideways", 2: "vertical"}


@dataclass(frozen=True)
class JointMap:
    """One gait joint in the file: its joint, the sign that turns its angle into the paper's,
    the paper angle of the file's zero pose, how far its axis lies from the ideal, its range in
    the paper's angle."""

    gait: str
    file_joint: str
    sign: int
    zero_rad: float
    axis_error_deg: float
    range_rad: tuple[float, float] | None  # None: the file gives no limit


@dataclass(frozen=True)
class FootMap:
    """A foot: its body, the sole's centre and axes in that body, its outline, and the box geom
    that is its sole plate (None: a plate is added)."""

    body: str
    sole_pos_m: tuple[float, float, float]
    sole_quat: tuple[float, float, float, float]
    length_m: float
    width_m: float
    thickness_m: float
    plate_geom: str | None


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
    hips = [_crossing(model, data, frame, leg, 1, 2, "hip roll", "hip pitch") for leg in legs]
    down0 = unit(np.mean([feet_points[id(leg)].mean(axis=0) for leg in legs], axis=0) - com)
    soles = [lowest(feet_points[id(leg)], -down0, SOLE_BAND_M) for leg in legs]
    up = unit(np.mean(hips, axis=0) - np.mean(soles, axis=0))
    across = hips[0] - hips[1]
    across = unit(across - up * (across @ up))
    ankles = [_crossing(model, data, frame, leg, 4, 5, "ankle pitch", "ankle roll") for leg in legs]
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
        found = _leg_joints(model, data, frame, leg, to_trunk, hip, ankle, lengths)
        joints |= found
        feet[leg.side] = _foot(model, data, frame, leg, to_trunk, feet_points[id(leg)], ankle)
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


def _crossing(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    frame: Frame,
    leg: Leg,
    i: int,
    k: int,
    what_i: str,
    what_k: str,
) -> Vec:
    """Where the axes of the leg's hinges `i` and `k` cross; ImportRefused if they pass apart."""
    p, u = axis_line(model, data, frame, leg.joints[i])
    q, v = axis_line(model, data, frame, leg.joints[k])
    point, gap = closest(p, u, q, v)
    if gap > AXES_MEET_TOLERANCE_M:
        raise ImportRefused(
            f"the {what_i} axis of {joint_name(model, leg.joints[i])!r} and the {what_k} axis "
            f"of {joint_name(model, leg.joints[k])!r} pass {1000 * gap:.1f} mm apart; the "
            f"gait's leg (eqs 2–9) needs them to cross (at most {1000 * AXES_MEET_TOLERANCE_M:g} "
            "mm)"
        )
    return point


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


# --- each leg's joints ------------------------------------------------------------------------


def _pitch(v: Vec) -> float:
    """The forward angle of a downward vector v (trunk frame) from straight down."""
    return math.atan2(float(v[0]), float(-v[2]))


def _leg_joints(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    frame: Frame,
    leg: Leg,
    to_trunk: Vec,
    hip: Vec,
    ankle: Vec,
    lengths: dict[str, list[float]],
) -> dict[str, JointMap]:
    """Classify, sign and zero the leg's six hinges; ImportRefused naming a misplaced one."""
    side_sign = 1.0 if leg.side == "l" else -1.0
    found = {}
    axes = {}
    for j, gait in zip(leg.joints, LEG_JOINTS, strict=True):
        axis = to_trunk @ axis_line(model, data, frame, j)[1]
        want = np.array(EXPECTED_AXIS[gait]) * (side_sign if gait in MIRRORED else 1.0)
        cos = float(np.clip(axis @ want, -1.0, 1.0))
        error = math.degrees(math.acos(abs(cos)))
        if error > AXIS_TOLERANCE_DEG:
            nearest = AXIS_WORD[int(np.argmax(np.abs(axis)))]
            raise ImportRefused(
                f"{'left' if leg.side == 'l' else 'right'} leg, joint {leg.joints.index(j) + 1} "
                f"of 6, {joint_name(model, j)!r}: its axis is {error:.1f}° from "
                f"{AXIS_WORD[int(np.argmax(np.abs(want)))]}, which a {gait.replace('_', ' ')} "
                f"needs there (at most {AXIS_TOLERANCE_DEG:g}°; the axis is nearest {nearest}); "
                "the gait's leg turns hip yaw, roll, pitch, knee, ankle pitch, roll in that order"
            )
        axes[gait] = (j, 1 if cos > 0 else -1, error)
    yaw_point, yaw_axis = axis_line(model, data, frame, leg.joints[0])
    _, gap = closest(hip, yaw_axis, yaw_point, yaw_axis)
    if gap > AXES_MEET_TOLERANCE_M:
        raise ImportRefused(
            f"the hip yaw axis of {joint_name(model, leg.joints[0])!r} passes {1000 * gap:.1f} mm "
            f"from the hip's roll/pitch crossing; the gait turns the leg about that point (at "
            f"most {1000 * AXES_MEET_TOLERANCE_M:g} mm)"
        )
    knee_point, knee_axis = axis_line(model, data, frame, leg.joints[3])
    knee = knee_point + knee_axis * ((hip - knee_point) @ knee_axis)
    thigh, shank = to_trunk @ (knee - hip), to_trunk @ (ankle - knee)
    lengths.setdefault("thigh", []).append(float(np.linalg.norm(thigh)))
    lengths.setdefault("shank", []).append(float(np.linalg.norm(shank)))
    leg_line = to_trunk @ (ankle - hip)
    zero = {
        "hip_yaw": 0.0,  # the soles' outlines are taken along the trunk's axes
        "hip_roll": math.atan2(side_sign * float(leg_line[1]), float(-leg_line[2])),
        "hip_pitch": _pitch(thigh),
        "knee": _pitch(shank) - _pitch(thigh),
        "ankle_pitch": -_pitch(shank),  # the sole lies flat in the zero pose
    }
    zero["ankle_roll"] = -zero["hip_roll"]
    for gait, (j, sign, error) in axes.items():
        name = f"{leg.side}_{gait}"
        span = None
        if model.jnt_limited[j]:
            lo, hi = sorted(sign * float(r) for r in model.jnt_range[j])
            ref = sign * float(model.qpos0[model.jnt_qposadr[j]])  # the file's own zero
            span = (lo - ref + zero[gait], hi - ref + zero[gait])
        found[name] = JointMap(name, joint_name(model, j), sign, zero[gait], error, span)
    return found


def _foot(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    frame: Frame,
    leg: Leg,
    to_trunk: Vec,
    points: Vec,
    ankle: Vec,
) -> FootMap:
    """The sole of the leg's foot in the foot body: centre, axes (the trunk's in the zero pose),
    outline, and the box that is its plate if one is."""
    trunk_points = points @ to_trunk.T
    height = trunk_points[:, 2]
    sole = trunk_points[height <= height.min() + SOLE_BAND_M]
    lo, hi = sole.min(axis=0), sole.max(axis=0)
    centre_trunk = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, height.min()])
    centre_root = to_trunk.T @ centre_trunk
    body_pos = frame.point(data.xpos[leg.foot])
    body_rot = frame.rotation.T @ data.xmat[leg.foot].reshape(3, 3)  # foot axes in the root frame
    sole_pos = body_rot.T @ (centre_root - body_pos)
    sole_rot = body_rot.T @ to_trunk.T  # sole (trunk-aligned) axes in the foot body
    plate, thickness = _plate(model, data, frame, leg.foot, to_trunk, height.min(), hi - lo)
    return FootMap(
        body=body_name(model, leg.foot),
        sole_pos_m=(float(sole_pos[0]), float(sole_pos[1]), float(sole_pos[2])),
        sole_quat=quat_of(sole_rot),
        length_m=float(hi[0] - lo[0]),
        width_m=float(hi[1] - lo[1]),
        thickness_m=thickness,
        plate_geom=plate,
    )


def _plate(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    frame: Frame,
    foot: int,
    to_trunk: Vec,
    lowest: float,
    outline: Vec,
) -> tuple[str | None, float]:
    """The foot's named box geom that is the whole sole (its bottom the lowest, its axes the
    trunk's, its size the sole's `outline`), with its thickness; (None,
    ADDED_PLATE_THICKNESS_M) where there is none."""
    for b in subtree_of(model, foot):
        for g in range(model.ngeom):
            if model.geom_bodyid[g] != b or model.geom_type[g] != mujoco.mjtGeom.mjGEOM_BOX:
                continue
            if not collides(model, g):
                continue
            axes = to_trunk @ frame.rotation.T @ data.geom_xmat[g].reshape(3, 3)
            if not np.allclose(np.abs(axes), np.eye(3), atol=math.radians(1.0)):
                continue
            bottom = (to_trunk @ frame.point(geom_points(model, data, g)).T)[2].min()
            size = 2 * model.geom_size[g][:2]
            named = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
            if abs(bottom - lowest) < 5e-4 and np.allclose(size, outline[:2], atol=1e-3) and named:
                return element_name(model, mujoco.mjtObj.mjOBJ_GEOM, g), 2 * float(
                    model.geom_size[g][2]
                )
    return None, ADDED_PLATE_THICKNESS_M


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
