"""Each CAD leg's hinges as the gait's joints (docs/DESIGN.md §3, §16): classified by axis in
chain order, signed and zeroed as the paper's angles, with their ranges; where two axes cross;
each foot's sole and plate. What the gait cannot drive is refused (`ImportRefused`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

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
    quat_of,
    subtree_of,
)
from app.robots.cad_legs import ImportRefused, Leg, body_name
from app.robots.description_parts import LEG_JOINTS

#: a hinge's axis may lie this far from what its place in the chain needs: the gait's inverse
#: kinematics (eqs 2–9) assumes exact axes; 5° tilts a 0.3 rad swing's foot by under 0.03 rad
AXIS_TOLERANCE_DEG = 5.0
#: axes that must cross (hip roll/pitch, ankle pitch/roll, the hip yaw through the hip's
#: crossing) may pass this far apart: a CAD export places them to a tenth of a millimetre, and
#: 2 mm moves the foot by less than the servos' play does
AXES_MEET_TOLERANCE_M = 0.002
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


def crossing(
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


def _pitch(v: Vec) -> float:
    """The forward angle of a downward vector v (trunk frame) from straight down."""
    return math.atan2(float(v[0]), float(-v[2]))


def leg_joints(
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


def foot_map(
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
