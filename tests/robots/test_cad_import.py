"""`artro robot import` (docs/DESIGN.md §16): ArtRo exported as MJCF, then with renamed joints,
turned link frames, a Y-up root and flipped joint axes, maps to the same joints and signs and
moves as the built-in ArtRo; each refusal is made with a file built here with MjSpec."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from app.params.presets import builtin_presets
from app.robots import load_description, model_xml
from app.robots.cad_import import import_robot
from app.robots.model import RobotModel
from app.sim.headless import run
from gait import JOINT_NAMES, Motion

#: Darwin-OP's way of naming the same joints (docs/DESIGN.md §16: names cannot be trusted)
DARWIN = {
    "hip_yaw": "j_pelvis",
    "hip_roll": "j_thigh1",
    "hip_pitch": "j_thigh2",
    "knee": "j_tibia",
    "ankle_pitch": "j_ankle1",
    "ankle_roll": "j_ankle2",
}
SITES = ("l_sole", "r_sole", "l_hip", "r_hip", "l_ankle", "r_ankle")


def artro_spec() -> mujoco.MjSpec:
    """The built-in ArtRo as MJCF, less the studio's sensors (a CAD export has none of them)."""
    spec = mujoco.MjSpec.from_string(model_xml(load_description("artro")))
    for sensor in list(spec.sensors):
        spec.delete(sensor)
    return spec


def _rot(quat: list[float]) -> np.ndarray:
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.array(quat, dtype=np.float64))
    return mat.reshape(3, 3)


def _quat(spec: mujoco.MjSpec, element: object) -> list[float]:
    alt = element.alt  # type: ignore[attr-defined]
    if alt.type != mujoco.mjtOrientation.mjORIENTATION_QUAT:
        quat = spec.resolve_orientation(False, "xyz", alt)
        alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
        return list(quat)
    return list(element.quat)  # type: ignore[attr-defined]


def turn_frame(spec: mujoco.MjSpec, body: mujoco.MjsBody, quat: list[float]) -> None:
    """Turn `body`'s frame by `quat` and re-express everything in it: the model is unchanged,
    only the file's frames are (a CAD export's link frames turned any way)."""
    q = np.array(quat) / np.linalg.norm(quat)
    inverse = np.array([q[0], -q[1], -q[2], -q[3]])
    r_t = _rot(list(q)).T
    body_quat = np.zeros(4)
    mujoco.mju_mulQuat(body_quat, np.array(_quat(spec, body)), q)
    body.quat = list(body_quat)
    for child in [*body.bodies, *body.geoms, *body.sites]:
        child.pos = list(r_t @ np.array(child.pos))
        turned = np.zeros(4)
        mujoco.mju_mulQuat(turned, inverse, np.array(_quat(spec, child)))
        child.quat = list(turned)
    for joint in body.joints:
        joint.pos = list(r_t @ np.array(joint.pos))
        joint.axis = list(r_t @ np.array(joint.axis))


def variant(renamed=False, flipped=False, turned=False, y_up=False) -> mujoco.MjSpec:  # type: ignore[no-untyped-def]
    spec = artro_spec()
    if turned:
        for name, quat in (
            ("l_thigh", [0.5, 0.5, 0.5, 0.5]),
            ("r_foot", [0, 0, 0, 1]),
            ("l_hip_roll_link", [0.7071, 0, 0.7071, 0]),
        ):
            turn_frame(spec, spec.body(name), quat)
    if y_up:  # the root's frame with y up and x sideways, the robot lying in the file's world
        root = spec.body("trunk")
        turn_frame(spec, root, [0.5, 0.5, 0.5, 0.5])
        root.quat = [1.0, 0.0, 0.0, 0.0]
    if flipped:
        for name in ("l_hip_roll", "r_knee", "l_ankle_pitch", "r_hip_yaw"):
            joint = spec.joint(name)
            lo, hi = joint.range
            joint.axis = [-a for a in joint.axis]
            joint.range = [-hi, -lo]
    if renamed:
        for name in JOINT_NAMES:
            side, _, joint = name.partition("_")
            spec.joint(name).name = f"{DARWIN[joint]}_{side}"
            spec.actuator(name).target = f"{DARWIN[joint]}_{side}"
            spec.actuator(name).name = f"{DARWIN[joint]}_{side}_servo"
    return spec


def file_joint(name: str, renamed: bool) -> str:
    side, _, joint = name.partition("_")
    return f"{DARWIN[joint]}_{side}" if renamed else name


def imported(tmp_path: Path, spec: mujoco.MjSpec, name: str = "artro-cad") -> RobotModel:
    source = tmp_path / "robot.xml"
    source.write_text(spec.to_xml(), encoding="utf-8")
    result = import_robot(source, output=tmp_path / "robot.yaml", name=name)
    return RobotModel.load(result.description)


def site_positions(robot: RobotModel, angles: np.ndarray) -> np.ndarray:
    data = mujoco.MjData(robot.model)
    data.qpos[robot.qpos_adr] = angles
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    mujoco.mj_kinematics(robot.model, data)
    trunk = data.xpos[robot.trunk_id]
    return np.array([data.site(s).xpos - trunk for s in SITES])


CASES = {
    "plain": {},
    "renamed": {"renamed": True},
    "flipped": {"flipped": True},
    "turned": {"turned": True},
    "y_up": {"y_up": True},
    "all": {"renamed": True, "flipped": True, "turned": True, "y_up": True},
}


@pytest.mark.parametrize("case", CASES)
def test_artro_exported_maps_to_the_same_joints_signs_and_poses(tmp_path: Path, case: str) -> None:
    how = CASES[case]
    robot = imported(tmp_path, variant(**how))
    cad = robot.description.cad
    assert cad is not None
    flipped = (
        {"l_hip_roll", "r_knee", "l_ankle_pitch", "r_hip_yaw"} if how.get("flipped") else set()
    )
    for name in JOINT_NAMES:
        assert cad.joints[name].file_joint == file_joint(name, bool(how.get("renamed")))
        assert cad.joints[name].sign == (-1 if name in flipped else 1), name
        assert abs(cad.joints[name].zero_rad) < 1e-9
    builtin = RobotModel.load("artro")
    for key, value in builtin.description.geometry.model_dump().items():
        assert getattr(robot.description.geometry, key) == pytest.approx(value, abs=1e-6), key
    assert robot.total_mass_kg() == pytest.approx(builtin.total_mass_kg(), rel=1e-9)
    rng = np.random.default_rng(7)
    for _ in range(5):  # the same angles put the hips, ankles and soles at the same places
        angles = rng.uniform(-0.5, 0.5, 12)
        angles[[3, 9]] = -np.abs(angles[[3, 9]])
        np.testing.assert_allclose(
            site_positions(robot, angles), site_positions(builtin, angles), atol=1e-9
        )


def test_the_imported_artro_walks_as_the_builtin_one(tmp_path: Path) -> None:
    robot = imported(tmp_path, variant(renamed=True, flipped=True, turned=True, y_up=True))
    params = builtin_presets()["robust"].gait
    for motion in (Motion(a_p=0.07), Motion(a_r=0.1), Motion(a_y=0.2)):
        ours = run(params, motion, duration_s=10.0, warmup_s=3.0, robot=robot).metrics
        theirs = run(params, motion, duration_s=10.0, warmup_s=3.0).metrics
        assert ours["fell"] == theirs["fell"]
        for metric in ("forward_cm_s", "lateral_cm_s", "turn_deg_s"):
            a, b = ours[metric], theirs[metric]
            assert abs(a - b) <= max(0.05 * abs(b), 0.05), (motion, metric, a, b)


# --- refusals, each from a file made here ------------------------------------------------------


def _refusal(tmp_path: Path, spec: mujoco.MjSpec) -> str:
    source = tmp_path / "robot.xml"
    source.write_text(spec.to_xml(), encoding="utf-8")
    with pytest.raises(ValueError) as err:
        import_robot(source, output=tmp_path / "robot.yaml")
    return str(err.value)


def test_a_leg_of_five_joints_is_refused_naming_its_joints(tmp_path: Path) -> None:
    spec = artro_spec()
    spec.delete(spec.actuator("l_ankle_roll"))
    spec.delete(spec.joint("l_ankle_roll"))
    said = _refusal(tmp_path, spec)
    assert "has 5 hinge joints" in said and "l_ankle_pitch" in said


def test_an_oblique_axis_is_refused_with_its_angle(tmp_path: Path) -> None:
    spec = artro_spec()
    spec.joint("r_hip_roll").axis = [np.cos(0.2), 0.0, np.sin(0.2)]
    said = _refusal(tmp_path, spec)
    assert "'r_hip_roll'" in said and "11.5°" in said and "at most 5°" in said


def test_hip_axes_that_do_not_meet_are_refused_with_the_distance(tmp_path: Path) -> None:
    spec = artro_spec()
    spec.joint("l_hip_pitch").pos = [0.0, 0.0, -0.006]
    said = _refusal(tmp_path, spec)
    assert "6.0 mm apart" in said and "l_hip_pitch" in said


def test_legs_that_are_no_mirror_images_are_refused(tmp_path: Path) -> None:
    spec = artro_spec()
    body = spec.body("l_ankle_link")
    body.pos = [0.0, 0.0, -0.1]  # the left shank 10 mm longer
    said = _refusal(tmp_path, spec)
    assert "no mirror images" in said and "shank" in said


def test_a_foot_without_collision_geometry_is_refused(tmp_path: Path) -> None:
    spec = artro_spec()
    spec.geom("r_foot_plate").contype = 0
    spec.geom("r_foot_plate").conaffinity = 0
    said = _refusal(tmp_path, spec)
    assert "'r_foot'" in said and "no collision geometry" in said


def test_a_closed_chain_is_refused(tmp_path: Path) -> None:
    spec = artro_spec()
    spec.add_equality(
        type=mujoco.mjtEq.mjEQ_CONNECT,
        name="linkage",
        name1="l_shank",
        name2="l_thigh",
        objtype=mujoco.mjtObj.mjOBJ_BODY,
    )
    said = _refusal(tmp_path, spec)
    assert "'linkage'" in said and "open chains" in said


def test_a_third_leg_is_refused(tmp_path: Path) -> None:
    spec = artro_spec()
    tail = spec.body("trunk").add_body(name="tail", pos=[-0.1, 0.0, -0.1])
    tail.add_joint(name="tail_pitch", axis=[0, 1, 0])
    tail.add_geom(
        type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.01, 0.01, 0.17], pos=[0, 0, -0.0], mass=0.01
    )
    said = _refusal(tmp_path, spec)
    assert "'tail'" in said and "third leg" in said


def test_the_cli_imports_shows_the_mapping_and_refuses_in_one_sentence(tmp_path: Path) -> None:
    good = tmp_path / "good.xml"
    good.write_text(variant(renamed=True).to_xml(), encoding="utf-8")
    cli = [sys.executable, "-m", "app.cli", "robot"]
    done = subprocess.run(
        [*cli, "import", str(good), "-o", str(tmp_path / "good.yaml"), "--name", "darwinish"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "j_thigh1_l" in done.stdout
    shown = subprocess.run(
        [*cli, "show", str(tmp_path / "good.yaml")], capture_output=True, text=True, check=False
    )
    assert shown.returncode == 0, shown.stderr
    assert "l_hip_roll      j_thigh1_l" in shown.stdout
    spec = artro_spec()
    spec.joint("r_hip_roll").axis = [np.cos(0.2), 0.0, np.sin(0.2)]
    bad = tmp_path / "bad.xml"
    bad.write_text(spec.to_xml(), encoding="utf-8")
    refused = subprocess.run(
        [*cli, "import", str(bad), "-o", str(tmp_path / "bad.yaml")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert refused.returncode == 2
    assert "r_hip_roll" in refused.stderr and "Traceback" not in refused.stderr
    assert not (tmp_path / "bad.yaml").exists()
