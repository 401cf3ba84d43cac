"""What a job answers (`GET /api/jobs/{id}`, the 202 of a start): `Job.to_dict()` as one pydantic
model per kind, told apart by `kind`, each with its result's model, so `/openapi.json` describes
every job and its result. A field a model does not name still goes out (extra allowed); a key a
result leaves out stays out (routes answer with `exclude_unset`)."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

from app.server.jobs.axle_fitter import Kind as AxleFitKind
from app.server.jobs.ca_calibrator import Kind as CaCalibrationKind
from app.server.jobs.fit_job import Kind as FitKind
from app.server.jobs.registry import JobStatus
from app.server.jobs.robustness_job import Kind as RobustnessKind
from app.server.jobs.tune_job import Kind as TuneKind


class _Open(BaseModel):
    model_config = ConfigDict(extra="allow")


class Conflict(_Open):
    """Why a result was not applied (it is kept for `POST /api/jobs/{id}/apply`)."""

    status: int = Field(description="409")
    type: str = Field(description="version_conflict")
    msg: str
    version: int | None = Field(None, description="the version in use now")


class AxleFitResult(_Open):
    """`AxleFitResult` (app/analysis/axle_fit.py) and whether the paths use it."""

    axle_eff_m: float | None = Field(None, description="b_eff; null: CA does not steer")
    feet_m: float | None = None
    speed_m_s: float | None = None
    drift_deg_s: float | None = None
    gain: float | None = Field(None, description="b / b_eff: the share of eq (13)")
    a_p: float | None = None
    ca: list[float] | None = None
    turn_deg_s: list[float] | None = None
    sim_s: float | None = None
    applied: bool | None = None
    reason: str | None = None
    params_version: int | None = None
    fitted_from_version: int | None = None
    conflict: Conflict | None = None


class CaDirection(_Open):
    """One direction's calibration (`CaCalibration.to_dict()`), or its `error`."""

    yaw_per_ca: float | None = None
    field: str | None = None
    axle_eff_m: float | None = None
    gain: float | None = None
    converged: bool | None = None
    error: str | None = None


class CaCalibrationResult(_Open):
    forward: CaDirection | None = None
    backward: CaDirection | None = None
    steer: dict[str, Any] | None = Field(None, description="the steering group fitted")
    fitted_from_version: int | None = None
    applied: bool | None = None
    params_version: int | None = None
    conflict: Conflict | None = None


class RobustnessResult(_Open):
    """`artro bench robust`'s report of the gait (`GET /api/world/robustness` keeps it)."""

    finished_at: float | None = Field(None, description="Unix s")
    params_version: int | None = None


class TuneResult(_Open):
    preset: str | None = Field(None, description="the preset saved, tuned-ROBOT")
    robot: str | None = None
    loss: float | None = None
    walked: bool | None = None
    applied: bool | None = None
    not_loaded: str | None = Field(None, description="why it was saved and not loaded")
    params_version: int | None = None


class FitField(_Open):
    value: float
    sigma: float = Field(description="1 σ")
    identified: bool = Field(description="told by the recording")
    truth: float | None = Field(None, description="a simulated recording's hidden value")


class FitResult(_Open):
    """`artro fit --json`'s summary (app/study/fit_report.py) and where its files are."""

    converged: bool
    why_not: str | None = Field(None, description="why the fit did not converge")
    variation: str = Field(description="the fit, as `artro run --vary` takes it")
    world: str = Field(description="its name, as PUT /api/world answers it")
    fields: dict[str, FitField]
    correlated: list[list[str]] = Field(description="pairs correlated beyond 0.9")
    flat: list[str] = Field(description="coordinates whose σ spans half their bounds")
    source: str = Field(description="robot or simulation")
    fitted: str = Field(description="the fitted robot's description (.yaml)")
    report_dir: str
    traces: str = Field(description="the report's plot: GET this path")


class _JobAnswer(_Open):
    id: str
    status: JobStatus
    progress: float = Field(description="0..1")
    error: str | None
    started_s: float = Field(description="Unix s")
    finished_s: float | None
    from_version: int | None = Field(description="the parameter version it works on")
    detail: dict[str, Any] | None = Field(description="what a running job says besides")


class AxleFitJob(_JobAnswer):
    kind: AxleFitKind
    result: AxleFitResult | None


class CaCalibrationJob(_JobAnswer):
    kind: CaCalibrationKind
    result: CaCalibrationResult | None


class RobustnessJob(_JobAnswer):
    kind: RobustnessKind
    result: RobustnessResult | None


class TuneJob(_JobAnswer):
    kind: TuneKind
    result: TuneResult | None


class FitJob(_JobAnswer):
    kind: FitKind
    result: FitResult | None


JobAnswer = Annotated[
    AxleFitJob | CaCalibrationJob | RobustnessJob | TuneJob | FitJob, Field(discriminator="kind")
]
