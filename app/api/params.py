"""The parameter set: read, replace, patch, undo, redo; and the schema it follows."""

from typing import Any, Literal

from fastapi import APIRouter, HTTPException

from app.api.deps import RuntimeDep
from app.paramset import ParameterSet
from app.schema import ParamsBody, ParamsPatchBody, schema_description
from app.store import NothingToUndo

router = APIRouter(prefix="/api", tags=["parameters"])


@router.get("/params")
def get_params(runtime: RuntimeDep) -> dict[str, Any]:
    return runtime.store.snapshot().to_dict()


@router.put("/params")
def put_params(body: ParamsBody, runtime: RuntimeDep) -> dict[str, Any]:
    """Replace every parameter; invalid input changes nothing."""
    current = runtime.store.snapshot()
    pset = ParameterSet.from_dict({"name": current.name, **body.model_dump()})
    return runtime.store.replace(pset, "http").to_dict()


@router.patch("/params")
def patch_params(body: ParamsPatchBody, runtime: RuntimeDep) -> dict[str, Any]:
    """Change some parameters; the rest stay. Invalid input changes nothing."""
    return runtime.store.update(body.as_patch(), "http").to_dict()


@router.post("/params/{step}")
def history(step: Literal["undo", "redo"], runtime: RuntimeDep) -> dict[str, Any]:
    """Undo or redo a parameter change (409 when there is nothing to undo or redo)."""
    move = runtime.store.undo if step == "undo" else runtime.store.redo
    try:
        return move("http").to_dict()
    except NothingToUndo as exc:
        raise HTTPException(409, str(exc)) from exc


@router.get("/schema")
def schema() -> list[dict[str, Any]]:
    """Every parameter group and field: label, default, range, step, unit, equation, meaning."""
    return schema_description()
