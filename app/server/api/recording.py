"""Record and replay: the session's last 60 s (poses, pulses, parameter changes with their
sources), a replay position for the 3D view and the scope, export as a file or VCD, import."""

from __future__ import annotations

import json
import time
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import Response
from pydantic import BaseModel, ConfigDict, Field
from starlette.concurrency import run_in_threadpool

from app.firmware.build import DEFAULT_BOARD
from app.firmware.mega_pulses import board_frames_vcd, last_run
from app.firmware.vcd import edges_of_frames, vcd_text
from app.params.strict_text import ParameterImportError, load_json_strict
from app.server.api.answers import ANSWER, ReplayStatus
from app.server.api.answers_data import RecordedFrame, RecordingFile, RecordingSummary
from app.server.api.deps import JsonIntFrom0, ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, ApiError, responses
from app.server.recording.recorder import RECORD_FRAMES, Recording
from app.server.recording.recording_file import (
    EVENT_KINDS,
    INT32_MAX,
    KEYS,
    MAX_SECONDS,
    NQ,
    OCR_IDLE,
    PHASE_MAX,
    RecordingError,
    recording_from_json,
)
from app.server.recording.replay import NothingRecorded, OtherRobot
from app.server.services import Services
from hardware import CHANNELS, OCR_MAX, SLOTS_PER_FRAME, frame_edges

router = APIRouter(
    prefix="/api/recording",
    tags=["recording"],
    responses=GATE_RESPONSES,
    route_class=StrictJsonRoute,
)


class ReplayBody(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    index: JsonIntFrom0 | None = Field(
        None,
        description="position in the recording, 0 = its oldest frame; null: the newest",
    )


def _summary(services: Services) -> dict[str, Any]:
    return services.recorder.summary() | {"replay": services.replay_status()}


def _shown(services: Services) -> Recording:
    """The recording in replay, else the session so far."""
    return services.replay.recording or services.recorder.recording()


@router.get("", response_model=RecordingSummary, **ANSWER)
def get_recording(services: ServicesDep) -> dict[str, Any]:
    """What the ring buffer holds (frames, session times, the last 50 events) and the replay."""
    return _summary(services)


@router.post("/replay", response_model=ReplayStatus, responses=responses(404, 409, 422), **ANSWER)
def replay(body: ReplayBody, services: ServicesDep) -> dict[str, Any]:
    """Replay (the live simulation pauses) at `index`, or move there while replaying."""
    try:
        services.replay.enter(body.index)
    except NothingRecorded as exc:
        raise ApiError(409, str(exc), "nothing_recorded", loc=["body"]) from exc
    except IndexError as exc:  # no frame there: as GET /api/recording/frame/{index}
        raise ApiError(404, str(exc), "not_found", loc=["body", "index"]) from exc
    return services.replay_status()


@router.post("/live", response_model=ReplayStatus, **ANSWER)
def back_to_live(services: ServicesDep) -> dict[str, Any]:
    """Leave the replay; the simulation resumes if it ran before."""
    services.replay.leave()
    return services.replay_status()


@router.get("/frame/{index}", response_model=RecordedFrame, responses=responses(404, 422), **ANSWER)
def recorded_frame(index: int, services: ServicesDep) -> dict[str, Any]:
    """The scope frame at `index` of the replay (or of the session so far)."""
    try:
        return services.replay.frame_message(index, services.hardware.tdm)
    except IndexError as exc:
        raise ApiError(404, str(exc), "not_found", loc=["path", "index"]) from exc


def _download(text: str, suffix: str, media_type: str) -> Response:
    name = time.strftime(f"artro-recording-%Y%m%d-%H%M%S.{suffix}")
    headers = {"Content-Disposition": f'attachment; filename="{name}"'}
    return Response(text, media_type=media_type, headers=headers)


@router.get("/export", response_model=RecordingFile, responses=responses(409))
def export(services: ServicesDep) -> Response:
    """The recording (the replay's, or the session so far) as one JSON file: per frame the
    poses (qpos), the OCR table, phase, times and parameter version; the events; the parameter
    documents of every version in it."""
    rec = _shown(services)
    if not len(rec):
        raise ApiError(409, "nothing recorded yet", "nothing_recorded", loc=["path"])
    return _download(json.dumps(rec.to_json(), separators=(",", ":")), "json", "application/json")


@router.get(
    "/export.vcd",
    responses={200: {"content": {"text/plain": {"schema": {"type": "string"}}}}, **responses(409)},
)
def export_vcd(services: ServicesDep) -> Response:
    """The recording's nine pulse and select lines as a Value Change Dump (PulseView, GTKWave):
    OC1A..OC3C, SEL0..SEL2, from the recorded OCR tables as the hardware model puts them on the
    wires. Frames the Mega board drove (docs/BOARDS.md), live or replayed: its PCA9685's
    channels PWM0..PWM11 and a line per I2C part, high from START to STOP (409 for a replayed
    file of the Mega's, which keeps only the OCR tables)."""
    rec = _shown(services)
    if not len(rec):
        raise ApiError(409, "nothing recorded yet", "nothing_recorded", loc=["path"])
    trace = services.sim.live.board_trace()
    if trace is not None and services.replay.recording is None and len(trace):
        text = trace.vcd_text(f"the last {len(trace)} frames of the Mega board's drive")
        return _download(text, "vcd", "text/plain; charset=utf-8")
    mega = [(i, b) for i, b in enumerate(rec.boards) if b is not None]
    if mega:
        run = last_run([b for _, b in mega])
        first, last = mega[-len(run)][0], mega[-1][0]
        said = (f"recorded frames {int(rec.frame[first])}..{int(rec.frame[last])} the Mega "
                f"board drove, {rec.model}")  # fmt: skip
        return _download(board_frames_vcd(run, said), "vcd", "text/plain; charset=utf-8")
    board = services.sim.live.firmware_board
    if rec.drive.any() and board != DEFAULT_BOARD:
        raise ApiError(
            409,
            f"the {board} board drove this recording's firmware frames, kept as OCR tables only "
            "(no PCA9685 edges, no I2C bus: an imported file); available: the recording (GET "
            "/api/recording/export), or, back live, this download of the live drive",
            "no_board_lines",
            loc=["path"],
        )
    tdm = services.hardware.tdm
    edges = edges_of_frames([frame_edges(ocr, tdm) for ocr in rec.ocr])
    first_frame, last_frame = int(rec.frame[0]), int(rec.frame[-1])
    text = vcd_text(edges, 0, comment=f"recorded frames {first_frame}..{last_frame}, {rec.model}")
    return _download(text, "vcd", "text/plain; charset=utf-8")


def _frames(item: dict[str, Any]) -> dict[str, Any]:
    return {"type": "array", "minItems": 1, "maxItems": RECORD_FRAMES, "items": item}


def _list(item: dict[str, Any], n: int) -> dict[str, Any]:
    return {"type": "array", "minItems": n, "maxItems": n, "items": item}


SECONDS = {"type": "number", "minimum": 0, "maximum": MAX_SECONDS}
COLUMNS_SCHEMA = {
    "type": "object",
    "description": "one array per column, all with as many frames (JSON Schema cannot say that; "
    "a file whose columns differ in length is refused with 422)",
    "required": ["frame", "t_s", "sim_t_s", "phase", "qpos", "ocr", "version", "drive"],
    "additionalProperties": False,
    "properties": {
        "frame": _frames({"type": "integer", "minimum": 0}),
        "t_s": _frames(SECONDS),
        "sim_t_s": _frames(SECONDS),
        "phase": _frames({"type": "number", "minimum": -PHASE_MAX, "maximum": PHASE_MAX}),
        "qpos": _frames(_list({"type": "number"}, NQ)),
        "ocr": _frames(
            _list(
                _list(
                    {"type": "integer", "minimum": OCR_IDLE, "maximum": OCR_MAX}, SLOTS_PER_FRAME
                ),
                len(CHANNELS),
            )
        ),
        "version": _frames({"type": "integer", "minimum": 1, "maximum": INT32_MAX}),
        "drive": _frames({"type": "integer", "minimum": 0, "maximum": 1}),
    },
}
IMPORT_BODY: dict[str, Any] = {
    "requestBody": {
        "required": True,
        "description": "a recording file as GET /api/recording/export writes it (at most 16 MiB)",
        "content": {
            "application/json": {
                "schema": {
                    "type": "object",
                    "required": ["format", "format_version", "columns"],
                    "additionalProperties": False,
                    "properties": {
                        "format": {"const": "artro-recording"},
                        "format_version": {"const": 1},
                        "model": {"type": "string", "maxLength": 200},
                        "frame_s": {"const": 0.02},
                        "frames": {"type": "integer", "minimum": 1, "maximum": RECORD_FRAMES},
                        "columns": COLUMNS_SCHEMA,
                        "events": {
                            "type": "array",
                            "items": {
                                "type": "object",
                                "required": ["t_s", "kind"],
                                "properties": {"t_s": SECONDS, "kind": {"enum": list(EVENT_KINDS)}},
                            },
                        },
                        "params": {
                            "type": "object",
                            "description": "version -> the parameter document it was",
                            "patternProperties": {"^[0-9]+$": {"type": "object"}},
                            "additionalProperties": False,
                        },
                    },
                }
            }
        },
    }
}
assert set(
    IMPORT_BODY["requestBody"]["content"]["application/json"]["schema"]["properties"]
) == set(KEYS)


@router.post(
    "/import",
    response_model=ReplayStatus,
    openapi_extra=IMPORT_BODY,
    responses=responses(409, 413, 422, 429),
    **ANSWER,
)
async def import_recording(request: Request, services: ServicesDep) -> dict[str, Any]:
    """Load a recording file (from export) and replay it from its first frame; one import at
    a time (429 while another is read: each is seconds of parsing beside the simulation)."""
    if not services.importing.acquire(blocking=False):
        raise ApiError(
            429, "another recording is being imported: try again when it is done",
            "import_busy", headers={"Retry-After": "2"},
        )  # fmt: skip
    try:
        body, nq = await request.body(), services.model.nq
        try:  # megabytes of JSON: parsed and checked off the event loop
            rec = await run_in_threadpool(lambda: recording_from_json(load_json_strict(body), nq))
        except RecordingError as exc:
            loc = ["body", *exc.loc]
            raise ApiError(422, f"not a recording: {exc}", "invalid_recording", loc=loc) from exc
        except (ValueError, ParameterImportError, UnicodeDecodeError) as exc:
            raise ApiError(
                422, f"not a recording: {exc}", "invalid_recording", loc=["body"]
            ) from exc
    finally:
        services.importing.release()
    try:
        await run_in_threadpool(services.replay.enter, 0, recording=rec)  # its lock off the loop
    except OtherRobot as exc:
        raise ApiError(409, str(exc), "other_robot", loc=["body", "model"]) from exc
    except NothingRecorded as exc:
        raise ApiError(422, f"not a recording: {exc}", "invalid_recording", loc=["body"]) from exc
    return services.replay_status()
