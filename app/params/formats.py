"""Export and import of parameter sets (docs/DESIGN.md §6): JSON, YAML and the ATmega128 C header.

Exports are the same `ParameterSet.to_dict()` document; JSON and YAML re-import to the same
parameters, the C header is export-only. Imports are untrusted: see `parse_import`.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from app.params.document import ParameterSet
from app.params.strict_text import (
    ParameterImportError,
    check_plain,
    count_values,
    detect_format,
    load_json_strict,
    load_yaml_strict,
)
from gait.params import GROUP_NAMES, Motion, describe_fields, group_class
from hardware.firmware import HEADER_NAME, c_header
from hardware.servo import ServoCalibration
from hardware.tdm import DEFAULT_SELECT_CHANGE_TICKS, TdmConfig

if TYPE_CHECKING:
    from hardware import HardwareSetup

FORMATS = ("json", "yaml", "c")
MEDIA_TYPES = {"json": "application/json", "yaml": "application/yaml", "c": "text/x-c"}
MAX_IMPORT_BYTES = 64 * 1024
_OPTIONAL_KEYS = ("schema_version", "name", "robot", "created", "project_version")


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
    fmt = detect_format(text, content_type, filename)
    data = load_json_strict(text) if fmt == "json" else load_yaml_strict(text)
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
    count_values(data)
    check_plain(data)
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
