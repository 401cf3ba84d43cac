"""Evaluations in local worker processes (docs/DESIGN.md §9): `ChunkedEvaluator` on a pool of
spawned processes, each one MuJoCo thread with the robot compiled once. It answers whether
processes remove the loss of two MuJoCo threads in one process (decision 0007: on this VM, no)."""

from __future__ import annotations

import math
import multiprocessing
import os
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from app.evaluation._api import ExecutorError
from app.evaluation._chunks import RUNS_PER_TASK, ChunkedEvaluator, evaluate_chunk
from app.robots.model import RobotModel


class WorkerDied(ExecutorError):
    """A worker process ended mid-evaluation (killed, out of memory): the runs not finished have
    no result."""


class ProcessEvaluator(ChunkedEvaluator):
    """`Evaluator` on `processes` local worker processes (default: every core, at most 8),
    started once (spawned: no MuJoCo state is forked) and kept until `close`. A task is up to
    `runs_per_task` open-loop runs, fewer when a call has too few runs to give every process as
    many (so both cores stay busy to the end of a call); closed-loop runs of one walk go as
    whole groups, one a process at least (`lane_tasks`)."""

    def __init__(
        self,
        robot: RobotModel | None = None,
        processes: int | None = None,
        *,
        runs_per_task: int = RUNS_PER_TASK,
    ) -> None:
        super().__init__(robot or RobotModel.load())
        self.processes = processes or min(os.cpu_count() or 1, 8)
        self.runs_per_task = runs_per_task
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

    def lanes(self) -> int:
        return self.processes

    def _submit(self, chunk: list[dict[str, Any]], *args: Any) -> Future:
        return self._pool.submit(evaluate_chunk, self._robot_json, chunk, *args)

    def _lost(self, exc: BaseException, done: int, total: int) -> Exception | None:
        if not isinstance(exc, BrokenProcessPool):
            return None
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = self._start_pool()  # the next call runs on new processes
        return WorkerDied(
            f"a worker process ended after {done} of {total} runs ({exc}); the runs not "
            f"finished have no result"
        )
