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
    assert "no servo to change" in nothing.stdout and not (tmp_path / "x.yaml").exists()


def test_a_run_that_falls_says_why_in_one_line_and_counts_torque_limit_frames(weak):
    out = artro("run", "--robot", str(weak), "--motion", "0,0.05,0", "--duration", "6",
                "--warmup", "1", "--json")  # fmt: skip
    assert out.returncode == 0, out.stderr
    m = json.loads(out.stdout)
    assert m["fell"] and m["flags"]["torque_limit_frames"] > 0
    (line,) = [x for x in out.stderr.splitlines() if x.startswith("artro run: fell at")]
    assert f"fell at {m['fall_time_s']:.2f} s toward its " in line
    assert re.search(r"servos at their torque limit in the last 1 s \(\d+ frames\): \w+ \d+", line)
    assert f"artro robot check {weak} --suggest" in line and f"--robot {weak}" in line
    walking = artro("run", "--motion", "0,0.05,0", "--duration", "6", "--warmup", "1", "--json")
    assert "fell at" not in walking.stderr and not json.loads(walking.stdout)["fell"]


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
    from tests.test_robot_servos_own import MEASURED

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
