"""The server's axle fit, a background job (app/server/jobs.py): one at a time; the path tracker
then predicts with b_eff if it applies. The page (`POST /api/jobs/axle-fit`) and the viser button
(`fit`, from its own thread) start the same job."""

from __future__ import annotations

from typing import Any

from app.core.axle_fit import AxleFitResult, fit_effective_axle
from app.core.batch import BatchEvaluator
from app.core.robot import RobotModel
from app.server.jobs import Job, Jobs, Progress
from app.server.path_tracker import PathTracker
from gait import GaitParams, Motion

KIND = "axle-fit"


class _Counting:
    """A BatchEvaluator that runs the fit's simulations one by one and reports progress."""

    def __init__(self, progress: Progress, robot: RobotModel | None) -> None:
        self.inner = BatchEvaluator(robot, threads=1)
        self.progress = progress

    def evaluate(self, jobs: list[Any], **kwargs: Any) -> list[dict[str, Any]]:
        results = []
        for done, job in enumerate(jobs):
            self.progress(done / len(jobs))
            results.extend(self.inner.evaluate([job], **kwargs))
        return results


class AxleFitter:
    def __init__(self, jobs: Jobs | None = None, robot: RobotModel | None = None) -> None:
        self.robot = robot  # the fits walk this robot (default: the built-in one)
        self.jobs = jobs or Jobs()
        self.last: AxleFitResult | None = None
        self.fitted_gait: GaitParams | None = None  # the gait whose b_eff the paths use

    def start(
        self, params: GaitParams, motion: Motion, paths: PathTracker, *, params_version: int = 0
    ) -> Job:
        """Fit in the background; raises JobBusy (a RuntimeError) while a fit runs."""

        def work(progress: Progress) -> AxleFitResult:
            result = fit_effective_axle(params, motion, _Counting(progress, self.robot))  # type: ignore[arg-type]
            self.last = result
            if result.applies and result.axle_eff_m is not None:
                self.fitted_gait = params
                paths.set_axle(result.axle_eff_m, "fitted")
            return result

        def describe(result: AxleFitResult) -> dict[str, Any]:
            return result.to_dict() | {"params_version": params_version}

        return self.jobs.start(KIND, work, describe)

    def fit(self, params: GaitParams, motion: Motion, paths: PathTracker) -> AxleFitResult:
        """Start the job and wait for it (for a caller's own thread, never the event loop)."""
        job = self.start(params, motion, paths)
        job.finished.wait()
        if job.status != "done":
            raise RuntimeError(job.error)
        return job.value

    def stale(self, axle_source: str, gait: GaitParams) -> bool:
        """A fitted axle belongs to the gait it was fitted for: another gait makes it stale."""
        return axle_source == "fitted" and self.fitted_gait not in (None, gait)
