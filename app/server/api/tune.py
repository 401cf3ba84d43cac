""" "Tune for this robot": start `artro tune --robot`'s recipe on the robot in use as a job (202;
read and cancel it at /api/jobs/{id}), and the latest such job (docs/DESIGN.md §12, §14)."""

from typing import TYPE_CHECKING, Annotated, Any, Literal

from annotated_types import Ge
from fastapi import APIRouter, Body, Response
from pydantic import BaseModel, ConfigDict, Field, field_validator

from app.analysis.cases import CASES
from app.analysis.robot_start import START_RECIPE
from app.server.api.answers import ANSWER
from app.server.api.deps import WHOLE_FLOAT, JsonIntFrom1, ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, ApiError, responses
from app.server.jobs.registry import JobBusy, RobotChanged
from app.server.jobs.results import TuneJob
from app.server.jobs.tune_job import TuneBudget, WrongRobot, cases_of
from app.server.robot_shelf import UnknownRobot

router = APIRouter(
    prefix="/api", tags=["jobs"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)
if TYPE_CHECKING:  # a Literal of names known only when it runs: to mypy, a name
    CaseName = str
else:
    CaseName = Literal[tuple(c.name for c in CASES)]


class TuneBody(BaseModel):
    """The tune's size; every field left out is the start's recipe's (`artro tune --robot`)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    robot: str | None = Field(
        default=None,
        max_length=64,
        description="the robot in use (GET /api/robots, `loaded`); default it",
    )
    generations: JsonIntFrom1 = Field(
        default=START_RECIPE.generations, le=100, description="1 to 100"
    )
    popsize: Annotated[int, Ge(2), WHOLE_FLOAT] = Field(
        default=START_RECIPE.popsize, le=64, description="candidates, 2 to 64"
    )
    duration_s: float = Field(
        default=START_RECIPE.duration_s, gt=0, le=120, description="s per run"
    )
    warmup_s: float = Field(
        default=START_RECIPE.warmup_s, ge=0, le=60, description="s not measured"
    )
    cases: list[CaseName] = Field(
        default_factory=list,
        max_length=len(CASES),
        description="judge only these paper cases (and the CA pairs at their a_p), each once; "
        "none: all",
    )

    @field_validator("cases")
    @classmethod
    def _each_once(cls, cases: list[str]) -> list[str]:
        twice = sorted({c for c in cases if cases.count(c) > 1})
        if twice:
            raise ValueError(f"each case once: {', '.join(twice)} named twice")
        return cases


@router.post(
    "/jobs/tune",
    status_code=202,
    response_model=TuneJob,
    responses=responses(404, 409, 422),
    **ANSWER,
)
def start_tune(
    services: ServicesDep,
    response: Response,
    body: Annotated[TuneBody | None, Body()] = None,
) -> dict[str, Any]:
    """Tune the robot in use as `artro tune --robot` does (the nearest built-in preset, its
    clock scaled, the start's recipe; its Optuna study in DATA/studies/tune-ROBOT.log, resumed
    by a tune of the same size) in the background. `GET /api/jobs/{id}`: progress, `detail`
    (trials, budget, best loss); done, the preset tuned-ROBOT is saved and loaded (the motion in
    use kept) as one undoable change and `result` has its figures. `DELETE /api/jobs/{id}`
    stops it; nothing is loaded. 409 while a tune runs or for another robot than the one in use,
    404 for a robot not on offer, 422 for a size not allowed; nothing changes then."""
    body = body or TuneBody()
    budget = TuneBudget(
        generations=body.generations,
        popsize=body.popsize,
        duration_s=body.duration_s,
        warmup_s=body.warmup_s,
        cases=cases_of(body.cases),
    )
    try:
        if body.robot is not None:
            services.robots.get(body.robot)  # UnknownRobot names those on offer
        job = services.tuner.start(budget, robot=body.robot)
    except UnknownRobot as exc:
        raise ApiError(404, str(exc), "unknown_robot", loc=["body", "robot"]) from exc
    except WrongRobot as exc:
        raise ApiError(409, str(exc), "robot_not_in_use", loc=["body", "robot"]) from exc
    except JobBusy as exc:
        raise ApiError(
            409, f"{exc}; one tune runs at a time",
            "job_running", loc=["job", exc.job.id],
        ) from exc  # fmt: skip
    except RobotChanged as exc:
        raise ApiError(409, str(exc), "robot_changed", loc=["path"]) from exc
    except ValueError as exc:
        raise ApiError(422, str(exc), "invalid_tune", loc=["body"]) from exc
    response.headers["Location"] = f"/api/jobs/{job.id}"
    return job.to_dict()


@router.get("/tune", response_model=TuneJob, responses=responses(404), **ANSWER)
def latest_tune(services: ServicesDep) -> dict[str, Any]:
    """The latest tune job started since the server started (running or not), for a page that
    was reloaded meanwhile; 404 if none was."""
    job = services.tuner.latest
    if job is None:
        raise ApiError(404, "no tune has run yet: POST /api/jobs/tune starts one", "no_tune")
    return job.to_dict()
