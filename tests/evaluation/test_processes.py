"""The process evaluator (docs/DESIGN.md §9): two real spawned worker processes give the local
threads' results to the bit, in order, with progress and traces; a cancel stops it; a killed
worker is a clear error and the next call runs on new processes."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from app.evaluation import BatchEvaluator, Cancelled, Job, evaluator_for, same_results
from app.evaluation._processes import ProcessEvaluator, WorkerDied
from app.robots.model import RobotModel
from app.sim.metrics import Trace
from app.worlds.variations import parse_variation
from gait import Motion
from tests.testing.evaluation_support import CLOSED, assert_same_traces, varied_jobs

pytestmark = pytest.mark.slow
ROBOT = RobotModel.load()


@pytest.fixture(scope="module")
def workers():
    evaluator = evaluator_for(ROBOT, processes=2)
    assert isinstance(evaluator, ProcessEvaluator)
    with evaluator:
        yield evaluator


def test_two_processes_give_the_threads_results_to_the_bit(workers):
    runs = varied_jobs(6)
    seen: list[int] = []
    found: list[int] = []
    traces: list[Trace] = []
    local_traces: list[Trace] = []
    here = workers.evaluate(
        runs,
        duration_s=3.0,
        warmup_s=1.0,
        progress=lambda d, n: seen.append(d),
        traces=traces,
        on_result=lambda i, m: found.append(i),
    )
    local = BatchEvaluator(ROBOT, threads=2).evaluate(
        runs, duration_s=3.0, warmup_s=1.0, traces=local_traces
    )
    assert same_results(here, local)
    assert len({m["forward_cm_s"] for m in here}) == 6  # six different runs, in job order
    assert_same_traces(traces, local_traces)
    assert seen == sorted(seen) and seen[-1] == 6 and sorted(found) == list(range(6))
    assert workers.task_size(6) == 3  # both processes get a share of a small call


def test_closed_loop_runs_of_one_walk_go_to_the_processes_as_whole_groups(workers):
    walk = [
        Job(CLOSED, Motion(a_p=0.07), variation=parse_variation(f"friction={0.5 + 0.02 * i:.2f}"))
        for i in range(20)
    ]
    jobs = [*walk[:10], *varied_jobs(3)[::2], *walk[10:]]  # two open-loop runs between
    tasks = workers.tasks(jobs)
    grouped = [t for t in tasks if len(t) > 1]
    # the walk's 20 runs: one group a process (not tasks of `runs_per_task`), in job order
    assert [len(t) for t in grouped] == [10, 10] and grouped[0] == list(range(10))
    assert sorted(i for t in tasks for i in t) == list(range(22))
    short = jobs[6:14]  # 4 of the walk, the 2 others, 2 of the walk again
    here = workers.evaluate(short, duration_s=2.0, warmup_s=0.5)
    local = BatchEvaluator(ROBOT, threads=2).evaluate(short, duration_s=2.0, warmup_s=0.5)
    assert same_results(here, local)


def test_a_cancel_stops_the_evaluation(workers):
    cancel = threading.Event()

    def progress(done: int, _total: int) -> None:
        cancel.set()

    with pytest.raises(Cancelled, match="cancelled after"):
        workers.evaluate(
            varied_jobs(12), duration_s=3.0, warmup_s=1.0, progress=progress, cancel=cancel
        )  # fmt: skip


def test_a_killed_worker_is_a_clear_error_and_the_next_call_runs():
    with ProcessEvaluator(ROBOT, 2, runs_per_task=1) as evaluator:
        evaluator.evaluate(varied_jobs(2), duration_s=0.5, warmup_s=0.2)  # the processes are up
        pids = list(evaluator._pool._processes)
        killed = threading.Event()

        def progress(done: int, _total: int) -> None:
            if not killed.is_set():
                killed.set()
                os.kill(pids[0], signal.SIGKILL)

        with pytest.raises(WorkerDied, match="a worker process ended after"):
            evaluator.evaluate(varied_jobs(8), duration_s=3.0, warmup_s=1.0, progress=progress)
        again = evaluator.evaluate(varied_jobs(2), duration_s=1.0, warmup_s=0.2)
        assert same_results(
            again, BatchEvaluator(ROBOT).evaluate(varied_jobs(2), duration_s=1.0, warmup_s=0.2)
        )
