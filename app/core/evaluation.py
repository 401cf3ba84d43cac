"""The one evaluation API (docs/DESIGN.md §14): runs of a robot in, their metrics out, in order,
with progress and cancellation, identical whether they run in local threads (`BatchEvaluator`),
in local processes (`app.core.processes`) or on a Dask cluster (`app.core.cluster`);
`evaluator_for` picks one. A run is a `Job`."""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable, Sequence
from typing import Any, Protocol

from app.core.batch import BatchEvaluator, Cancelled, Job
from app.core.metrics import RunMetrics, Trace
from app.core.robot import RobotModel
from app.core.variations import NOMINAL, parse_variation
from gait import GaitParams, Motion

__all__ = ["Cancelled", "Evaluator", "Job", "evaluator_for", "job_from_dict", "job_to_dict"]

Progress = Callable[[int, int], None]
#: metrics that say how fast a run went, not what it did: they differ between executors
TIMING_KEYS = ("wall_s", "rtf")


class Evaluator(Protocol):
    """What every executor offers: the robot its runs walk, and `evaluate`."""

    robot: RobotModel

    def evaluate(
        self,
        jobs: Sequence[Job],
        *,
        duration_s: float,
        warmup_s: float = 5.0,
        progress: Progress | None = None,
        traces: list[Trace] | None = None,
        cancel: threading.Event | None = None,
        on_result: Callable[[int, RunMetrics], None] | None = None,
    ) -> list[RunMetrics]:
        """Metrics of each job, in order; `progress(done, total)` as runs finish and
        `on_result(index, metrics)` with each; each run's trunk `Trace` appended to `traces`,
        in job order, when given; Cancelled as soon as `cancel` is set (runs under way are
        dropped)."""
        ...


def evaluator_for(
    robot: RobotModel,
    *,
    cluster: str | None = None,
    threads: int | None = None,
    processes: int | None = None,
) -> Evaluator:
    """Local threads (default: every core), local worker processes of one thread each
    (`processes`; close it when done), or the Dask scheduler at `cluster` (tcp://HOST:PORT;
    the `cluster` extra); ClusterError if it cannot be reached."""
    if cluster:
        from app.core.cluster import ClusterEvaluator  # Dask is an optional extra

        return ClusterEvaluator(cluster, robot)
    if processes:
        from app.core.processes import ProcessEvaluator

        return ProcessEvaluator(robot, processes)
    return BatchEvaluator(robot, threads=threads)


def job_to_dict(job: Job) -> dict[str, Any]:
    """A job as plain data (what a cluster worker receives): exact, floats kept to the bit."""
    return {
        "params": job.params.to_dict(),
        "motion": dataclasses.asdict(job.motion),
        "start_motion": None if job.start_motion is None else dataclasses.asdict(job.start_motion),
        "variation": job.variation.to_text(),
    }


def job_from_dict(data: dict[str, Any]) -> Job:
    start = data.get("start_motion")
    text = data.get("variation", "")
    return Job(
        params=GaitParams.from_dict(data["params"]),
        motion=Motion(**data["motion"]),
        start_motion=None if start is None else Motion(**start),
        variation=parse_variation(text) if text else NOMINAL,
    )


def same_results(a: Sequence[RunMetrics], b: Sequence[RunMetrics]) -> bool:
    """Equal to the bit, but for how long the runs took."""
    strip = [{k: v for k, v in m.items() if k not in TIMING_KEYS} for m in (*a, *b)]
    return len(a) == len(b) and strip[: len(a)] == strip[len(a) :]
