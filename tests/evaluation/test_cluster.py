"""Evaluations on a real Dask cluster (docs/DESIGN.md §9): a `dask scheduler` and two
`dask worker` processes on loopback. Results equal the local threads' to the bit; a worker killed
mid-evaluation (SIGKILL) loses no result; a client of another version is refused naming both
versions; a scheduler that goes away is a clear error."""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator

import pytest

from app.evaluation import BatchEvaluator, job_to_dict, same_results
from app.evaluation._chunks import VersionMismatch, evaluate_chunk
from app.evaluation._dask import ClusterError, ClusterEvaluator
from app.robots.model import RobotModel
from app.sim.metrics import Trace
from tests.testing.cluster_support import LoopbackCluster
from tests.testing.evaluation_support import assert_same_traces, varied_jobs

pytestmark = pytest.mark.slow
ROBOT = RobotModel.load()


@pytest.fixture
def cluster() -> Iterator[LoopbackCluster]:
    with LoopbackCluster(workers=2) as c:
        yield c


def connect(cluster: LoopbackCluster, workers: int = 2) -> ClusterEvaluator:
    evaluator = ClusterEvaluator(cluster.address, ROBOT, runs_per_task=2)
    evaluator.client.wait_for_workers(workers, timeout=120)
    return evaluator


def test_two_workers_give_the_local_results_to_the_bit(cluster):
    evaluator = connect(cluster)
    try:
        runs = varied_jobs(8)
        seen: list[int] = []
        remote_traces: list[Trace] = []
        local_traces: list[Trace] = []
        remote = evaluator.evaluate(
            runs,
            duration_s=4.0,
            warmup_s=1.0,
            progress=lambda d, n: seen.append(d),
            traces=remote_traces,
        )
        local = BatchEvaluator(ROBOT, threads=2).evaluate(
            runs, duration_s=4.0, warmup_s=1.0, traces=local_traces
        )
        assert same_results(remote, local)
        # the trunk paths come back too (`bench paper --cluster` draws them), in job order
        assert len(remote_traces) == 8
        assert_same_traces(remote_traces, local_traces)
        assert seen == sorted(seen) and seen[-1] == 8
        assert len({m["forward_cm_s"] for m in remote}) == 8  # eight different runs came back
    finally:
        evaluator.close()


def test_a_killed_worker_loses_no_result(cluster):
    evaluator = connect(cluster)
    runs = varied_jobs(12)
    local = BatchEvaluator(ROBOT, threads=2).evaluate(runs, duration_s=4.0, warmup_s=1.0)
    first_result = threading.Event()
    victim = cluster.workers[0]

    def progress(done: int, _total: int) -> None:
        if not first_result.is_set():
            first_result.set()
            os.kill(victim.pid, signal.SIGKILL)  # mid-evaluation: tasks are queued on it

    try:
        remote = evaluator.evaluate(runs, duration_s=4.0, warmup_s=1.0, progress=progress)
        assert victim.wait(30) == -signal.SIGKILL
        assert same_results(remote, local)
        assert evaluator.workers() == 1
    finally:
        evaluator.close()


def test_a_worker_of_another_version_refuses_naming_both(cluster):
    evaluator = connect(cluster)
    try:
        future = evaluator.client.submit(
            evaluate_chunk, "{}", [job_to_dict(varied_jobs(1)[0])], 1.0, 0.0, "0.0.0-other"
        )
        with pytest.raises(
            VersionMismatch,
            match=r"this worker runs artro-gait-studio .+, the client 0\.0\.0-other",
        ):
            future.result(timeout=120)
    finally:
        evaluator.close()


def test_a_scheduler_that_goes_away_is_a_clear_error(cluster):
    evaluator = connect(cluster)
    try:
        cluster.scheduler.kill()
        cluster.scheduler.wait(30)
        with pytest.raises(ClusterError, match="went away"):
            evaluator.evaluate(varied_jobs(2), duration_s=2.0, warmup_s=0.0)
    finally:
        evaluator.close()


def test_no_scheduler_is_a_clear_error():
    with pytest.raises(ClusterError, match=r"no Dask scheduler answers at tcp://127\.0\.0\.1:9"):
        ClusterEvaluator("tcp://127.0.0.1:9", ROBOT)
