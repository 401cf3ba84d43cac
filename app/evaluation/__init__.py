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
    "close_evaluator",
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
    wait_workers_s: float | None = None,
) -> Evaluator:
    """Local threads (default: every core), local worker processes of one thread each
    (`processes`; close it when done), or the Dask scheduler at `cluster` (tcp://HOST:PORT;
    the `cluster` extra; a scheduler without a worker is waited on `wait_workers_s`, default
    60 s); ExecutorError, in a sentence, if it cannot be reached or is no address."""
    if cluster is not None:
        from app.evaluation._dask import WAIT_WORKERS_S, ClusterEvaluator  # an optional extra

        wait = WAIT_WORKERS_S if wait_workers_s is None else wait_workers_s
        return ClusterEvaluator(cluster, robot, wait_workers_s=wait)
    if processes:
        from app.evaluation._processes import ProcessEvaluator

        return ProcessEvaluator(robot, processes)
    return BatchEvaluator(robot, threads=threads)


def close_evaluator(evaluator: Evaluator) -> None:
    """Let go of what an executor holds (a cluster's client, worker processes; threads hold
    nothing): call it when done, on every path."""
    close = getattr(evaluator, "close", None)
    if close is not None:
        close()
