"""What the studio tells a builder whose robot cannot walk (issue 32, docs/DESIGN.md §7): `artro
robot check` names the lightest servo that carries each joint eq (1) finds short, `--suggest`
writes the robot with those servos, and a run that falls says in one line when, toward which
side, and which servos sat at their torque limit -- the installed command, a real simulation."""

from __future__ import annotations

import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from app.assets import builtin_robots_dir
from app.robots import load_description
from app.robots.checks import eq1_torques
from app.robots.servos import rating_at, servo_table
from app.robots.swap import mirror
from app.sim.headless import diagnose, fall_side

ARTRO = shutil.which("artro", path=str(Path(sys.executable).parent)) or "artro"


def artro(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([ARTRO, *args], capture_output=True, text=True, timeout=300)


@pytest.fixture
def weak(tmp_path) -> Path:
    """ArtRo with an SG90 on every joint at 4.8 V: eight joints short by eq (1)."""
    doc = yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))
    doc["name"], doc["servo"], doc["supply_voltage_v"] = "weak", "SG90", 4.8
    doc["total_mass_kg"] = round(1.65 - 12 * (0.055 - 0.009), 4)
    path = tmp_path / "weak.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def test_check_names_the_lightest_servo_that_carries_each_short_joint(weak):
    out = artro("robot", "check", str(weak))
    assert out.returncode == 0, out.stderr
    short = [t for t in eq1_torques(load_description(weak)) if t.margin < 0]
    assert len(short) == 8
    table = servo_table()
    for t in short:
        lines = out.stdout.splitlines()
        (line,) = [x for x in lines if x.strip().startswith(f"advice: {t.joint}:")]
        name = re.search(r"is the (\S+) \(", line)[1]
        carried = rating_at(table[name], 4.8, name)[0]
        assert carried >= t.required_nm  # it carries the joint ...
        lighter = [  # ... and no lighter PWM servo of the table does
            n for n, s in table.items()
            if s.signal == "pwm" and s.mass_kg < table[name].mass_kg
            and (stall_at(n, 4.8) or 0.0) >= t.required_nm
        ]  # fmt: skip
        assert lighter == [], line


def test_suggest_never_writes_over_the_description_it_read(weak):
    """The README's quick start wrote `--suggest -o my.yaml` over my.yaml: 71 lines of a
    builder's notes became 346 without a comment."""
    before = weak.read_text(encoding="utf-8")
    out = artro("robot", "check", str(weak), "--suggest", "-o", str(weak))
    assert out.returncode == 2 and "is the description read" in out.stderr
    assert "give another file, e.g. -o weak-suggested.yaml" in out.stderr
    assert weak.read_text(encoding="utf-8") == before


def stall_at(name: str, volts: float) -> float | None:
    """A servo's stall torque at `volts`, N·m (None: not rated there)."""
    try:
        return rating_at(servo_table()[name], volts, name)[0]
    except ValueError:
        return None


def test_suggest_writes_a_robot_whose_servos_carry_it(weak, tmp_path):
    out = artro("robot", "check", str(weak), "--suggest", "-o", str(tmp_path / "strong.yaml"))
    assert out.returncode == 0, out.stderr
    assert "l_hip_roll: SG90 -> MG996R" in out.stdout and "next: artro robot check" in out.stdout
    strong = load_description(tmp_path / "strong.yaml")
    assert all(t.margin >= 0 for t in eq1_torques(strong))  # eq (1) holds on every joint
    # built alike on both legs, it stays so (a symmetric robot had got one hip roll swapped)
    assert all(strong.joint_servo(j) == strong.joint_servo(mirror(j)) for j in strong.joints)
    before = load_description(weak)
    table = servo_table()
    moved = sum(
        table[strong.joint_servo(j)].mass_kg - table[before.joint_servo(j)].mass_kg
        for j in strong.joints
    )  # the masses follow the servos
    assert math.isclose(strong.total_mass_kg, before.total_mass_kg + moved, abs_tol=1e-6)
    again = artro("robot", "check", str(tmp_path / "strong.yaml"))
    assert again.returncode == 0 and "warning" not in again.stdout
    nothing = artro("robot", "check", "artro", "--suggest", "-o", str(tmp_path / "x.yaml"))
    # the quick start's next line reads -o's file: it gets the robot as it is (the README's)
    assert "no servo to change: -o" in nothing.stdout and nothing.returncode == 0
    kept = load_description(tmp_path / "x.yaml")
    assert kept.name == "artro-suggested" and kept.joints == load_description("artro").joints


def test_a_run_that_falls_says_why_in_one_line_and_counts_torque_limit_frames(weak):
    out = artro("run", "--robot", str(weak), "--motion", "0,0.05,0", "--duration", "6",
                "--warmup", "1", "--json")  # fmt: skip
    assert out.returncode == 1, out.stderr  # 1: it fell
    m = json.loads(out.stdout)
    assert m["fell"] and m["flags"]["torque_limit_frames"] > 0
    (line,) = [x for x in out.stderr.splitlines() if x.startswith("artro run: fell at")]
    assert f"fell at {m['fall_time_s']:.2f} s toward its " in line
    assert re.search(r"servos at their torque limit beyond a walk.s usual share in the last 1 s "
                     r"\(\d+ frames\): \w+ \d+", line)  # fmt: skip
    assert f"artro robot check {weak} --suggest" in line and f"--robot {weak}" in line
    walking = artro("run", "--motion", "0,0.05,0", "--duration", "6", "--warmup", "1", "--json")
    assert "fell at" not in walking.stderr and not json.loads(walking.stdout)["fell"]


def test_the_advice_after_a_fall_never_sends_to_a_command_with_nothing_to_do():
    """`--suggest` was advised where eq (1) passes every servo (it then said "no servo to
    change"), and a tune where the set in use was that robot's own tune."""
    from app.cli.run import fall_advice
    from app.params.presets import builtin_presets
    from app.robots.model import RobotModel

    artro_robot, presets = RobotModel.load("artro"), builtin_presets()
    own = fall_advice(artro_robot, presets["robust"], ("l_knee", "r_knee"), "artro")
    assert "--suggest" not in own and "a gait tuned for this robot" not in own
    assert own == (
        "stronger servos on l_knee, r_knee (eq (1) carries them standing, walking asks more: "
        "the DS3218 of the table, or a servo of your own in the file's `servos`) or a smaller "
        "motion, or a longer tune of 'robust' (artro tune --robot artro --base robust with more "
        "--generations)"
    )
    other = fall_advice(artro_robot, presets["micro-tuned"], (), "artro")
    assert other == "a gait tuned for this robot (artro tune --robot artro)"


@pytest.mark.parametrize(
    ("axis", "angle", "side"),
    [((0, 1, 0), 0.9, "front"), ((0, 1, 0), -0.9, "back"), ((1, 0, 0), -0.9, "left"),
     ((1, 0, 0), 0.9, "right")],
)  # fmt: skip
def test_the_side_of_a_fall_is_the_trunks_own(axis, angle, side):
    """Pitching about y (forward, nose down: +), rolling about x (right side down: +), at any
    heading: the side is the trunk's own, not the world's."""
    for heading in (0.0, 1.2, -2.5):
        tilt = np.array([math.cos(angle / 2), *(math.sin(angle / 2) * np.array(axis))])
        turn = np.array([math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2)])
        w1, x1, y1, z1 = turn
        w2, x2, y2, z2 = tilt
        quat = np.array([
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ])  # fmt: skip
        found, degrees = fall_side(quat)
        assert found == side and math.isclose(degrees, math.degrees(abs(angle)), abs_tol=1e-6)
    assert "no servo at its torque limit" in diagnose(1.0, quat, np.zeros((50, 12), bool))


def test_check_and_suggest_offer_the_files_own_servo_without_a_total_mass(tmp_path):
    """A builder's own servo in the file (lighter and stronger than the table's that carry the
    weak joints) is the one named and swapped in; with no total_mass_kg, the parts' sum."""
    from tests.robots.test_robot_servos_own import MEASURED

    doc = yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))
    doc["name"], doc["servo"], doc["supply_voltage_v"] = "weak-own", "SG90", 4.8
    del doc["total_mass_kg"]
    doc["servos"] = {"BUILDER-40G": MEASURED}
    path = tmp_path / "weak-own.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    out = artro("robot", "check", str(path))
    assert out.returncode == 0, out.stderr
    advice = [x for x in out.stdout.splitlines() if x.strip().startswith("advice:")]
    assert len(advice) == 8 and all("is the BUILDER-40G (" in x for x in advice), advice
    out = artro("robot", "check", str(path), "--suggest", "-o", str(tmp_path / "strong.yaml"))
    assert out.returncode == 0, out.stderr
    assert "SG90 -> BUILDER-40G" in out.stdout and "wrote" in out.stdout
    strong = load_description(tmp_path / "strong.yaml")
    assert all(t.margin >= 0 for t in eq1_torques(strong))


def artro_doc() -> dict:
    return yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))


def with_trunk_times(factor: float, name: str, folder: Path) -> Path:
    """ArtRo with its trunk's parts `factor` times as heavy, written as NAME.yaml in `folder`."""
    doc = artro_doc()
    doc["name"] = name
    for part in doc["trunk"]:
        part["mass_kg"] = round(factor * part["mass_kg"], 6)
    doc.pop("total_mass_kg", None)
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def test_eq1_covers_the_robots_own_gait_not_only_the_papers(tmp_path):
    """ArtRo with three times its trunk: the paper's poses leave the knees a third to spare, its
    default preset's (robust) ask more than their MG996R gives. The check used the paper's
    alone, so `--suggest` cleared a robot that could not step."""
    from app.robots.gait_reach import preset_gait
    from gait import GaitParams

    path = with_trunk_times(3, "heavy", tmp_path)
    heavy = load_description(path)
    paper = {t.joint: t for t in eq1_torques(heavy, GaitParams())}
    own = {t.joint: t for t in eq1_torques(heavy, preset_gait(heavy.default_preset))}
    checked = {t.joint: t for t in eq1_torques(heavy)}
    assert paper["l_knee"].margin > 0.2 and own["l_knee"].margin < 0  # the two gaits differ
    for joint, t in checked.items():  # the check takes the worse of the two
        assert t.required_nm == max(paper[joint].required_nm, own[joint].required_nm)
    out = artro("robot", "check", str(path))
    assert re.search(r"l_knee: the MG996R stalls at .* short", out.stdout + out.stderr)


def test_a_range_that_holds_the_papers_reach_but_not_the_default_presets_is_refused(tmp_path):
    """Joint ranges just wide enough for the paper's constants passed, and the robot's own
    preset (then robust) walked into its limits: 59 % slower forward, 86 % sideways."""
    from app.robots.gait_reach import REACH_CASES, REACH_PHASES
    from gait import JOINT_NAMES, GaitParams, LegGeometry, joint_angles_with_flags

    doc = artro_doc()
    geometry = LegGeometry(upper_m=doc["geometry"]["thigh_m"], lower_m=doc["geometry"]["shank_m"])
    phases = np.linspace(-math.pi, math.pi, REACH_PHASES, endpoint=False)
    poses = np.concatenate(
        [joint_angles_with_flags(GaitParams(), m, phases, geometry).values for m in REACH_CASES]
    )
    doc["name"] = "narrow"
    for i, joint in enumerate(JOINT_NAMES):  # the paper's reach and a hair more
        if joint.endswith("knee"):
            continue  # the knees' own check: from the shortest leg to straight
        low, high = float(poses[:, i].min()) - 0.01, float(poses[:, i].max()) + 0.01
        doc["joints"].setdefault(joint, {})["range_rad"] = [min(low, -0.01), max(high, 0.01)]
    path = tmp_path / "narrow.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    out = artro("robot", "check", str(path))
    assert out.returncode == 2
    assert f"default_preset '{doc['default_preset']}' walking forward, backward, sideways" in \
        out.stderr  # fmt: skip


def test_suggest_fails_when_no_servo_carries_a_joint(tmp_path):
    """It said that none carries some joint and exited 0, as if the robot were fine."""
    path = with_trunk_times(12, "anvil", tmp_path)
    out = artro("robot", "check", str(path), "--suggest", "-o", str(tmp_path / "out.yaml"))
    assert out.returncode == 1, out.stdout + out.stderr
    assert "no servo of the table or the file carries" in out.stdout
    assert "eq (1) still fails there (exit status 1)" in out.stdout  # what it wrote is not enough
