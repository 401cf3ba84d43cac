"""Finding robots: the built-in descriptions (`models/robots/*.yaml`) by name, or a file of the
user's; each read, validated and refused with errors that name the field (docs/DESIGN.md §7)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import yaml
from pydantic import ValidationError

from app.assets import builtin_robots_dir
from app.robots.description import RobotDescription

BUILTIN_DEFAULT = "artro"


class RobotError(ValueError):
    """A robot that cannot be loaded: an unknown name, an unreadable file or an invalid
    description. The message names every field that is wrong and what is allowed."""


def builtin_robot_names() -> list[str]:
    """The built-in robots, the default first."""
    names = sorted(p.stem for p in builtin_robots_dir().glob("*.yaml"))
    return sorted(names, key=lambda n: n != BUILTIN_DEFAULT)


def describe_errors(err: ValidationError, source: str) -> str:
    """One line per problem: `field.path: message`."""
    lines = []
    for e in err.errors():
        where = ".".join(str(p) for p in e["loc"]) or "(document)"
        msg = e["msg"].removeprefix("Value error, ")
        lines.append(f"  {where}: {msg}")
    return f"{source} is not a valid robot description:\n" + "\n".join(lines)


def parse_description(raw: object, source: str) -> RobotDescription:
    """Validate a document (parsed YAML or JSON); RobotError naming each bad field."""
    try:
        return RobotDescription.model_validate(raw)
    except ValidationError as err:
        raise RobotError(describe_errors(err, source)) from None


def read_description(path: Path) -> RobotDescription:
    try:
        raw = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise RobotError(f"cannot read the robot description {path}: {err.strerror}") from None
    except yaml.YAMLError as err:
        raise RobotError(f"{path} is not YAML: {err}") from None
    return parse_description(raw, str(path))


@cache
def _builtin(name: str) -> RobotDescription:
    return read_description(builtin_robots_dir() / f"{name}.yaml")


def load_description(robot: str | Path | RobotDescription | None = None) -> RobotDescription:
    """A robot by built-in name (default: `artro`), by file path (.yaml, .yml or .json), or
    as given; RobotError otherwise."""
    if isinstance(robot, RobotDescription):
        return robot
    if robot is None:
        return _builtin(BUILTIN_DEFAULT)
    text = str(robot)
    path = Path(text).expanduser()
    if path.suffix in (".yaml", ".yml", ".json") or path.exists() or "/" in text:
        if not path.is_file():
            raise RobotError(f"no robot description file {text!r}")
        return read_description(path)
    if text not in builtin_robot_names():
        raise RobotError(
            f"unknown robot {text!r}: the built-in robots are {', '.join(builtin_robot_names())}, "
            f"or give the path of a .yaml description"
        )
    return _builtin(text)
