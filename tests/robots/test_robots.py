"""Robot descriptions (docs/DESIGN.md §7): the schema refuses what cannot be built or walked and
names the field, the servo table's rule gives the MuJoCo settings, the model is built in code with
the names and sites of docs/DESIGN.md §3, and a second robot of another size works the same way."""

from __future__ import annotations

import copy
import math
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from app.assets import builtin_robots_dir
from app.robots import (
    RobotError,
    build_spec,
    builtin_robot_names,
    load_description,
    model_xml,
    parse_description,
    servo_settings,
    servo_table,
)
from app.robots.checks import eq1_torques, robot_warnings
from app.robots.model import RobotModel
from app.robots.servos import KGF_CM_TO_NM
from gait import ARTRO_LEG, JOINT_NAMES, GaitParams, Motion, joint_angles_with_flags
from hardware import ChannelMap

ROOT = Path(__file__).resolve().parents[2]


def artro_doc() -> dict:
    return yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))


def refused(doc: dict) -> str:
    with pytest.raises(RobotError) as err:
        parse_description(doc, "my.yaml")
    return str(err.value)


# --- the servo table and its rule ------------------------------------------------------------


def test_every_servo_names_its_source_and_states_voltages():
    table = servo_table()
    assert {"MG996R", "MG90S", "SG90", "DS3218", "AX-12A"} <= set(table)
    for spec in table.values():
        assert len(spec.source) > 20 and spec.ratings
    assert table["AX-12A"].signal == "bus" and "TDM-PWM" in table["AX-12A"].assumed.bus


def test_a_datasheet_becomes_mujoco_settings_by_one_rule():
    s = servo_settings("MG996R", 6.0)
    stall = 11.0 * KGF_CM_TO_NM
    speed = math.radians(60) / 0.14
    assert s.stall_torque_nm == pytest.approx(stall)
    assert s.no_load_speed_rad_s == pytest.approx(speed)
    assert s.damping_nm_s_rad == pytest.approx(stall / speed)
    assert s.kp_nm_rad == pytest.approx(stall / 0.24)
    assert not s.interpolated
    # between the datasheet's voltages: linear, and said so
    mid = servo_settings("MG996R", 5.4)
    assert mid.stall_torque_nm == pytest.approx((9.4 + 11.0) / 2 * KGF_CM_TO_NM)
    assert mid.interpolated


@pytest.mark.parametrize(("servo", "volts"), [("MG996R", 7.4), ("SG90", 6.0), ("MG90S", 3.3)])
def test_a_voltage_the_datasheet_does_not_cover_is_refused(servo, volts):
    with pytest.raises(ValueError, match=f"{servo}: the datasheet states figures at"):
        servo_settings(servo, volts)


# --- ArtRo, built from its description ---------------------------------------------------------


ROBOT = RobotModel.load("artro")


def test_artro_is_built_in_code_with_the_names_of_the_design():
    spec = build_spec(ROBOT.description)
    assert spec.compiler.degree is False  # radians, set explicitly
    m = ROBOT.model
    assert [m.joint(i + 1).name for i in range(12)] == list(JOINT_NAMES)  # after the free joint
    assert [m.actuator(i).name for i in range(12)] == list(JOINT_NAMES)
    for site in ("imu", "l_hip", "r_hip", "l_ankle", "r_ankle", "l_sole", "r_sole"):
        m.site(site)
    for sensor in ("imu_gyro", "imu_accel", "l_sole_pos", "r_sole_pos"):
        m.sensor(sensor)
    assert m.body("trunk").jntnum == 1 and m.joint("root").type == mujoco.mjtJoint.mjJNT_FREE
    assert m.joint("l_knee").range[1] == pytest.approx(0.05)  # radians, not degrees
    assert m.opt.timestep == pytest.approx(0.001)


def test_artro_masses_lengths_and_servos_follow_the_description():
    desc = ROBOT.description
    assert ROBOT.total_mass_kg() == pytest.approx(desc.total_mass_kg) == pytest.approx(1.65)
    assert ROBOT.geometry == ARTRO_LEG  # the gait's built-in default is ArtRo's description
    measured = ROBOT.measured_leg_geometry()
    assert measured.upper_m == pytest.approx(0.09) and measured.lower_m == pytest.approx(0.09)
    stall = 11.0 * KGF_CM_TO_NM
    m = ROBOT.model
    np.testing.assert_allclose(m.actuator_forcerange[:, 1], stall)
    np.testing.assert_allclose(m.actuator_gainprm[:, 0], stall / 0.24)
    np.testing.assert_allclose(m.dof_damping[6:], stall / (math.radians(60) / 0.14))
    hw = ROBOT.hardware()
    assert hw.tdm.channel_map == ChannelMap.default()
    np.testing.assert_allclose(hw.calibration.max_rad, np.pi / 2)


def test_the_exported_mjcf_is_the_same_model():
    """MuJoCo writes numbers with six significant digits, so the file is that close."""
    xml = model_xml(ROBOT.description)
    again = mujoco.MjModel.from_xml_string(xml)
    m = ROBOT.model
    for name in ("body_mass", "body_pos", "jnt_axis", "jnt_range", "actuator_gainprm", "geom_size"):
        np.testing.assert_allclose(getattr(again, name), getattr(m, name), rtol=1e-5, err_msg=name)
    assert 'angle="radian"' in xml


def test_the_gait_uses_the_loaded_robots_legs():
    """On a robot with longer legs the same gait bends the knee less for the same eta."""
    doc = artro_doc()
    doc["geometry"]["thigh_m"] = doc["geometry"]["shank_m"] = 0.12
    longer = RobotModel.load(parse_description(doc, "long"))
    phi = np.linspace(-np.pi, np.pi, 16, endpoint=False)
    q_artro = joint_angles_with_flags(GaitParams(), Motion(a_p=0.07), phi, ROBOT.geometry).values
    q_long = joint_angles_with_flags(GaitParams(), Motion(a_p=0.07), phi, longer.geometry).values
    assert longer.geometry.upper_m == 0.12
    np.testing.assert_allclose(q_long, q_artro, atol=1e-12)  # eta drives the knee: equal shape
    from app.sim.frame_loop import FrameLoop

    sim = FrameLoop(longer, motion=Motion(a_p=0.07))
    assert sim.standing_height_m > FrameLoop(ROBOT).standing_height_m + 0.05


# --- refused before anything runs --------------------------------------------------------------


def _set(doc: dict, path: str, value: object) -> dict:
    doc = copy.deepcopy(doc)
    *parents, last = path.split(".")
    node = doc
    for key in parents:
        node = node[key]
    node[last] = value
    return doc


@pytest.mark.parametrize(
    ("path", "value", "named"),
    [
        ("servo", "MG999", "unknown servo 'MG999'"),
        ("joints.l_knee", {"servo": "XYZ"}, "joints.l_knee.servo: unknown servo"),
        ("geometry.thigh_m", 0.0, "geometry.thigh_m"),
        ("geometry.shank_m", -0.09, "geometry.shank_m"),
        ("total_mass_kg", 1.7, "total_mass_kg: the parts add up to 1.6500 kg"),
        ("links.thigh", [{"name": "plates", "mass_kg": -0.03}], "links.thigh.0.mass_kg"),
        ("joints.r_knee", {"range_rad": [-0.3, 0.05]}, "joints.r_knee.range_rad"),
        ("tdm_channels.OC1C", ["l_ankle_roll", "l_knee"], "l_knee is on both"),
        (
            "tdm_channels.OC1A",
            ["l_hip_yaw", "l_hip_roll", "l_hip_pitch", "l_knee", "l_ankle_pitch", "l_ankle_roll"],
            "at most 5 pulses per line",
        ),
        ("tdm_channels.OC9A", ["l_knee"], "unknown line 'OC9A'"),
        (
            "joints.l_hip_yaw",
            {"calibration": {"pulse_min_us": 550}},
            "joints.l_hip_yaw.calibration",
        ),
        ("joints.l_hip_yaw", {"servo": "AX-12A"}, "AX-12A is a bus servo"),
        ("contact.friction", 1.3, "contact.friction"),
        ("supply_voltage_v", 7.4, "the datasheet states figures at 4.8 V and 6 V only"),
        ("surprise", 1, "surprise"),
    ],
)
def test_a_bad_description_is_refused_naming_the_field(path, value, named):
    doc = _set(artro_doc(), path, value)
    if path == "joints.l_hip_yaw" and value.get("servo") == "AX-12A":
        doc["total_mass_kg"] = 1.65 - 0.055 + 0.0546
    message = refused(doc)
    assert named in message, message
    assert message.startswith("my.yaml is not a valid robot description")


def test_a_pwm_servo_outside_its_pulse_range_is_refused():
    doc = _set(artro_doc(), "joints.l_knee", {"servo": "SG90", "range_rad": [-1.5708, 0.05]})
    doc["joints"]["l_knee"]["calibration"] = {"pulse_max_us": 2400}
    doc["supply_voltage_v"] = 4.8
    doc["servo"] = "SG90"
    doc["total_mass_kg"] = 1.65 - 12 * (0.055 - 0.009)
    parse_description(doc, "sg90")  # 2400 µs is inside the SG90's 500-2400
    doc["joints"]["l_knee"]["calibration"] = {"pulse_min_us": 600, "pulse_max_us": 2450}
    assert "pulse_max_us" in refused(doc) or "2450" in refused(doc)


def test_a_servo_too_weak_for_its_load_gets_a_warning_with_the_numbers():
    doc = artro_doc()
    doc["servo"], doc["supply_voltage_v"] = "SG90", 4.8
    doc["total_mass_kg"] = round(1.65 - 12 * (0.055 - 0.009), 4)
    weak = parse_description(doc, "weak")
    warnings = robot_warnings(weak)
    assert any("l_hip_roll: the SG90 stalls at 0.177 N·m, eq (1) asks" in w for w in warnings)
    assert robot_warnings(ROBOT.description) == []  # ArtRo's MG996R hold their static loads
    torques = {t.joint: t for t in eq1_torques(ROBOT.description)}
    assert torques["l_hip_roll"].standing_nm > 0.3  # standing on one leg, weight beside it
    assert torques["l_knee"].gait_worst_nm > torques["l_knee"].standing_nm  # a bent knee


def test_figures_between_datasheet_voltages_are_said_for_every_joint_once():
    doc = artro_doc()
    doc["joints"]["r_knee"]["servo"] = "DS3218"
    doc["joints"]["r_ankle_pitch"] = {**doc["joints"].get("r_ankle_pitch", {}), "servo": "DS3218"}
    doc.pop("total_mass_kg", None)
    (said,) = [w for w in robot_warnings(parse_description(doc, "two")) if "interpolated" in w]
    assert said.startswith("joints r_knee, r_ankle_pitch: the DS3218's figures at ")  # both


def test_an_unknown_robot_or_file_says_what_there_is():
    with pytest.raises(RobotError, match="the built-in robots are artro, micro"):
        load_description("nao")
    with pytest.raises(RobotError, match="no robot description file"):
        load_description("missing/robot.yaml")


# --- the second robot --------------------------------------------------------------------------


def test_the_micro_robot_is_half_the_size_and_a_quarter_of_the_mass():
    assert builtin_robot_names()[:1] == ["artro"] and "micro" in builtin_robot_names()
    micro = RobotModel.load("micro")
    assert micro.geometry.max_length_m == pytest.approx(ARTRO_LEG.max_length_m / 2)
    assert micro.total_mass_kg() == pytest.approx(1.65 / 4, rel=0.02)
    assert {micro.description.joint_servo(j) for j in JOINT_NAMES} == {"MG90S"}
    assert micro.model.actuator_forcerange[0, 1] == pytest.approx(2.2 * KGF_CM_TO_NM)
    assert robot_warnings(micro.description) == []
    from app.params.presets import builtin_presets

    preset = builtin_presets()[micro.description.default_preset]
    assert preset.robot == "micro"


def test_artro_robot_commands(tmp_path):
    def artro(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "app.cli", *args], capture_output=True, text=True, cwd=ROOT
        )

    listed = artro("robot", "list")
    assert listed.returncode == 0 and "artro" in listed.stdout and "micro" in listed.stdout
    bad = tmp_path / "my.yaml"
    bad.write_text(yaml.safe_dump(_set(artro_doc(), "geometry.thigh_m", -1)), encoding="utf-8")
    checked = artro("robot", "check", str(bad))
    assert checked.returncode == 2 and "geometry.thigh_m" in checked.stderr, checked.stderr
    out = tmp_path / "micro.xml"
    assert artro("robot", "export-mjcf", "micro", "-o", str(out)).returncode == 0
    assert mujoco.MjModel.from_xml_path(str(out)).nu == 12
