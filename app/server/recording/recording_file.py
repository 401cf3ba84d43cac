"""A recording file read back (POST /api/recording/import) as strictly as PUT /api/params reads a
parameter set: every column's shape, JSON type and range, the events, the parameter documents;
the first problem is named with where it is; nothing is half-loaded (docs/DESIGN.md §10, §14)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, TypeGuard

import numpy as np

from app.params.document import ParameterSet
from app.params.formats import every_problem
from app.server.recording.recorder import (
    FORMAT,
    FORMAT_VERSION,
    MAX_EVENTS,
    MAX_PARAM_DOCUMENTS,
    RECORD_FRAMES,
    Recording,
)
from app.server.sim.sim_commands import PUSH_RANGE_N_S
from app.sim.planning import FRAME_S
from gait import JOINT_NAMES, Motion
from gait.params import replace_checked
from hardware import CHANNELS, OCR_MAX, SLOTS_PER_FRAME

NQ = 7 + len(JOINT_NAMES)  # the built-in model: a free trunk joint, then the twelve servos
MAX_SECONDS = 1e9
F32_MAX = float(np.finfo(np.float32).max)
PHASE_MAX = float(np.float32(math.pi))  # the phase is stored as float32: pi rounds up
INT64_MAX = 2**63 - 1
INT32_MAX = 2**31 - 1
OCR_IDLE = -1
KEYS = ("format", "format_version", "model", "frame_s", "frames", "columns", "events", "params")
EVENT_KINDS = ("params", "reset", "fall", "drive", "push", "robot")  # as the recorder logs them


def columns_spec(nq: int) -> dict[str, tuple[tuple[int, ...], bool, float, float, Any]]:
    """column -> (shape of one frame, integers only, lowest, highest, stored dtype)."""
    return {
        "frame": ((), True, 0, INT64_MAX, np.int64),
        "t_s": ((), False, 0.0, MAX_SECONDS, np.float64),
        "sim_t_s": ((), False, 0.0, MAX_SECONDS, np.float64),
        "phase": ((), False, -PHASE_MAX, PHASE_MAX, np.float32),
        "qpos": ((nq,), False, -F32_MAX, F32_MAX, np.float32),
        "ocr": ((len(CHANNELS), SLOTS_PER_FRAME), True, OCR_IDLE, OCR_MAX, np.int16),
        "version": ((), True, 1, INT32_MAX, np.int32),
        "drive": ((), True, 0, 1, np.int8),
    }


class RecordingError(ValueError):
    """What is wrong with a recording file, and where (`loc`: keys and indices into it)."""

    def __init__(self, loc: Sequence[str | int], msg: str) -> None:
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in loc).lstrip(".")
        super().__init__(f"{where}: {msg}" if where else msg)
        self.loc, self.msg = list(loc), msg


def _is_number(value: Any) -> TypeGuard[int | float]:
    return type(value) in (int, float)  # never a bool or a string


def _leaves(value: Any, shape: tuple[int, ...], loc: list[str | int]) -> list[Any]:
    """The numbers of one frame's value of `shape`, flattened; RecordingError where it differs."""
    if not shape:
        if not _is_number(value):
            raise RecordingError(loc, f"must be a number, got {type(value).__name__}")
        return [value]
    if not isinstance(value, list) or len(value) != shape[0]:
        got = f"{len(value)} items" if isinstance(value, list) else type(value).__name__
        raise RecordingError(loc, f"must be a list of {shape[0]} items, got {got}")
    out: list[Any] = []
    for i, item in enumerate(value):
        out += _leaves(item, shape[1:], [*loc, i])
    return out


def _column(name: str, values: Any, spec: tuple, frames: int | None) -> np.ndarray:
    shape, integers, low, high, dtype = spec
    loc: list[str | int] = ["columns", name]
    if not isinstance(values, list) or not 1 <= len(values) <= RECORD_FRAMES:
        raise RecordingError(loc, f"must be a list of 1 to {RECORD_FRAMES} frames")
    if frames is not None and len(values) != frames:
        raise RecordingError(loc, f"has {len(values)} frames, the columns before it {frames}")
    flat: list[Any] = []
    for i, value in enumerate(values):
        numbers = _leaves(value, shape, [*loc, i])
        for j, x in enumerate(numbers):
            whole = type(x) is int or (type(x) is float and math.isfinite(x) and x.is_integer())
            if integers and not whole:
                at = (
                    [*loc, i, *(int(k) for k in np.unravel_index(j, shape))] if shape else [*loc, i]
                )
                raise RecordingError(at, f"must be a whole number, got {str(x)[:40]}")
            if not (type(x) is int or math.isfinite(x)) or not low <= x <= high:
                at = (
                    [*loc, i, *(int(k) for k in np.unravel_index(j, shape))] if shape else [*loc, i]
                )
                raise RecordingError(at, f"{str(x)[:40]} is outside {low:g} to {high:g}")
        flat += numbers
    kind = np.int64 if integers else np.float64
    return np.asarray(flat, dtype=kind).reshape((len(values), *shape)).astype(dtype)


def _event(event: Any, loc: list[str | int]) -> dict[str, Any]:
    if not isinstance(event, dict):
        raise RecordingError(loc, "an event must be an object")
    kind = event.get("kind")
    if kind not in EVENT_KINDS:
        raise RecordingError([*loc, "kind"], f"must be one of {', '.join(EVENT_KINDS)}")
    t = event.get("t_s")
    if not _is_number(t) or not math.isfinite(t) or not 0 <= t <= MAX_SECONDS:
        raise RecordingError([*loc, "t_s"], f"must be a number of seconds, 0 to {MAX_SECONDS:g}")
    allowed = {
        "params": {"version", "source", "changed"},
        "reset": set(),
        "fall": {"motion"},
        "drive": {"drive"},
        "push": {"impulse_n_s", "direction_deg"},
        "robot": {"robot"},
    }[kind]
    for key in set(event) - {"kind", "t_s"} - allowed:
        raise RecordingError([*loc, key], f"unknown for a {kind} event; allowed: t_s, kind, "
                             f"{', '.join(sorted(allowed)) or 'nothing else'}")  # fmt: skip
    if kind == "params":
        version, source, changed = event.get("version"), event.get("source"), event.get("changed")
        if type(version) is not int or not 1 <= version <= INT32_MAX:
            raise RecordingError([*loc, "version"], "must be a parameter version (an integer >= 1)")
        if not isinstance(source, str) or len(source) > 64:
            raise RecordingError([*loc, "source"], "must be a name of at most 64 characters")
        if not isinstance(changed, list) or not all(
            isinstance(c, str) and len(c) <= 64 for c in changed
        ):
            raise RecordingError([*loc, "changed"], "must be a list of parameter names")
    elif kind == "fall":
        try:
            motion: Any = event.get("motion")  # anything: replace_checked refuses a non-object
            replace_checked(Motion(), motion, "motion")
        except (ValueError, TypeError) as exc:
            raise RecordingError([*loc, "motion"], str(exc)) from None
    elif kind == "drive" and event.get("drive") not in ("model", "firmware"):
        raise RecordingError([*loc, "drive"], "must be model or firmware")
    elif kind == "push":
        for key, (low, high) in (("impulse_n_s", PUSH_RANGE_N_S), ("direction_deg", (-180, 180))):
            value = event.get(key)
            if not _is_number(value) or not low <= value <= high:
                raise RecordingError([*loc, key], f"must be a number, {low:g} to {high:g}")
    elif kind == "robot":
        robot = event.get("robot")
        if not isinstance(robot, str) or not 1 <= len(robot) <= 64:
            raise RecordingError([*loc, "robot"], "must be a robot's name, 1 to 64 characters")
    return event


def _params(documents: Any) -> dict[int, dict[str, Any]]:
    if not isinstance(documents, dict) or len(documents) > MAX_PARAM_DOCUMENTS:
        raise RecordingError(
            ["params"], f"must be an object of at most {MAX_PARAM_DOCUMENTS} version -> document"
        )
    out = {}
    for key, doc in documents.items():
        if not (key.isascii() and key.isdigit()) or not 1 <= int(key) <= INT32_MAX:
            raise RecordingError(["params", key[:20]], "a key must be a parameter version (1, 2..)")
        problems = every_problem(doc) if isinstance(doc, dict) else []
        if problems:
            first = problems[0]
            raise RecordingError(["params", key, *first["loc"]], first["msg"])
        if isinstance(doc, dict):
            for text in ("name", "created", "project_version"):
                if text in doc and not isinstance(doc[text], str):
                    raise RecordingError(["params", key, text], "must be a string")
        try:
            ParameterSet.from_dict(doc)
        except (ValueError, TypeError) as exc:
            raise RecordingError(["params", key], str(exc)) from None
        out[int(key)] = doc
    return out


def recording_from_json(data: Any, nq: int) -> Recording:
    """A recording file read back; RecordingError (a ValueError) naming the first problem and
    where it is; nothing is half-loaded."""
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise RecordingError(["format"], f"not an ArtRo recording: 'format' must be {FORMAT!r}")
    for key in data:
        if key not in KEYS:
            raise RecordingError([key[:64]], f"unknown key; allowed: {', '.join(KEYS)}")
    version = data.get("format_version")
    if type(version) is not int or version != FORMAT_VERSION:
        raise RecordingError(
            ["format_version"], f"must be {FORMAT_VERSION} (an integer), got {version!r:.40}"
        )
    model = data.get("model", "")
    if not isinstance(model, str) or len(model) > 200:
        raise RecordingError(["model"], "must be the model's name, at most 200 characters")
    frame_s = data.get("frame_s", FRAME_S)
    if not _is_number(frame_s) or frame_s != FRAME_S:
        raise RecordingError(["frame_s"], f"must be {FRAME_S} (the 20 ms frame)")
    columns = data.get("columns")
    specs = columns_spec(nq)
    if not isinstance(columns, dict):
        raise RecordingError(["columns"], "must be an object of arrays")
    for name in columns:
        if name not in specs:
            raise RecordingError(["columns", name[:64]], f"unknown; allowed: {', '.join(specs)}")
    arrays: dict[str, Any] = {}  # the columns, each an array (Recording takes them by name)
    frames: int | None = None
    for name, spec in specs.items():
        if name not in columns:
            raise RecordingError(["columns", name], f"missing; a recording has {', '.join(specs)}")
        arrays[name] = _column(name, columns[name], spec, frames)
        frames = len(arrays[name])
    count = data.get("frames", frames)
    if type(count) is not int or count != frames:
        raise RecordingError(["frames"], f"must be the number of frames in the columns, {frames}")
    events = data.get("events", [])
    if not isinstance(events, list) or len(events) > MAX_EVENTS:
        raise RecordingError(["events"], f"must be a list of at most {MAX_EVENTS} objects")
    return Recording(
        **arrays,
        events=tuple(_event(e, ["events", i]) for i, e in enumerate(events)),
        params=_params(data.get("params", {})),
        model=model,
    )
