"""What the robot import's tests share: the built-in ArtRo exported as a CAD file's MJCF (its
joints renamed as Darwin-OP names them), a cube as a binary STL, a mesh added, a zip made."""

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
