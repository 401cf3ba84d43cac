"""The types of the one evaluation API (docs/DESIGN.md §6): a run is a `Job`, an executor is an
`Evaluator`; a job as plain data (`job_to_dict`, `job_from_dict`) is what leaves the process."""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from app.robots.model import RobotModel
from app.sim.metrics import RunMetrics, Trace
from app.worlds.variations import NOMINAL, Variation, parse_variation
from gait import GaitParams, Motion

Progress = Callable[[int, int], None]
OnResult = Callable[[int, RunMetrics], None]
#: metrics that say how fast a run went, not what it did: they differ between executors
TIMING_KEYS = ("wall_s", "rtf")


class Cancelled(RuntimeError):
    """An evaluation was cancelled; the runs it did not finish have no result."""


class ExecutorError(RuntimeError):
    """An executor cannot run the runs, or lost some: a cluster not reached or gone, a worker
    process that died, a worker of another version of the project."""


@dataclass(frozen=True)
class Job:
    """One run: gait constants and the motion vector with CA, constant for the whole run, on the
    evaluator's robot as varied by `variation` (docs/DESIGN.md §8; default: nominal)."""

    params: GaitParams
    motion: Motion
    #: the motion the run starts in and ramps from (default: `motion`), as `FrameLoop` takes it
    start_motion: Motion | None = None
    variation: Variation = NOMINAL


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
        on_result: OnResult | None = None,
    ) -> list[RunMetrics]:
        """Metrics of each job, in order; `progress(done, total)` as runs finish and
        `on_result(index, metrics)` with each; each run's trunk `Trace` appended to `traces`,
        in job order, when given; Cancelled as soon as `cancel` is set (runs under way are
        dropped)."""
        ...


def job_to_dict(job: Job) -> dict[str, Any]:
    """A job as plain data (what a worker receives): exact, floats kept to the bit."""
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
