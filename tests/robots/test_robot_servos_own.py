"""A robot file's own servos (issue 32 item 1, docs/DESIGN.md §7): validated as the table's, named
by joints as the table's are, carried into the model and the eq (1) advice; a table name is
refused with its file and line. The servos the table gained load, each with its source."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import pytest
import yaml

from app.assets import builtin_robots_dir
from app.params.presets import builtin_presets
from app.robots import RobotDescription, RobotError, load_description, parse_description
from app.robots.checks import eq1_torques
from app.robots.model import RobotModel
from app.robots.servos import KGF_CM_TO_NM, rating_at, servo_table
from app.robots.swap import lightest_servo, suggest_servos, write_description
from app.sim.headless import run
from gait import Motion

ARTRO = yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))
#: a servo a builder measured: 14 kgf·cm at 6 V from a 10 cm arm on a kitchen scale
MEASURED = {
    "maker": "a builder",
    "signal": "pwm",
    "source": "measured: stall on a 10 cm arm pressing a kitchen scale at 6 V; speed filmed",
    "ratings": [
        {"voltage_v": 4.8, "stall_torque_kgf_cm": 12.0, "speed_s_per_60deg": 0.18},
        {"voltage_v": 6.0, "stall_torque_kgf_cm": 14.0, "speed_s_per_60deg": 0.15},
    ],
    "mass_kg": 0.040,
    "case_mm": [42.0, 20.0, 40.5],
    "pulse_min_us": 500,
    "pulse_max_us": 2500,
    "travel_deg": 180,
    "assumed": {
        "saturation_error_rad": 0.24,
        "saturation_error": "as the table's MG996R (guess)",
        "armature_kg_m2": 0.005,
        "frictionloss_nm": 0.02,
    },
}
NEW_SERVOS = ("MG995", "DS3225", "LX-16A", "STS3215", "XL430-W250")


def with_own_servo(name: str = "KNEE-M", joints: tuple[str, ...] = ("l_knee", "r_knee")) -> dict:
    doc = copy.deepcopy(ARTRO)
    doc["name"] = "own"
    del doc["total_mass_kg"]  # the parts' sum: the servo's mass differs from the MG996R's
    doc["servos"] = {name: copy.deepcopy(MEASURED)}
    for joint in joints:
        doc["joints"][joint]["servo"] = name
    return doc


def load_description_doc(doc: dict) -> RobotDescription:
    return parse_description(doc, "own.yaml")


def written(tmp_path: Path, doc: dict, name: str = "own.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return path


def test_a_robot_with_its_own_knee_servo_is_built_with_its_figures_and_walks(tmp_path):
    robot = RobotModel.load(written(tmp_path, with_own_servo()))
    knee = robot.model.actuator("l_knee").id
    assert robot.model.actuator_forcerange[knee, 1] == pytest.approx(14.0 * KGF_CM_TO_NM)
    hip = robot.model.actuator("l_hip_pitch").id
    assert robot.model.actuator_forcerange[hip, 1] == pytest.approx(11.0 * KGF_CM_TO_NM)
    assert robot.total_mass_kg() == pytest.approx(1.65 - 2 * (0.055 - 0.040))
    result = run(
        builtin_presets()["tuned"].gait,
        Motion(a_p=0.05),
        duration_s=4.0,
        warmup_s=1.0,
        robot=robot,
    )
    assert not result.metrics["fell"], result.diagnosis
    assert result.metrics["forward_cm_s"] > 0.5


def test_a_servo_named_like_one_of_the_table_is_refused_with_file_and_line(tmp_path):
    path = written(tmp_path, with_own_servo("MG996R"))
    line = path.read_text(encoding="utf-8").splitlines().index("  MG996R:") + 1
    with pytest.raises(RobotError) as err:
        load_description(path)
    message = str(err.value)
    assert message.startswith(f"{path} is not a valid robot description"), message
    assert "servos.MG996R: MG996R is a servo of the table (models/servos.yaml)" in message
    assert f"(line {line})" in message, message


@pytest.mark.parametrize(
    ("field", "value", "said"),
    [
        ("stall", "14", "Input should be a valid number"),
        ("stall", math.inf, "Input should be a finite number"),
        ("pulse_min_us", None, "a pwm servo states its pulse range"),
        ("source", "", "String should have at least 1 character"),
        ("ratings", [], "should have at least 1 item"),
        ("surprise", 1, "Extra inputs are not permitted"),
    ],
)
def test_an_own_servo_is_validated_as_the_tables_are(field, value, said):
    doc = with_own_servo()
    servo = doc["servos"]["KNEE-M"]
    if field == "stall":
        servo["ratings"][0]["stall_torque_kgf_cm"] = value
    else:
        servo[field] = value
    with pytest.raises(RobotError) as err:
        load_description_doc(doc)
    assert "servos.KNEE-M" in str(err.value) and said in str(err.value), str(err.value)


def test_an_own_bus_servo_is_refused_where_the_tdm_pwm_drive_is_concerned():
    doc = with_own_servo()
    doc["servos"]["KNEE-M"] |= {"signal": "bus", "pulse_min_us": None, "pulse_max_us": None}
    with pytest.raises(RobotError, match="KNEE-M is a bus servo; the TDM-PWM output"):
        load_description_doc(doc)


@pytest.mark.parametrize("name", NEW_SERVOS)
def test_every_new_servo_of_the_table_has_its_source_and_says_what_is_assumed(name):
    spec = servo_table()[name]
    assert spec.maker in spec.source or name.split("-")[0] in spec.source
    assert any(ch.isdigit() for ch in spec.source) and " V" in spec.source
    for rating in spec.ratings:  # every line is rated: a voltage inside gives its figures
        stall_nm, speed_rad_s, interpolated = rating_at(spec, rating.voltage_v, name)
        assert stall_nm > 0.5 and speed_rad_s > 0 and not interpolated
    reasons = spec.assumed.model_extra or {}
    assert reasons, f"{name}: the assumed values say why"
    if spec.signal == "bus":
        assert "TDM-PWM" in reasons["bus"] and spec.pulse_min_us is None
    else:
        assert spec.pulse_min_us is not None and spec.pulse_max_us is not None


def test_a_table_pwm_servo_can_be_swapped_in_and_a_new_bus_servo_cannot():
    doc = copy.deepcopy(ARTRO)
    doc["joints"]["l_knee"]["servo"] = "MG995"
    doc["total_mass_kg"] = None
    assert load_description_doc(doc).joint_servo("l_knee") == "MG995"
    doc["joints"]["l_knee"]["servo"] = "STS3215"
    with pytest.raises(RobotError, match="STS3215 is a bus servo"):
        load_description_doc(doc)


def test_the_eq1_advice_names_the_files_own_servo_when_it_is_the_lightest(tmp_path):
    """SG90s at 4.8 V are short on eight joints; the file's 40 g servo carries them, lighter
    than the table's 55 g MG995 and MG996R: the advice and --suggest name it."""
    doc = with_own_servo(joints=())
    doc["servo"], doc["supply_voltage_v"] = "SG90", 4.8
    weak = load_description_doc(doc)
    short = [t for t in eq1_torques(weak) if t.margin < 0]
    assert short
    own = 12.0 * KGF_CM_TO_NM
    for t in short:
        assert t.required_nm < own
        table_only = lightest_servo(t.required_nm, 4.8)
        assert table_only is not None and table_only.name != "KNEE-M"
        both = lightest_servo(t.required_nm, 4.8, servos=weak.servo_catalogue())
        assert both is not None and both.name == "KNEE-M" and both.mass_kg == 0.040
    found = suggest_servos(weak, lambda r: {t.joint: t.required_nm for t in eq1_torques(r)})
    assert {new for _, _, new, _ in found.swaps} == {"KNEE-M"} and not found.uncarried
    path = write_description(found.robot, tmp_path / "suggested.yaml")
    again = load_description(path)
    assert again.servos["KNEE-M"] == weak.servos["KNEE-M"]
    assert all(t.margin >= 0 for t in eq1_torques(again))
    assert {again.joint_servo(j) for j, *_ in found.swaps} == {"KNEE-M"}
