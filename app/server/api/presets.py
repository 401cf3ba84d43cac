"""Named presets, their diff, and export/import of parameter sets (JSON, YAML, C header)."""

import dataclasses
from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Query, Request, Response

from app.params.document import ParameterSet
from app.params.formats import (
    FORMATS,
    MAX_IMPORT_BYTES,
    ImportTooLarge,
    ParameterImportError,
    export_text,
    parse_import,
)
from app.params.presets import PresetError, PresetNotFound, diff
from app.server.api.deps import ServicesDep
from app.server.services import Services

router = APIRouter(prefix="/api", tags=["presets"])

CURRENT = "current"  # in a diff: the parameters in use now


def _get(services: Services, name: str) -> ParameterSet:
    if name == CURRENT:
        return services.store.snapshot().parameter_set()
    try:
        return services.presets.get(name)
    except PresetNotFound as exc:
        raise HTTPException(404, f"no preset named {name!r}") from exc
    except PresetError as exc:
        raise HTTPException(422, str(exc)) from exc


@router.get("/presets")
def list_presets(services: ServicesDep) -> dict[str, Any]:
    infos = services.presets.list()
    return {
        "presets": [info.to_dict() for info in infos],
        "problems": [problem.to_dict() for problem in services.presets.problems],
    }


@router.get("/presets/diff")
def diff_presets(
    services: ServicesDep,
    a: Annotated[str, Query(description="preset name, or 'current'")],
    b: Annotated[str, Query(description="preset name, or 'current'")] = CURRENT,
) -> dict[str, Any]:
    """Every field in which two parameter sets differ."""
    return {"a": a, "b": b, "differences": diff(_get(services, a), _get(services, b))}


@router.get("/presets/{name}")
def get_preset(name: str, services: ServicesDep) -> dict[str, Any]:
    return _get(services, name).to_dict()


@router.put("/presets/{name}", status_code=201)
def save_preset(name: str, services: ServicesDep) -> dict[str, Any]:
    """Save the parameters in use now under this name."""
    if name == CURRENT:
        raise HTTPException(422, f"{CURRENT!r} is reserved for the parameters in use")
    try:
        return services.presets.save(name, services.store.snapshot().parameter_set()).to_dict()
    except PresetError as exc:
        raise HTTPException(422, str(exc)) from exc


@router.delete("/presets/{name}")
def delete_preset(name: str, services: ServicesDep) -> dict[str, Any]:
    try:
        services.presets.delete(name)
    except PresetNotFound as exc:
        raise HTTPException(404, f"no preset named {name!r}") from exc
    except PresetError as exc:
        raise HTTPException(422, str(exc)) from exc
    return {"deleted": name}


@router.post("/presets/{name}/load")
def load_preset(
    name: str,
    services: ServicesDep,
    keep_motion: Annotated[
        bool, Query(description="keep the motion vector and CA in use; load only the gait")
    ] = False,
) -> dict[str, Any]:
    """Make a preset the parameters in use (undoable)."""
    pset = _get(services, name)
    if keep_motion:
        pset = dataclasses.replace(pset, motion=services.store.snapshot().motion)
    return services.store.replace(pset, "preset").to_dict()


@router.get("/export")
def export(
    services: ServicesDep,
    format: Annotated[str, Query(description=f"one of {', '.join(FORMATS)}")] = "json",
) -> Response:
    """The parameters in use as a file: JSON, YAML, or a C header for the ATmega128 firmware."""
    if format not in FORMATS:
        raise HTTPException(422, f"unknown format {format!r}; allowed: {', '.join(FORMATS)}")
    text, media_type, filename = export_text(
        services.store.snapshot().parameter_set(), format, hardware=services.sim.hardware
    )
    headers = {"Content-Disposition": f'attachment; filename="{filename}"'}
    return Response(text, media_type=media_type, headers=headers)


@router.post("/import")
async def import_params(request: Request, services: ServicesDep) -> dict[str, Any]:
    """Upload a JSON or YAML parameter set (at most 64 KiB) and make it the one in use."""
    raw = bytearray()
    async for chunk in request.stream():
        raw += chunk
        if len(raw) > MAX_IMPORT_BYTES:
            raise HTTPException(413, f"import larger than {MAX_IMPORT_BYTES} bytes")
    try:
        pset = parse_import(bytes(raw), request.headers.get("content-type"))
    except ImportTooLarge as exc:
        raise HTTPException(413, str(exc)) from exc
    except ParameterImportError as exc:  # every wrong field, with its path, when there are several
        detail = exc.problems if len(exc.problems) > 1 else str(exc)
        raise HTTPException(422, detail) from exc
    return services.store.replace(pset, "import").to_dict()
