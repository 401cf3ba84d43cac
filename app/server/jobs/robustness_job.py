"""The dashboard's robustness job: the current gait walks the paper's cases and CA ±0.1 on N
model variations in the background (docs/DESIGN.md §10, §12), with progress and cancellation; the
report is `artro bench robust`'s, for the page to draw."""

from __future__ import annotations

import json
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from typing import Any, Literal

from app.analysis.robust_cases import ROBUST_CASES
from app.analysis.robustness import run_robust
from app.evaluation import Cancelled, close_evaluator, evaluator_for
from app.evaluation.progress import time_left_s
from app.robots.model import RobotModel
from app.server.jobs.registry import Job, JobCancelled, Jobs, Reporter
from app.server.param_store import ParameterStore, Snapshot
from app.worlds.sampling import VariationRanges

Kind = Literal["robustness"]  # its jobs' `kind` (app/server/jobs/results.py)
KIND: Kind = "robustness"
SAMPLES, DURATION_S, WARMUP_S = 24, 12.0, 4.0  # ~4 minutes of one core for 225 runs
REPORTS_KEPT = 16  # the last report of this many gaits (a reload of the page shows it again)


def gait_key(snap: Snapshot) -> str:
    """What a report belongs to: the robot and every gait constant (the motion is the cases')."""
    return json.dumps([snap.robot, snap.gait.to_dict()], sort_keys=True)


class RobustnessRunner:
    """Starts robustness jobs on the store's current gait (one at a time)."""

    def __init__(
        self,
        jobs: Jobs,
        store: ParameterStore,
        robot_now: Callable[[], RobotModel],
        cluster: str | None = None,
        backend: dict[str, Any] | None = None,
        wait_workers_s: float | None = None,
    ) -> None:
        """Jobs walk the robot `robot_now()` names when they start, on `cluster` (waiting
        `wait_workers_s` for a worker, default 60 s) or with `backend` (`evaluator_for`'s
        backend and device; default: the CPU's)."""
        self.jobs, self.store, self.robot_now, self.cluster = jobs, store, robot_now, cluster
        self.wait_workers_s = wait_workers_s
        self.backend = backend or {}
        self._reports: OrderedDict[str, dict[str, Any]] = OrderedDict()  # gait key -> report
        self._lock = threading.Lock()

    def last_report(self, snap: Snapshot) -> dict[str, Any] | None:
        """The last finished report of `snap`'s gait on its robot (None: none kept), with when
        it finished (`finished_at`, Unix seconds) and the version it was run on."""
        with self._lock:
            return self._reports.get(gait_key(snap))

    def _keep(self, snap: Snapshot, report: dict[str, Any]) -> None:
        key = gait_key(snap)
        kept = report | {"finished_at": time.time(), "params_version": snap.version}
        with self._lock:
            self._reports.pop(key, None)
            self._reports[key] = kept
            while len(self._reports) > REPORTS_KEPT:
                self._reports.popitem(last=False)

    def start(self, *, samples: int = SAMPLES, seed: int = 0) -> Job:
        snap = self.store.snapshot()
        name = f"{snap.name} (v{snap.version})"
        robot = self.robot_now()

        def work(progress: Reporter) -> dict[str, Any]:
            job: Job = progress.job
            started = time.monotonic()
            job.detail = {"runs": 0, "runs_total": runs_of(samples), "left_s": None}

            def runs_walked(done: int, total: int) -> None:
                """The runs walked of all and the time left at their pace (issue 56, item 13),
                a new dict each time: a reader never sees one change."""
                left = time_left_s(time.monotonic() - started, done, total)
                job.detail = {"runs": done, "runs_total": total, "left_s": left}
                progress(done / total)

            # one thread locally: the live simulation keeps the other core
            evaluator = evaluator_for(
                robot,
                cluster=self.cluster,
                threads=1,
                wait_workers_s=self.wait_workers_s,
                **self.backend,
            )
            try:
                report = run_robust(
                    [(name, snap.gait, snap.name)],
                    evaluator,
                    samples=samples,
                    seed=seed,
                    ranges=VariationRanges(),
                    duration_s=DURATION_S,
                    warmup_s=WARMUP_S,
                    progress=runs_walked,
                    # looked at between chunks by every executor: a Warp batch reports progress
                    # only as its worlds end, and went on minutes after a DELETE
                    cancel=job.cancel,
                )
            except Cancelled as stopped:  # said as any job says it, and how far it came
                try:
                    progress(None)  # JobCancelled: by DELETE, or the server stopped
                except JobCancelled as said:
                    raise JobCancelled(f"{said} ({stopped})") from None
                raise
            finally:  # a Warp host's processes, a Dask client: each job's own
                close_evaluator(evaluator)
            self._keep(snap, report)
            return report

        return self.jobs.start(KIND, work, robot=robot.name)


def runs_of(samples: int) -> int:
    return (samples + 1) * len(ROBUST_CASES)
