"""A robot upload's checks (`app/server/http/robot_upload.py`) without a server: what a zip may
hold, which file is the robot, file references that leave the folder however they are combined, and
nothing written on a refusal."""

from __future__ import annotations

import pytest

from app.server.http.robot_upload import UploadRefused, unpack
from tests.testing.cad_support import zipped

MJCF = b"<mujoco><worldbody/></mujoco>"


def _refused(tmp_path, body: bytes, name: str = "robot.zip", chosen: str | None = None) -> str:
    with pytest.raises(UploadRefused) as err:
        unpack(body, name, tmp_path / "refused", chosen)
    assert not (tmp_path / "refused").exists()
    return str(err.value)


def test_the_robot_file_is_the_one_nearest_the_top_not_included_by_another(tmp_path):
    scene = b'<mujoco><include file="parts/robot.xml"/></mujoco>'
    body = zipped({"pkg/scene.xml": scene, "pkg/parts/robot.xml": MJCF,
                   "pkg/package.xml": b"<package/>", "pkg/meshes/a.stl": b"solid"})  # fmt: skip
    done = unpack(body, "robot.zip", tmp_path / "up")
    assert done.robot_file == tmp_path / "up" / "pkg" / "scene.xml" and done.files == 4
    chosen = unpack(body, "robot.zip", tmp_path / "up2", "pkg/parts/robot.xml")
    assert chosen.robot_file.name == "robot.xml"
    said = _refused(tmp_path, body, chosen="pkg/package.xml")
    assert "is no URDF (<robot>) or MJCF (<mujoco>) file: its root element is <package>" in said


def test_a_meshdir_and_a_file_that_leave_the_folder_together_are_refused(tmp_path):
    xml = (b'<mujoco><compiler meshdir="../../"/><asset><mesh file="../a.stl"/></asset>'
           b"<worldbody/></mujoco>")  # fmt: skip
    said = _refused(tmp_path, zipped({"a/b/robot.xml": xml, "a/b/m.stl": b""}))
    assert "<mesh file='../a.stl'> leaves the upload's folder" in said
    hidden = b'<mujoco><include file="parts.inc"/></mujoco>'
    assert "includes .xml files only" in _refused(tmp_path, hidden, "r.xml")
    url = b'<robot name="r"><link name="l"><visual><geometry><mesh filename="http://x/a.stl"/>'
    url += b"</geometry></visual></link></robot>"
    assert "is named relative to the robot file" in _refused(tmp_path, url, "r.urdf")


def test_a_name_both_file_and_folder_an_encrypted_member_and_utf16_are_refused(tmp_path):
    said = _refused(tmp_path, zipped({"robot.xml": MJCF, "robot.xml/a.stl": b""}))
    assert "is both a file and a folder" in said
    body = bytearray(zipped({"robot.xml": MJCF}))
    body[6] |= 1  # the local header's flags: encrypted
    body[body.rindex(b"PK\x01\x02") + 8] |= 1  # and the central directory's
    assert "is encrypted" in _refused(tmp_path, bytes(body))
    utf16 = '<?xml version="1.0" encoding="UTF-16"?><mujoco/>'.encode("utf-16")
    assert "is no UTF-8 text" in _refused(tmp_path, utf16, "robot.xml")


def test_file_names_a_member_of_a_zip_only(tmp_path):
    assert "is not in robot.zip" in _refused(tmp_path, zipped({"a.xml": MJCF}), chosen="b.xml")
    said = _refused(tmp_path, MJCF, "robot.xml", chosen="robot.xml")
    assert "file= names the robot file within a .zip" in said
