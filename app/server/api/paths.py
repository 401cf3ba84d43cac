"""The actual trunk path and the differential-drive prediction (the axle fit: api/jobs.py)."""

from typing import Any

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from app.server.api.answers import ANSWER, Accepted, Axle, PathView
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, responses
from app.server.sim.sim_commands import Reanchor

router = APIRouter(
    prefix="/api/path", tags=["paths"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)


class AnchorBody(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)
    speed_m_s: float | None = Field(
        None, ge=-0.5, le=0.5, description="fix V by hand; null measures it"
    )


@router.get("", response_model=PathView, **ANSWER)
def get_path(services: ServicesDep) -> dict[str, Any]:
    """Actual and predicted paths as [t, x, y, yaw] rows, with V, b, turn radius and rates;
    `axle_stale` when b is a fitted b_eff of another gait than the one in use."""
    view = services.paths.view()
    gait = services.snapshot().gait
    return view | {"axle_stale": services.axle_fitter.stale(view["axle_source"], gait)}


@router.post("/clear", response_model=Accepted, **ANSWER)
def clear(services: ServicesDep) -> dict[str, Any]:
    """Forget the path walked so far; the prediction starts again at the robot's next pose."""
    services.paths.clear()
    return {"accepted": "clear"}


@router.post("/anchor", response_model=Accepted, responses=responses(422), **ANSWER)
def reanchor(services: ServicesDep, body: AnchorBody | None = None) -> dict[str, Any]:
    """Start the prediction again at the robot's current pose."""
    services.send(Reanchor(None if body is None else body.speed_m_s))
    return {"accepted": "reanchor"}


class AxleBody(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)
    axle_m: float | None = Field(
        ..., ge=0.01, le=2.0, description="axle b of the prediction; null = the feet distance"
    )


@router.put("/axle", response_model=Axle, responses=responses(422), **ANSWER)
def set_axle(services: ServicesDep, body: AxleBody) -> dict[str, Any]:
    """Predict with this axle b (m), or with the measured distance between the feet (null)."""
    services.paths.set_axle(body.axle_m, "manual")
    return {"axle_m": body.axle_m, "axle_source": "feet" if body.axle_m is None else "manual"}
