"""Background jobs of the server (the axle fit, the CA calibration): started by a request that
answers 202 at once, run in a thread, read back with their progress and result, cancelled on
request; a job's result applies only onto what it was fitted from (docs/DESIGN.md §6, §14)."""

from __future__ import annotations

import ctypes
import dataclasses
import functools
import itertools
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

KEEP_JOBS = 20


def release_free_heap() -> None:
    """Hand the C heap's free pages back to the system (glibc's `malloc_trim`; nothing where
    the C library has none). A job's thread frees its simulations' arrays into a malloc arena
    of its own, which stays resident: over 120 cancelled jobs the server's RSS rose ~15 MB a
    job to a 440-470 MB plateau while ~45 MB were in use (decision 0048)."""
    trim = getattr(_libc(), "malloc_trim", None)
    if trim is not None:
        trim(0)


@functools.cache
def _libc() -> ctypes.CDLL | None:
    try:
        return ctypes.CDLL(None)
    except OSError:
        return None


#: Report progress (0..1), or None just to check for cancellation; raises JobCancelled then
#: (a `Reporter`).
Progress = Callable[[float | None], None]
#: Apply a job's kept result onto the parameter version named: returns what changed.
Applier = Callable[[int], dict[str, Any]]


class RobotChanged(RuntimeError):
    """The robot in use changed as a job started (the switch's guard had not seen it yet):
    the job was let go before it ran."""


class JobBusy(RuntimeError):
    """A job of that kind is already running."""

    def __init__(self, job: Job) -> None:
        super().__init__(
            f"a {job.kind} job is already running ({job.id}): wait for it to finish or cancel "
            f"it (DELETE /api/jobs/{job.id})"
        )
        self.job = job


class JobCancelled(RuntimeError):
    """The job was cancelled (DELETE /api/jobs/{id}) or the server is stopping: a running job
    ends at its next progress report."""


class StaleVersion(RuntimeError):
    """What a job fitted belongs to another parameter version than the one in use."""


HIDDEN = frozenset({"value", "finished", "cancel", "applier"})
JobStatus = Literal["running", "done", "failed", "cancelled"]


@dataclass
class Job:
    id: str
    kind: str
    status: JobStatus = "running"
    progress: float = 0.0  # 0..1
    result: dict[str, Any] | None = None
    error: str | None = None
    started_s: float = field(default_factory=time.time)
    finished_s: float | None = None
    from_version: int | None = None  # the parameter version the job works on
    detail: dict[str, Any] | None = None  # what a running job says besides its progress
    value: Any = field(default=None, repr=False)  # what the work returned
    finished: threading.Event = field(default_factory=threading.Event, repr=False)
    cancel: threading.Event = field(default_factory=threading.Event, repr=False)
    #: applies the kept result of a job that could not apply it itself (a conflict)
    applier: Applier | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {
            f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in HIDDEN
        }


class Reporter:
    """The `progress` a job's work gets: `progress(fraction)` reports (None only checks), and
    raises JobCancelled once the job is cancelled or the server stops; `progress.job` is the job
    (for a work that leaves a result to apply later: `job.applier`)."""

    def __init__(self, job: Job, stopping: threading.Event) -> None:
        self.job, self._stopping = job, stopping

    def __call__(self, fraction: float | None = None) -> None:
        if self._stopping.is_set():  # no simulation outlives the server
            raise JobCancelled("the server stopped before the job finished")
        if self.job.cancel.is_set():
            raise JobCancelled(f"cancelled (DELETE /api/jobs/{self.job.id}); nothing was applied")
        if fraction is not None:
            self.job.progress = min(max(float(fraction), 0.0), 1.0)


class Jobs:
    """At most one running job per kind; the running ones and the latest finished ones (up to
    KEEP_JOBS in all) are kept for reading."""

    def __init__(self) -> None:
        self._stopping = threading.Event()
        self._lock = threading.Lock()
        self._jobs: OrderedDict[str, Job] = OrderedDict()
        self._ids = itertools.count(1)
        #: the robot in use, read after any change of robots lands (`settled_robot`): a job
        #: started for another is let go (None: not checked)
        self.robot_in_use: Callable[[], str] | None = None

    def start(
        self,
        kind: str,
        work: Callable[[Reporter], Any],
        describe: Callable[[Any], dict[str, Any]] = dict,
        *,
        from_version: int | None = None,
        robot: str | None = None,
    ) -> Job:
        """Run `work(progress)` in a thread; `describe(its value)` is the result, an exception
        the error. Raises JobBusy while a job of this kind runs, RobotChanged when `robot`
        (what the job walks) is no longer in use once the job is registered: a switch of
        robots refuses while a job runs, and one that passed its guard just before is seen
        here (docs/DESIGN.md §10)."""
        with self._lock:
            if self._stopping.is_set():
                raise JobCancelled("the server is stopping")
            for job in self._jobs.values():
                if job.kind == kind and job.status == "running":
                    raise JobBusy(job)
            job = Job(id=f"{kind}-{next(self._ids)}", kind=kind, from_version=from_version)
            self._jobs[job.id] = job
            self._forget_finished()
        if robot is not None and self.robot_in_use is not None:
            if (now := self.robot_in_use()) != robot:
                with self._lock:
                    self._jobs.pop(job.id, None)
                raise RobotChanged(
                    f"the robot changed from {robot!r} to {now!r} as the {kind} job started: "
                    "it did not run; start it again"
                )

        progress = Reporter(job, self._stopping)

        def run() -> None:
            try:
                job.value = work(progress)
                job.result = describe(job.value)
            except JobCancelled as exc:
                cancelled = job.cancel.is_set() and not self._stopping.is_set()
                job.error, job.status = str(exc), "cancelled" if cancelled else "failed"
            except Exception as exc:  # reported in the job, never lost in a thread
                job.error, job.status = str(exc) or type(exc).__name__, "failed"
            else:
                job.progress, job.status = 1.0, "done"
            job.finished_s = time.time()
            job.finished.set()
            release_free_heap()

        threading.Thread(target=run, name=f"artro-job-{job.id}", daemon=True).start()
        return job

    def _forget_finished(self) -> None:
        """Drop the oldest finished jobs past KEEP_JOBS (under the lock). A running job is never
        dropped: it stays readable and cancellable, and keeps refusing a second job of its kind
        and a switch of robots."""
        finished = [job_id for job_id, job in self._jobs.items() if job.status != "running"]
        for job_id in finished[: max(0, len(self._jobs) - KEEP_JOBS)]:
            del self._jobs[job_id]

    def stop(self, timeout_s: float = 30.0) -> None:
        """Cancel the running jobs (at their next progress report) and wait for them."""
        self._stopping.set()
        with self._lock:
            running = [job for job in self._jobs.values() if job.status == "running"]
        for job in running:  # an evaluation looks at its job's cancel between its chunks
            job.cancel.set()
        deadline = time.monotonic() + timeout_s
        for job in running:
            job.finished.wait(max(0.0, deadline - time.monotonic()))

    def running(self) -> list[Job]:
        """The jobs running now."""
        with self._lock:
            return [job for job in self._jobs.values() if job.status == "running"]

    def get(self, job_id: str) -> Job | None:
        with self._lock:
            return self._jobs.get(job_id)

    def cancel(self, job: Job, timeout_s: float = 10.0) -> bool:
        """Ask a running job to stop at its next progress report and wait for it (bounded);
        False if it had already finished."""
        if job.finished.is_set():
            return False
        job.cancel.set()
        job.finished.wait(timeout_s)
        return True


def only_onto(version: int, robot: str | None = None) -> Callable[[Any], None]:
    """A store check (app/server/param_store.py): the change applies only onto `version`, and
    (given `robot`) only while that robot is the one in use: what a job fitted on one robot
    never lands on another."""

    def check(current: Any) -> None:
        if robot is not None:
            on_robot(robot)(current)
        if current.version != version:
            raise StaleVersion(
                f"the parameters changed while the job ran (version {version} is now "
                f"{current.version}, changed by {current.source}): not applied; the result is "
                f"kept: POST /api/jobs/{{id}}/apply with the version to apply it onto"
            )

    return check


def on_robot(robot: str) -> Callable[[Any], None]:
    """A store check: the change applies only while `robot` is the robot in use."""

    def check(current: Any) -> None:
        if current.robot != robot:
            raise StaleVersion(
                f"the result was fitted on the robot {robot!r}; the robot in use is "
                f"{current.robot!r}: not applied (run the job again on {current.robot!r})"
            )

    return check


def conflict(exc: StaleVersion, current_version: int | None) -> dict[str, Any]:
    """What a job that could not apply its result says about it (a 409 in the job's result)."""
    return {"status": 409, "type": "version_conflict", "msg": str(exc), "version": current_version}
