"""A described robot written as URDF (`artro robot export-urdf`, docs/DESIGN.md §16): one link
per body of its compiled model with the body's mass and inertia, a revolute joint per hinge
with its limits, damping and friction, the colliding geoms as collision shapes and the rest
as visuals; `artro robot import` reads it back to the same robot."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from app.robots.builder import build_model
from app.robots.description import RobotDescription


def model_urdf(robot: RobotDescription) -> str:
    """The robot (not its floor) as URDF text; ValueError for a body URDF cannot hold."""
    model = build_model(robot)
    urdf = ET.Element("robot", name=robot.name)
    trunk = model.body("trunk").id
    for b in range(1, model.nbody):
        if model.body_rootid[b] != trunk:
            continue
        _link(urdf, model, b)
        if b != trunk:
            _joint(urdf, model, b)
    ET.indent(urdf)
    return '<?xml version="1.0"?>\n' + ET.tostring(urdf, encoding="unicode") + "\n"


def _fmt(values: ArrayLike) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def _rpy(quat: np.ndarray) -> list[float]:
    """URDF's fixed-axis roll, pitch, yaw of a rotation given as a quaternion (w, x, y, z)."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=np.float64))
    r = mat.reshape(3, 3)
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    return [math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])]


def _origin(parent: ET.Element, pos: np.ndarray, quat: np.ndarray) -> None:
    ET.SubElement(parent, "origin", xyz=_fmt(pos), rpy=_fmt(_rpy(quat)))


def _link(urdf: ET.Element, model: mujoco.MjModel, b: int) -> None:
    link = ET.SubElement(urdf, "link", name=model.body(b).name)
    inertial = ET.SubElement(link, "inertial")
    _origin(inertial, model.body_ipos[b], model.body_iquat[b])
    ET.SubElement(inertial, "mass", value=_fmt(model.body_mass[b]))
    ixx, iyy, izz = (float(i) for i in model.body_inertia[b])
    ET.SubElement(
        inertial, "inertia", ixx=_fmt(ixx), iyy=_fmt(iyy), izz=_fmt(izz), ixy="0", ixz="0", iyz="0"
    )
    for g in range(model.ngeom):
        if model.geom_bodyid[g] != b:
            continue
        shape = _shape(model, g)
        if shape is None:
            continue
        collides = bool(model.geom_contype[g] or model.geom_conaffinity[g])
        element = ET.SubElement(
            link, "collision" if collides else "visual", name=model.geom(g).name
        )
        _origin(element, model.geom_pos[g], model.geom_quat[g])
        geometry = ET.SubElement(element, "geometry")
        ET.SubElement(geometry, shape[0], shape[1])


def _shape(model: mujoco.MjModel, g: int) -> tuple[str, dict[str, str]] | None:
    size = model.geom_size[g]
    kind = model.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return "box", {"size": _fmt(2 * size)}
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return "sphere", {"radius": _fmt(size[0])}
    if kind in (mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER):
        return "cylinder", {"radius": _fmt(size[0]), "length": _fmt(2 * size[1])}
    return None


def _joint(urdf: ET.Element, model: mujoco.MjModel, b: int) -> None:
    parent, child = model.body(int(model.body_parentid[b])).name, model.body(b).name
    count = int(model.body_jntnum[b])
    if count > 1:
        raise ValueError(f"body {child!r} has {count} joints; a URDF link has one")
    if count == 0:
        joint = ET.SubElement(urdf, "joint", name=f"{child}_fixed", type="fixed")
    else:
        j = int(model.body_jntadr[b])
        if np.any(model.jnt_pos[j]):
            raise ValueError(f"joint {model.joint(j).name!r} is off its body's origin")
        joint = ET.SubElement(urdf, "joint", name=model.joint(j).name, type="revolute")
        ET.SubElement(joint, "axis", xyz=_fmt(model.jnt_axis[j]))
        lo, hi = model.jnt_range[j]
        act = [a for a in range(model.nu) if model.actuator_trnid[a, 0] == j]
        effort = float(model.actuator_forcerange[act[0], 1]) if act else 0.0
        ET.SubElement(
            joint, "limit", lower=_fmt(lo), upper=_fmt(hi), effort=_fmt(effort), velocity="10"
        )
        dof = int(model.jnt_dofadr[j])
        ET.SubElement(
            joint,
            "dynamics",
            damping=_fmt(model.dof_damping[dof]),
            friction=_fmt(model.dof_frictionloss[dof]),
        )
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    _origin(joint, model.body_pos[b], model.body_quat[b])
