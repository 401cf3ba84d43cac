"""The one evaluation API (docs/DESIGN.md §9): runs of a robot (`Job`) in, their metrics out, in
order, with progress and cancellation, identical whether they run in local threads, local
processes or on a Dask cluster; `evaluator_for` picks the executor."""

from __future__ import annotations

from app.evaluation._api import (
    TIMING_KEYS,
    Cancelled,
    Evaluator,
    ExecutorError,
    Job,
    OnResult,
    Progress,
    job_from_dict,
    job_to_dict,
    same_results,
)
from app.evaluation._lanes import BatchEvaluator
from app.robots.model import RobotModel

__all__ = [
    "TIMING_KEYS",
    "BatchEvaluator",
    "Cancelled",
    "Evaluator",
    "ExecutorError",
    "Job",
    "OnResult",
    "Progress",
    "evaluator_for",
    "job_from_dict",
    "job_to_dict",
    "same_results",
]


def evaluator_for(
    robot: RobotModel,
    *,
    cluster: str | None = None,
    threads: int | None = None,
    processes: int | None = None,
) -> Evaluator:
    """Local threads (default: every core), local worker processes of one thread each
    (`processes`; close it when done), or the Dask scheduler at `cluster` (tcp://HOST:PORT;
    the `cluster` extra); ExecutorError if it cannot be reached."""
    if cluster:
        from app.evaluation._dask import ClusterEvaluator  # Dask is an optional extra

        return ClusterEvaluator(cluster, robot)
    if processes:
        from app.evaluation._processes import ProcessEvaluator

        return ProcessEvaluator(robot, processes)
    return BatchEvaluator(robot, threads=threads)
