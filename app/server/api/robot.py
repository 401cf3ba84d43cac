"""The robot being simulated: its description, the figures that follow from it, the JSON Schema
of a description, the robots on offer, and a switch to another (docs/DESIGN.md §7)."""

from typing import Any

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field
from starlette.concurrency import run_in_threadpool

from app.robots import RobotDescription
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.errors import GATE_RESPONSES, ApiError, responses
from app.server.param_store import RobotBusy
from app.server.robot_shelf import UnknownRobot

router = APIRouter(
    prefix="/api", tags=["robot"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)


class RobotBody(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    name: str = Field(max_length=64, description="a robot of GET /api/robots")


@router.get("/robot")
async def robot(services: ServicesDep) -> dict[str, Any]:
    """The loaded robot's description and derived figures: total and link masses, leg lengths,
    each joint's servo settings (force range, kp, damping, armature, friction loss) and eq (1)'s
    required torque and margin per joint, with warnings."""
    return await run_in_threadpool(lambda: services.robot.summary())  # its lock off the loop


@router.get("/robot/schema")
def robot_schema() -> dict[str, Any]:
    """The JSON Schema of a robot description (`models/robots/artro.yaml` is one)."""
    return RobotDescription.model_json_schema()


@router.get("/robots")
def robots(services: ServicesDep) -> dict[str, Any]:
    """The robots this server can simulate (the one it was started with and the built-in
    ones): name, title, total mass, leg lengths, default preset; and which is loaded."""
    offered = []
    for name in services.robots.names():
        robot = services.robots.get(name)
        offered.append(
            {
                "name": name,
                "title": robot.description.title,
                "total_mass_kg": robot.total_mass_kg(),
                "leg_m": robot.geometry.upper_m + robot.geometry.lower_m,
                "default_preset": robot.description.default_preset,
            }
        )
    return {"loaded": services.robot.name, "robots": offered}


@router.put("/robot", responses=responses(404, 409, 422))
def switch_robot(body: RobotBody, services: ServicesDep) -> dict[str, Any]:
    """Simulate another robot from the next frame: the robot starts over, standing, in its
    default preset, in the same world. A new parameter version: undo (POST /api/params/undo)
    goes back to the robot and set before. Refused, with nothing changed, for a robot not on
    offer (404, as for a preset or ghost named that is not there) and while a job or a replay runs
    or the firmware drives (409)."""
    try:
        snapshot, changed = services.switch_robot(body.name)
    except UnknownRobot as exc:
        raise ApiError(404, str(exc), "unknown_robot", loc=["body", "name"]) from exc
    except RobotBusy as exc:
        raise ApiError(
            409, str(exc), "robot_busy", version=services.store.snapshot().version
        ) from exc
    return {"robot": body.name, "changed": changed, "params": snapshot.to_dict()}
