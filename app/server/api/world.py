"""The world the live robot walks in (a model variation, docs/DESIGN.md §8) and the robustness
job that walks the current gait on many of them."""

from dataclasses import asdict
from typing import Annotated, Any

from annotated_types import Ge
from fastapi import APIRouter, Body, Response
from pydantic import BaseModel, ConfigDict, Field

from app.server.api.answers import ANSWER, RobustnessReport, World, WorldName
from app.server.api.deps import WHOLE_FLOAT, JsonIntFrom0, ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, ApiError, responses
from app.server.jobs.registry import JobBusy, RobotChanged
from app.server.jobs.results import RobustnessJob
from app.server.sim.sim_commands import SetWorld
from app.worlds.fitted import fitted_variation
from app.worlds.sampling import VariationRanges
from app.worlds.variations import FIELDS, NOMINAL, parse_variation

router = APIRouter(
    prefix="/api", tags=["world"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)


class WorldBody(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    variation: str = Field(
        max_length=2000,
        description="as `artro run --vary` takes it, e.g. friction=0.4,latency_ms=40,cal.l_knee=1;"
        " empty: the nominal model",
    )


class RobustnessBody(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    samples: Annotated[int, Ge(4), WHOLE_FLOAT] = Field(
        default=24, le=400, description="variations to walk (4 to 400)"
    )
    seed: JsonIntFrom0 = Field(default=0, le=2**31 - 1, description="of the variations drawn")


def _world(services: Any) -> dict[str, Any]:
    name = services.sim_status().world
    variation = NOMINAL if name == "nominal" else parse_variation(name)
    return {
        "variation": name,
        "values": {f: getattr(variation, f) for f in FIELDS},
        "ranges": asdict(VariationRanges()),
        "fitted": _fitted(services, name),
    }


def _fitted(services: Any, name: str) -> str | None:
    """Whose fit the world `name` is: the fitted robot's recording, or a fit job's id."""
    fitted = services.robot.description.fitted
    if fitted is not None and name != NOMINAL.name:
        try:
            if fitted_variation(services.robot).name == name:
                return fitted.recording or "the fitted robot"
        except ValueError:
            pass
    return services.fitter.fitted_by(name) if name != NOMINAL.name else None


@router.get("/world", response_model=World, **ANSWER)
def get_world(services: ServicesDep) -> dict[str, Any]:
    """The variation the live robot walks in (`nominal` when none), each field's value and the
    default ranges of `artro bench robust`."""
    return _world(services)


@router.put("/world", response_model=WorldName, responses=responses(422), **ANSWER)
def put_world(body: WorldBody, services: ServicesDep) -> dict[str, Any]:
    """Walk on in another world from the next frame on (friction, masses, servo, latency, play,
    tilt, calibration); the robot is not reset. A bad text changes nothing (422)."""
    try:
        variation = parse_variation(body.variation) if body.variation.strip() else NOMINAL
    except (ValueError, TypeError) as exc:
        raise ApiError(422, str(exc), "invalid_variation", loc=["body", "variation"]) from exc
    services.send(SetWorld(variation))
    return {"variation": variation.name}


@router.delete("/world", response_model=WorldName, **ANSWER)
def reset_world(services: ServicesDep) -> dict[str, Any]:
    """Back to the nominal model."""
    services.send(SetWorld(NOMINAL))
    return {"variation": NOMINAL.name}


@router.get(
    "/world/robustness", response_model=RobustnessReport, responses=responses(404), **ANSWER
)
def last_robustness(services: ServicesDep) -> dict[str, Any]:
    """The last finished robustness report of the gait in use on the robot in use (kept for the
    last 16 gaits while the server runs), with `finished_at` (Unix s) and `params_version`;
    404 if none was run on it."""
    report = services.robustness.last_report(services.snapshot())
    if report is None:
        raise ApiError(404, "no robustness report of this gait yet: run one", "no_report")
    return report


@router.post(
    "/jobs/robustness",
    status_code=202,
    response_model=RobustnessJob,
    responses=responses(409, 422),
    **ANSWER,
)
def start_robustness(
    services: ServicesDep,
    response: Response,
    body: Annotated[RobustnessBody | None, Body()] = None,
) -> dict[str, Any]:
    """Walk the current gait through the paper's cases and CA ±0.1 on `samples` variations in
    the background (`artro bench robust`'s report); `GET /api/jobs/{id}` gives the progress
    and the report."""
    body = body or RobustnessBody()
    try:
        job = services.robustness.start(samples=body.samples, seed=body.seed)
    except JobBusy as exc:
        raise ApiError(409, str(exc), "job_running", loc=["job", exc.job.id]) from exc
    except RobotChanged as exc:
        raise ApiError(409, str(exc), "robot_changed", loc=["path"]) from exc
    response.headers["Location"] = f"/api/jobs/{job.id}"
    return job.to_dict()
