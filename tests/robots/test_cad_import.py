"""`artro robot import` (docs/DESIGN.md §16): ArtRo exported as MJCF, then with renamed joints,
turned link frames, a Y-up root and flipped joint axes, maps to the same joints and signs and
moves as the built-in ArtRo; each refusal is made with a file built here with MjSpec."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from app.evaluation import BatchEvaluator, Job
from app.firmware.build import wiring
from app.params.presets import builtin_presets
from app.robots import load_description, model_xml
from app.robots.cad_import import import_robot
from app.robots.cad_mapping import ImportRefused
from app.robots.model import RobotModel
from app.sim.headless import run
from app.sim.metrics import MOTION_METRICS
from app.sim.planning import _servo_setpoints
from gait import JOINT_NAMES, GaitParams, Motion
from hardware.servo_bus import BusLink
from tests.testing.cad_support import box_stl, op3_like

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
    picture = tmp_path / "good.png"
    shown = subprocess.run(
        [*cli, "show", str(tmp_path / "good.yaml"), "--png", str(picture)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert shown.returncode == 0, shown.stderr
    assert "l_hip_roll      j_thigh1_l" in shown.stdout
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and picture.stat().st_size > 20_000
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


# --- a biped of another maker's layout ---------------------------------------------------------


OP3_SIGNS = {
    "hip_yaw": -1,
    "hip_roll": -1,
    "hip_pitch": -1,
    "knee": -1,
    "ankle_pitch": 1,
    "ankle_roll": 1,
}
OP3_HELD = [
    "head_pan",
    "head_tilt",
    "l_sho_pitch",
    "l_sho_roll",
    "l_el",
    "r_sho_pitch",
    "r_sho_roll",
    "r_el",
]


def op3_imported(tmp_path: Path, **options: object) -> RobotModel:
    source = tmp_path / "op3.xml"
    source.write_text(op3_like().to_xml(), encoding="utf-8")
    result = import_robot(source, output=tmp_path / "op3.yaml", name="op3-like", **options)
    return RobotModel.load(result.description)


def test_a_biped_whose_geometry_cannot_tell_its_front_asks_for_forward(tmp_path: Path) -> None:
    source = tmp_path / "op3.xml"
    source.write_text(op3_like().to_xml(), encoding="utf-8")
    with pytest.raises(ImportRefused, match="--forward"):
        import_robot(source, output=tmp_path / "op3.yaml")


def test_an_op3_like_biped_maps_its_legs_holds_its_arms_and_keeps_its_mass(tmp_path: Path) -> None:
    robot = op3_imported(tmp_path, forward="+x", servo="XM430-W350", keep_actuators=True)
    cad = robot.description.cad
    assert cad is not None and cad.forward_from == "given"
    for name in JOINT_NAMES:
        side, _, joint = name.partition("_")
        want = OP3_SIGNS[joint] * (1 if side == "l" else -1)  # OP3 mirrors every axis
        assert cad.joints[name].sign == want, name
        assert cad.joints[name].file_joint.replace("ank_", "ankle_") == name
    assert list(cad.held) == OP3_HELD
    geo = robot.description.geometry
    assert (geo.thigh_m, geo.shank_m) == (pytest.approx(0.11015), pytest.approx(0.110))
    assert geo.ankle_to_sole_m == pytest.approx(0.0305, abs=1e-3)
    assert robot.total_mass_kg() == pytest.approx(float(op3_like().compile().body_subtreemass[1]))
    assert robot.model.nu == 12 and robot.model.nq == 19  # the arms and head are rigid
    kp = robot.model.actuator_gainprm[robot.actuator_ids, 0]
    np.testing.assert_allclose(kp, 21.1)  # the file's own servos, kept


def test_paper_angles_move_an_op3_like_sole_as_they_move_artros(tmp_path: Path) -> None:
    robot, artro = op3_imported(tmp_path, forward="+x"), RobotModel.load("artro")
    for i, name in enumerate(JOINT_NAMES):
        angles = np.zeros(12)
        angles[i] = -0.3 if name.endswith("knee") else 0.3
        moved = [_sole_motion(r, angles, name[0]) for r in (robot, artro)]
        for ours, theirs in zip(*moved, strict=True):
            if np.linalg.norm(theirs) > 1e-6:
                assert ours @ theirs > 0, (name, ours, theirs)


def _sole_motion(robot: RobotModel, angles: np.ndarray, side: str) -> list[np.ndarray]:
    """How the sole moves (m) and turns (rad) from the straight pose at `angles`."""
    data = mujoco.MjData(robot.model)
    out = []
    for pose in (np.zeros(12), angles):
        data.qpos[robot.qpos_adr] = pose
        data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
        mujoco.mj_kinematics(robot.model, data)
        out.append((data.site(f"{side}_sole").xpos.copy(), data.site(f"{side}_sole").xmat.copy()))
    (p0, r0), (p1, r1) = out
    turn = np.zeros(3)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, (r1.reshape(3, 3) @ r0.reshape(3, 3).T).ravel())
    mujoco.mju_quat2Vel(turn, quat, 1.0)
    return [p1 - p0, turn]


def test_an_op3_like_biped_stands_ten_seconds_on_its_own_servos(tmp_path: Path) -> None:
    robot = op3_imported(tmp_path, forward="+x", servo="XM430-W350", keep_actuators=True)
    model = robot.model
    data = mujoco.MjData(model)
    data.qpos[2] = robot.standing_height_m(np.zeros(12)) + 0.002
    data.ctrl[:] = 0.0  # the straight pose, the paper's zero
    start = float(data.qpos[2])
    while data.time < 10.0:
        mujoco.mj_step(model, data)
    up = data.xmat[robot.trunk_id].reshape(3, 3)[:, 2]
    assert up[2] > np.cos(np.radians(10)), up  # upright within 10°
    assert data.qpos[2] > start - 0.02


# --- round trip through URDF ------------------------------------------------------------------


def exported_urdf(path: Path) -> None:
    """`artro robot export-urdf artro -o PATH`, as a user runs it."""
    done = subprocess.run(
        [sys.executable, "-m", "app.cli", "robot", "export-urdf", "artro", "-o", str(path)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr


def test_artro_exported_as_urdf_imports_back_to_its_lengths_masses_and_walk(tmp_path: Path) -> None:
    source = tmp_path / "artro.urdf"
    exported_urdf(source)
    result = import_robot(source, output=tmp_path / "artro-urdf.yaml", name="artro-urdf")
    robot, builtin = RobotModel.load(result.description), RobotModel.load("artro")
    for key, value in builtin.description.geometry.model_dump().items():
        assert getattr(robot.description.geometry, key) == pytest.approx(value, abs=1e-3), key
    assert robot.total_mass_kg() == pytest.approx(builtin.total_mass_kg(), rel=0.01)
    angles = np.linspace(-0.4, 0.4, 12)
    np.testing.assert_allclose(
        site_positions(robot, angles), site_positions(builtin, angles), atol=1e-6
    )
    params = builtin_presets()["robust"].gait
    ours = run(params, Motion(a_p=0.07), duration_s=10.0, warmup_s=3.0, robot=robot).metrics
    theirs = run(params, Motion(a_p=0.07), duration_s=10.0, warmup_s=3.0).metrics
    assert ours["fell"] == theirs["fell"] is False
    assert ours["forward_cm_s"] == pytest.approx(theirs["forward_cm_s"], rel=0.05)


# --- meshes -----------------------------------------------------------------------------------


def test_a_mesh_is_found_through_package_dirs_and_a_missing_one_is_named(tmp_path: Path) -> None:
    urdf = tmp_path / "robot.urdf"
    exported_urdf(urdf)
    mesh = '<mesh filename="package://my_robot/meshes/lid.stl"/>'
    lid = f'<collision name="lid"><origin xyz="0 0 0.09"/><geometry>{mesh}</geometry></collision>'
    text = urdf.read_text(encoding="utf-8").replace("</inertial>", "</inertial>" + lid, 1)
    urdf.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=r"package://my_robot/meshes/lid\.stl.*--package-dir"):
        import_robot(urdf, output=tmp_path / "robot.yaml")
    (tmp_path / "ws" / "my_robot" / "meshes").mkdir(parents=True)
    (tmp_path / "ws" / "my_robot" / "meshes" / "lid.stl").write_bytes(box_stl(0.02))
    result = import_robot(
        urdf, output=tmp_path / "robot.yaml", package_dirs=(str(tmp_path / "ws"),)
    )
    robot = RobotModel.load(result.description)
    assert robot.model.nmesh == 1
    assert robot.total_mass_kg() == pytest.approx(RobotModel.load("artro").total_mass_kg())


# --- a robot of bus servos: a sync write per frame, not TDM-PWM -------------------------------


def test_a_bus_servo_robot_gets_its_goals_by_sync_write(tmp_path: Path) -> None:
    robot = op3_imported(tmp_path, forward="+x", servo="XM430-W350")
    hardware = robot.hardware()
    assert hardware.bus == BusLink("dynamixel", 1_000_000)
    angles = np.random.default_rng(3).uniform(-0.4, 0.4, (5, 12))
    _ocr, _sat, setpoint, substep = _servo_setpoints(angles, hardware, 20, 0.001)
    steps = setpoint / (2 * np.pi / 4096)
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)  # 4096 steps a turn
    assert np.abs(setpoint - angles).max() <= np.pi / 4096 + 1e-12
    # a sync write of 12 goals: 14 bytes of head, 5 a servo, a 2-byte CRC: 74 bytes (more
    # where a value needs byte stuffing), 740 µs at 1 Mbit/s: every goal acts in step 1
    assert (substep == 1).all()
    slow = dataclasses.replace(hardware, bus=BusLink("dynamixel", 57_600))
    _ocr, _sat, _set, substep = _servo_setpoints(angles, slow, 20, 0.001)
    assert (substep == 13).all()  # 74 × 10 bits at 57 600 baud: 12.85 ms


def test_a_bus_servo_robot_runs_the_same_in_the_lanes_as_in_artro_run(tmp_path: Path) -> None:
    robot = op3_imported(tmp_path, forward="+x", servo="XM430-W350")
    jobs = [Job(GaitParams(), Motion(a_p=0.05)), Job(GaitParams(), Motion(a_r=0.05))]
    batch = BatchEvaluator(robot=robot, threads=2).evaluate(jobs, duration_s=3.0, warmup_s=1.0)
    single = [
        run(j.params, j.motion, duration_s=3.0, warmup_s=1.0, robot=robot).metrics for j in jobs
    ]
    compared = ("fell", *MOTION_METRICS, "sim_s")  # what the lanes measure, as test_batch
    assert [{k: m[k] for k in compared} for m in batch] == [
        {k: m[k] for k in compared} for m in single
    ]


def test_the_firmware_is_not_built_for_a_robot_of_bus_servos(tmp_path: Path) -> None:
    robot = op3_imported(tmp_path, forward="+x", servo="XM430-W350")
    with pytest.raises(ValueError, match=r"bus servos.*TDM-PWM pulses"):
        wiring(robot)
