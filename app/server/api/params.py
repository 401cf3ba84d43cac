"""The parameter set: read, replace, patch, undo, redo; and the schema it follows."""

from typing import Any, Literal

from fastapi import APIRouter, HTTPException

from app.params.document import ParameterSet
from app.params.schema import ParamsBody, ParamsPatchBody, schema_description
from app.server.api.deps import ServicesDep
from app.server.param_store import NothingToUndo

router = APIRouter(prefix="/api", tags=["parameters"])


@router.get("/params")
def get_params(services: ServicesDep) -> dict[str, Any]:
    return services.store.snapshot().to_dict()


@router.put("/params")
def put_params(body: ParamsBody, services: ServicesDep) -> dict[str, Any]:
    """Replace every parameter; invalid input changes nothing."""
    current = services.store.snapshot()
    pset = ParameterSet.from_dict({"name": current.name, **body.model_dump()})
    return services.store.replace(pset, "http").to_dict()


@router.patch("/params")
def patch_params(body: ParamsPatchBody, services: ServicesDep) -> dict[str, Any]:
    """Change some parameters; the rest stay. Invalid input changes nothing."""
    return services.store.update(body.as_patch(), "http").to_dict()


@router.post("/params/{step}")
def history(step: Literal["undo", "redo"], services: ServicesDep) -> dict[str, Any]:
    """Undo or redo a parameter change (409 when there is nothing to undo or redo)."""
    move = services.store.undo if step == "undo" else services.store.redo
    try:
        return move("http").to_dict()
    except NothingToUndo as exc:
        raise HTTPException(409, str(exc)) from exc


@router.get("/schema")
def schema() -> list[dict[str, Any]]:
    """Every parameter group and field: label, default, range, step, unit, equation, meaning."""
    return schema_description()
