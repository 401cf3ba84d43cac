"""Evaluations on a Dask distributed cluster (docs/DESIGN.md §14, docs/CLUSTER.md): the same
`evaluate` as the local threads, the runs sent in chunks to the workers as plain data (the robot's
description, the parameter sets, the variations' text), never as pickled models."""

from __future__ import annotations

import json
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import CancelledError
from functools import lru_cache
from typing import Any

from app.assets import project_version
from app.core.batch import BatchEvaluator, Cancelled, Job
from app.core.metrics import RunMetrics, Trace
from app.core.robot import RobotModel
from app.robots import parse_description

RUNS_PER_TASK = 8  # a task of 8 runs of 20 s is ~5 s of a core: the round trip is < 1 % of it
CONNECT_TIMEOUT_S = 10


class ClusterError(RuntimeError):
    """The scheduler cannot be reached or went away, or a worker cannot take our runs."""


def worker_version() -> str:
    """What a worker reports when asked (runs on the worker)."""
    return project_version()


@lru_cache(maxsize=8)
def _worker_evaluator(robot_json: str) -> BatchEvaluator:
    """The compiled model of a robot, built once per worker process and robot."""
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
    from app.core.evaluation import job_from_dict

    ours = project_version()
    if ours != version:
        raise ClusterError(
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
    """The jobs of one `evaluate` call cut into chunks as plain data (what `evaluate_chunk`
    takes), and their results as chunks come back in any order: `metrics` and `traces` in job
    order, `on_result` and `progress` called as each chunk arrives. Shared by the executors that
    send chunks away (a cluster, local processes)."""

    def __init__(
        self,
        jobs: Sequence[Job],
        size: int,
        *,
        with_traces: bool,
        progress: Callable[[int, int], None] | None,
        on_result: Callable[[int, RunMetrics], None] | None,
    ) -> None:
        from app.core.evaluation import job_to_dict

        self.size, self.total, self.with_traces = size, len(jobs), with_traces
        self.chunks = [
            [job_to_dict(j) for j in jobs[i : i + size]] for i in range(0, len(jobs), size)
        ]
        self._metrics: list[list[RunMetrics]] = [[] for _ in self.chunks]
        self._traces: list[list[Trace]] = [[] for _ in self.chunks]
        self._progress, self._on_result = progress, on_result
        self.done = 0

    def arrived(self, i: int, result: list) -> None:
        """Chunk i's result (metrics, or (metrics, trace) pairs with traces)."""
        if self.with_traces:
            self._traces[i] = [trace for _m, trace in result]
            result = [metrics for metrics, _t in result]
        self._metrics[i] = result
        if self._on_result is not None:
            for k, metrics in enumerate(result):
                self._on_result(i * self.size + k, metrics)
        self.done += len(result)
        if self._progress is not None:
            self._progress(self.done, self.total)

    def cancelled(self) -> Cancelled:
        return Cancelled(f"cancelled after {self.done} of {self.total} runs")

    def results(self, traces: list[Trace] | None) -> list[RunMetrics]:
        if traces is not None:
            traces.extend(trace for chunk in self._traces for trace in chunk)
        return [m for chunk in self._metrics for m in chunk]


class ClusterEvaluator:
    """`Evaluator` on the Dask scheduler at `address`. A worker that dies loses no result: its
    tasks run again on another (Dask recomputes what a lost worker held); a scheduler that goes
    away is a ClusterError; so is a worker of another project version, naming both."""

    def __init__(self, address: str, robot: RobotModel, *, runs_per_task: int = RUNS_PER_TASK):
        try:
            from distributed import Client
        except ImportError as exc:  # the optional extra
            raise ClusterError(
                'a cluster needs Dask: pip install "artro-gait-studio[cluster]"'
            ) from exc
        self.address = address
        self.robot = robot
        self.runs_per_task = runs_per_task
        self._robot_json = json.dumps(robot.description.model_dump(mode="json"), sort_keys=True)
        try:
            self.client = Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
        except OSError as exc:
            raise ClusterError(f"no Dask scheduler answers at {address}: {exc}") from exc
        self.check_versions()

    def check_versions(self) -> None:
        """ClusterError if a worker runs another version of the project (or none)."""
        ours = project_version()
        try:
            found = self.client.run(worker_version)
        except Exception as exc:  # a worker without the project cannot even import this
            raise ClusterError(f"the workers at {self.address} cannot run artro: {exc}") from exc
        other = {w: v for w, v in found.items() if v != ours}
        if other:
            listed = ", ".join(f"{w} runs {v}" for w, v in sorted(other.items()))
            raise ClusterError(f"this is artro-gait-studio {ours}; refused workers: {listed}")

    def workers(self) -> int:
        return len(self.client.scheduler_info().get("workers", {}))

    def close(self) -> None:
        self.client.close()

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
        """As `BatchEvaluator.evaluate`; with `traces`, the workers send each run's trunk trace
        back too (one sample per frame: ~40 kB a minute of walking)."""
        from distributed import as_completed

        runs = ChunkedRuns(
            jobs, self.runs_per_task, with_traces=traces is not None, progress=progress,
            on_result=on_result,
        )  # fmt: skip
        version = project_version()
        try:
            futures = [
                self.client.submit(
                    evaluate_chunk, self._robot_json, chunk, duration_s, warmup_s, version,
                    traces is not None, pure=False, retries=1,
                )
                for chunk in runs.chunks
            ]  # fmt: skip
            index = {f.key: i for i, f in enumerate(futures)}
            for future in as_completed(futures, loop=self.client.loop):
                if cancel is not None and cancel.is_set():
                    self.client.cancel(futures)
                    raise runs.cancelled()
                runs.arrived(index[future.key], future.result())
        except (Cancelled, ClusterError):
            raise
        except (OSError, TimeoutError, CancelledError) as exc:  # Dask's, when it lost the line
            raise ClusterError(
                f"the Dask scheduler at {self.address} went away ({type(exc).__name__}: {exc}); "
                f"the runs not finished have no result"
            ) from exc
        return runs.results(traces)
