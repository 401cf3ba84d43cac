"""The actual trunk path and the differential-drive prediction."""

from typing import Any

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from app.api.deps import RuntimeDep

router = APIRouter(prefix="/api/path", tags=["paths"])


class AnchorBody(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)
    speed_m_s: float | None = Field(
        None, ge=-0.5, le=0.5, description="fix V by hand; null measures it"
    )


@router.get("")
def get_path(runtime: RuntimeDep) -> dict[str, Any]:
    """Actual and predicted paths as [t, x, y, yaw] rows, with V, b, turn radius and rates."""
    return runtime.sim.paths.view()


@router.post("/anchor")
def reanchor(runtime: RuntimeDep, body: AnchorBody | None = None) -> dict[str, Any]:
    """Start the prediction again at the robot's current pose."""
    runtime.sim.command("reanchor", None if body is None else body.speed_m_s)
    return {"accepted": "reanchor"}
