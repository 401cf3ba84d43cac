"""The dashboard's "Calibrate CA", a background job (app/server/jobs/registry.py): fits the
steering term's K for the current gait walking forward and backward
(`app.analysis.ca_calibration`), applies both as one undoable change onto the version it fitted,
and lets the predicted path use the fitted b_eff (docs/DESIGN.md §4, §14)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, Literal

from app.analysis.axle_fit import walking_amplitude
from app.analysis.ca_calibration import CalibrationError, calibrate_ca, with_k
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
    only_onto,
)
from app.server.param_store import ParameterStore
from app.server.sim.path_tracker import PathTracker
from app.sim.metrics import RunMetrics

Kind = Literal["calibrate-ca"]  # its jobs' `kind` (app/server/jobs/results.py)
KIND: Kind = "calibrate-ca"
SOURCE = "calibration"  # the store's source of the change it makes
STAGES = 8  # progress lines a direction prints, about (for a progress fraction)


class _Checked:
    """A BatchEvaluator that runs walks one by one, asking the job after each whether to stop."""

    def __init__(self, progress: Progress, robot: RobotModel | None = None) -> None:
        self.inner = BatchEvaluator(robot, threads=1)  # the live simulation keeps the other core
        self.progress = progress
        self.robot = self.inner.robot  # what its walks walk (the Evaluator protocol)

    def evaluate(self, jobs: Sequence[Walk], **kwargs: Any) -> list[RunMetrics]:
        results: list[RunMetrics] = []
        for job in jobs:
            self.progress(None)  # a cancelled job stops here
            results.extend(self.inner.evaluate([job], **kwargs))
        return results


class CaCalibrator:
    """One calibration at a time, sharing the server's jobs with the axle fit."""

    def __init__(
        self,
        jobs: Jobs,
        store: ParameterStore,
        paths: PathTracker,
        robot_now: Callable[[], RobotModel],
    ) -> None:
        """A calibration walks the robot `robot_now()` names when it starts."""
        self.robot_now = robot_now
        self.jobs, self.store, self.paths = jobs, store, paths

    def start(self, *, duration_s: float = 20.0) -> Job:
        """Calibrate the gait in the store now; raises JobBusy while one runs. The fitted K apply
        only onto the version calibrated; otherwise the result says so (a 409) and keeps them
        for `Job.applier`."""
        snap = self.store.snapshot()
        size = abs(walking_amplitude(snap.motion))
        robot = self.robot_now()

        def work(progress: Reporter) -> dict[str, Any]:
            gait, lines = snap.gait, [0]
            found: dict[str, dict[str, Any]] = {}  # direction: its result or its error

            def say(_line: str) -> None:
                lines[0] += 1
                progress(min(lines[0] / (2 * STAGES), 0.95))

            for a_p in (size, -size):
                direction = "forward" if a_p > 0 else "backward"
                try:
                    result = calibrate_ca(
                        gait,
                        dataclasses.replace(snap.motion, a_p=a_p),
                        _Checked(progress, robot),
                        duration_s=duration_s,
                        say=say,
                    )
                except CalibrationError as exc:
                    found[direction] = {"error": str(exc)}
                    continue
                gait = with_k(gait, a_p, result.yaw_per_ca)
                found[direction] = result.to_dict()
            if all("error" in v for v in found.values()):
                raise CalibrationError("; ".join(f"{d}: {v['error']}" for d, v in found.items()))
            steer = dataclasses.asdict(gait.steer)
            axle = found.get("forward", {}).get("axle_eff_m")

            def apply(version: int) -> dict[str, Any]:
                changed = self.store.update(
                    {"gait": {"steer": steer}}, SOURCE, check=only_onto(version, robot.name)
                )
                if axle and axle > 0:
                    self.paths.set_axle(axle, "fitted")
                return {"applied": True, "params_version": changed.version}

            kept = {"steer": steer, "fitted_from_version": snap.version, **found}
            try:
                return kept | apply(snap.version)
            except StaleVersion as exc:
                progress.job.applier = apply
                now = self.store.snapshot().version
                return kept | {
                    "applied": False,
                    "params_version": None,
                    "conflict": conflict(exc, now),
                }

        return self.jobs.start(KIND, work, from_version=snap.version, robot=robot.name)
