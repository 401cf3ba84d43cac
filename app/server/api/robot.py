"""The robot being simulated: its description, the figures that follow from it, and the JSON
Schema of a description (docs/DESIGN.md §12)."""

from typing import Any

from fastapi import APIRouter
from starlette.concurrency import run_in_threadpool

from app.robots import RobotDescription
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.errors import GUARD_RESPONSES

router = APIRouter(
    prefix="/api/robot", tags=["robot"], responses=GUARD_RESPONSES, route_class=StrictJsonRoute
)


@router.get("")
async def robot(services: ServicesDep) -> dict[str, Any]:
    """The loaded robot's description and derived figures: total and link masses, leg lengths,
    each joint's servo settings (force range, kp, damping, armature, friction loss) and eq (1)'s
    required torque and margin per joint, with warnings."""
    return await run_in_threadpool(services.robot.summary)


@router.get("/schema")
def robot_schema() -> dict[str, Any]:
    """The JSON Schema of a robot description (`models/robots/artro.yaml` is one)."""
    return RobotDescription.model_json_schema()
