"""An imported robot's MuJoCo model (docs/DESIGN.md §16): the file as MuJoCo reads it, its root
under a free `trunk` in the studio's frame, the mapped joints renamed with their sign and zero
(qpos is the paper's angle), every other joint rigid, and the studio's soles, force sensor
zones, IMU, servos and sensors added. The file's masses and geometry stay as they are."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import TypeVar

import mujoco
import numpy as np

from app.robots.description import RobotDescription
from app.robots.description_parts import LEG_JOINTS
from app.robots.model_parts import (
    BODY_GROUP,
    FSR_CORNERS,
    add_actuator,
    add_fsr_zones,
    add_sensors,
    collide,
    joint_settings,
)
from app.robots.mujoco_warnings import keep_warnings_out_of_the_folder

T = TypeVar("T")

# attaching the file's root with no prefix keeps its names, which the description maps by
warnings.filterwarnings("ignore", message="Attaching a spec with an empty prefix")

#: names the studio gives; an element of the file with one of them is renamed NAME_file
RESERVED = {"trunk", "root", "imu", "floor", "sun"}


class CadFileError(ValueError):
    """The file cannot be read or compiled: the message names the file and what is wrong."""


def read_file_spec(path: Path, package_dirs: tuple[str, ...] = ()) -> mujoco.MjSpec:
    """The file as MuJoCo reads it, its meshes resolved (relative to the file, through
    `package://` in `package_dirs`); CadFileError naming a missing mesh or MuJoCo's words."""
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except (ValueError, OSError) as err:
        said = " ".join(str(err).split())
        raise CadFileError(f"{path}: MuJoCo cannot read it: {said}") from None
    spec.compiler.fusestatic = False  # the bodies as the file has them (URDF's default fuses)
    spec.strippath = False
    base = path.parent / (spec.meshdir or "")
    missing = []
    for mesh in spec.meshes:
        if not mesh.file:
            continue
        found = _resolve(mesh.file, base, package_dirs)
        if found is None:
            missing.append(mesh.file)
        else:
            mesh.file = str(found)
    spec.meshdir = ""
    if missing:
        raise CadFileError(
            f"{path}: mesh file(s) not found: {', '.join(missing[:5])}"
            + (f" and {len(missing) - 5} more" if len(missing) > 5 else "")
            + " (looked beside the file"
            + (f" and in {', '.join(package_dirs)}" if package_dirs else "; give --package-dir DIR")
            + ")"
        )
    return spec


def _resolve(name: str, base: Path, package_dirs: tuple[str, ...]) -> Path | None:
    if name.startswith("package://"):
        rest = Path(name.removeprefix("package://"))
        tries = [Path(d) / rest for d in package_dirs]
        tries += [Path(d) / Path(*rest.parts[1:]) for d in package_dirs if len(rest.parts) > 1]
        tries += [base / Path(*rest.parts[1:])] if len(rest.parts) > 1 else []
    else:
        tries = [Path(name) if Path(name).is_absolute() else base / name]
    return next((p.resolve() for p in tries if p.is_file()), None)


def robot_root(spec: mujoco.MjSpec) -> mujoco.MjsBody:
    """The file's one body at the top (its robot); CadFileError if there is none or several."""
    tops = [b for b in spec.worldbody.bodies]
    if len(tops) != 1:
        names = ", ".join(repr(b.name) for b in tops) or "none"
        raise CadFileError(
            f"the file has {len(tops)} bodies at its top ({names}); a robot file has one root "
            "body (its trunk), the legs below it"
        )
    return tops[0]


def strip_scene(spec: mujoco.MjSpec, root: mujoco.MjsBody, *, constraints: bool = True) -> None:
    """What the studio brings itself goes: the file's floor and lights, actuators, sensors,
    keyframes, contact pairs and the root's own free joint; with `constraints`, its equality
    constraints and tendons too (the mapping refuses those that close a leg's chain)."""
    for kind in ("geoms", "sites", "lights", "cameras"):
        for element in list(getattr(spec.worldbody, kind)):
            spec.delete(element)
    kinds = [spec.actuators, spec.sensors, spec.keys, spec.pairs, spec.excludes]
    for elements in kinds + ([spec.equalities, spec.tendons] if constraints else []):
        for element in list(elements):
            spec.delete(element)
    for joint in list(root.joints):
        spec.delete(joint)


def add_cad_robot(scene: mujoco.MjSpec, robot: RobotDescription) -> None:
    """The imported robot of `robot.cad` into the `scene` (`app.robots.builder.scene_spec`)."""
    cad = robot.cad
    assert cad is not None
    spec = read_file_spec(Path(cad.file), cad.package_dirs)
    file_acts = _file_actuators(spec) if cad.keep_actuators else {}
    kept = {
        gait: file_acts[j.file_joint] for gait, j in cad.joints.items() if j.file_joint in file_acts
    }
    root = robot_root(spec)
    if root.name != cad.root_body:
        raise CadFileError(
            f"{cad.file}: its root body is {root.name!r}, the description says "
            f"{cad.root_body!r}: the file changed since the import (import it again)"
        )
    strip_scene(spec, root)
    mapped = {j.file_joint for j in cad.joints.values()}
    plates = {f.plate_geom for f in cad.feet.values() if f.plate_geom}
    _rename_clashes(spec, mapped | plates)
    for name in cad.held:
        spec.delete(_element(spec.joint(name), "joint", name, cad.file))
    settings = joint_settings(robot)
    for gait, j in cad.joints.items():
        joint = _element(spec.joint(j.file_joint), "joint", j.file_joint, cad.file)
        lo, hi = robot.joints[gait].range_rad
        joint.name = gait
        joint.axis = [j.sign * a for a in joint.axis]
        joint.ref = j.zero_rad
        joint.range = [lo, hi]
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        if not cad.keep_actuators:
            s = settings[gait]
            joint.damping = [s.damping_nm_s_rad, 0.0, 0.0]  # linear damping, as the builder's
            joint.armature = s.armature_kg_m2
            joint.frictionloss = s.frictionloss_nm
    friction = [
        robot.contact.friction,
        robot.contact.torsional_friction,
        robot.contact.rolling_friction,
    ]
    for geom in spec.geoms:
        if geom.contype or geom.conaffinity:
            geom.friction, geom.condim = friction, robot.contact.condim
    for side in cad.feet:
        _add_sole(spec, robot, side)
    for name, site in cad.sites.items():
        body = _element(spec.body(site.body), "body", site.body, cad.file)
        body.add_site(name=name, pos=list(site.pos_m), size=[0.006, 0, 0])

    for kind in ("textures", "materials"):  # the scene's own of a name win (its floor, servos)
        ours = {element.name for element in getattr(scene, kind)}
        for element in list(getattr(spec, kind)):
            if element.name in ours:
                spec.delete(element)
    trunk = scene.worldbody.add_body(name="trunk", pos=[0, 0, robot.geometry.standing_height_m])
    trunk.add_freejoint(name="root")
    if cad.imu_site is None:
        trunk.add_site(name="imu", pos=[0, 0, 0], size=[0.005, 0, 0])
    frame = trunk.add_frame(quat=list(cad.trunk_quat))
    root.pos, root.quat = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]  # the trunk's origin is the root's
    keep_warnings_out_of_the_folder()  # MuJoCo says a prefix-less attach may not save as XML
    with warnings.catch_warnings():  # the file's options give way to the scene's; no prefix
        warnings.simplefilter("ignore")
        frame.attach_body(root, "", "")
    scene.compiler.fusestatic = True  # the root and every held limb join the body above
    if cad.imu_site is not None:
        scene.site(cad.imu_site).name = "imu"
    for side in ("l", "r"):
        for joint in LEG_JOINTS:
            name = f"{side}_{joint}"
            add_actuator(scene, robot, name)
            if name in kept:
                _keep(scene.actuator(name), kept[name])
    add_sensors(scene)


def _element(found: T | None, kind: str, name: str, file: str) -> T:
    if found is None:
        raise CadFileError(f"{file}: no {kind} {name!r}: the file changed since the import")
    return found


def _rename_clashes(spec: mujoco.MjSpec, mapped: set[str]) -> None:
    """An element of the file named as the studio names its own gets _file appended (but the
    `mapped` joints and plates, which become those elements)."""
    ours = set(RESERVED)
    for side in ("l", "r"):
        ours |= {f"{side}_{j}" for j in LEG_JOINTS} | {f"{side}_{j}_torque" for j in LEG_JOINTS}
        ours |= {f"{side}_{s}" for s in ("hip", "ankle", "sole", "foot_plate", "sole_pos")}
        ours |= {f"{side}_fsr_{c}" for c in FSR_CORNERS}
    for kind in ("bodies", "joints", "geoms", "sites"):
        for element in getattr(spec, kind):
            if element.name in ours and element.name not in mapped:
                element.name = f"{element.name}_file"


def _add_sole(spec: mujoco.MjSpec, robot: RobotDescription, side: str) -> None:
    """The sole site, its plate (the file's box, renamed, or a thin box added under the foot's
    outline, the file's own foot geometry then off the floor) and the force sensor zones."""
    cad = robot.cad
    assert cad is not None
    foot = cad.feet["l" if side == "l" else "r"]
    geo = robot.geometry
    body = spec.body(foot.body)
    quat = list(foot.sole_quat)
    body.add_site(name=f"{side}_sole", pos=list(foot.sole_pos_m), quat=quat, size=[0.006, 0, 0])
    flat = np.zeros(9)
    mujoco.mju_quat2Mat(flat, np.array(quat))
    rot = flat.reshape(3, 3)
    at = np.array(foot.sole_pos_m)
    if foot.plate_geom is not None:
        spec.geom(foot.plate_geom).name = f"{side}_foot_plate"
    else:
        for geom in _subtree_geoms(body):
            geom.contype = geom.conaffinity = 0
        plate = body.add_geom(
            name=f"{side}_foot_plate",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[geo.foot_length_m / 2, geo.foot_width_m / 2, geo.foot_thickness_m / 2],
            pos=list(at + rot @ [0, 0, geo.foot_thickness_m / 2]),
            quat=quat,
            mass=0.0,
        )
        collide(plate, robot, BODY_GROUP)
    add_fsr_zones(body, side, list(at), (geo.foot_length_m, geo.foot_width_m), rot, quat)


def _subtree_geoms(body: mujoco.MjsBody) -> list[mujoco.MjsGeom]:
    out = list(body.geoms)
    for child in body.bodies:
        out += _subtree_geoms(child)
    return out


def _file_actuators(spec: mujoco.MjSpec) -> dict[str, dict[str, object]]:
    """The file's position actuators by the joint they drive (read before they go)."""
    return {
        act.target: {
            "gainprm": list(act.gainprm),
            "biasprm": list(act.biasprm),
            "forcerange": list(act.forcerange),
            "forcelimited": act.forcelimited,
        }
        for act in spec.actuators
        if act.trntype == mujoco.mjtTrn.mjTRN_JOINT
    }


def _keep(act: mujoco.MjsActuator, file_act: dict[str, object]) -> None:
    """The file's actuator's gains and force limit on the studio's actuator of that joint."""
    act.gainprm = file_act["gainprm"]
    act.biasprm = file_act["biasprm"]
    if file_act["forcelimited"] == mujoco.mjtLimited.mjLIMITED_TRUE:
        act.forcerange = file_act["forcerange"]
