"""The MuJoCo model of a robot description, built in code with `mujoco.MjSpec`: floor, robot,
joints and actuators named as the gait's joints, sites and sensors as docs/DESIGN.md §3 says, axes
so that qpos is the paper's angle; the right leg built with the side sign, not mirrored. Servo
figures become settings through `servo_settings` alone (docs/DESIGN.md §7)."""

from __future__ import annotations

import re
import warnings

import mujoco

from app.robots.cad_builder import add_cad_robot
from app.robots.description import RobotDescription
from app.robots.description_parts import LEG_JOINTS, LegJoint, LinkName, Part
from app.robots.model_parts import (
    BODY_GROUP,
    FLOOR_GROUP,
    add_actuator,
    add_fsr_zones,
    add_sensors,
    collide,
    joint_settings,
)

TIMESTEP_S = 0.001  # 20 physics steps per 20 ms TDM frame
MATERIALS = {
    "aluminium": (0.78, 0.80, 0.82, 1.0),
    "servo": (0.12, 0.12, 0.14, 1.0),
    "dummy": (0.55, 0.35, 0.20, 1.0),
    "board": (0.10, 0.45, 0.20, 1.0),
    "plastic": (0.92, 0.92, 0.90, 1.0),
}
# per leg joint: axis on the left leg, whether the right leg reverses it, the link it moves
AXES = {
    "hip_yaw": ((0.0, 0.0, 1.0), True, "hip_yaw_link"),
    "hip_roll": ((1.0, 0.0, 0.0), True, "hip_roll_link"),
    "hip_pitch": ((0.0, -1.0, 0.0), False, "thigh"),
    "knee": ((0.0, -1.0, 0.0), False, "shank"),
    "ankle_pitch": ((0.0, -1.0, 0.0), False, "ankle_link"),
    "ankle_roll": ((1.0, 0.0, 0.0), True, "foot"),
}
DESCRIPTION_LINK: dict[str, LinkName] = {  # body name suffix -> the description's `links` key
    "hip_yaw_link": "hip_yaw",
    "hip_roll_link": "hip_roll",
    "thigh": "thigh",
    "shank": "shank",
    "ankle_link": "ankle",
    "foot": "foot",
}


def build_spec(robot: RobotDescription) -> mujoco.MjSpec:
    """The scene (floor, light, materials) with the robot standing on it, as an `MjSpec`; an
    imported robot's from its file (`app.robots.cad_builder`)."""
    spec = scene_spec(robot)
    if robot.cad is not None:
        add_cad_robot(spec, robot)
        return spec
    _add_robot(spec, robot)
    return spec


def scene_spec(robot: RobotDescription) -> mujoco.MjSpec:
    """The floor, light, materials and physics options every robot stands in."""
    spec = mujoco.MjSpec()
    spec.modelname = robot.name
    spec.compiler.degree = False  # every angle below is in radians
    spec.compiler.autolimits = True
    spec.option.timestep = TIMESTEP_S
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.memory = 2 * 1024 * 1024
    spec.visual.global_.offwidth, spec.visual.global_.offheight = 1280, 720
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.6, 0.6, 0.6]
    _add_materials(spec)

    light = spec.worldbody.add_light(name="sun", pos=[0, 0, 3], dir=[0, 0, -1])
    light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    floor = spec.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], material="floor"
    )
    collide(floor, robot, FLOOR_GROUP)
    return spec


def _add_robot(spec: mujoco.MjSpec, robot: RobotDescription) -> None:
    geo = robot.geometry
    trunk = spec.worldbody.add_body(name="trunk", pos=[0, 0, geo.standing_height_m])
    trunk.add_freejoint(name="root")
    for i, part in enumerate(robot.trunk):
        _add_part(trunk, robot, part, _trunk_geom_name(i, part), length_m=0.0)
    trunk.add_site(name="imu", pos=[0, 0, 0], size=[0.005, 0, 0])
    for side, sign in (("l", 1.0), ("r", -1.0)):
        _add_leg(spec, trunk, robot, side, sign)

    for side in ("l", "r"):
        for joint in LEG_JOINTS:
            add_actuator(spec, robot, f"{side}_{joint}")
    add_sensors(spec)


def build_model(robot: RobotDescription) -> mujoco.MjModel:
    """The compiled model; ValueError with MuJoCo's message if it does not compile, or naming
    the part that starts inside the floor."""
    try:
        with warnings.catch_warnings():  # an imported robot's file is attached with no prefix
            warnings.filterwarnings("ignore", message="Attaching a spec with an empty prefix")
            model = build_spec(robot).compile()
    except ValueError as err:
        element = re.search(r"Element name '(\w+)'", str(err))
        field = f" (the description's {_field_of(element.group(1))})" if element else ""
        said = " ".join(str(err).split())
        raise ValueError(
            f"robot {robot.name!r}: the model does not compile{field}: {said}"
        ) from err
    _check_only_the_soles_touch(model, robot)
    return model


def _check_only_the_soles_touch(model: mujoco.MjModel, robot: RobotDescription) -> None:
    """Standing (straight legs, soles on the floor), no colliding part is inside the floor: the
    contact would throw the robot up at the first step."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    floor = model.geom("floor").id
    soles = {model.geom(f"{side}_foot_plate").id for side in ("l", "r")}
    for contact in data.contact[: data.ncon]:
        pair = {int(contact.geom1), int(contact.geom2)}
        if floor in pair and not pair & soles and contact.dist < -1e-4:
            (geom,) = pair - {floor}
            raise ValueError(
                f"{_field_of(model.geom(geom).name)}: a colliding part starts "
                f"{-contact.dist * 1000:.0f} mm inside the floor with the robot standing; move "
                "it above the soles (pos_m, its size) or set collides: false"
            )


def _field_of(name: str) -> str:
    """The description's field of a part's geom ("trunk_abdomen_0": "trunk.0", "l_thigh_1":
    "links.thigh.1") or of a leg's body ("l_foot": "links.foot"); else the name as it is."""
    head, _, index = name.rpartition("_")
    if head.startswith("trunk_") and index.isdigit():
        return f"trunk.{index}"
    side, _, rest = (head if index.isdigit() else name).partition("_")
    if side in ("l", "r") and rest in DESCRIPTION_LINK:
        link = f"links.{DESCRIPTION_LINK[rest]}"
        return f"{link}.{index}" if index.isdigit() else link
    return name


def model_xml(robot: RobotDescription) -> str:
    """The model as MJCF text (`artro robot export-mjcf`)."""
    spec = build_spec(robot)
    spec.compile()
    return spec.to_xml()


# --- parts ------------------------------------------------------------------------------------


def _add_materials(spec: mujoco.MjSpec) -> None:
    spec.add_texture(
        name="grid",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        width=512,
        height=512,
        rgb1=[0.82, 0.82, 0.80],
        rgb2=[0.72, 0.72, 0.70],
    )
    floor = spec.add_material(name="floor", texrepeat=[20, 20])
    floor.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    for name, rgba in MATERIALS.items():
        spec.add_material(name=name, rgba=list(rgba))


def _visual(geom: mujoco.MjsGeom) -> None:
    geom.contype = geom.conaffinity = 0
    geom.group = BODY_GROUP


def _trunk_geom_name(index: int, part: Part) -> str:
    words = part.name.replace("(", "").replace(")", "").split()
    return "trunk_" + "_".join(w.lower() for w in words[:2]) + f"_{index}"


def _add_part(
    body: mujoco.MjsBody, robot: RobotDescription, part: Part, name: str, *, length_m: float
) -> None:
    """A part's geom: a box, a capsule along the link (length_m below the joint), or a point."""
    if part.capsule_radius_m is not None:
        inset = part.capsule_inset_m
        geom = body.add_geom(
            name=name,
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0, 0, -inset, 0, 0, -(length_m - inset)],
            size=[part.capsule_radius_m, 0, 0],
            mass=part.mass_kg,
        )
    elif part.box_m is not None:
        geom = body.add_geom(
            name=name,
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[s / 2 for s in part.box_m],
            pos=list(part.pos_m),
            mass=part.mass_kg,
        )
    else:
        geom = body.add_geom(
            name=name,
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[0.002, 0, 0],
            pos=list(part.pos_m),
            mass=part.mass_kg,
        )
    geom.material = part.material
    if part.collides:
        collide(geom, robot, BODY_GROUP)
    else:
        _visual(geom)


def _add_servo_case(
    body: mujoco.MjsBody, robot: RobotDescription, joint: LegJoint, at: list[float], side: str
) -> None:
    """The case of `joint`'s servo in `body`, `at` the joint's position in that body; the mount's
    y offset mirrors on the right leg."""
    name = f"{side}_{joint}"
    spec = robot.joint_servo_spec(name)
    mount = robot.servo_mounts[joint]
    box = mount.box_m or tuple(mm / 1000.0 for mm in spec.case_mm)
    geom = body.add_geom(
        name=f"{name}_servo",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[s / 2 for s in box],
        pos=[a + p for a, p in zip(at, _mirror(mount.pos_m, side), strict=True)],
        mass=spec.mass_kg,
        material="servo",
    )
    geom.alt.euler = list(mount.euler_rad)
    _visual(geom)


def _add_leg(
    spec: mujoco.MjSpec, trunk: mujoco.MjsBody, robot: RobotDescription, side: str, sign: float
) -> None:
    geo = robot.geometry
    hip_yaw_at = [0.0, sign * geo.hip_spacing_m / 2, -geo.hip_yaw_offset_m]
    _add_servo_case(trunk, robot, "hip_yaw", hip_yaw_at, side)
    # each joint's body position in its parent, and the length of the link it moves
    chain: list[tuple[LegJoint, list[float], float]] = [
        ("hip_yaw", hip_yaw_at, geo.hip_roll_offset_m),
        ("hip_roll", [0.0, 0.0, -geo.hip_roll_offset_m], 0.0),
        ("hip_pitch", [0.0, 0.0, 0.0], geo.thigh_m),
        ("knee", [0.0, 0.0, -geo.thigh_m], geo.shank_m),
        ("ankle_pitch", [0.0, 0.0, -geo.shank_m], 0.0),
        ("ankle_roll", [0.0, 0.0, 0.0], geo.ankle_to_sole_m),
    ]
    settings = joint_settings(robot)
    parent = trunk
    for k, (joint, pos, length_m) in enumerate(chain):
        axis, mirrored, body_name = AXES[joint]
        body = parent.add_body(name=f"{side}_{body_name}", pos=pos)
        name = f"{side}_{joint}"
        s = settings[name]
        body.add_joint(
            name=name,
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=[-a if (mirrored and sign < 0) else a for a in axis],
            range=list(robot.joints[name].range_rad),
            damping=s.damping_nm_s_rad,
            armature=s.armature_kg_m2,
            frictionloss=s.frictionloss_nm,
        )
        for i, part in enumerate(robot.links.get(DESCRIPTION_LINK[body_name], ())):
            if body_name == "foot":
                continue  # the foot's parts weigh the plate below
            _add_part(body, robot, _sided(part, sign), f"{side}_{body_name}_{i}", length_m=length_m)
        if joint == "hip_pitch":
            body.add_site(name=f"{side}_hip", pos=[0, 0, 0], size=[0.006, 0, 0])
        if joint == "ankle_pitch":
            body.add_site(name=f"{side}_ankle", pos=[0, 0, 0], size=[0.006, 0, 0])
        if k + 1 < len(chain):
            next_joint, next_pos, _ = chain[k + 1]
            _add_servo_case(body, robot, next_joint, list(next_pos), side)
        parent = body
    _add_foot(parent, robot, side)


def _mirror(pos: tuple[float, float, float], side: str) -> tuple[float, float, float]:
    return pos if side == "l" else (pos[0], -pos[1], pos[2])


def _sided(part: Part, sign: float) -> Part:
    x, y, z = part.pos_m
    return part if sign > 0 else part.model_copy(update={"pos_m": (x, -y, z)})


def _add_foot(foot: mujoco.MjsBody, robot: RobotDescription, side: str) -> None:
    geo = robot.geometry
    mass = sum(p.mass_kg for p in robot.links.get("foot", ()))
    plate = foot.add_geom(
        name=f"{side}_foot_plate",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[geo.foot_length_m / 2, geo.foot_width_m / 2, geo.foot_thickness_m / 2],
        pos=[0, 0, -(geo.ankle_to_sole_m - geo.foot_thickness_m / 2)],
        mass=mass,
        material="aluminium",
    )
    collide(plate, robot, BODY_GROUP)
    foot.add_site(name=f"{side}_sole", pos=[0, 0, -geo.ankle_to_sole_m], size=[0.006, 0, 0])
    add_fsr_zones(
        foot, side, [0.0, 0.0, -geo.ankle_to_sole_m], (geo.foot_length_m, geo.foot_width_m)
    )
