"""The robot being simulated: its description, the figures that follow from it, the JSON Schema
of a description, the robots on offer, a switch to another, a URDF or MJCF imported (§7, §16)."""

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Query, Request
from pydantic import BaseModel, ConfigDict, Field
from starlette.concurrency import run_in_threadpool

from app.robots import RobotDescription
from app.robots.servos import servo_table
from app.server.api.answers import ANSWER
from app.server.api.answers_data import (
    Cancelled,
    RobotImported,
    RobotList,
    RobotSummary,
    RobotSwitched,
)
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, PATTERN_RULES, ApiError, responses
from app.server.http.robot_upload import (
    MAX_DEPTH,
    MAX_NAME_BYTES,
    MAX_UNPACKED_BYTES,
    MAX_UPLOAD_BYTES,
    MAX_ZIP_FILES,
    UploadRefused,
)
from app.server.jobs.robot_importer import ImportBusy, ImportFailed, ImportOptions
from app.server.param_store import RobotBusy
from app.server.robot_shelf import UnknownRobot

router = APIRouter(
    prefix="/api", tags=["robot"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)


class RobotBody(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    name: str = Field(max_length=64, description="a robot of GET /api/robots")


@router.get("/robot", response_model=RobotSummary, **ANSWER)
async def robot(services: ServicesDep) -> dict[str, Any]:
    """The loaded robot's description and derived figures: total and link masses, leg lengths,
    each joint's servo settings (force range, kp, damping, armature, friction loss) and eq (1)'s
    required torque and margin per joint, with warnings."""
    return await run_in_threadpool(lambda: services.robot.summary())  # its lock off the loop


@router.get("/robot/schema", response_model=dict[str, Any])
def robot_schema() -> dict[str, Any]:
    """The JSON Schema of a robot description (`models/robots/artro.yaml` is one)."""
    return RobotDescription.model_json_schema()


@router.get("/robots", response_model=RobotList, **ANSWER)
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


@router.put("/robot", response_model=RobotSwitched, responses=responses(404, 409, 422), **ANSWER)
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
        raise ApiError(409, str(exc), "robot_busy", version=services.snapshot().version) from exc
    return {"robot": body.name, "changed": changed, "params": snapshot.to_dict()}


UPLOAD_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "application/octet-stream": {
                "schema": {
                    "type": "string",
                    "format": "binary",
                    "description": f"a .urdf, an MJCF .xml, or a .zip of one with its meshes; at "
                    f"most {MAX_UPLOAD_BYTES} bytes, a zip of {MAX_ZIP_FILES} entries, "
                    f"{MAX_UNPACKED_BYTES} bytes unpacked, {MAX_DEPTH} folders deep",
                }
            }
        },
    }
}
REFUSED = {"refused": 422, "timed_out": 422, "cancelled": 409}
ROBOT_NAME = r"^[a-z][a-z0-9_-]{0,35}$"  # a description's name, room left for a '-2'
PATTERN_RULES[ROBOT_NAME] = (
    "a robot's name is a lower-case letter, then up to 35 lower-case letters, digits, '-' or '_'"
)


@router.post(
    "/robot/import",
    response_model=RobotImported,
    openapi_extra=UPLOAD_BODY,
    responses=responses(409, 413, 422, 429),
    **ANSWER,
)
async def import_robot_file(
    request: Request,
    services: ServicesDep,
    filename: Annotated[
        str,
        Query(
            min_length=1,
            max_length=MAX_NAME_BYTES,
            description="the uploaded file's name, ending .urdf, .xml or .zip",
        ),
    ],
    file: Annotated[
        str | None,
        Query(max_length=1024, description="the robot file within a zip holding several"),
    ] = None,
    name: Annotated[
        str | None,
        Query(
            pattern=ROBOT_NAME,
            description="the robot's name (default: from the file's)",
        ),
    ] = None,
    servo: Annotated[
        str, Query(max_length=64, description="every leg joint's servo (GET /api/servos)")
    ] = "MG996R",
    keep_actuators: bool = False,
    forward: Annotated[
        Literal["+x", "-x", "+y", "-y", "+z", "-z"] | None,
        Query(description="the file's root axis the toes point along, where geometry cannot tell"),
    ] = None,
) -> dict[str, Any]:
    """Import a URDF or MJCF biped as `artro robot import` does (docs/DESIGN.md §16), in a child
    process with a deadline, and offer it (GET /api/robots); switch to it with PUT /api/robot. The
    answer: its figures, the mapping (gait joint, file joint, sign, zero, axis error) and notes.
    Refused in words with nothing kept: a hostile or unreadable upload, a robot the gait cannot
    drive, a deadline passed (422); cancelled (409); while another import runs (429)."""
    if servo not in (known := servo_table()):
        msg = f"unknown servo {servo!r}; known: {', '.join(sorted(known))}"
        raise ApiError(422, msg, "unknown_servo", loc=["query", "servo"])
    body = await request.body()
    options = ImportOptions(name, servo, keep_actuators, forward, file)
    try:
        return await run_in_threadpool(services.importer.run, body, filename, options)
    except ImportBusy as exc:
        raise ApiError(429, str(exc), "import_busy", headers={"Retry-After": "2"}) from exc
    except UploadRefused as exc:
        raise ApiError(422, f"not imported: {exc}", "upload_refused", loc=["body"]) from exc
    except ImportFailed as exc:
        raise ApiError(
            REFUSED[exc.kind], f"not imported: {exc}", f"import_{exc.kind}", loc=["body"]
        ) from exc


@router.delete("/robot/import", response_model=Cancelled, **ANSWER)
def cancel_robot_import(services: ServicesDep) -> dict[str, Any]:
    """Cancel the robot import that runs (its child stopped, nothing kept); whether one ran."""
    return {"cancelled": services.importer.cancel()}
