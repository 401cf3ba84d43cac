"""The contract of every executor (the `Evaluator` protocol, docs/DESIGN.md §9), one suite run on
each: results in job order, `on_result` once a job and `progress` up to the total, traces when
asked, a fall reported, a cancel before the call and during it. A new backend gets the suite by a
line in EXECUTORS; its own file tests what only it does (tests/evaluation/test_batch.py,
test_processes.py, test_cluster.py, test_warp_executor.py)."""

from __future__ import annotations

import contextlib
import re
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import pytest

from app.evaluation import (
    Cancelled,
    Evaluator,
    Job,
    close_evaluator,
    evaluator_for,
    same_results,
)
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.metrics import RunMetrics, Trace
from app.worlds.variations import parse_variation
from gait import Motion
from tests.testing.cluster_support import LoopbackCluster
from tests.testing.evaluation_support import assert_same_traces

ROBOT = RobotModel.load()
TUNED = builtin_presets()["tuned"].gait
DURATION_S, WARMUP_S, FRAME_S = 1.5, 0.5, 0.02
#: four walks that differ in every motion metric (forward, back, turning, sideways), each on its
#: own floor, so a result out of order shows
WALKS = [
    Job(TUNED, motion, variation=parse_variation(f"friction={friction}"))
    for motion, friction in (
        (Motion(a_p=0.07), 0.6),
        (Motion(a_p=-0.07), 0.7),
        (Motion(a_y=0.2), 0.8),
        (Motion(a_r=0.1), 0.9),
    )
]
#: pushed over in its first frames (it falls at about 0.1 s, in the first segment of any executor)
FALLS = Job(TUNED, Motion(), variation=parse_variation("push_n_s=3,push_time_s=0.02"))
JOBS = [*WALKS, FALLS]


@contextlib.contextmanager
def threads() -> Iterator[Evaluator]:
    yield evaluator_for(ROBOT, threads=2)


@contextlib.contextmanager
def processes() -> Iterator[Evaluator]:
    evaluator = evaluator_for(ROBOT, processes=2)
    try:
        yield evaluator
    finally:
        close_evaluator(evaluator)


@contextlib.contextmanager
def dask() -> Iterator[Evaluator]:
    """Two `dask worker` processes on loopback (tests/testing/cluster_support.py), tasks of two
    runs (a call of five is three tasks, so a cancel finds runs under way)."""
    with LoopbackCluster(workers=2) as cluster:
        evaluator = evaluator_for(ROBOT, cluster=cluster.address, wait_workers_s=120)
        try:
            evaluator.client.wait_for_workers(2, timeout=120)
            evaluator.runs_per_task = 2
            yield evaluator
        finally:
            close_evaluator(evaluator)


@contextlib.contextmanager
def warp_cpu() -> Iterator[Evaluator]:
    evaluator = evaluator_for(ROBOT, backend="warp", device="cpu", notice=None)
    try:
        yield evaluator
    finally:
        close_evaluator(evaluator)


@dataclass(frozen=True)
class Executor:
    open: Callable[[], contextlib.AbstractContextManager[Evaluator]]
    #: its results and traces equal the threads' to the bit (else close: float32 physics)
    exact: bool


#: every executor that runs here; the slow ones start processes or compile Warp's kernels
EXECUTORS = [
    pytest.param(Executor(threads, exact=True), id="threads"),
    pytest.param(Executor(processes, exact=True), id="processes", marks=pytest.mark.slow),
    pytest.param(Executor(dask, exact=True), id="dask", marks=pytest.mark.slow),
    pytest.param(Executor(warp_cpu, exact=False), id="warp-cpu", marks=pytest.mark.slow),
]


@pytest.fixture(scope="module", params=EXECUTORS)
def executor(request) -> Iterator[tuple[Evaluator, bool]]:
    """(the evaluator, whether it is exact), opened once for the module's tests."""
    with request.param.open() as evaluator:
        yield evaluator, request.param.exact


@pytest.fixture(scope="module")
def reference() -> tuple[list[RunMetrics], list[Trace]]:
    """The local threads' metrics and traces of JOBS."""
    traces: list[Trace] = []
    metrics = evaluator_for(ROBOT, threads=2).evaluate(
        JOBS, duration_s=DURATION_S, warmup_s=WARMUP_S, traces=traces
    )
    return metrics, traces


@dataclass
class Call:
    """One call of JOBS on an executor with every callback and traces, and what came back."""

    results: list[RunMetrics]
    traces: list[Trace]
    #: (job index, metrics) as `on_result` was called
    seen: list[tuple[int, RunMetrics]]
    #: (done, total) as `progress` was called
    progress: list[tuple[int, int]]


@pytest.fixture(scope="module")
def called(executor) -> Call:
    """JOBS run once on the executor (each call of Warp's CPU device takes a while)."""
    evaluator, _exact = executor
    call = Call([], [], [], [])
    call.results = evaluator.evaluate(
        JOBS,
        duration_s=DURATION_S,
        warmup_s=WARMUP_S,
        traces=call.traces,
        progress=lambda done, total: call.progress.append((done, total)),
        on_result=lambda index, metrics: call.seen.append((index, metrics)),
    )
    return call


def motion_of(metrics: RunMetrics) -> np.ndarray:
    return np.array([metrics[k] for k in ("forward_cm_s", "lateral_cm_s", "turn_deg_s")])


def end_of(trace: Trace) -> np.ndarray:
    return np.array([trace.x_m[-1], trace.y_m[-1]])


def nearest(found: list[np.ndarray], wanted: list[np.ndarray]) -> list[int]:
    """For each of `found`, the index of the nearest of `wanted`."""
    return [int(np.argmin([np.linalg.norm(f - w) for w in wanted])) for f in found]


def test_results_come_in_job_order(executor, called, reference):
    """To the bit for an exact executor; else each walk nearest the same job's walk on the
    threads, and the same run falls."""
    _evaluator, exact = executor
    expected, _traces = reference
    assert len(called.results) == len(JOBS)
    if exact:
        assert same_results(called.results, expected)
    walks = len(WALKS)
    assert nearest(
        [motion_of(m) for m in called.results[:walks]], [motion_of(m) for m in expected[:walks]]
    ) == list(range(walks))
    assert (
        [m["fell"] for m in called.results]
        == [m["fell"] for m in expected]
        == [
            *[False] * walks,
            True,
        ]
    )


def test_on_result_once_a_job_with_its_result_and_progress_up_to_the_total(called):
    n = len(JOBS)
    assert sorted(index for index, _m in called.seen) == list(range(n))
    assert all(metrics == called.results[index] for index, metrics in called.seen)
    dones = [done for done, _total in called.progress]
    assert {total for _done, total in called.progress} == {n}
    assert dones == sorted(dones) and dones[-1] == n


def test_traces_come_when_asked_one_a_job_in_job_order(executor, called, reference):
    _evaluator, exact = executor
    _expected, expected_traces = reference
    assert len(called.traces) == len(JOBS)
    for metrics, trace in zip(called.results, called.traces, strict=True):
        # a sample a frame, to the run's end (its fall)
        assert len(trace.t_s) == round(metrics["sim_s"] / FRAME_S)
        assert np.all(np.diff(trace.t_s) > 0)
        assert trace.t_s[-1] == pytest.approx(metrics["sim_s"], abs=FRAME_S)
    if exact:
        assert_same_traces(called.traces, expected_traces)
    assert nearest([end_of(t) for t in called.traces], [end_of(t) for t in expected_traces]) == (
        list(range(len(JOBS)))
    )


def test_a_run_that_falls_says_so_and_when_and_the_others_walk_on(called):
    *walked, fallen = called.results
    assert fallen["fell"] and 0 < fallen["fall_time_s"] < 0.5
    assert fallen["sim_s"] == pytest.approx(fallen["fall_time_s"], abs=FRAME_S)
    for metrics in walked:
        assert not metrics["fell"] and metrics.get("fall_time_s") is None
        assert metrics["sim_s"] == pytest.approx(DURATION_S)


def test_a_cancel_set_before_the_call_runs_nothing(executor):
    evaluator, _exact = executor
    cancel, calls = threading.Event(), []
    cancel.set()
    with pytest.raises(Cancelled, match="cancelled after 0 of 2 runs"):
        evaluator.evaluate(
            WALKS[:2],
            duration_s=DURATION_S,
            warmup_s=WARMUP_S,
            cancel=cancel,
            progress=lambda done, total: calls.append(("progress", done, total)),
            on_result=lambda index, _m: calls.append(("result", index)),
        )
    assert calls == []


def test_a_cancel_during_the_call_stops_it_and_the_evaluator_runs_on(executor):
    """The fallen run's result sets `cancel` while the walks are under way (55 frames: past the
    first segment of Warp's, in which the run falls): Cancelled, saying how many runs finished
    (those `on_result` saw); the next call (short, without traces) runs as if none had been."""
    evaluator, exact = executor
    jobs = [FALLS, *WALKS]
    cancel, seen = threading.Event(), []

    def on_result(index: int, _metrics: RunMetrics) -> None:
        seen.append(index)
        cancel.set()

    with pytest.raises(Cancelled) as raised:
        evaluator.evaluate(
            jobs, duration_s=1.1, warmup_s=WARMUP_S, cancel=cancel, on_result=on_result
        )
    said = re.fullmatch(rf"cancelled after (\d+) of {len(jobs)} runs", str(raised.value))
    assert said is not None, str(raised.value)
    assert 1 <= int(said.group(1)) == len(seen) < len(jobs) and len(set(seen)) == len(seen)
    again = evaluator.evaluate(WALKS[:1], duration_s=0.4, warmup_s=0.1)
    assert len(again) == 1 and not again[0]["fell"]
    if exact:
        alone = evaluator_for(ROBOT, threads=1).evaluate(WALKS[:1], duration_s=0.4, warmup_s=0.1)
        assert same_results(again, alone)
