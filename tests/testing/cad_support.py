"""What the robot import's tests share: the built-in ArtRo exported as a CAD file's MJCF (its
joints renamed as Darwin-OP names them), an OP3-like biped made with MjSpec, a cube as a binary
STL, a mesh added, a zip made."""

from __future__ import annotations

import io
import struct
import warnings
import zipfile

import mujoco

from app.robots import load_description, model_xml
from app.robots.urdf_export import model_urdf
from gait import JOINT_NAMES

#: Darwin-OP's names for the joints: the import maps by geometry, never by name
DARWIN = {"hip_yaw": "j_pelvis", "hip_roll": "j_thigh1", "hip_pitch": "j_thigh2",
          "knee": "j_tibia", "ankle_pitch": "j_ankle1", "ankle_roll": "j_ankle2"}  # fmt: skip


def artro_mjcf(renamed: bool = True, drop: str | None = None) -> str:
    """The built-in ArtRo as a CAD export's MJCF: no sensors, joints renamed; `drop`: a joint
    taken out (a leg the gait cannot drive)."""
    spec = mujoco.MjSpec.from_string(model_xml(load_description("artro")))
    for sensor in list(spec.sensors):
        spec.delete(sensor)
    if drop:
        spec.delete(spec.actuator(drop))
        spec.delete(spec.joint(drop))
    if renamed:
        for name in JOINT_NAMES:
            if name == drop:
                continue
            side, _, joint = name.partition("_")
            spec.joint(name).name = f"{DARWIN[joint]}_{side}"
            spec.actuator(name).target = f"{DARWIN[joint]}_{side}"
            spec.actuator(name).name = f"{DARWIN[joint]}_{side}_servo"
    return spec.to_xml()


def box_stl(half: float = 0.02) -> bytes:
    """A binary STL of a cube: 12 triangles, wound outwards."""
    corners = [(x, y, z) for x in (-half, half) for y in (-half, half) for z in (-half, half)]
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]  # fmt: skip
    out = bytearray(b"box".ljust(80, b" ") + struct.pack("<I", len(faces)))
    for face in faces:
        out += struct.pack("<3f", 0, 0, 0)
        for i in face:
            out += struct.pack("<3f", *corners[i])
        out += struct.pack("<H", 0)
    return bytes(out)


def with_mesh(xml: str, file: str = "meshes/shell.stl") -> str:
    """`xml` with a visual mesh on the trunk read from `file`."""
    xml = xml.replace(
        "<worldbody>", f'<asset><mesh name="shell" file="{file}"/></asset>\n<worldbody>', 1
    )
    return xml.replace(
        '<joint name="root" type="free"/>',
        '<joint name="root" type="free"/><geom name="shell" type="mesh" mesh="shell" '
        'contype="0" conaffinity="0" group="1" mass="0"/>',
        1,
    )


def zipped(members: dict[str, bytes], links: tuple[str, ...] = ()) -> bytes:
    buffer = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a duplicate name, on purpose
        with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
            for name, data in members.items():
                archive.writestr(name, data)
            for name in links:
                info = zipfile.ZipInfo(name)
                info.external_attr = 0o120777 << 16  # a symbolic link, as `zip -y` stores one
                archive.writestr(info, "../../etc/passwd")
    return buffer.getvalue()


def artro_urdf_with_mesh(mesh: str = "package://artro_description/meshes/shell.stl") -> str:
    """The built-in ArtRo as URDF, a collision mesh on its trunk named `mesh` (ROS's way)."""
    urdf = model_urdf(load_description("artro"))
    end = urdf.index("</link>", urdf.index('<link name="trunk"'))
    shell = f'<collision><geometry><mesh filename="{mesh}"/></geometry></collision>'
    return urdf[:end] + shell + urdf[end:]


def op3_like() -> mujoco.MjSpec:
    """A biped of OP3's layout made here (not its file): hip yaw through the roll/pitch
    crossing, thigh 0.110 m, shank 0.110 m, 3.15 kg, arms and a head, box feet centred under
    the ankles 30 mm down, knees without a range, axes turned as OP3 turns them, no meshes."""
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.modelname = "op3-like"
    d = spec.default
    d.joint.damping = [1.084, 0, 0]
    d.joint.armature = 0.045
    d.joint.frictionloss = 0.03
    root = spec.worldbody.add_body(name="body_link", pos=[0, 0, 0.3])
    root.add_freejoint()
    _inertial(root, 1.349, [-0.015, 0, 0.066])
    root.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.07, 0.07], pos=[-0.015, 0, 0.075])
    pan = _link(root, "head_pan_link", [-0.001, 0, 0.1365], "head_pan", [0, 0, 1], 0.0118)
    tilt = _link(pan, "head_tilt_link", [0.01, 0.019, 0.0285], "head_tilt", [0, -1, 0], 0.1363)
    tilt.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.03, 0.03], pos=[0, -0.019, 0.03])
    for side, s in (("l", 1.0), ("r", -1.0)):
        sho = _link(
            root,
            f"{side}_sho_pitch_link",
            [-0.001, s * 0.06, 0.111],
            f"{side}_sho_pitch",
            [0, s, 0],
            0.0118,
        )
        roll = _link(
            sho,
            f"{side}_sho_roll_link",
            [0.019, s * 0.0285, -0.01],
            f"{side}_sho_roll",
            [-1, 0, 0],
            0.1776,
        )
        el = _link(
            roll, f"{side}_el_link", [0, s * 0.0904, -0.0001], f"{side}_el", [1, 0, 0], 0.0413
        )
        el.add_geom(
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            size=[0.012, 0.03, 0],
            pos=[-0.019, s * 0.05, 0],
            quat=[0.7071, 0.7071, 0, 0],
        )
        yaw = _link(
            root, f"{side}_hip_yaw_link", [0, s * 0.035, 0], f"{side}_hip_yaw", [0, 0, -1], 0.0118
        )
        hroll = _link(
            yaw,
            f"{side}_hip_roll_link",
            [-0.024, 0, -0.0285],
            f"{side}_hip_roll",
            [-1, 0, 0],
            0.1789,
        )
        pitch = _link(
            hroll,
            f"{side}_hip_pitch_link",
            [0.0241, s * 0.019, 0],
            f"{side}_hip_pitch",
            [0, s, 0],
            0.1154,
        )
        knee = _link(
            pitch, f"{side}_knee_link", [0, 0, -0.11015], f"{side}_knee", [0, s, 0], 0.0402
        )
        ank = _link(
            knee, f"{side}_ank_pitch_link", [0, 0, -0.11], f"{side}_ank_pitch", [0, -s, 0], 0.1789
        )
        foot = _link(
            ank,
            f"{side}_ank_roll_link",
            [-0.0241, -s * 0.019, 0],
            f"{side}_ank_roll",
            [1, 0, 0],
            0.0693,
        )
        foot.add_geom(
            name=f"{side}_sole_box",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[0.0635, 0.028, 0.004],
            pos=[0.0241, s * 0.019, -0.0265],
            mass=0,
        )
    for joint in spec.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
            act = spec.add_actuator(
                name=f"{joint.name}_act", target=joint.name, trntype=mujoco.mjtTrn.mjTRN_JOINT
            )
            act.set_to_position(kp=21.1)
            act.forcerange = [-5, 5]
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    return spec


def _inertial(body, mass, pos):
    body.mass, body.ipos = mass, pos
    body.inertia = [1e-4 + mass * 1e-3] * 3
    body.explicitinertial = True


def _link(parent, name, pos, joint, axis, mass):
    body = parent.add_body(name=name, pos=pos)
    body.add_joint(name=joint, axis=axis)
    _inertial(body, mass, [0, 0, -0.01])
    return body
