"""Background jobs of the server (the axle fit): started by a request that answers 202 at once,
run in a thread, read back with their progress and result (docs/DESIGN.md §6)."""

from __future__ import annotations

import dataclasses
import itertools
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

KEEP_JOBS = 20

Progress = Callable[[float], None]


class JobBusy(RuntimeError):
    """A job of that kind is already running."""

    def __init__(self, job: Job) -> None:
        super().__init__(f"a {job.kind} job is already running ({job.id}); wait for it to finish")
        self.job = job


@dataclass
class Job:
    id: str
    kind: str
    status: str = "running"  # running | done | failed
    progress: float = 0.0  # 0..1
    result: dict[str, Any] | None = None
    error: str | None = None
    started_s: float = field(default_factory=time.time)
    finished_s: float | None = None
    value: Any = field(default=None, repr=False)  # what the work returned
    finished: threading.Event = field(default_factory=threading.Event, repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)[:-2]}


class JobCancelled(RuntimeError):
    """The server is stopping: a running job ends at its next progress report."""


class Jobs:
    """At most one running job per kind; the latest KEEP_JOBS are kept for reading."""

    def __init__(self) -> None:
        self._stopping = threading.Event()
        self._lock = threading.Lock()
        self._jobs: OrderedDict[str, Job] = OrderedDict()
        self._ids = itertools.count(1)

    def start(
        self,
        kind: str,
        work: Callable[[Progress], Any],
        describe: Callable[[Any], dict[str, Any]] = dict,
    ) -> Job:
        """Run `work(progress)` in a thread; `describe(its value)` is the result, an exception
        the error. Raises JobBusy while a job of this kind runs."""
        with self._lock:
            if self._stopping.is_set():
                raise JobCancelled("the server is stopping")
            for job in self._jobs.values():
                if job.kind == kind and job.status == "running":
                    raise JobBusy(job)
            job = Job(id=f"{kind}-{next(self._ids)}", kind=kind)
            self._jobs[job.id] = job
            while len(self._jobs) > KEEP_JOBS:
                self._jobs.popitem(last=False)

        def progress(fraction: float) -> None:
            if self._stopping.is_set():  # no simulation outlives the server
                raise JobCancelled("the server stopped before the job finished")
            job.progress = min(max(float(fraction), 0.0), 1.0)

        def run() -> None:
            try:
                job.value = work(progress)
                job.result = describe(job.value)
            except Exception as exc:  # reported in the job, never lost in a thread
                job.error, job.status = str(exc) or type(exc).__name__, "failed"
            else:
                job.progress, job.status = 1.0, "done"
            job.finished_s = time.time()
            job.finished.set()

        threading.Thread(target=run, name=f"artro-job-{job.id}", daemon=True).start()
        return job

    def stop(self, timeout_s: float = 30.0) -> None:
        """Cancel the running jobs (at their next progress report) and wait for them."""
        self._stopping.set()
        with self._lock:
            running = [job for job in self._jobs.values() if job.status == "running"]
        deadline = time.monotonic() + timeout_s
        for job in running:
            job.finished.wait(max(0.0, deadline - time.monotonic()))

    def get(self, job_id: str) -> Job | None:
        with self._lock:
            return self._jobs.get(job_id)
