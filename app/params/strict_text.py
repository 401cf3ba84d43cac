"""Untrusted JSON and YAML read by the one rule of the project (docs/DESIGN.md §6, §14): UTF-8,
no duplicate keys, finite numbers of at most MAX_DIGITS digits, no YAML anchors, aliases or tags,
at most MAX_DEPTH levels and MAX_VALUES keys and values; ParameterImportError says what is wrong."""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING, Any, ClassVar

import yaml

MAX_DEPTH = 8  # a parameter set is 3 levels deep (document -> gait -> group)
MAX_DIGITS = 40  # a number's digits at most: a parameter takes a few
MAX_VALUES = 1000  # a parameter set has about 70 keys and values: refused before any work on more
_YAML_SUFFIXES = (".yaml", ".yml")
_TIMESTAMP_TAG = "tag:yaml.org,2002:timestamp"


class ParameterImportError(ValueError):
    """An imported parameter set was rejected; the message says why and what is allowed.

    `problems` lists every field that is wrong, as {"loc": [...], "msg": ...}, when the document
    could be read at all (the message then names them all too)."""

    def __init__(self, message: str, problems: list[dict[str, Any]] | None = None) -> None:
        super().__init__(message)
        self.problems = problems or []


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


def detect_format(text: str, content_type: str | None, filename: str | None) -> str:
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


def load_yaml_strict(text: str) -> Any:
    """YAML by the same rules, and no anchors or aliases, tags, deep nesting or more than
    MAX_VALUES keys and values (ParameterImportError naming where)."""
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


def count_values(value: Any) -> None:
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


def check_plain(value: Any, path: str = "document", depth: int = 0) -> None:
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
            check_plain(item, f"{path}.{key}" if depth else key, depth + 1)
    elif isinstance(value, list):
        for index, item in enumerate(value):
            check_plain(item, f"{path}[{index}]", depth + 1)
    else:
        raise ParameterImportError(
            f"{path}: a {type(value).__name__} value is not allowed; use only objects, lists, "
            "strings, numbers, true/false and null"
        )
