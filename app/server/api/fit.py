""" "Fit to a recording": the recording format's JSON schema, a fit job started on an uploaded
recording of the identify routine (checked before it starts), the latest fit and its report's
plot (docs/FIT.md, "On the dashboard")."""

from typing import Annotated, Any

from fastapi import APIRouter, Query, Request, Response
from fastapi.responses import FileResponse
from starlette.concurrency import run_in_threadpool

from app.analysis.identify_record import RecordingError, recording_schema
from app.server.api.answers import ANSWER, Answer
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, ApiError, responses
from app.server.jobs.registry import JobBusy, RobotChanged
from app.server.jobs.results import FitJob

router = APIRouter(
    prefix="/api/fit", tags=["jobs"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)
FIT_BODY = {
    "requestBody": {
        "required": True,
        "description": "a recording of the identify routine (GET /api/fit/schema), as a file",
        "content": {"application/json": {"schema": {"type": "object"}}},
    }
}


class RecordingSchema(Answer):
    """The JSON schema of `artro-identify-recording` version 1 (docs/FIT.md §2)."""

    title: str
    type: str
    properties: dict[str, Any]


@router.get("/schema", response_model=RecordingSchema, **ANSWER)
def fit_schema() -> dict[str, Any]:
    """The recording format a fit reads, as a JSON schema (`app/analysis/identify_record.py`)."""
    return recording_schema()


@router.post(
    "",
    status_code=202,
    response_model=FitJob,
    openapi_extra=FIT_BODY,
    responses=responses(409, 413, 422),
    **ANSWER,
)
async def start_fit(
    request: Request,
    services: ServicesDep,
    response: Response,
    fields: Annotated[
        str | None,
        Query(
            max_length=300,
            description="artro fit --fields, e.g. kp_scale,latency_ms; default: its default fields",
        ),
    ] = None,
    budget: Annotated[
        int | None, Query(ge=10, le=5000, description="replays, 10 to 5000; default 160")
    ] = None,
) -> dict[str, Any]:
    """Fit the model of the robot in use to the recording in the body as `artro fit --json`
    does, in the background (DATA/fits/JOB-fitted.yaml and JOB-fit/). The recording is read
    whole and checked first: 422 saying what is wrong (truncated, not a recording, another
    robot, frames lost ...), nothing started. `GET /api/jobs/{id}`: progress, `detail`
    (percent, best loss, time left); done, `result` is the fit's summary. `DELETE
    /api/jobs/{id}` stops the child. 409 while a fit runs."""
    body = await request.body()
    try:
        text = body.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ApiError(422, "the recording is not UTF-8 text", "invalid_recording",
                       loc=["body"]) from exc  # fmt: skip
    try:
        job = await run_in_threadpool(services.fitter.start, text, fields, budget)
    except RecordingError as exc:
        raise ApiError(422, str(exc), "invalid_recording", loc=["body"]) from exc
    except ValueError as exc:
        raise ApiError(422, str(exc), "invalid_fit", loc=["query"]) from exc
    except JobBusy as exc:
        raise ApiError(
            409, f"{exc}; one fit runs at a time", "job_running", loc=["job", exc.job.id]
        ) from exc
    except RobotChanged as exc:
        raise ApiError(409, str(exc), "robot_changed", loc=["path"]) from exc
    response.headers["Location"] = f"/api/jobs/{job.id}"
    return job.to_dict()


@router.get("", response_model=FitJob, responses=responses(404), **ANSWER)
def latest_fit(services: ServicesDep) -> dict[str, Any]:
    """The latest fit job since the server started (running or not); 404 if none was."""
    job = services.fitter.latest
    if job is None:
        raise ApiError(404, "no fit has run yet: POST /api/fit starts one", "no_fit")
    return job.to_dict()


@router.get(
    "/{job_id}/traces.png",
    response_class=FileResponse,
    responses={200: {"content": {"image/png": {}}}, **responses(404, 422)},
)
def fit_traces(job_id: str, services: ServicesDep) -> FileResponse:
    """The fit report's plot: the recording against the nominal's and the fit's replay."""
    path = services.fitter.report_dir(job_id) / "traces.png"
    if not job_id.replace("-", "").isalnum() or not path.is_file():
        raise ApiError(404, f"no fit report for {job_id!r}", "not_found", loc=["path", "job_id"])
    return FileResponse(path, media_type="image/png")
