"""Background jobs: start the axle fit or the CA calibration (202 at once), read any job."""

from typing import Annotated, Any

from fastapi import APIRouter, Path, Response
from starlette.exceptions import HTTPException as StarletteHTTPException

from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.axle_fitter import KIND
from app.server.ca_calibrator import KIND as CALIBRATE
from app.server.errors import GUARD_RESPONSES, ApiError, responses
from app.server.jobs import JobBusy

router = APIRouter(
    prefix="/api/jobs", tags=["jobs"], responses=GUARD_RESPONSES, route_class=StrictJsonRoute
)


@router.post("/axle-fit", status_code=202, responses=responses(409))
def start_axle_fit(services: ServicesDep, response: Response) -> dict[str, Any]:
    """Fit the effective axle b_eff of the current gait from simulated curve walks (CA = -0.1,
    0, +0.1 at the current a_p, 20 s each) in the background, then predict with it. Answers at
    once with the job; `GET /api/jobs/{id}` gives its progress and, when done, the fit."""
    snap = services.store.snapshot()
    try:
        job = services.axle_fitter.start(
            snap.gait, snap.motion, services.sim.paths, params_version=snap.version
        )
    except JobBusy as exc:
        raise ApiError(409, str(exc), "job_running", loc=["job", exc.job.id]) from exc
    response.headers["Location"] = f"/api/jobs/{job.id}"
    return job.to_dict()


@router.post("/calibrate-ca", status_code=202, responses=responses(409))
def start_ca_calibration(services: ServicesDep, response: Response) -> dict[str, Any]:
    """Fit the steering term K for the current gait, walking forward and backward (CA = -0.1,
    0, +0.1, 20 s each, a few rounds) in the background, so that CA turns it as eq (13) says;
    applies both K as one undoable change (source "calibration") and predicts the path with the
    fitted b_eff. `GET /api/jobs/{id}` gives the progress and, when done, the fit."""
    try:
        job = services.ca_calibrator.start()
    except JobBusy as exc:
        raise ApiError(409, str(exc), "job_running", loc=["job", exc.job.id]) from exc
    response.headers["Location"] = f"/api/jobs/{job.id}"
    return job.to_dict()


@router.get("/{job_id}", responses=responses(404, 422))
def get_job(
    job_id: Annotated[str, Path(max_length=64, description="as POST returned it")],
    services: ServicesDep,
) -> dict[str, Any]:
    """A job: status (running, done, failed), progress 0..1, and its result or error."""
    if job_id in (KIND, CALIBRATE):  # these start jobs (POST), they are not one
        raise StarletteHTTPException(405)
    job = services.axle_fitter.jobs.get(job_id)
    if job is None:
        raise ApiError(404, f"no job {job_id[:64]!r} (the latest 20 are kept)", "not_found")
    return job.to_dict()
