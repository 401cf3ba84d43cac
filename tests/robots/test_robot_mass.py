"""Masses a builder can give (issue 32 item 2, docs/DESIGN.md §7): `total_mass_kg` is optional
(the parts' sum is used and `artro robot check` prints it); a stated total is checked against a
kitchen scale's honest tolerance, 2 % of the parts or 5 g, whichever is larger, beyond which it
is refused naming both figures and the tolerance."""

from __future__ import annotations

import copy
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from app.assets import builtin_robots_dir
from app.robots import RobotError, parse_description
from app.robots.checks import robot_warnings
from app.robots.description import mass_tolerance_kg
from app.robots.model import RobotModel
from app.robots.swap import with_servo

ARTRO = yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))
MICRO = yaml.safe_load((builtin_robots_dir() / "micro.yaml").read_text(encoding="utf-8"))
ARTRO_CMD = shutil.which("artro", path=str(Path(sys.executable).parent)) or "artro"


def stated(doc: dict, total_kg: float | None) -> dict:
    doc = copy.deepcopy(doc)
    if total_kg is None:
        del doc["total_mass_kg"]
    else:
        doc["total_mass_kg"] = total_kg
    return doc


def test_the_tolerance_is_two_percent_of_the_parts_or_five_grams():
    assert mass_tolerance_kg(1.65) == pytest.approx(0.033)  # ArtRo
    assert mass_tolerance_kg(0.4128) == pytest.approx(0.008256)  # micro
    assert mass_tolerance_kg(0.1) == pytest.approx(0.005)  # the floor: wires alone differ
    assert mass_tolerance_kg(0.25) == pytest.approx(0.005)  # where the two meet


def test_without_a_total_the_parts_sum_is_used(tmp_path):
    desc = parse_description(stated(ARTRO, None), "artro-unweighed")
    assert desc.total_mass_kg is None
    assert desc.parts_mass_kg() == pytest.approx(1.65)
    assert RobotModel.load(desc).total_mass_kg() == pytest.approx(1.65)
    assert not any("total_mass_kg" in w for w in robot_warnings(desc))
    swapped = with_servo(desc, ["l_knee", "r_knee"], "DS3218")  # nothing stated, nothing moved
    assert swapped.total_mass_kg is None
    assert swapped.parts_mass_kg() == pytest.approx(1.65 + 2 * (0.060 - 0.055))


def test_robot_check_prints_the_parts_sum_of_a_robot_without_a_total(tmp_path):
    doc = stated(ARTRO, None)
    doc["name"] = "unweighed"
    path = tmp_path / "unweighed.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    out = subprocess.run(
        [ARTRO_CMD, "robot", "check", str(path)], capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert "unweighed: valid; 1.650 kg" in out.stdout, out.stdout


@pytest.mark.parametrize(
    ("doc", "off_kg"),
    [(ARTRO, 0.030), (ARTRO, -0.030), (MICRO, 0.008), (MICRO, -0.007)],
)
def test_a_total_within_a_scales_tolerance_is_taken_with_a_warning(doc, off_kg):
    parts = parse_description(stated(doc, None), "parts").parts_mass_kg()
    desc = parse_description(stated(doc, round(parts + off_kg, 4)), "weighed")
    assert desc.parts_mass_kg() == pytest.approx(parts)
    assert RobotModel.load(desc).total_mass_kg() == pytest.approx(parts)  # the model: parts
    (said,) = [w for w in robot_warnings(desc) if w.startswith("total_mass_kg")]
    assert f"{desc.total_mass_kg:.3f} kg" in said and f"{parts:.3f} kg" in said
    assert f"{1000 * off_kg:+.0f} g" in said, said


@pytest.mark.parametrize(
    ("doc", "total_kg", "said"),
    [
        (ARTRO, 1.69, "the parts add up to 1.6500 kg (links and 12 servos), 40 g from the "
         "stated 1.6900 kg; allowed: ±33 g"),
        (ARTRO, 1.60, "the parts add up to 1.6500 kg (links and 12 servos), 50 g from the "
         "stated 1.6000 kg; allowed: ±33 g"),
        (MICRO, 0.4228, "the parts add up to 0.4128 kg (links and 12 servos), 10 g from the "
         "stated 0.4228 kg; allowed: ±8 g"),
    ],
)  # fmt: skip
def test_a_total_beyond_the_tolerance_is_refused_naming_both_figures(doc, total_kg, said):
    with pytest.raises(RobotError) as err:
        parse_description(stated(doc, total_kg), "my.yaml")
    message = str(err.value)
    assert message.startswith("my.yaml is not a valid robot description")
    assert f"total_mass_kg: {said}" in message, message
    assert "leave total_mass_kg out to use the parts' sum" in message


def test_a_refused_total_names_its_line_in_the_file(tmp_path):
    path = tmp_path / "heavy.yaml"
    text = (builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8")
    path.write_text(text.replace("total_mass_kg: 1.65", "total_mass_kg: 1.75"), encoding="utf-8")
    line = text.splitlines().index("total_mass_kg: 1.65") + 1
    with pytest.raises(RobotError, match=rf"allowed: ±33 g.* \(line {line}\)"):
        RobotModel.load(path)


def test_the_built_in_robots_state_their_parts_exactly():
    for doc in (ARTRO, MICRO):
        desc = parse_description(doc, doc["name"])
        assert desc.total_mass_kg == pytest.approx(desc.parts_mass_kg(), abs=5e-4)
        assert not any(w.startswith("total_mass_kg") for w in robot_warnings(desc))


def test_robot_check_names_the_robot_as_the_user_wrote_it(tmp_path):
    doc = stated(ARTRO, None)
    doc["name"] = "my"
    path = tmp_path / "other.yaml"  # a file named otherwise than the robot in it
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    out = subprocess.run(
        [ARTRO_CMD, "robot", "check", str(path)], capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith(f"{path} (robot my): valid; 1.650 kg"), out.stdout
