"""The dashboard's robot import (POST /api/robot/import, docs/DESIGN.md §16) on a live server:
ArtRo exported as MJCF with renamed joints maps, goes on offer and switches as one undoable
change; a zip with a mesh imports; each hostile or unreadable upload is refused in words, with
nothing left on disk; an import past its deadline is stopped, in words."""

from __future__ import annotations

import io
import threading
import warnings
import zipfile
from pathlib import Path

import pytest

from app.server.http.robot_upload import MAX_UNPACKED_BYTES, MAX_UPLOAD_BYTES, MAX_ZIP_FILES
from gait import JOINT_NAMES
from tests.testing.cad_support import artro_mjcf, artro_urdf_with_mesh, box_stl, with_mesh, zipped
from tests.testing.server_harness import client, running_server, wait_for

UPLOAD = {"content-type": "application/octet-stream"}


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    data = tmp_path_factory.mktemp("data")
    with running_server(data) as (base_url, _app):
        with client(base_url) as http:
            http.timeout = 120
            yield http, data


def _post(http, body: bytes, filename: str, **params: str):
    return http.post("/api/robot/import", params={"filename": filename, **params}, content=body,
                     headers=UPLOAD)  # fmt: skip


def _folders(data: Path) -> set[str]:
    robots = data / "robots"
    return {p.name for p in robots.iterdir()} if robots.exists() else set()


def test_an_exported_artro_imports_maps_by_geometry_and_switches_as_one_undoable_change(served):
    http, data = served
    answer = _post(http, artro_mjcf().encode(), "darwin-legs.xml")
    assert answer.status_code == 200, answer.text
    body = answer.json()
    assert body["robot"] == "darwin-legs" and body["file"] == "darwin-legs.xml"
    rows = {row["joint"]: row for row in body["mapping"]}
    assert set(rows) == set(JOINT_NAMES)
    assert rows["l_knee"]["file_joint"] == "j_tibia_l" and rows["r_hip_yaw"]["sign"] in (1, -1)
    assert all(row["axis_error_deg"] < 0.01 for row in rows.values())
    assert body["total_mass_kg"] == pytest.approx(1.65, rel=0.01)
    assert Path(body["written"]).is_file() and "darwin-legs" in _folders(data)
    offered = http.get("/api/robots").json()
    assert [r["name"] for r in offered["robots"]][-1] == "darwin-legs"
    before = http.get("/api/params").json()
    switched = http.put("/api/robot", json={"name": "darwin-legs"}).json()
    assert switched["changed"] and switched["params"]["version"] == before["version"] + 1
    assert http.get("/api/robot").json()["name"] == "darwin-legs"
    undone = http.post("/api/params/undo").json()
    assert undone["robot"] == "artro" and undone["name"] == before["name"]
    # the same file again: a second robot of its own name, said in a note
    again = _post(http, artro_mjcf().encode(), "darwin-legs.xml").json()
    assert (
        again["robot"] == "darwin-legs-2" and "darwin-legs is on offer already" in again["notes"][0]
    )


def test_a_zip_of_an_mjcf_with_its_mesh_in_a_folder_imports(served):
    http, data = served
    body = zipped({
        "op/robot.xml": with_mesh(artro_mjcf(renamed=False)).encode(),
        "op/meshes/shell.stl": box_stl(),
        "__MACOSX/op/._robot.xml": b"\x00\x05\x16\x07 resource fork",
    })  # fmt: skip
    answer = _post(http, body, "op.zip", name="meshed")
    assert answer.status_code == 200, answer.text
    assert answer.json()["file"] == "op/robot.xml"
    folder = data / "robots" / "meshed"
    assert (folder / "op" / "meshes" / "shell.stl").read_bytes() == box_stl()
    assert not (folder / "__MACOSX").exists()


def test_a_ros_package_zip_of_a_urdf_with_a_package_mesh_imports(served):
    http, _data = served
    body = zipped({
        "artro_description/urdf/artro.urdf": artro_urdf_with_mesh().encode(),
        "artro_description/meshes/shell.stl": box_stl(),
    })  # fmt: skip
    answer = _post(http, body, "artro_description.zip", name="rosy")
    assert answer.status_code == 200, answer.text
    assert answer.json()["file"] == "artro_description/urdf/artro.urdf"
    assert answer.json()["total_mass_kg"] == pytest.approx(1.65, rel=0.01)


HOSTILE = {
    "dotdot": (zipped({"robot.xml": b"<mujoco/>", "../evil.stl": b"x"}), "leaves the zip's folder"),
    "absolute": (zipped({"/etc/robot.xml": b"<mujoco/>"}), "is an absolute name"),
    "link": (zipped({"robot.xml": b"<mujoco/>"}, links=("meshes/a.stl",)), "is a link"),
    "many": (
        zipped({f"m{i}.stl": b"x" for i in range(MAX_ZIP_FILES + 1)}),
        f"a robot's zip may hold {MAX_ZIP_FILES}",
    ),
    "bomb": (
        zipped({"robot.xml": b"<mujoco/>", "big.stl": bytes(MAX_UNPACKED_BYTES + 1)}),
        f"may unpack to {MAX_UNPACKED_BYTES}",
    ),
    "entity": (
        b'<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
        b"<robot name='x'>&x;</robot>",
        "has a DTD or an entity",
    ),
    "mesh outside": (
        with_mesh(artro_mjcf(), "../../secret.stl").encode(),
        "leaves the upload's folder",
    ),
    "mesh absolute": (with_mesh(artro_mjcf(), "/etc/passwd").encode(), "is an absolute name"),
    "no xml": (b"solid box\nendsolid", "is no XML"),
    "two robots": (
        zipped({"a.urdf": b"<robot name='a'/>", "b.xml": b"<mujoco/>"}),
        "holds 2 robot files (a.urdf, b.xml): zip one, or name it with file=",
    ),
    "no robot": (zipped({"notes.txt": b"hello"}), "holds no URDF (<robot>) or MJCF (<mujoco>)"),
}


@pytest.mark.parametrize("case", HOSTILE)
def test_a_hostile_upload_is_refused_in_words_with_nothing_on_disk(served, case):
    http, data = served
    body, words = HOSTILE[case]
    before = _folders(data)
    suffix = ".zip" if body.startswith(b"PK") else ".xml"
    answer = _post(http, body, f"robot{suffix}")
    assert answer.status_code == 422, answer.text
    assert answer.json()["detail"][0]["type"] == "upload_refused"
    assert words in answer.json()["message"], answer.json()["message"]
    assert _folders(data) == before


def test_a_duplicate_member_and_a_bad_name_are_refused(served):
    http, data = served
    before = _folders(data)
    buffer = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with zipfile.ZipFile(buffer, "w") as archive:
            archive.writestr("robot.xml", b"<mujoco/>")
            archive.writestr("robot.xml", b"<robot/>")
    answer = _post(http, buffer.getvalue(), "robot.zip")
    assert answer.status_code == 422 and "is in it twice" in answer.json()["message"]
    named = _post(http, b"<mujoco/>", "robot.stl")
    assert named.status_code == 422 and "a .urdf or an MJCF .xml file" in named.json()["message"]
    folder = _post(http, b"<mujoco/>", "../robot.xml")
    assert folder.status_code == 422 and "with no folder in it" in folder.json()["message"]
    assert _folders(data) == before


def test_an_unknown_servo_is_refused_naming_those_known(served):
    http, data = served
    before = _folders(data)
    answer = _post(http, artro_mjcf().encode(), "robot.xml", servo="SG9000")
    assert answer.status_code == 422 and answer.json()["detail"][0]["loc"] == ["query", "servo"]
    assert "unknown servo 'SG9000'; known:" in answer.json()["message"]
    assert "MG996R" in answer.json()["message"] and _folders(data) == before


def test_a_body_over_the_cap_is_refused_before_it_is_read(served):
    http, _data = served
    answer = _post(http, bytes(MAX_UPLOAD_BYTES + 1), "robot.zip")
    assert answer.status_code == 413 and str(MAX_UPLOAD_BYTES) in answer.json()["message"]
    form = http.post("/api/robot/import", params={"filename": "r.xml"}, content=b"<mujoco/>",
                     headers={"content-type": "text/plain"})  # fmt: skip
    assert form.status_code == 415 and "application/octet-stream" in form.json()["message"]


def test_what_mujoco_cannot_read_or_the_gait_cannot_drive_is_refused_naming_it(served):
    http, data = served
    before = _folders(data)
    empty = _post(http, b"<mujoco><worldbody/></mujoco>", "empty.xml")
    assert empty.status_code == 422, empty.text
    assert empty.json()["detail"][0]["type"] == "import_refused"
    said = empty.json()["message"]
    assert "has 0 bodies at its top" in said and str(data) not in said
    legless = _post(http, artro_mjcf(renamed=False, drop="l_ankle_roll").encode(), "five.xml")
    assert legless.status_code == 422, legless.text
    said = legless.json()["message"]
    assert "has 5 hinge joints" in said and "l_ankle_pitch" in said
    missing = _post(http, with_mesh(artro_mjcf()).encode(), "meshless.xml")
    assert missing.status_code == 422, missing.text
    said = missing.json()["message"]
    assert "meshes/shell.stl" in said and "upload a .zip of the robot file with its meshes" in said
    assert _folders(data) == before
    names = [r["name"] for r in http.get("/api/robots").json()["robots"]]
    assert not {"empty", "five", "meshless"} & set(names)


def test_an_import_past_its_deadline_is_stopped_in_words(tmp_path):
    with running_server(tmp_path, robot_import_timeout_s=0.01) as (base_url, _app):
        with client(base_url) as http:
            answer = _post(http, artro_mjcf().encode(), "slow.xml")
            assert answer.status_code == 422, answer.text
            assert answer.json()["detail"][0]["type"] == "import_timed_out"
            assert "took longer than 0.01 s and was stopped" in answer.json()["message"]
            assert _folders(tmp_path) == set()
            assert http.delete("/api/robot/import").json() == {"cancelled": False}


def test_an_import_cancelled_while_it_runs_keeps_nothing(tmp_path):
    with running_server(tmp_path) as (base_url, app):
        importer = app.state.services.importer
        with client(base_url) as http:
            http.timeout = 120
            answers = []
            thread = threading.Thread(
                target=lambda: answers.append(_post(http, artro_mjcf().encode(), "gone.xml"))
            )
            thread.start()
            wait_for(lambda: importer._child is not None, "the import's child runs")
            second = _post(http, artro_mjcf().encode(), "second.xml")
            assert second.status_code == 429 and "another robot is being imported" in second.text
            assert http.delete("/api/robot/import").json() == {"cancelled": True}
            thread.join(60)
            answer = answers[0]
            assert answer.status_code == 409, answer.text
            assert "the import was cancelled; nothing was imported" in answer.json()["message"]
            assert _folders(tmp_path) == set()
            assert "gone" not in [r["name"] for r in http.get("/api/robots").json()["robots"]]
