"""The one evaluation API (docs/DESIGN.md §9): runs of a robot (`Job`) in, their metrics out, in
order, with progress and cancellation, identical whether they run in local threads, local
processes or on a Dask cluster, and close to them as the worlds of a MuJoCo Warp batch
(docs/GPU.md); `evaluator_for` picks the executor."""

from __future__ import annotations

import sys
from collections.abc import Callable

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
from app.evaluation._warp import DEVICES  # warp itself loads when a WarpEvaluator is made
from app.robots.model import RobotModel


def print_to_stderr(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


#: `backend=`: today's executors (threads, processes, a cluster), MuJoCo Warp, or Warp when a
#: CUDA device and the `gpu` extra are there, else the CPU's
BACKENDS = ("cpu", "warp", "auto")

__all__ = [
    "BACKENDS",
    "DEVICES",
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
    backend: str = "cpu",
    device: str | None = None,
    notice: Callable[[str], None] | None = print_to_stderr,
) -> Evaluator:
    """Local threads (default: every core), local worker processes of one thread each
    (`processes`; close it when done), or the Dask scheduler at `cluster` (tcp://HOST:PORT;
    the `cluster` extra; a scheduler without a worker is waited on `wait_workers_s`, default
    60 s); ExecutorError, in a sentence, if it cannot be reached or is no address.

    `backend="warp"`: the runs of each call as the worlds of one MuJoCo Warp batch on `device`
    ("cuda", the default, or "cpu", Warp's slow CPU device; the `gpu` extra; `notice` hears,
    once per device and process, that the kernels compile: stderr by default); "auto": Warp
    on `device` when the extra is there and, for "cuda" (its default), a CUDA device, else the
    CPU's executors, the choice and why said to `notice` (`_warp.auto_choice`).
    ExecutorError for an unknown backend, Warp with a cluster or processes, a missing extra or
    no CUDA device (docs/GPU.md)."""
    if backend not in BACKENDS:
        raise ExecutorError(f"backend must be one of {', '.join(BACKENDS)}, got {backend!r}")
    if backend == "auto":  # said, with why: a GPU run and a CPU one differ by a hundred times
        from app.evaluation._warp import auto_choice

        elsewhere = "--cluster" if cluster is not None else "--processes" if processes else None
        backend, device, why = auto_choice(device, elsewhere)
        if notice is not None:
            notice(f"--backend auto: {why}")
    if backend == "warp":
        if cluster is not None:
            raise ExecutorError(
                "--backend warp runs every job in this process's one batch: leave out --cluster"
            )
        if processes:  # no command has processes; a caller of this function does
            raise ExecutorError(
                "backend='warp' runs every job in this process's one batch: "
                "worker processes (processes=) are the CPU's executors"
            )
        from app.evaluation._warp import WarpEvaluator  # the gpu extra, imported when used

        return WarpEvaluator(robot, device=device or "cuda", notice=notice)
    if cluster is not None:
        from app.evaluation._dask import WAIT_WORKERS_S, ClusterEvaluator  # an optional extra

        wait = WAIT_WORKERS_S if wait_workers_s is None else wait_workers_s
        return ClusterEvaluator(cluster, robot, wait_workers_s=wait)
    if processes:
        from app.evaluation._processes import ProcessEvaluator

        return ProcessEvaluator(robot, processes)
    return BatchEvaluator(robot, threads=threads)


def close_evaluator(evaluator: Evaluator) -> None:
    """Let go of what an executor holds (a cluster's client, worker processes, a Warp
    evaluator's host processes; threads hold nothing): call it when done, on every path."""
    close = getattr(evaluator, "close", None)
    if close is not None:
        close()
