"""The A/B ghost: a preset or an earlier version walks beside the live robot (docs/DESIGN.md
§10)."""

from __future__ import annotations

import dataclasses
from typing import Any

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from app.params.presets import PresetError, PresetNotFound, diff
from app.server.api.answers import ANSWER, GhostAccepted, GhostState
from app.server.api.deps import JsonIntFrom1, ServicesDep, StrictJsonRoute
from app.server.api.presets import NAME_SCHEMA_PATTERN
from app.server.http.errors import GATE_RESPONSES, ApiError, responses
from app.server.services import Services
from app.server.sim.sim_commands import RemoveGhost, SetGhost

router = APIRouter(
    prefix="/api", tags=["ghost"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)


class PresetGhost(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    preset: str = Field(
        max_length=64, pattern=NAME_SCHEMA_PATTERN, description="a built-in or saved preset"
    )


class VersionGhost(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    version: JsonIntFrom1 = Field(
        description="an earlier parameter version (undo history) or the current"
    )


def _state(services: Services) -> dict[str, Any]:
    status = services.ghost_status()
    versions = [
        {"version": s.version, "name": s.name, "source": s.source}
        for s in services.store.versions()
    ]
    if status is None:
        return {"enabled": False, "versions": versions}
    live = services.snapshot().parameter_set()
    ghost_set = dataclasses.replace(live, gait=status.params)
    delta = status.delta()
    return {
        "enabled": True,
        "source": status.source,
        "phase_locked": status.phase_locked,
        "note": status.note,
        "fell": status.fell,
        "window_s": status.window_s,
        "diff": [
            {"field": d["field"], "live": d["a"], "ghost": d["b"]} for d in diff(live, ghost_set)
        ],
        "metrics": {
            "live": None if status.live is None else dataclasses.asdict(status.live),
            "ghost": None if status.ghost is None else dataclasses.asdict(status.ghost),
            "delta": None if delta is None else dataclasses.asdict(delta),
        },
        "versions": versions,
    }


@router.get("/ghost", response_model=GhostState, **ANSWER)
def get_ghost(services: ServicesDep) -> dict[str, Any]:
    """The ghost's source, phase lock, its parameter differences from the live set, and speed,
    turn rate and gyro RMS of both robots over the last 10 s (with ghost - live)."""
    return _state(services)


@router.put("/ghost", response_model=GhostAccepted, responses=responses(404, 422), **ANSWER)
def put_ghost(body: PresetGhost | VersionGhost, services: ServicesDep) -> dict[str, Any]:
    """Let a preset or an earlier version walk beside the live robot, phase-locked, with the live
    motion vector and CA. It replaces any ghost there was. `warnings` says if the set was tuned
    for another robot than the one here (the ghost walks it on this one)."""
    if isinstance(body, PresetGhost):
        try:
            pset, source = services.presets.get(body.preset), f"preset {body.preset}"
        except PresetNotFound as exc:
            names = ", ".join(p.name for p in services.presets.list())
            raise ApiError(
                404, f"no preset named {body.preset!r}; presets: {names}", "not_found",
                loc=["body", "preset"],
            ) from exc  # fmt: skip
        except PresetError as exc:
            raise ApiError(422, str(exc), "invalid_preset", loc=["body", "preset"]) from exc
    else:
        found = {s.version: s for s in services.store.versions()}
        if body.version not in found:
            allowed = ", ".join(str(v) for v in sorted(found))
            raise ApiError(
                404, f"no version {body.version} to compare with; versions: {allowed}",
                "not_found", loc=["body", "version"],
            )  # fmt: skip
        pset, source = found[body.version].parameter_set(), f"version {body.version}"
    services.send(SetGhost(pset.gait, source))
    return {"accepted": "ghost", "source": source, "warnings": services.robot_warnings(pset)}


@router.delete("/ghost", response_model=GhostAccepted, **ANSWER)
def delete_ghost(services: ServicesDep) -> dict[str, Any]:
    """No ghost."""
    services.send(RemoveGhost())
    return {"accepted": "ghost", "source": None}
