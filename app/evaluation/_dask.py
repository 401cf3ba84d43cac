"""Evaluations on a Dask distributed cluster (docs/DESIGN.md §9, docs/CLUSTER.md):
`ChunkedEvaluator` on a Dask client, the runs sent to the workers as plain data (the robot's
description, the parameter sets, the variations' text), never as pickled models."""

from __future__ import annotations

from concurrent.futures import CancelledError
from typing import Any

from app.assets import project_version
from app.evaluation._api import ExecutorError
from app.evaluation._chunks import RUNS_PER_TASK, ChunkedEvaluator, evaluate_chunk
from app.robots.model import RobotModel

CONNECT_TIMEOUT_S = 10


class ClusterError(ExecutorError):
    """The scheduler cannot be reached or went away, or a worker cannot take our runs."""


def worker_version() -> str:
    """What a worker reports when asked (runs on the worker)."""
    return project_version()


class ClusterEvaluator(ChunkedEvaluator):
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
        super().__init__(robot)
        self.address = address
        self.runs_per_task = runs_per_task
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

    def task_size(self, runs: int) -> int:
        return self.runs_per_task

    def _submit(self, chunk: list[dict[str, Any]], *args: Any) -> Any:
        return self.client.submit(
            evaluate_chunk, self._robot_json, chunk, *args, pure=False, retries=1
        )

    def _lost(self, exc: BaseException, done: int, total: int) -> Exception | None:
        if not isinstance(exc, OSError | TimeoutError | CancelledError):
            return None  # Dask's errors when it lost the line to the scheduler
        return ClusterError(
            f"the Dask scheduler at {self.address} went away ({type(exc).__name__}: {exc}); "
            f"the runs not finished have no result"
        )
