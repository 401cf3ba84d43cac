"""Health, state and simulation control."""

from typing import Any, Literal

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from app.params.document import project_version
from app.server.api.deps import ServicesDep
from app.server.sim_thread import SPEED_RANGE, Command

router = APIRouter(tags=["simulation"])


class SpeedBody(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)
    speed: float = Field(ge=SPEED_RANGE[0], le=SPEED_RANGE[1], description="x real time")


@router.get("/api/health")
def health(services: ServicesDep) -> dict[str, Any]:
    return {
        "status": "ok" if services.sim.alive else "simulation stopped",
        "version": project_version(),
        "viser_port": services.config.viser_port if services.viewer is not None else None,
    }


@router.get("/api/state")
def state(services: ServicesDep) -> dict[str, Any]:
    """Sim time, real-time factor, fell, trunk pose, parameter version and more."""
    sim = services.sim
    return sim.status().to_dict() | {
        "params_version": services.store.snapshot().version,
        "scope": {"clients": sim.scope.client_count, "dropped": sim.scope.dropped},
        "running": sim.alive,
    }


@router.post("/api/sim/{action}")
def control(action: Literal["reset", "pause", "resume", "step"], services: ServicesDep) -> dict:
    """Reset the robot, pause, resume, or advance one 20 ms frame (pauses first)."""
    services.sim.command(Command(action))
    return {"accepted": action}


@router.put("/api/sim/speed")
def set_speed(body: SpeedBody, services: ServicesDep) -> dict:
    services.sim.command(Command.SPEED, body.speed)
    return {"accepted": "speed", "speed": body.speed}
