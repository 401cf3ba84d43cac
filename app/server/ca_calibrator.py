"""The dashboard's "Calibrate CA", a background job (app/server/jobs.py): fits the steering term's
K for the current gait walking forward and backward (`app.core.ca_calibration`), applies both
as one undoable change, and lets the predicted path use the fitted b_eff (docs/DESIGN.md §4)."""

from __future__ import annotations

import dataclasses
from typing import Any

from app.core.axle_fit import walking_amplitude
from app.core.batch import BatchEvaluator
from app.core.ca_calibration import CalibrationError, calibrate_ca, with_k
from app.core.robot import RobotModel
from app.server.jobs import Job, Jobs, Progress
from app.server.param_store import ParameterStore
from app.server.path_tracker import PathTracker

KIND = "calibrate-ca"
SOURCE = "calibration"  # the store's source of the change it makes
STAGES = 8  # progress lines a direction prints, about (for a progress fraction)


class CaCalibrator:
    """One calibration at a time, sharing the server's jobs with the axle fit."""

    def __init__(
        self,
        jobs: Jobs,
        store: ParameterStore,
        paths: PathTracker,
        robot: RobotModel | None = None,
    ) -> None:
        self.robot = robot  # the calibration walks this robot (default: the built-in one)
        self.jobs, self.store, self.paths = jobs, store, paths

    def start(self, *, duration_s: float = 20.0) -> Job:
        """Calibrate the gait in the store now; raises JobBusy while one runs."""
        snap = self.store.snapshot()
        size = abs(walking_amplitude(snap.motion))

        def work(progress: Progress) -> dict[str, Any]:
            gait, found, lines = snap.gait, {}, [0]

            def say(_line: str) -> None:
                lines[0] += 1
                progress(min(lines[0] / (2 * STAGES), 0.95))

            for a_p in (size, -size):
                direction = "forward" if a_p > 0 else "backward"
                try:
                    result = calibrate_ca(
                        gait,
                        dataclasses.replace(snap.motion, a_p=a_p),
                        # one thread: the live simulation keeps the other core
                        BatchEvaluator(self.robot, threads=1),
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
            version = self.store.update({"gait": {"steer": steer}}, SOURCE).version
            forward = found.get("forward", {})
            if forward.get("axle_eff_m") and forward["axle_eff_m"] > 0:
                self.paths.set_axle(forward["axle_eff_m"], "fitted")
            return {"steer": steer, "params_version": version, **found}

        return self.jobs.start(KIND, work)
