"""Named presets, their diff, and export/import of parameter sets (JSON, YAML, C header)."""

import dataclasses
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Path, Query, Request, Response
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException as StarletteHTTPException

from app.params.document import ParameterSet
from app.params.formats import MAX_IMPORT_BYTES, ImportTooLarge, export_text, parse_import
from app.params.presets import NAME_RULE, PresetError, PresetNotFound, diff
from app.params.schema import ImportBody, ImportBodyV1, inline_schema
from app.params.strict_text import ParameterImportError
from app.server.api.answers import (
    ANSWER,
    Deleted,
    ParameterDocument,
    Params,
    PresetDiff,
    PresetList,
)
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, PATTERN_RULES, ApiError, responses
from app.server.http.request_gate import JSON_TYPES, YAML_TYPES
from app.server.services import Services

router = APIRouter(
    prefix="/api", tags=["presets"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)

CURRENT = "current"  # in a diff: the parameters in use now
# NAME_RULE as a JSON-schema pattern (no '..', no trailing '.'): clients see what is allowed
NAME_SCHEMA_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_-]*(\.[A-Za-z0-9_-]+)*$"
PATTERN_RULES[NAME_SCHEMA_PATTERN] = f"a preset name is {NAME_RULE}"
Name = Annotated[
    str, Path(max_length=64, pattern=NAME_SCHEMA_PATTERN, description=f"a preset name: {NAME_RULE}")
]
Other = Annotated[
    str,
    Query(max_length=64, pattern=NAME_SCHEMA_PATTERN, description="preset name, or 'current'"),
]
DIFF = "diff"  # GET /api/presets/diff is the diff, never a preset


def _not_the_diff(name: str) -> None:
    """/api/presets/diff answers GET only: other methods there get 405 with that Allow."""
    if name == DIFF:
        raise StarletteHTTPException(405)


def _get(services: Services, name: str) -> ParameterSet:
    if name == CURRENT:
        return services.snapshot().parameter_set()
    try:
        return services.presets.get(name)
    except PresetNotFound as exc:
        raise ApiError(404, f"no preset named {name[:64]!r}", "not_found", loc=["path"]) from exc
    except PresetError as exc:
        raise ApiError(422, str(exc), "invalid_preset", loc=["path"]) from exc


@router.get("/presets", response_model=PresetList, **ANSWER)
def list_presets(services: ServicesDep) -> dict[str, Any]:
    infos = services.presets.list()
    return {
        "presets": [info.to_dict() for info in infos],
        "problems": [problem.to_dict() for problem in services.presets.problems],
    }


@router.get("/presets/diff", response_model=PresetDiff, responses=responses(404, 422), **ANSWER)
def diff_presets(services: ServicesDep, a: Other, b: Other = CURRENT) -> dict[str, Any]:
    """Every field in which two parameter sets differ ("diff" is not a preset name)."""
    return {"a": a, "b": b, "differences": diff(_get(services, a), _get(services, b))}


@router.get(
    "/presets/{name}", response_model=ParameterDocument, responses=responses(404, 422), **ANSWER
)
def get_preset(name: Name, services: ServicesDep) -> dict[str, Any]:
    return _get(services, name).to_dict()


@router.put(
    "/presets/{name}",
    status_code=201,
    response_model=ParameterDocument,
    responses=responses(422, 507),
    **ANSWER,
)
def save_preset(name: Name, services: ServicesDep) -> dict[str, Any]:
    """Save the parameters in use now under this name (not a built-in or reserved one); 507
    when the disk is full (nothing is written)."""
    _not_the_diff(name)
    try:
        return services.presets.save(name, services.snapshot().parameter_set()).to_dict()
    except PresetError as exc:
        raise ApiError(422, str(exc), "invalid_preset", loc=["path"]) from exc


@router.delete("/presets/{name}", response_model=Deleted, responses=responses(404, 422), **ANSWER)
def delete_preset(name: Name, services: ServicesDep) -> dict[str, Any]:
    _not_the_diff(name)
    try:
        services.presets.delete(name)
    except PresetNotFound as exc:
        raise ApiError(404, f"no preset named {name!r}", "not_found", loc=["path"]) from exc
    except PresetError as exc:
        raise ApiError(422, str(exc), "invalid_preset", loc=["path"]) from exc
    return {"deleted": name}


@router.post("/presets/{name}/load", response_model=Params, responses=responses(404, 422), **ANSWER)
def load_preset(
    name: Name,
    services: ServicesDep,
    keep_motion: Annotated[
        bool, Query(description="keep the motion vector and CA in use; load only the gait")
    ] = False,
) -> dict[str, Any]:
    """Make a preset the parameters in use (undoable). `warnings` says if it was tuned for
    another robot than the one simulated."""
    pset = _get(services, name)
    if keep_motion:
        pset = dataclasses.replace(pset, motion=services.snapshot().motion)
    loaded = services.store.replace(pset, "preset").to_dict()
    return loaded | {"warnings": services.robot_warnings(pset)}


EXPORT_CONTENT = {
    "application/json": {"schema": {"type": "object"}},
    "application/yaml": {"schema": {"type": "object"}},
    "text/x-c": {"schema": {"type": "string"}},
}


@router.get(
    "/export",
    response_class=Response,
    responses={200: {"content": EXPORT_CONTENT}, **responses(422)},
)
def export(
    services: ServicesDep,
    format: Annotated[Literal["json", "yaml", "c"], Query(description="the file format")] = "json",
) -> Response:
    """The parameters in use as a file: JSON, YAML, or a C header for the ATmega128 firmware."""
    text, media_type, filename = export_text(
        services.snapshot().parameter_set(), format, hardware=services.hardware
    )
    headers = {"Content-Disposition": f'attachment; filename="{filename}"'}
    return Response(text, media_type=media_type, headers=headers)


_DOCUMENT = inline_schema(ImportBody, ImportBodyV1)
IMPORT_BODY = {
    "requestBody": {
        "required": True,
        "description": f"a parameter set, at most {MAX_IMPORT_BYTES // 1024} KiB: an exported "
        "file or what GET /api/params returns; groups or fields left out take the paper's value",
        "content": {media: {"schema": _DOCUMENT} for media in sorted(JSON_TYPES | YAML_TYPES)},
    }
}


@router.post(
    "/import",
    response_model=Params,
    openapi_extra=IMPORT_BODY,
    responses=responses(413, 422),
    **ANSWER,
)
async def import_params(request: Request, services: ServicesDep) -> dict[str, Any]:
    """Upload a JSON or YAML parameter set (at most 64 KiB) and make it the one in use."""
    raw = bytearray()
    async for chunk in request.stream():  # the request gate has refused bodies over the limit
        raw += chunk
    try:  # parsing (YAML especially) takes milliseconds: never on the event loop
        pset = await run_in_threadpool(
            parse_import, bytes(raw), request.headers.get("content-type")
        )
    except ImportTooLarge as exc:
        raise ApiError(413, str(exc), "body_too_large", loc=["body"]) from exc
    except ParameterImportError as exc:  # every wrong field, with its path, when there are several
        items = [p | {"type": "invalid_import"} for p in exc.problems]
        raise ApiError(422, str(exc), "invalid_import", loc=["body"], items=items) from exc
    except ValueError as exc:
        raise ApiError(422, str(exc), "invalid_import", loc=["body"]) from exc
    return await run_in_threadpool(_make_current, services, pset)


def _make_current(services: Services, pset: ParameterSet) -> dict[str, Any]:
    """The imported set in use, and what it warns of: off the event loop (the store's change
    runs every listener: the simulation's, the 3D view's ~100 controls)."""
    loaded = services.store.replace(pset, "import").to_dict()
    return loaded | {"warnings": services.robot_warnings(pset)}
