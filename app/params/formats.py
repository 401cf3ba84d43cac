"""Export and import of parameter sets (docs/DESIGN.md §6): JSON, YAML and the ATmega128 C header.

Exports are the same `ParameterSet.to_dict()` document; JSON and YAML re-import to the same
parameters, the C header is export-only. Imports are untrusted: see `parse_import`.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import yaml

from app.params.document import ParameterSet
from gait.params import GROUP_NAMES, Motion, describe_fields, group_class
from hardware.firmware import HEADER_NAME, c_header
from hardware.servo import ServoCalibration
from hardware.tdm import DEFAULT_SELECT_CHANGE_TICKS, TdmConfig

if TYPE_CHECKING:
    from hardware import HardwareSetup

FORMATS = ("json", "yaml", "c")
MEDIA_TYPES = {"json": "application/json", "yaml": "application/yaml", "c": "text/x-c"}
MAX_IMPORT_BYTES = 64 * 1024
MAX_DEPTH = 8  # a parameter set is 3 levels deep (document -> gait -> group)
MAX_DIGITS = 40  # a number's digits at most: a parameter takes a few
MAX_VALUES = 1000  # a parameter set has about 70 keys and values: refused before any work on more
_YAML_SUFFIXES = (".yaml", ".yml")
_OPTIONAL_KEYS = ("schema_version", "name", "robot", "created", "project_version")
_TIMESTAMP_TAG = "tag:yaml.org,2002:timestamp"


class ParameterImportError(ValueError):
    """An imported parameter set was rejected; the message says why and what is allowed.

    `problems` lists every field that is wrong, as {"loc": [...], "msg": ...}, when the document
    could be read at all (the message then names them all too)."""

    def __init__(self, message: str, problems: list[dict[str, Any]] | None = None) -> None:
        super().__init__(message)
        self.problems = problems or []


class ImportTooLarge(ParameterImportError):
    """The upload is larger than MAX_IMPORT_BYTES."""


def _field_comments() -> dict[str, str]:
    """'swing.v' -> 'rad, eq (24): phase shift ...' for the defines of the C header."""
    comments: dict[str, str] = {}
    for name, _, meta in describe_fields(Motion):
        comments[name] = f"{meta['unit']}, eq {meta['eq']}: {meta['doc']}"
    for group in GROUP_NAMES:
        for name, _, meta in describe_fields(group_class(group)):
            where = f", eq {meta['eq']}" if meta.get("eq") else ""
            comments[f"{group}.{name}"] = f"{meta['unit']}{where}: {meta['doc']}"
    return comments


def _file_stem(name: str) -> str:
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._")
    return stem[:64] or "parameters"


def export_text(
    pset: ParameterSet, fmt: str, *, hardware: HardwareSetup | None = None
) -> tuple[str, str, str]:
    """Serialise a parameter set.

    Args:
        pset: the parameter set; empty `created`/`project_version` are filled in (now, this
            project's version).
        fmt: one of FORMATS ("json", "yaml", "c"), case-insensitive.
        hardware: servo calibration and TDM set-up for the C header (anything with `.calibration`
            and `.tdm`, e.g. `hardware.HardwareSetup`); default: uncalibrated servos, the
            default channel map, select change at 4900 ticks.

    Returns:
        (text, media_type, filename), e.g. ('{...}', 'application/json', 'paper.json').

    Raises:
        ValueError: for an unknown format, naming the allowed ones.
    """
    key = fmt.strip().lower() if isinstance(fmt, str) else fmt
    if key not in FORMATS:
        raise ValueError(f"unknown export format {fmt!r}; allowed: {', '.join(FORMATS)}")
    doc = pset.to_dict()
    if key == "json":
        text = json.dumps(doc, indent=2, allow_nan=False) + "\n"
        return text, MEDIA_TYPES[key], f"{_file_stem(pset.name)}.json"
    if key == "yaml":
        text = yaml.safe_dump(doc, sort_keys=False, default_flow_style=False, allow_unicode=True)
        return text, MEDIA_TYPES[key], f"{_file_stem(pset.name)}.yaml"
    calibration = hardware.calibration if hardware is not None else ServoCalibration.default()
    tdm = (
        hardware.tdm
        if hardware is not None
        else TdmConfig(select_change_ticks=DEFAULT_SELECT_CHANGE_TICKS)
    )
    text = c_header(
        doc,
        calibration=calibration,
        channel_map=tdm.channel_map,
        select_change_ticks=tdm.select_change_ticks,
        comments=_field_comments(),
    )
    return text, MEDIA_TYPES[key], HEADER_NAME


if TYPE_CHECKING:  # the loader it is mixed into
    _Constructor = yaml.constructor.SafeConstructor
else:
    _Constructor = object


class _StrictRules(_Constructor):
    """For a SafeLoader: keep unquoted dates as strings and reject duplicate keys."""

    yaml_implicit_resolvers: ClassVar[dict[Any, Any]] = {
        first: [(tag, rx) for tag, rx in resolvers if tag != _TIMESTAMP_TAG]
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if isinstance(key, str) and key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark
                )
            seen.add(key if isinstance(key, str) else id(key_node))
        return super().construct_mapping(node, deep=deep)


class _StrictYamlLoader(_StrictRules, yaml.SafeLoader):
    """SafeLoader (pure Python) with the strict rules."""


class _StrictCYamlLoader(_StrictRules, getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]  # a base chosen at run time
    """The same rules on libyaml's C parser when PyYAML has it: a 64 KiB upload parses in
    milliseconds instead of seconds of the GIL (docs/DESIGN.md §6)."""


_LOADER = _StrictCYamlLoader if hasattr(yaml, "CSafeLoader") else _StrictYamlLoader


def _yaml_whole_number(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> int:
    """A YAML integer as SafeLoader reads it, its digits counted first (`_check_digits`)."""
    _check_digits(str(loader.construct_scalar(node)))
    return int(yaml.SafeLoader.construct_yaml_int(loader, node))


for _loader in (_StrictYamlLoader, _StrictCYamlLoader):
    _loader.add_constructor("tag:yaml.org,2002:int", _yaml_whole_number)


def _detect_format(text: str, content_type: str | None, filename: str | None) -> str:
    """'json' or 'yaml': a specific content type wins, then the file suffix, then the text."""
    media = (content_type or "").split(";")[0].strip().lower()
    if media.endswith(("/json", "+json")):
        return "json"
    if media.endswith(("/yaml", "/x-yaml", "+yaml")):
        return "yaml"
    suffix = (filename or "").lower()
    if suffix.endswith(".json"):
        return "json"
    if suffix.endswith(_YAML_SUFFIXES):
        return "yaml"
    return "json" if text.lstrip()[:1] in ("{", "[") else "yaml"


def _reject_constant(token: str) -> Any:
    raise ParameterImportError(f"{token} is not allowed in JSON: every number must be finite")


def _whole_number(token: str) -> int:
    """A JSON integer, its digits counted first (`_check_digits`)."""
    _check_digits(token)
    return int(token)


def _check_digits(number: str) -> None:
    """ParameterImportError for a number of more than MAX_DIGITS digits (Python refuses 4300,
    naming a setting of its own; no parameter takes a number so long)."""
    digits = len(number.lstrip("-+").replace("_", ""))
    if digits > MAX_DIGITS:
        raise ParameterImportError(
            f"a whole number of {digits} digits; a parameter's number has at most {MAX_DIGITS}"
        )


def _json_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise ParameterImportError(f"duplicate key {key!r}: each key may appear once")
        result[key] = value
    return result


def load_json_strict(text: str | bytes) -> Any:
    """JSON with the one rule of the whole project: duplicate keys and NaN/Infinity are refused
    (ParameterImportError naming the key), never silently resolved."""
    return _load_json(text)


def _load_json(text: str | bytes) -> Any:
    if isinstance(text, bytes | bytearray):
        try:  # JSON is UTF-8 (RFC 8259); json.loads would guess UTF-16 or UTF-32 from the bytes
            text = bytes(text).decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise ParameterImportError(
                f"not UTF-8 text (byte {exc.start}): JSON must be UTF-8"
            ) from None
    try:
        return json.loads(
            text,
            parse_constant=_reject_constant,
            parse_int=_whole_number,
            object_pairs_hook=_json_pairs,
        )
    except json.JSONDecodeError as exc:
        raise ParameterImportError(
            f"malformed JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from exc
    except RecursionError as exc:
        raise ParameterImportError(
            f"JSON nested too deeply (a parameter set is 3 levels, and no body this project "
            f"reads is deeper than {MAX_DEPTH})"
        ) from exc
    except ParameterImportError:
        raise
    except ValueError as exc:  # what else the JSON reader refuses
        raise ParameterImportError(f"malformed JSON: {exc}") from exc


def _where(mark: Any) -> str:
    return f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""


def _load_yaml(text: str) -> Any:
    try:
        depth = 0  # checked while streaming: PyYAML's scanner is slow on deep flow nesting
        for count, event in enumerate(yaml.parse(text, Loader=_LOADER)):
            if count > 2 * MAX_VALUES:
                raise ParameterImportError(_too_many(event.start_mark))
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > MAX_DEPTH:
                    raise ParameterImportError(
                        f"YAML nested too deeply{_where(event.start_mark)} (a parameter set is "
                        "3 levels)"
                    )
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
            anchor = getattr(event, "anchor", None)
            if isinstance(event, yaml.AliasEvent) or anchor is not None:
                raise ParameterImportError(
                    f"YAML anchors and aliases (&{anchor} / *{anchor}) are not allowed in a "
                    f"parameter set{_where(event.start_mark)}"
                )
        return yaml.load(text, Loader=_LOADER)  # a SafeLoader subclass: no objects
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        raise ParameterImportError(f"malformed YAML{_where(mark)}: {exc.problem}") from exc
    except yaml.YAMLError as exc:
        raise ParameterImportError(f"malformed YAML: {exc}") from exc
    except RecursionError as exc:
        raise ParameterImportError("YAML nested too deeply (a parameter set is 3 levels)") from exc


def _too_many(mark: Any = None) -> str:
    return (
        f"more than {MAX_VALUES} keys and values{_where(mark)}: a parameter set has about 70 "
        "(motion, clock and the phase groups)"
    )


def _count_values(value: Any) -> None:
    """Refuse a document with more than MAX_VALUES keys and values before checking any."""
    count, todo = 0, [value]
    while todo:
        item = todo.pop()
        count += 1
        if isinstance(item, dict):
            count += len(item)
            todo.extend(item.values())
        elif isinstance(item, list):
            todo.extend(item)
        if count > MAX_VALUES:
            raise ParameterImportError(_too_many())


def _check_plain(value: Any, path: str = "document", depth: int = 0) -> None:
    """Only dict (str keys) / list / str / finite number / bool / None, at most MAX_DEPTH deep."""
    if depth > MAX_DEPTH:
        raise ParameterImportError(f"{path}: nested too deeply (a parameter set is 3 levels)")
    if value is None or isinstance(value, bool | str):
        return
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ParameterImportError(f"{path} = {value!r}: every number must be finite")
    elif isinstance(value, int):
        try:
            float(value)
        except OverflowError as exc:
            raise ParameterImportError(f"{path}: number too large") from exc
    elif isinstance(value, dict):
        for key, item in value.items():
            if not isinstance(key, str):
                raise ParameterImportError(f"{path}: keys must be strings, got {key!r}")
            _check_plain(item, f"{path}.{key}" if depth else key, depth + 1)
    elif isinstance(value, list):
        for index, item in enumerate(value):
            _check_plain(item, f"{path}[{index}]", depth + 1)
    else:
        raise ParameterImportError(
            f"{path}: a {type(value).__name__} value is not allowed; use only objects, lists, "
            "strings, numbers, true/false and null"
        )


def parse_import(
    raw: bytes, content_type: str | None = None, filename: str | None = None
) -> ParameterSet:
    """Parse and validate an uploaded parameter set (JSON or YAML).

    Imports are untrusted input (HTTP uploads, CLI files) and are validated here, at the edge: a
    size limit, UTF-8 only, JSON or YAML (chosen from the content type, then the file name, then
    the first character), a mapping of plain values only (no YAML tags, anchors or aliases), finite
    numbers, no duplicate keys, and then everything `ParameterSet.from_dict` checks.

    Args:
        raw: the file's bytes, at most MAX_IMPORT_BYTES.
        content_type: the upload's media type, if known (e.g. 'application/json').
        filename: the upload's file name, if known (its suffix picks the format).

    Returns:
        The parameter set, provenance as uploaded.

    Raises:
        ImportTooLarge: over MAX_IMPORT_BYTES.
        ParameterImportError: not UTF-8, malformed, not a mapping, non-finite numbers, YAML
            anchors/aliases or tags, or anything ParameterSet.from_dict rejects.
    """
    if not isinstance(raw, bytes | bytearray | memoryview):
        raise ParameterImportError(f"expected the file's bytes, got {type(raw).__name__}")
    if len(raw) > MAX_IMPORT_BYTES:
        raise ImportTooLarge(
            f"the file is {len(raw)} bytes; a parameter set may be at most {MAX_IMPORT_BYTES} "
            f"bytes ({MAX_IMPORT_BYTES // 1024} KiB)"
        )
    try:
        text = bytes(raw).decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ParameterImportError(
            f"the file is not UTF-8 text (invalid byte 0x{exc.object[exc.start]:02x} at offset "
            f"{exc.start}); upload a JSON or YAML parameter set"
        ) from exc
    if "\x00" in text:
        raise ParameterImportError("the file contains NUL bytes; upload a JSON or YAML text file")
    if not text.strip():
        raise ParameterImportError("the file is empty; upload a JSON or YAML parameter set")
    fmt = _detect_format(text, content_type, filename)
    data = _load_json(text) if fmt == "json" else _load_yaml(text)
    if not isinstance(data, dict):
        kind = "null" if data is None else type(data).__name__
        raise ParameterImportError(
            f"a parameter set must be a {fmt.upper()} object (mapping) with keys like 'motion' "
            f"and 'gait', got {kind}"
        )
    if {"geometry", "joints", "servo"} <= data.keys():  # twelve unknown keys said nothing useful
        raise ParameterImportError(
            "this is a robot description, not a parameter set: a robot is given with --robot "
            "(or the dashboard's robot switch)"
        )
    _count_values(data)
    _check_plain(data)
    version = data.get("version", 0)
    if version is None or type(version) is int or (type(version) is float and version.is_integer()):
        data = {k: v for k, v in data.items() if k != "version"}  # as GET /api/params gives it
    # null provenance means "not given", as in the API's documents (app/params/schema.py)
    data = {k: v for k, v in data.items() if not (v is None and k in _OPTIONAL_KEYS)}
    for key in ("created", "project_version"):
        if key in data and not isinstance(data[key], str):
            raise ParameterImportError(f"{key} must be a string, got {data[key]!r}")
    try:
        return ParameterSet.from_dict(data)
    except (ValueError, TypeError, OverflowError) as exc:
        problems = every_problem(data)
        if len(problems) > 1:
            listed = "; ".join(f"{'.'.join(map(str, p['loc']))}: {p['msg']}" for p in problems)
            message = f"invalid parameter set, {len(problems)} problems: {listed}"
            raise ParameterImportError(message, problems) from exc
        raise ParameterImportError(f"invalid parameter set: {exc}", problems) from exc


def every_problem(data: dict[str, Any]) -> list[dict[str, Any]]:
    """Every wrong field of a parameter-set document, not only the first: unknown top-level keys,
    then what the schema's patch model (app/params/schema.py) finds in `motion` and `gait`."""
    from pydantic import ValidationError

    from app.params.document import TOP_LEVEL_KEYS
    from app.params.schema import ParamsPatchBody

    problems: list[dict[str, Any]] = [
        {"loc": [key], "msg": f"unknown key; allowed: {', '.join(TOP_LEVEL_KEYS)}"}
        for key in data
        if key not in TOP_LEVEL_KEYS
    ]
    try:
        ParamsPatchBody.model_validate({k: data[k] for k in ("motion", "gait") if k in data})
    except ValidationError as exc:
        problems += [
            {"loc": list(e["loc"]), "msg": e["msg"] + _allowed(e["loc"])} for e in exc.errors()
        ]
    return problems


def _allowed(loc: tuple[Any, ...]) -> str:
    """' (allowed: 1.5 to 6.0)' for a numeric field at ('gait', 'swing', 'v'), ('motion', 'a_p')."""
    cls: type | None = Motion if loc[:1] == ("motion",) and len(loc) == 2 else None
    if loc[:1] == ("gait",) and len(loc) == 3:
        try:
            cls = group_class(str(loc[1]))
        except (KeyError, ValueError):
            return ""
    if cls is None:
        return ""
    for name, _default, meta in describe_fields(cls):
        if name == loc[-1] and "min" in meta:
            unit = "" if meta["unit"] == "1" else f" {meta['unit']}"
            return f" (allowed: {meta['min']} to {meta['max']}{unit})"
    return ""


def load_parameter_set(path: Path | str) -> ParameterSet:
    """Read a parameter-set file, JSON or YAML (as `artro export` writes them), by the rules of an
    import (`parse_import`: UTF-8, no duplicate keys, finite numbers, every wrong field named);
    ValueError names the file and what is wrong with it."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"{path}: cannot be read ({exc.strerror or exc})") from exc
    try:
        return parse_import(raw, filename=path.name)
    except ParameterImportError as exc:
        raise ValueError(f"{path}: {exc}") from exc
