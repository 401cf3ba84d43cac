"""The executors that send runs away in chunks (local processes, a Dask cluster) are one
`ChunkedEvaluator` over `concurrent.futures`-style futures: the jobs as plain data, one task per
chunk (`evaluate_chunk`, run where the robot is compiled once), results back in job order."""

from __future__ import annotations

import json
import queue
import threading
from abc import ABC, abstractmethod
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

from app.assets import project_version
from app.evaluation._api import (
    Cancelled,
    ExecutorError,
    Job,
    OnResult,
    Progress,
    job_from_dict,
    job_to_dict,
)
from app.evaluation._groups import lane_tasks
from app.evaluation._lanes import BatchEvaluator
from app.robots import parse_description
from app.robots.model import RobotModel
from app.robots.mujoco_warnings import keep_warnings_out_of_the_folder
from app.sim.metrics import RunMetrics, Trace
from gait import feedback

RUNS_PER_TASK = 8  # a task of 8 open-loop runs of 20 s is ~5 s of a core: the round trip < 1 %
POLL_S = 0.2  # how often a waiting `evaluate` looks at its cancel event


class VersionMismatch(ExecutorError):
    """A worker runs another version of the project than the caller."""


@lru_cache(maxsize=8)
def _worker_evaluator(robot_json: str) -> BatchEvaluator:
    """The compiled model of a robot, built once per worker process and robot (the worker's
    MuJoCo warnings kept out of its folder)."""
    keep_warnings_out_of_the_folder()
    robot = RobotModel.load(parse_description(json.loads(robot_json), "the robot sent"))
    return BatchEvaluator(robot, threads=1)


def evaluate_chunk(
    robot_json: str,
    jobs: list[dict[str, Any]],
    duration_s: float,
    warmup_s: float,
    version: str,
    with_traces: bool = False,
) -> list[RunMetrics] | list[tuple[RunMetrics, Trace]]:
    """One task: the metrics of `jobs` on the robot described by `robot_json`, with each run's
    trunk trace if asked (runs on a worker; refuses to run for another version of the
    project)."""
    ours = project_version()
    if ours != version:
        raise VersionMismatch(
            f"this worker runs artro-gait-studio {ours}, the client {version}: install the same "
            f"version on both"
        )
    evaluator = _worker_evaluator(robot_json)
    traces: list[Trace] | None = [] if with_traces else None
    metrics = evaluator.evaluate(
        [job_from_dict(j) for j in jobs], duration_s=duration_s, warmup_s=warmup_s, traces=traces
    )
    return metrics if traces is None else list(zip(metrics, traces, strict=True))


class ChunkedRuns:
    """The jobs of one `evaluate` call cut into tasks (`lane_tasks`: lists of job indices) as
    plain data (what `evaluate_chunk` takes), and their results as tasks come back in any
    order: `metrics` and `traces` in job order, `on_result` and `progress` called as each task
    arrives."""

    def __init__(
        self,
        jobs: Sequence[Job],
        tasks: list[list[int]],
        *,
        with_traces: bool,
        progress: Progress | None,
        on_result: OnResult | None,
    ) -> None:
        self.tasks, self.total, self.with_traces = tasks, len(jobs), with_traces
        self.chunks = [[job_to_dict(jobs[i]) for i in task] for task in tasks]
        self._metrics: list[RunMetrics | None] = [None] * len(jobs)
        self._traces: list[Trace | None] = [None] * len(jobs)
        self._progress, self._on_result = progress, on_result
        self.done = 0

    def arrived(self, i: int, result: list) -> None:
        """Task i's result (metrics, or (metrics, trace) pairs with traces)."""
        if self.with_traces:
            for job, (_metrics, trace) in zip(self.tasks[i], result, strict=True):
                self._traces[job] = trace
            result = [metrics for metrics, _t in result]
        for job, metrics in zip(self.tasks[i], result, strict=True):
            self._metrics[job] = metrics
            if self._on_result is not None:
                self._on_result(job, metrics)
        self.done += len(result)
        if self._progress is not None:
            self._progress(self.done, self.total)

    def cancelled(self) -> Cancelled:
        return Cancelled(f"cancelled after {self.done} of {self.total} runs")

    def results(self, traces: list[Trace] | None) -> list[RunMetrics]:
        if traces is not None:
            traces.extend(trace for trace in self._traces if trace is not None)
        return [metrics for metrics in self._metrics if metrics is not None]


class ChunkedEvaluator(ABC):
    """`Evaluator` over any executor whose `submit` gives futures with `add_done_callback`,
    `result` and `cancel` (`concurrent.futures`, Dask). A subclass says how to submit a task,
    how many runs a task takes, and which executor errors mean that runs were lost."""

    robot: RobotModel

    def __init__(self, robot: RobotModel) -> None:
        self.robot = robot
        self._robot_json = json.dumps(robot.description.model_dump(mode="json"), sort_keys=True)

    @abstractmethod
    def _submit(self, chunk: list[dict[str, Any]], *args: Any) -> Any:
        """A future of `evaluate_chunk(robot_json, chunk, *args)` on the executor."""

    @abstractmethod
    def task_size(self, runs: int) -> int:
        """Open-loop runs per task for a call of `runs` of them."""

    @abstractmethod
    def lanes(self) -> int:
        """How many tasks the executor runs at once (its workers)."""

    def tasks(self, jobs: Sequence[Job]) -> list[list[int]]:
        """The jobs' indices cut into tasks (`lane_tasks`): open-loop runs `task_size` at a
        time, closed-loop runs of one walk in whole groups, at least one a worker."""
        open_runs = sum(not feedback.any_law_on(job.params) for job in jobs)
        return lane_tasks(jobs, self.lanes(), max(1, self.task_size(open_runs)))

    @abstractmethod
    def _lost(self, exc: BaseException, done: int, total: int) -> Exception | None:
        """The error to raise when `exc` means the executor lost runs, else None (re-raised)."""

    def evaluate(
        self,
        jobs: Sequence[Job],
        *,
        duration_s: float,
        warmup_s: float = 5.0,
        progress: Progress | None = None,
        traces: list[Trace] | None = None,
        cancel: threading.Event | None = None,
        on_result: OnResult | None = None,
    ) -> list[RunMetrics]:
        """As `BatchEvaluator.evaluate`; runs under way when `cancel` is set are dropped. With
        `traces`, each run's trunk trace comes back too (one sample per frame: ~40 kB a
        minute of walking)."""
        with_traces = traces is not None
        finished: queue.SimpleQueue[Any] = queue.SimpleQueue()
        index: dict[int, int] = {}
        args = (duration_s, warmup_s, project_version(), with_traces)
        futures = []
        runs: ChunkedRuns | None = None
        try:
            runs = ChunkedRuns(
                jobs, self.tasks(jobs), with_traces=with_traces, progress=progress,
                on_result=on_result,
            )  # fmt: skip
            for i, chunk in enumerate(runs.chunks):
                future = self._submit(chunk, *args)
                index[id(future)] = i
                futures.append(future)
                future.add_done_callback(finished.put)
            while runs.done < runs.total:
                if cancel is not None and cancel.is_set():
                    for future in futures:
                        future.cancel()
                    raise runs.cancelled()
                try:
                    future = finished.get(timeout=POLL_S)
                except queue.Empty:
                    continue
                runs.arrived(index[id(future)], future.result())
        except (Cancelled, VersionMismatch):
            raise
        except Exception as exc:  # the executor's own, also while the tasks are cut (workers)
            lost = self._lost(exc, 0 if runs is None else runs.done, len(jobs))
            if lost is None:
                raise
            raise lost from exc
        return runs.results(traces)
