"""Background jobs: start the axle fit or the CA calibration (202 at once), read any job, cancel
a running one, apply the kept result of one that could not apply it (docs/DESIGN.md §14)."""

from typing import Annotated, Any

from fastapi import APIRouter, Path, Response
from pydantic import BaseModel, ConfigDict, Field
from starlette.exceptions import HTTPException as StarletteHTTPException

from app.server.api.answers import ANSWER
from app.server.api.deps import JsonIntFrom1, ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, ApiError, responses
from app.server.jobs.axle_fitter import KIND
from app.server.jobs.ca_calibrator import KIND as CALIBRATE
from app.server.jobs.registry import KEEP_JOBS, Job, JobBusy, RobotChanged, StaleVersion
from app.server.jobs.results import AxleFitJob, CaCalibrationJob, JobAnswer
from app.server.jobs.robustness_job import KIND as ROBUSTNESS
from app.server.jobs.tune_job import KIND as TUNE
from app.server.services import Services

router = APIRouter(
    prefix="/api/jobs", tags=["jobs"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)

JobId = Annotated[str, Path(max_length=64, description="as POST returned it")]


class StartBody(BaseModel):
    """A job takes no options: an empty object (or no body)."""

    model_config = ConfigDict(extra="forbid", strict=True)


class ApplyBody(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    version: JsonIntFrom1 = Field(
        description="the parameter version in use to apply the result onto (GET /api/params); "
        "409 if it is no longer the one in use"
    )


@router.post(
    "/axle-fit",
    status_code=202,
    response_model=AxleFitJob,
    responses=responses(409, 422),
    **ANSWER,
)
def start_axle_fit(
    services: ServicesDep, response: Response, body: StartBody | None = None
) -> dict[str, Any]:
    """Fit the effective axle b_eff of the current gait from simulated curve walks (CA = -0.1,
    0, +0.1 at the current a_p, 20 s each) in the background, then predict with it, if neither
    the parameters nor the axle changed meanwhile. Answers at once with the job (`from_version`:
    the version it fits); `GET /api/jobs/{id}` gives its progress and, when done, the fit."""
    snap = services.snapshot()
    try:
        job = services.axle_fitter.start(
            snap.gait, snap.motion, services.paths, params_version=snap.version
        )
    except JobBusy as exc:
        raise ApiError(409, str(exc), "job_running", loc=["job", exc.job.id]) from exc
    except RobotChanged as exc:
        raise ApiError(409, str(exc), "robot_changed", loc=["path"]) from exc
    response.headers["Location"] = f"/api/jobs/{job.id}"
    return job.to_dict()


@router.post(
    "/calibrate-ca",
    status_code=202,
    response_model=CaCalibrationJob,
    responses=responses(409, 422),
    **ANSWER,
)
def start_ca_calibration(
    services: ServicesDep, response: Response, body: StartBody | None = None
) -> dict[str, Any]:
    """Fit the steering term K for the current gait, walking forward and backward (CA = -0.1,
    0, +0.1, 20 s each, a few rounds) in the background, so that CA turns it as eq (13) says;
    applies both K as one undoable change (source "calibration") onto the version it fitted
    (`from_version`) and predicts the path with the fitted b_eff. Changed meanwhile, the result
    says so (`applied` false, `conflict`) and is kept: `POST /api/jobs/{id}/apply`."""
    try:
        job = services.ca_calibrator.start()
    except JobBusy as exc:
        raise ApiError(409, str(exc), "job_running", loc=["job", exc.job.id]) from exc
    except RobotChanged as exc:
        raise ApiError(409, str(exc), "robot_changed", loc=["path"]) from exc
    response.headers["Location"] = f"/api/jobs/{job.id}"
    return job.to_dict()


def _job(job_id: str, services: Services) -> Job:
    if job_id in (KIND, CALIBRATE, TUNE, ROBUSTNESS):  # these start jobs (POST), not one
        raise StarletteHTTPException(405)
    job = services.jobs.get(job_id)
    if job is None:
        raise ApiError(
            404, f"no job {job_id[:64]!r} (the running and the latest {KEEP_JOBS} are kept)",
            "not_found",
            loc=["path", "job_id"],
        )  # fmt: skip
    return job


@router.get("/{job_id}", response_model=JobAnswer, responses=responses(404, 422), **ANSWER)
def get_job(job_id: JobId, services: ServicesDep) -> dict[str, Any]:
    """A job: status (running, done, failed, cancelled), progress 0..1, the version it works on
    (`from_version`), and its result or error."""
    return _job(job_id, services).to_dict()


@router.delete("/{job_id}", response_model=JobAnswer, responses=responses(404, 409, 422), **ANSWER)
def cancel_job(job_id: JobId, services: ServicesDep) -> dict[str, Any]:
    """Cancel a running job: it stops at its next simulated walk and applies nothing (status
    cancelled). 409 if it has already finished."""
    job = _job(job_id, services)
    if not services.jobs.cancel(job):
        raise ApiError(
            409, f"job {job.id} has already finished ({job.status}): nothing to cancel",
            "job_finished", loc=["path", "job_id"],
        )  # fmt: skip
    return job.to_dict()


@router.post(
    "/{job_id}/apply", response_model=JobAnswer, responses=responses(404, 409, 422), **ANSWER
)
def apply_job(job_id: JobId, body: ApplyBody, services: ServicesDep) -> dict[str, Any]:
    """Apply the result a finished job kept because the parameters (or the axle) changed while
    it ran, onto the version in use, named in the body (409 if that is no longer the one)."""
    job = _job(job_id, services)
    applier, job.applier = job.applier, None  # applied once, also by two clients at a time
    if job.status != "done" or applier is None:
        state = "has nothing kept to apply" if job.status == "done" else f"is {job.status}"
        raise ApiError(409, f"job {job.id} {state}", "nothing_to_apply", loc=["path", "job_id"])
    try:
        applied = applier(body.version)
    except StaleVersion as exc:
        job.applier = applier  # still kept
        current = services.snapshot().version
        raise ApiError(
            409, str(exc), "version_conflict", loc=["body", "version"], version=current
        ) from exc
    job.result = (job.result or {}) | applied | {"conflict": None}
    return job.to_dict()
