"""Finding robots: the built-in descriptions (`models/robots/*.yaml`) by name, or a file of the
user's; each read, validated and refused with errors that name the field (docs/DESIGN.md §7)."""

from __future__ import annotations

import re
from functools import cache
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from app.assets import builtin_robots_dir
from app.robots.cad_source import resolved
from app.robots.description import RobotDescription

BUILTIN_DEFAULT = "artro"
#: a description is a page (the built-in artro.yaml is 4 KiB). The one limit of a description,
#: wherever it comes from: written out (`description_json`, as it is handed to a tune's child or
#: a pool's workers), and as a file, checked before reading, so that a 48 MB file is refused at
#: once instead of parsed for minutes. Written out, a description accepted is never over it.
MAX_DESCRIPTION_BYTES = 256 * 1024
#: the deepest a description nests (links > thigh > a part > box_m is 4)
MAX_DEPTH = 8
#: the YAML events (values, keys, lists, maps) a description may hold: artro.yaml has ~400
MAX_EVENTS = 20_000
#: the problems a refusal lists (a malformed file can have a hundred thousand)
MAX_LISTED_ERRORS = 20
#: the field a check's message starts with ("servos.MG90S: ..."), where pydantic gives no path
_LEADING_FIELD = re.compile(r"^([A-Za-z_][\w-]*(?:\.[\w.-]+)*): ")


class RobotError(ValueError):
    """A robot that cannot be loaded: an unknown name, an unreadable file or an invalid
    description. The message names every field that is wrong and what is allowed."""


def builtin_robot_names() -> list[str]:
    """The built-in robots, the default first."""
    names = sorted(p.stem for p in builtin_robots_dir().glob("*.yaml"))
    return sorted(names, key=lambda n: n != BUILTIN_DEFAULT)


def describe_errors(err: ValidationError, source: str, text: str | None = None) -> str:
    """One line per problem: `field.path: message` (the message alone for the whole document),
    with `(line N)` where the field is found in the file's `text`."""
    root = _composed(text)
    lines = []
    errors = err.errors()
    for e in errors[:MAX_LISTED_ERRORS]:
        where = ".".join(str(p) for p in e["loc"])
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] in ("float_type", "int_type") and isinstance(e.get("input"), str):
            msg += f", got the text {e['input']!r} (numbers are written as 1650, 1.65 or 1.65e3)"
        line = f"  {where}: {msg}" if where else f"  {msg}"
        named = where or ((m := _LEADING_FIELD.match(msg)) and m.group(1))
        at = _line_of(root, named) if named else None
        lines.append(f"{line} (line {at})" if at else line)
    if len(errors) > MAX_LISTED_ERRORS:
        lines.append(f"  ... and {len(errors) - MAX_LISTED_ERRORS} more")
    return f"{source} is not a valid robot description:\n" + "\n".join(lines)


def _composed(text: str | None) -> yaml.Node | None:
    if text is None:
        return None
    try:
        return yaml.compose(text, Loader=_DescriptionLoader)
    except yaml.YAMLError:
        return None


def _line_of(node: yaml.Node | None, where: str) -> int | None:
    """The line (from 1) of the deepest key or item of the dotted path `where` in the composed
    document (None: not found)."""
    line = None
    for part in where.split("."):
        if isinstance(node, yaml.MappingNode):
            found = [(k, v) for k, v in node.value if getattr(k, "value", None) == part]
            if not found:
                break
            line, node = found[0][0].start_mark.line + 1, found[0][1]
        elif isinstance(node, yaml.SequenceNode) and part.isdigit() and int(part) < len(node.value):
            node = node.value[int(part)]
            line = node.start_mark.line + 1
        else:
            break
    return line


def parse_description(raw: object, source: str, text: str | None = None) -> RobotDescription:
    """Validate a document (parsed YAML or JSON, from the file `text` if given, for the lines);
    RobotError naming each bad field, or saying it is over MAX_DESCRIPTION_BYTES written out."""
    try:
        desc = RobotDescription.model_validate(raw)
    except ValidationError as err:
        raise RobotError(describe_errors(err, source, text)) from None
    size = len(description_json(desc).encode())
    if size > MAX_DESCRIPTION_BYTES:
        raise RobotError(
            f"{source} is a robot description of {size:,} bytes written out (as JSON, its "
            f"defaults left out); a robot description is at most "
            f"{MAX_DESCRIPTION_BYTES // 1024} KiB (the built-in artro is 2 KiB so)"
        )
    return desc


def description_json(desc: RobotDescription) -> str:
    """`desc` written out as one process hands it to another (a tune's child reads it as its
    file): compact JSON, the defaults left out. MAX_DESCRIPTION_BYTES bounds it."""
    return desc.model_dump_json(exclude_defaults=True)


def read_description(path: Path) -> RobotDescription:
    """The description in the file at `path` (YAML or JSON, UTF-8, at most
    MAX_DESCRIPTION_BYTES); RobotError naming the file and what is wrong."""
    try:
        size = path.stat().st_size
        if size > MAX_DESCRIPTION_BYTES:
            raise RobotError(
                f"{path} is {size:,} bytes; a robot description is at most "
                f"{MAX_DESCRIPTION_BYTES // 1024} KiB (the built-in artro.yaml is 4 KiB)"
            )
        data = path.read_bytes()
    except OSError as err:
        raise RobotError(f"cannot read the robot description {path}: {err.strerror}") from None
    text = decoded(data, path)
    description = parse_description(load_yaml(text, path), str(path), text)
    if description.cad is None:
        return description
    return description.model_copy(update={"cad": resolved(description.cad, path.parent)})


def decoded(data: bytes, path: Path | str) -> str:
    """`data` as UTF-8 text (a UTF-8 byte-order mark dropped); RobotError otherwise."""
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise RobotError(f"{path} is UTF-16 text; save it as UTF-8")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise RobotError(
            f"{path} is not UTF-8 text (byte 0x{data[err.start]:02x} at offset {err.start}); "
            "save it as UTF-8"
        ) from None


class _DescriptionLoader(yaml.SafeLoader):
    """SafeLoader that refuses a key given twice (YAML would keep the last, silently) and reads
    numbers as YAML 1.2 and JSON do: `5e-05` and `4.0e3` are numbers (YAML 1.1 made them
    strings), `1_650` and `0:1.65` are not (YAML 1.1 made them 1650 and 1.65)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[object] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if isinstance(key, str) and key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"the key {key!r} is given twice", key_node.start_mark
                )
            seen.add(key if isinstance(key, str) else id(key_node))
        return super().construct_mapping(node, deep=deep)


#: the digits of a number at most (Python refuses 4300, naming a setting of its own)
MAX_DIGITS = 40
_INT, _FLOAT = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float"
# numbers as YAML 1.2's core schema reads them, as JSON does: YAML 1.1's 1_650 (1650), 0:1.65
# (sexagesimal, 1.65), 017 (octal, 15) and 0b11 are not numbers there, so not here either
_DescriptionLoader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in found if tag not in (_INT, _FLOAT)]
    for first, found in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_DescriptionLoader.add_implicit_resolver(
    _INT, re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$"), list("-+0123456789")
)
_DescriptionLoader.add_implicit_resolver(
    _FLOAT,
    re.compile(
        r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
        r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"
    ),
    list("-+0123456789."),
)


def _construct_int(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> int:
    """A YAML 1.2 integer: decimal (017 is 17), 0o octal or 0x hexadecimal; ConstructorError
    for one of more than MAX_DIGITS digits."""
    text = str(loader.construct_scalar(node))
    digits = len(text.lstrip("-+"))
    if digits > MAX_DIGITS:
        raise yaml.constructor.ConstructorError(
            None, None, f"a number of {digits} digits; one has at most {MAX_DIGITS} here",
            node.start_mark,
        )  # fmt: skip
    if text.startswith(("0o", "0x")):
        return int(text[2:], 8 if text[1] == "o" else 16)
    return int(text)


_DescriptionLoader.add_constructor(_INT, _construct_int)


def load_yaml(text: str, path: Path | str) -> object:
    """The YAML (or JSON) document in `text`; RobotError naming `path`, line and column for
    malformed YAML, a key given twice, anchors, or nesting deeper than MAX_DEPTH."""

    def where(mark: Any) -> str:
        return f"{path}, line {mark.line + 1}, column {mark.column + 1}" if mark else str(path)

    try:
        depth = 0  # checked while streaming, before anything recursive sees the document
        for count, event in enumerate(yaml.parse(text, Loader=_DescriptionLoader)):
            if count > MAX_EVENTS:
                raise RobotError(
                    f"{where(event.start_mark)}: more than {MAX_EVENTS:,} values; a robot "
                    "description holds a few hundred"
                )
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > MAX_DEPTH:
                    raise RobotError(
                        f"{where(event.start_mark)}: nested {depth} levels deep; a robot "
                        f"description nests at most {MAX_DEPTH}"
                    )
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
            if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
                raise RobotError(
                    f"{where(event.start_mark)}: YAML anchors and aliases are not allowed in a "
                    "robot description; write each value out"
                )
        return yaml.load(text, Loader=_DescriptionLoader)  # a SafeLoader: no objects
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        raise RobotError(f"{where(mark)}: malformed YAML: {err.problem}") from None
    except yaml.reader.ReaderError as err:  # a control character: at a position, not a mark
        before = text[: err.position]
        line, column = before.count("\n") + 1, err.position - before.rfind("\n")
        raise RobotError(
            f"{path}, line {line}, column {column}: the character U+{err.character:04X} has no "
            "place in a description (YAML allows no control characters but tab and newline)"
        ) from None
    except yaml.YAMLError as err:
        raise RobotError(f"{path} is not YAML: {err}") from None


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
    if text in builtin_robot_names():  # a file of that name is ./NAME
        return _builtin(text)
    if path.suffix in (".yaml", ".yml", ".json") or path.exists() or "/" in text:
        if not path.is_file():
            raise RobotError(f"no robot description file {text!r}")
        return not_a_builtin_impostor(read_description(path), text)
    if text not in builtin_robot_names():
        raise RobotError(
            f"unknown robot {text!r}: the built-in robots are {', '.join(builtin_robot_names())}, "
            f"or give the path of a .yaml description"
        )
    return _builtin(text)


def not_a_builtin_impostor(desc: RobotDescription, source: str) -> RobotDescription:
    """`desc`, unless it takes a built-in robot's name without being that robot (its presets,
    `tuned-NAME` and studies would then mix with the built-in's); RobotError then."""
    plain = desc.model_copy(update={"fitted": None})  # a fitted robot is still that robot
    if desc.name in builtin_robot_names() and plain != _builtin(desc.name):
        raise RobotError(
            f"{source} is named {desc.name!r} like a built-in robot it is not; give it a name of "
            "its own (name: in the description)"
        )
    return desc
