"""Robot description files a hostile tester or a newcomer writes (docs/DESIGN.md §7): each refused
at once with a sentence naming the file, the field or line, and what is allowed; nothing that
cannot walk or cannot be simulated gets through."""

from __future__ import annotations

import copy
import math
import re
import subprocess
import sys

import pytest
import yaml

from app.assets import builtin_robots_dir
from app.robots import RobotError, build_model, load_description, parse_description
from app.robots.library import MAX_DEPTH, MAX_DESCRIPTION_BYTES, load_yaml, read_description
from app.robots.model import RobotModel
from app.server.robot_shelf import RobotShelf

ARTRO_TEXT = (builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8")


def artro_doc() -> dict:
    return yaml.safe_load(ARTRO_TEXT)


def with_value(path: str, value: object) -> dict:
    doc = copy.deepcopy(artro_doc())
    *parents, last = path.split(".")
    node = doc
    for key in parents:
        node = node[int(key)] if isinstance(node, list) else node[key]
    node[last] = value
    return doc


def refused_file(tmp_path, data: bytes, name: str = "my.yaml") -> str:
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(RobotError) as err:
        load_description(path)
    return str(err.value)


def test_a_huge_file_is_refused_before_it_is_read(tmp_path):
    path = tmp_path / "huge.yaml"
    with path.open("wb") as f:  # an unknown field holding a long list: 48 MB once took >240 s
        f.write(ARTRO_TEXT.encode() + b"junk: [" + b"1, " * (MAX_DESCRIPTION_BYTES // 3) + b"1]\n")
    with pytest.raises(RobotError, match=r"huge.yaml is [\d,]+ bytes; .* at most 256 KiB"):
        load_description(path)


def test_a_description_over_the_limit_written_out_is_refused_wherever_it_comes_from(tmp_path):
    """One limit on the description (issue 56, item 11): written out as it is handed on, not
    only as the file it was read from, so that what one process accepts the next accepts too."""
    from app.robots.library import description_json

    doc = artro_doc()
    doc["trunk"] += [{"name": f"{i:04d} " + "w" * 75, "mass_kg": 0.0} for i in range(2600)]
    with pytest.raises(RobotError, match=r"the JSON sent is a robot description of [\d,]+ bytes "
                       r"written out .*; a robot description is at most 256 KiB"):  # fmt: skip
        parse_description(doc, "the JSON sent")
    within = parse_description(artro_doc(), "artro.yaml")
    assert len(description_json(within).encode()) < 4 * 1024  # the built-in: 2 KiB so


@pytest.mark.parametrize(
    ("data", "said"),
    [
        ("name: rob\xe9\n".encode("latin-1"), "is not UTF-8 text (byte 0xe9 at offset 9)"),
        (ARTRO_TEXT.encode("utf-16"), "is UTF-16 text; save it as UTF-8"),
        (b"a: " + b"[" * 900 + b"]" * 900, f"nested 9 levels deep; .* at most {MAX_DEPTH}"),
        (b"name: x\nname: y\n", "line 2, column 1: malformed YAML: the key 'name' is given twice"),
        (b"a: &x 1\nb: *x\n", "anchors and aliases are not allowed"),
        (b"name: [1,\n", "my.yaml, line 2, column 1: malformed YAML"),
        (b"name: !!python/object:os.system x\n", "my.yaml, line 1, column 7: malformed YAML"),
        (b"name: x\ntitle: a\x00b\n", "my.yaml, line 2, column 9: the character U+0000 has no"),
    ],
)
def test_an_unreadable_file_is_named_with_what_is_wrong(tmp_path, data, said):
    message = refused_file(tmp_path, data)
    assert "my.yaml" in message and "<unicode string>" not in message, message
    assert said in message or re.search(said, message), message


@pytest.mark.parametrize(
    ("written", "said"),
    [
        ("1_650", "total_mass_kg: Input should be a valid number, got the text '1_650'"),
        ("0:1.65", "total_mass_kg: Input should be a valid number, got the text '0:1.65'"),
        ("1" * 5000, "line 11, column 16: malformed YAML: a number of 5000 digits; one has at"),
    ],
)
def test_numbers_are_read_as_yaml_1_2_reads_them(tmp_path, written, said):
    """Issue 56 item 18: YAML 1.1 read `1_650` as 1650 and `0:1.65` (base 60) as 1.65, where
    YAML 1.2 and JSON read text; 5000 digits gave Python's advice (sys.set_int_max_str_digits).
    Each is refused, naming the line; 1.65e0 is a number, and 017 is 17, not octal 15."""
    line = "total_mass_kg: 1.65\n"
    assert ARTRO_TEXT.splitlines(keepends=True)[10] == line  # line 11
    message = refused_file(
        tmp_path, ARTRO_TEXT.replace(line, f"total_mass_kg: {written}\n").encode()
    )
    assert said in message and "sys." not in message, message
    (tmp_path / "e.yaml").write_text(ARTRO_TEXT.replace(line, "total_mass_kg: 1.65e0\n"))
    assert load_description(tmp_path / "e.yaml").total_mass_kg == 1.65
    assert load_yaml("a: 017\nb: 0o17\nc: 0x1F\nd: +5\n", "x") == {
        "a": 17,
        "b": 15,
        "c": 31,
        "d": 5,
    }


def test_a_key_given_twice_in_a_real_description_names_key_and_line(tmp_path):
    text = ARTRO_TEXT.replace("\nservo: MG996R", "\nservo: SG90\nservo: MG996R", 1)
    line = text.splitlines().index("servo: SG90") + 2  # the second one is named
    message = refused_file(tmp_path, text.encode())
    assert f"line {line}, column 1: malformed YAML: the key 'servo' is given twice" in message


@pytest.mark.parametrize(
    ("path", "value", "said"),
    [
        ("geometry.thigh_m", "0.09", "geometry.thigh_m: Input should be a valid number"),
        ("geometry.thigh_m", True, "geometry.thigh_m: Input should be a valid number"),
        ("geometry.shank_m", math.inf, "geometry.shank_m: Input should be a finite number"),
        ("geometry.foot_length_m", 1e308, "geometry.foot_length_m: Input should be less than"),
        ("trunk.0.pos_m", [0.0, math.inf, 0.0], "trunk.0.pos_m.1: Input should be a finite"),
        ("trunk.0.mass_kg", math.nan, "trunk.0.mass_kg: Input should be a finite number"),
        ("title", b"\x00\x01", "title: Input should be a valid string"),
        ("links.thigh.0.capsule_inset_m", 0.3, "capsule_inset_m: 0.3 m from each end leaves no"),
        ("joints.l_hip_pitch", {"range_rad": [-0.01, 0.01]}, "l_hip_pitch.range_rad: -0.0100"),
        ("joints.r_ankle_roll", {"range_rad": [-0.2, 1.0]}, "does not hold the gait's reach"),
        ("default_preset", "nosuch", "default_preset: 'nosuch' is not a built-in preset; built"),
        # the fourteenth session's probe: impossible robots the checks had let through
        ("geometry.thigh_m", 1e-6, "geometry.thigh_m: Input should be greater than or equal to"),
        ("trunk.0.box_m", [5e-324, 0.1, 0.1], "trunk.0.box_m.0: Input should be greater than"),
        ("geometry.foot_length_m", 1.0, "must not exceed the leg's length, hip to sole (0.215"),
        (
            "trunk",
            [{"name": f"ballast {i}", "mass_kg": 10.0} for i in range(3)],
            "the parts add up to 31.020 kg (links and 12 servos); a small servo-driven biped",
        ),
        ("servo_mounts", {"hip_yaw": {}}, "servo_mounts: no mount for ['hip_roll', 'hip_pitch',"),
        ("links.foot", [], "links.foot: the foot plate must weigh something"),
        ("links.foot.0.box_m", [0.5, 0.5, 0.01], "links.foot.0: the foot's parts weigh its plate"),
    ],
)
def test_a_description_that_cannot_walk_or_be_simulated_is_refused(path, value, said):
    doc = with_value(path, value)
    if path.startswith("links.thigh"):
        doc["links"]["thigh"][0].setdefault("capsule_radius_m", 0.01)
    with pytest.raises(RobotError) as err:
        parse_description(doc, "my.yaml")
    message = str(err.value)
    assert said in message and "(document)" not in message, message


def test_a_robot_that_takes_a_builtins_name_is_refused_by_the_server(tmp_path):
    doc = artro_doc()
    doc["title"] = "my own, named artro"
    path = tmp_path / "artro-copy.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    with pytest.raises(ValueError, match="named 'artro' like a built-in robot it is not"):
        RobotModel.load(path)  # what every command loads a robot by
    with pytest.raises(ValueError, match="named 'artro' like a built-in robot it is not"):
        RobotShelf(RobotModel.of_model(read_description(path), build_model(read_description(path))))
    RobotShelf(RobotModel.load("artro"))  # the built-in itself is fine
    RobotModel.load(builtin_robots_dir() / "artro.yaml")  # and so is its own file
    run = subprocess.run(
        [sys.executable, "-m", "app.cli", "serve", "--robot", str(path), "--port", "1"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert run.returncode == 2 and "like a built-in robot" in run.stderr, run.stderr
