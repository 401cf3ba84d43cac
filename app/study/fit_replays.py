"""Where a fit's replays run (docs/FIT.md): each one the routine replayed at a physics point,
scored against the recording with the IMU's errors fitted in closed form; in this process, on
worker processes, or on a Dask cluster's workers (the robot sent as its description)."""

from __future__ import annotations

import json
import threading
import uuid
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from app.analysis import fit_sensors
from app.analysis.identify_replay import Traces, play
from app.analysis.identify_routine import ROUTINES
from app.robots import parse_description
from app.robots.model import RobotModel
from app.robots.mujoco_warnings import keep_warnings_out_of_the_folder
from app.study import fit_space
from app.worlds.variations import Variation
from gait import GaitParams


class FitCancelled(RuntimeError):
    """The fit was cancelled; nothing was written."""


# --- the work a process does: one replay at a point --------------------------------------------

_WORKER: dict[str, Any] = {}


def start_worker(
    robot: str,
    params: dict[str, Any],
    routine: str,
    recording: Traces,
    present: bool,
    fixed: str,
    lengths: list[int],
) -> None:
    _WORKER.update(
        robot=load_robot(robot),
        params=GaitParams.from_dict(params),
        routine=ROUTINES[routine],
        recorded=recording,
        present=present,
        fixed=fit_space.parse_fixed([fixed] if fixed else []),
        lengths=lengths,
    )


def load_robot(robot: str) -> RobotModel:
    """A robot by name or description file, or as its description's JSON (what a Dask worker
    is sent: the file may not be there)."""
    if robot.lstrip().startswith("{"):
        return RobotModel.load(parse_description(json.loads(robot), "the robot sent"))
    return RobotModel.load(robot)


def replay(values: dict[str, float], segments: int | None = None) -> Traces:
    """The routine (its first `segments` only, when given) replayed at the physics `values`."""
    w = _WORKER
    variation = fit_space.physics_variation(values, w["fixed"])
    routine, lengths = w["routine"][:segments], w["lengths"][:segments]
    return play(w["robot"], w["params"], routine, variation, sensor_errors=False, lengths=lengths)


def score(
    values: dict[str, float], imu: tuple[str, ...], segments: int | None = None
) -> tuple[float, dict[str, float]]:
    """The loss at the physics point `values` over the routine's first `segments` (all: None),
    the IMU's errors fitted there (those in `imu`)."""
    w = _WORKER
    recorded = within(w["recorded"], sum(w["lengths"][:segments]))
    replayed = aligned(replay(values, segments), recorded)
    errors = imu_fit(replayed, recorded, imu, w["fixed"])
    cycles = fit_sensors.Cycles(tuple(w["lengths"][:segments]), w["params"].clock.freq_hz)
    parts = fit_sensors.residuals(replayed, errors, recorded, w["present"], cycles)
    return fit_sensors.soft_l1(parts), fit_space.imu_values(errors)


TASKS: dict[str, Callable[..., Any]] = {"score": score, "replay": replay}


def on_dask_worker(key: str, init: tuple[Any, ...], task: str, *args: Any) -> Any:
    """A Dask task: `TASKS[task](*args)`, the worker's state made from `init` the first time
    it sees the fit `key` (a worker keeps one fit's state at a time)."""
    if _WORKER.get("key") != key:
        keep_warnings_out_of_the_folder()
        start_worker(*init)
        _WORKER["key"] = key
    return TASKS[task](*args)


def within(traces: Traces, frames: int) -> Traces:
    """The rows of `traces` in the routine's first `frames` frames."""
    return traces.at(np.flatnonzero(traces.positions < frames))


def aligned(replayed: Traces, recorded: Traces) -> Traces:
    """The replay's rows at the recording's frames (a recording may lack some)."""
    return replayed.at(recorded.positions)


def imu_fit(
    replayed: Traces, recorded: Traces, imu: tuple[str, ...], fixed: Variation
) -> fit_sensors.ImuErrors:
    """The IMU's errors in `imu` fitted, the others as `fixed` holds them."""
    errors = fit_sensors.fit_imu(
        replayed, recorded, bias="gyro_bias_deg_s" in imu, tilt="imu_tilt_x_deg" in imu
    )
    held = fit_space.imu_errors({}, fixed)
    return fit_sensors.ImuErrors(
        errors.imu_tilt_bias_deg if "imu_tilt_x_deg" in imu else held.imu_tilt_bias_deg,
        errors.imu_tilt_direction_deg if "imu_tilt_x_deg" in imu else held.imu_tilt_direction_deg,
        errors.gyro_bias_deg_s if "gyro_bias_deg_s" in imu else held.gyro_bias_deg_s,
    )


# --- where they run ------------------------------------------------------------------------------


class Replays:
    """Runs `TASKS` at many points, results in order: in this process (`workers` 1), on
    `workers` processes, or on the Dask scheduler at `cluster` (its workers sent `init` once,
    the robot as its description; the version checked and a worker awaited up to
    `wait_workers_s` as every command's `--cluster` does, docs/CLUSTER.md). `cancel` set:
    FitCancelled at the next batch."""

    def __init__(
        self,
        init: tuple[Any, ...],
        *,
        workers: int = 1,
        cluster: str | None = None,
        wait_workers_s: float | None = None,
        cancel: threading.Event | None = None,
    ) -> None:
        self.cancel = cancel
        self.pool: ProcessPoolExecutor | None = None
        self.cluster: Any = None
        if cluster is not None:
            from app.evaluation._dask import WAIT_WORKERS_S, ClusterEvaluator  # optional extra

            wait = WAIT_WORKERS_S if wait_workers_s is None else wait_workers_s
            robot = load_robot(init[0])  # the client's own: only a cluster needs it here
            self.cluster = ClusterEvaluator(cluster, robot, wait_workers_s=wait)
            self.key = uuid.uuid4().hex
            sent = json.dumps(robot.description.model_dump(mode="json"), sort_keys=True)
            try:
                (self.init,) = self.cluster.client.scatter([(sent, *init[1:])], broadcast=True)
            except BaseException:  # the client closed, not left to its finaliser
                self.cluster.close()
                raise
        elif workers > 1:
            self.pool = ProcessPoolExecutor(workers, initializer=start_worker, initargs=init)
        else:
            start_worker(*init)

    def map(self, task: str, points: list[tuple[Any, ...]]) -> list[Any]:
        """`TASKS[task](*p)` for each point `p`, in order."""
        if self.cancel is not None and self.cancel.is_set():
            raise FitCancelled("the fit was cancelled; nothing was written")
        if not points:
            return []
        if self.cluster is not None:
            n = len(points)
            futures = self.cluster.client.map(
                on_dask_worker, [self.key] * n, [self.init] * n, [task] * n,
                *zip(*points, strict=True), pure=False, retries=1,
            )  # fmt: skip
            return list(self.cluster.client.gather(futures))
        if self.pool is not None:
            return list(self.pool.map(TASKS[task], *zip(*points, strict=True)))
        return [TASKS[task](*p) for p in points]

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(cancel_futures=True)
        if self.cluster is not None:
            self.cluster.close()
