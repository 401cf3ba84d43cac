"""Evaluations in local worker processes (docs/DESIGN.md §14): the same `evaluate` as the local
threads and the cluster, each process one MuJoCo thread, the runs sent as a cluster's chunks
(`app.core.cluster.evaluate_chunk`), the robot compiled once per process. It asks whether
processes remove the loss of two MuJoCo threads in one process; on this VM they do not (§14)."""

from __future__ import annotations

import json
import math
import multiprocessing
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from app.assets import project_version
from app.core.batch import Job
from app.core.cluster import RUNS_PER_TASK, ChunkedRuns, evaluate_chunk
from app.core.metrics import RunMetrics, Trace
from app.core.robot import RobotModel


class WorkerDied(RuntimeError):
    """A worker process ended mid-evaluation (killed, out of memory): the runs not finished have
    no result."""


class ProcessEvaluator:
    """`Evaluator` on `processes` local worker processes (default: every core, at most 8),
    started once (spawned: no MuJoCo state is forked) and kept until `close`. A task is up to
    `runs_per_task` runs, fewer when a call has too few runs to give every process as many
    (so both cores stay busy to the end of a call)."""

    def __init__(
        self,
        robot: RobotModel | None = None,
        processes: int | None = None,
        *,
        runs_per_task: int = RUNS_PER_TASK,
    ) -> None:
        self.robot = robot or RobotModel.load()
        self.processes = processes or min(os.cpu_count() or 1, 8)
        self.runs_per_task = runs_per_task
        self._robot_json = json.dumps(
            self.robot.description.model_dump(mode="json"), sort_keys=True
        )
        self._pool = self._start_pool()

    def _start_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(self.processes, mp_context=multiprocessing.get_context("spawn"))

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> ProcessEvaluator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def task_size(self, runs: int) -> int:
        return max(1, min(self.runs_per_task, math.ceil(runs / self.processes)))

    def evaluate(
        self,
        jobs: Sequence[Job],
        *,
        duration_s: float,
        warmup_s: float = 5.0,
        progress: Callable[[int, int], None] | None = None,
        traces: list[Trace] | None = None,
        cancel: threading.Event | None = None,
        on_result: Callable[[int, RunMetrics], None] | None = None,
    ) -> list[RunMetrics]:
        """As `BatchEvaluator.evaluate`; runs under way when `cancel` is set are dropped."""
        runs = ChunkedRuns(
            jobs, self.task_size(len(jobs)), with_traces=traces is not None, progress=progress,
            on_result=on_result,
        )  # fmt: skip
        version = project_version()
        try:
            futures = {
                self._pool.submit(
                    evaluate_chunk, self._robot_json, chunk, duration_s, warmup_s, version,
                    traces is not None,
                ): i
                for i, chunk in enumerate(runs.chunks)
            }  # fmt: skip
            pending = set(futures)
            while pending:
                finished, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                for future in sorted(finished, key=futures.__getitem__):
                    if cancel is not None and cancel.is_set():
                        break
                    runs.arrived(futures[future], future.result())
                if cancel is not None and cancel.is_set():
                    for future in pending:
                        future.cancel()
                    raise runs.cancelled()
        except BrokenProcessPool as exc:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = self._start_pool()  # the next call runs on new processes
            raise WorkerDied(
                f"a worker process ended after {runs.done} of {len(jobs)} runs ({exc}); the runs "
                f"not finished have no result"
            ) from exc
        return runs.results(traces)
