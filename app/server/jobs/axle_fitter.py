"""The server's axle fit, a background job (app/server/jobs/registry.py): one at a time; the path
tracker then predicts with b_eff if it applies and nothing changed meanwhile (§14). The page (`POST
/api/jobs/axle-fit`) and the viser button (`fit`, from its own thread) start the same job."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Literal

from app.analysis.axle_fit import AxleFitResult, fit_effective_axle
from app.evaluation import BatchEvaluator
from app.evaluation import Job as Walk
from app.robots.model import RobotModel
from app.server.jobs.registry import (
    Job,
    Jobs,
    Progress,
    Reporter,
    StaleVersion,
    conflict,
    on_robot,
)
from app.server.param_store import ParameterStore
from app.server.sim.path_tracker import PathTracker
from app.sim.metrics import RunMetrics
from gait import GaitParams, Motion

Kind = Literal["axle-fit"]  # its jobs' `kind` (app/server/jobs/results.py)
KIND: Kind = "axle-fit"


class _Counting:
    """A BatchEvaluator that runs the fit's simulations one by one and reports progress."""

    def __init__(self, progress: Progress, robot: RobotModel | None) -> None:
        self.inner = BatchEvaluator(robot, threads=1)
        self.progress = progress
        self.robot = self.inner.robot  # what its walks walk (the Evaluator protocol)

    def evaluate(self, jobs: Sequence[Walk], **kwargs: Any) -> list[RunMetrics]:
        results: list[RunMetrics] = []
        for done, job in enumerate(jobs):
            self.progress(done / len(jobs))
            results.extend(self.inner.evaluate([job], **kwargs))
        return results


class AxleFitter:
    def __init__(
        self,
        jobs: Jobs | None = None,
        store: ParameterStore | None = None,
        robot_now: Callable[[], RobotModel] | None = None,
    ) -> None:
        # a fit walks the robot `robot_now()` names when it starts (default: the built-in one)
        self.robot_now = robot_now or RobotModel.load
        self.jobs = jobs or Jobs()
        self.store = store  # what a fit's version is checked against, when there is one
        self.last: AxleFitResult | None = None
        self.fitted_gait: GaitParams | None = None  # the gait whose b_eff the paths use

    def start(
        self,
        params: GaitParams,
        motion: Motion,
        paths: PathTracker,
        *,
        params_version: int | None = None,
    ) -> Job:
        """Fit in the background; raises JobBusy (a RuntimeError) while a fit runs. The fitted
        b_eff applies only if the parameter version (default: the store's now) and the axle are
        still those of the start; otherwise the result says so (a 409) and keeps it for
        `Job.applier`."""
        if params_version is None and self.store is not None:
            params_version = self.store.snapshot().version
        axle_serial = paths.axle_serial
        robot = self.robot_now()
        fitted: list[Any] = []  # this fit's result: a kept applier applies it, not a later fit's

        def apply(version: int | None, serial: int | None = None) -> dict[str, Any]:
            if self.store is not None and version is not None:
                current = self.store.snapshot()
                on_robot(robot.name)(current)
                if current.version != version:
                    raise StaleVersion(
                        f"the parameters changed while the fit ran (version {version} is now "
                        f"{current.version}, changed by {current.source}): not applied; the "
                        "result is kept: POST /api/jobs/{id}/apply with the version to apply "
                        "it onto"
                    )
            result = fitted[0]
            assert result.axle_eff_m is not None
            if not paths.set_axle(result.axle_eff_m, "fitted", only_onto=serial):
                raise StaleVersion(
                    "the axle b was set while the fit ran: not applied; the result is kept: "
                    "POST /api/jobs/{id}/apply with the parameter version to apply it onto"
                )
            self.fitted_gait = params
            return {"applied": True}

        def work(progress: Reporter) -> dict[str, Any]:
            result = fit_effective_axle(params, motion, _Counting(progress, robot))
            self.last = result
            fitted.append(result)
            done = result.to_dict() | {
                "params_version": params_version,
                "fitted_from_version": params_version,
                "applied": False,
            }
            if not (result.applies and result.axle_eff_m is not None):
                return done
            try:
                return done | apply(params_version, axle_serial)
            except StaleVersion as exc:
                progress.job.applier = apply
                now = None if self.store is None else self.store.snapshot().version
                return done | {"conflict": conflict(exc, now)}

        return self.jobs.start(KIND, work, from_version=params_version, robot=robot.name)

    def fit(self, params: GaitParams, motion: Motion, paths: PathTracker) -> dict[str, Any]:
        """Start the job and wait for it (for a caller's own thread, never the event loop); its
        result (`AxleFitResult.to_dict()` with `applied` and any `conflict`)."""
        job = self.start(params, motion, paths)
        job.finished.wait()
        if job.status != "done" or job.result is None:
            raise RuntimeError(job.error)
        return job.result

    def stale(self, axle_source: str, gait: GaitParams) -> bool:
        """A fitted axle belongs to the gait it was fitted for: another gait makes it stale."""
        return axle_source == "fitted" and self.fitted_gait not in (None, gait)
