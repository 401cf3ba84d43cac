"""Robots that cannot be, and files that say what they mean in other words: what the fourteenth
session's probe of robot descriptions found. Each is refused naming the field, or read as meant."""

from __future__ import annotations

import copy
import json
import subprocess
import sys

import pytest
import yaml

from app.assets import builtin_robots_dir
from app.robots import RobotError, load_description, parse_description
from app.robots.library import MAX_LISTED_ERRORS
from app.robots.model import RobotModel
from app.robots.swap import derived_name
from tests.robots.test_robot_servos_own import MEASURED

ARTRO_TEXT = (builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8")


def artro_doc(name: str = "mine") -> dict:
    doc = yaml.safe_load(ARTRO_TEXT)
    doc["name"] = name
    return doc


def artro(*args: str, cwd=None) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "app.cli", *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=cwd)


@pytest.mark.parametrize(
    ("where", "field"),
    [(("trunk", 0), "trunk.0"), (("links", "thigh", 0), "links.thigh.0")],
)
def test_a_colliding_part_inside_the_floor_is_refused_naming_it(where, field):
    """A box 30 cm below its body, colliding: the model threw the robot metres up, and runs
    said it walked."""
    doc = artro_doc()
    node = doc
    for key in where:
        node = node[key]
    node.update(box_m=[0.04, 0.04, 0.04], pos_m=[0.0, 0.0, -0.3], collides=True)
    node.pop("capsule_radius_m", None)
    desc = parse_description(doc, "mine.yaml")  # valid as a document: the model finds it
    with pytest.raises(ValueError, match=rf"^{field}: a colliding part starts \d+ mm inside"):
        RobotModel.load(desc)
    node.update(collides=False)  # the same part, drawn only: nothing touches the floor
    RobotModel.load(parse_description(doc, "mine.yaml"))


@pytest.mark.parametrize(
    ("path", "value", "said"),
    [
        (("assumed", "saturation_error_rad"), 1e-12, "assumed.saturation_error_rad: Input should"),
        (("ratings", 0, "speed_s_per_60deg"), 5e-324, "ratings.0.speed_s_per_60deg: Input should"),
        (("mass_kg",), 1e-9, "mass_kg: Input should be greater than or equal to 0.001"),
    ],
)
def test_a_servo_figure_that_makes_no_servo_is_refused(path, value, said):
    """A saturation error of 5e-324 rad made the gain infinite: `run` blew up, `robot show
    --json` failed on the infinity, and `bench robust` called every run a fall."""
    servo = copy.deepcopy(MEASURED)
    node = servo
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    doc = artro_doc()
    doc["servos"] = {"MINE-1": servo}
    doc["joints"]["l_knee"]["servo"] = "MINE-1"
    del doc["total_mass_kg"]
    with pytest.raises(RobotError, match=f"servos.MINE-1.{said}"):
        parse_description(doc, "mine.yaml")


def test_numbers_with_an_exponent_are_numbers_in_yaml_and_json(tmp_path):
    """YAML 1.1 read `4e-3` (no dot) as a string, so `robot show --json`'s own output, saved
    as .json, was refused as "not a valid number"."""
    text = ARTRO_TEXT.replace("name: artro", "name: mine", 1)
    text = text.replace("foot_thickness_m: 0.004", "foot_thickness_m: 4e-3", 1)
    assert "4e-3" in text
    (tmp_path / "mine.yaml").write_text(text, encoding="utf-8")
    mine = load_description(tmp_path / "mine.yaml")
    assert mine.geometry.foot_thickness_m == 0.004
    servo = copy.deepcopy(MEASURED)
    servo["assumed"]["armature_kg_m2"] = 5e-05  # a small servo's rotor
    doc = artro_doc()
    doc["servos"] = {"MINE-1": servo}
    doc["joints"]["l_knee"]["servo"] = doc["joints"]["r_knee"]["servo"] = "MINE-1"
    del doc["total_mass_kg"]
    (tmp_path / "mine.yaml").write_text(yaml.safe_dump(doc), encoding="utf-8")
    shown = artro("robot", "show", str(tmp_path / "mine.yaml"), "--json")
    assert shown.returncode == 0, shown.stderr
    written = json.dumps(json.loads(shown.stdout)["description"])
    assert "5e-05" in written  # json writes small numbers with an exponent: what failed
    (tmp_path / "mine-copy.json").write_text(written, encoding="utf-8")
    assert load_description(tmp_path / "mine-copy.json") == parse_description(doc, "mine")


def test_a_file_of_many_errors_lists_a_few_and_counts_the_rest(tmp_path):
    path = tmp_path / "many.yaml"
    path.write_text("trunk: [" + ", ".join(["0"] * 500) + "]\n", encoding="utf-8")
    with pytest.raises(RobotError) as err:
        load_description(path)
    lines = str(err.value).splitlines()
    assert len(lines) == 1 + MAX_LISTED_ERRORS + 1, lines[-3:]
    assert lines[-1].strip().startswith("... and ") and lines[-1].endswith(" more")
    path.write_text("trunk: [" + "0," * 120_000 + "0]\n", encoding="utf-8")  # under 256 KiB
    with pytest.raises(RobotError, match=r"many.yaml, line 1, column \d+: more than 20,000 values"):
        load_description(path)  # 12 s and 120 010 lines before the count


def test_a_builtin_name_is_the_builtin_robot_whatever_the_folder_holds(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "micro").mkdir()  # a folder named like the robot hid it
    (tmp_path / "artro").write_text("not a robot", encoding="utf-8")
    assert load_description("micro").name == "micro"
    assert load_description("artro").name == "artro"


def test_export_mjcf_never_writes_over_the_description_it_read(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text(ARTRO_TEXT.replace("name: artro", "name: mine", 1), encoding="utf-8")
    out = artro("robot", "export-mjcf", str(path), "-o", str(path))
    assert out.returncode == 2 and "is the description read" in out.stderr, out.stderr
    assert path.read_text(encoding="utf-8").startswith(ARTRO_TEXT[:40])
    out = artro("robot", "export-mjcf", str(path), "-o", str(tmp_path / "mine.xml"))
    assert out.returncode == 0 and (tmp_path / "mine.xml").read_text().startswith("<mujoco")


def test_a_suggested_robot_gets_a_name_and_file_of_its_own(tmp_path):
    """A 40-character name came back unchanged from `[:40]`: the suggested robot (other
    servos, another mass) shared the original's presets and studies."""
    long = "b" * 40
    assert derived_name(long, "suggested") == "b" * 30 + "-suggested"
    assert derived_name("my", "mg996r") == "my-mg996r"
    doc = artro_doc(long)
    doc["servo"], doc["supply_voltage_v"] = "SG90", 4.8  # too weak: something to suggest
    doc["title"] = "t" * 200
    del doc["total_mass_kg"]
    (tmp_path / "long.yaml").write_text(yaml.safe_dump(doc), encoding="utf-8")
    out = artro("robot", "check", "long.yaml", "--suggest", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    written = load_description(tmp_path / f"{'b' * 30}-suggested.yaml")
    assert written.name == "b" * 30 + "-suggested" and len(written.title) == 200
    again = artro("robot", "check", "long.yaml", "--suggest", cwd=tmp_path)
    assert again.returncode == 2 and "exists: give -o" in again.stderr, again.stderr
