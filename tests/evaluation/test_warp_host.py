"""The Warp batch's host work over worker processes (`app/evaluation/_warp_pool.py`,
`_warp_host.py`, docs/GPU.md "Where the time goes"): planning writes what `plan_open_loop`
plans; two spawned workers plan and measure to the bit of the calling process; a Warp batch over
them gives the same metrics and traces; its shared memory is gone after a call, a cancelled call
and a failed one; a killed worker is a clear error and the next call starts new ones. The Warp
tests run on Warp's CPU device (the gpu extra, as tests/evaluation/test_warp_executor.py): two small
batches and a cancelled one."""

from __future__ import annotations

import dataclasses
import os
import threading
from pathlib import Path

import mujoco
import numpy as np
import pytest
from mujoco import rollout

from app.evaluation import Cancelled, Job, close_evaluator, same_results
from app.evaluation._open_loop import plan_open_loop
from app.evaluation._processes import WorkerDied
from app.evaluation._warp import WarpEvaluator
from app.evaluation._warp_host import WorldEnds, plan_batch
from app.evaluation._warp_pool import (
    SHM_PREFIX,
    HostArray,
    HostPool,
    initial_arrays,
    plan_worlds,
    varied_robots,
)
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.metrics import Trace
from app.worlds.variations import parse_variation
from gait import GaitParams, Motion
from tests.testing.evaluation_support import assert_same_traces

FRAMES, STEPS = 60, 20  # 1.2 s runs where no Warp steps them
_ROBUST = builtin_presets()["robust"].gait
ROBUST = dataclasses.replace(_ROBUST, tilt=dataclasses.replace(_ROBUST.tilt, enabled=True))
#: open loop and closed, nominal and varied, a start motion, a push that fells its world
JOBS = [
    Job(GaitParams(), Motion(a_p=0.07)),
    Job(GaitParams(), Motion(a_y=0.2), variation=parse_variation("friction=0.5,kp_scale=1.2")),
    Job(
        ROBUST,
        Motion(a_p=0.07, ca=0.1),
        variation=parse_variation("latency_ms=10,gyro_noise_deg_s=0.1,imu_delay_ms=12"),
    ),
    Job(
        GaitParams(),
        Motion(a_r=0.1),
        start_motion=Motion(),
        variation=parse_variation("trunk_mass_scale=1.3,push_n_s=3,push_time_s=0.3"),
    ),
]


@pytest.fixture(scope="module")
def robot():
    return RobotModel.load()


@pytest.fixture(scope="module")
def pool(robot):
    """Two spawned workers, shared by the module's tests that do not kill them."""
    host = HostPool(robot, 2)
    yield host
    host.close()


def our_shared_memory() -> list[str]:
    """The batches' shared memory this process made that still has a name."""
    return sorted(p.name for p in Path("/dev/shm").glob(f"{SHM_PREFIX}{os.getpid()}-*"))


def planned_here(robot, jobs, n_frames=FRAMES):
    """`plan_worlds` in this process: (controls, initial rows, starts, closed-loop rows)."""
    control = np.empty((len(jobs), n_frames * STEPS, robot.model.nu), np.float32)
    initial = initial_arrays(robot.model, len(jobs))
    robots = varied_robots(robot, jobs, {})
    data = mujoco.MjData(robot.model)
    starts, rows = plan_worlds(robots, jobs, n_frames, control, initial, {}, data)
    return control, initial, starts, rows


def test_planning_writes_what_plan_open_loop_plans(robot):
    """Each world's controls are `plan_open_loop`'s, cast to float32; its initial rows are its
    start's; a sensor row comes for the closed-loop world alone, MuJoCo's at its start."""
    control, initial, starts, rows = planned_here(robot, JOBS)
    assert list(rows) == [2]
    for w, (world, job) in enumerate(zip(varied_robots(robot, JOBS, {}), JOBS, strict=True)):
        data = mujoco.MjData(robot.model)
        start, want = plan_open_loop(world, job, FRAMES, data)  # no plan cache: planned anew
        assert want.dtype == np.float64
        assert np.array_equal(control[w], want.astype(np.float32)), w
        assert np.array_equal(starts[w].state, start.state) and starts[w].phase == start.phase
        assert np.array_equal(initial["ctrl"][w], start.ctrl)
        assert np.array_equal(initial["qpos"][w], start.state[1 : 1 + robot.model.nq])
        if w in rows:
            assert np.array_equal(rows[w], data.sensordata)


def test_two_workers_plan_to_the_bit_of_this_process(robot, pool):
    """The controls written by the workers into shared memory, the initial rows, the starts
    and the closed-loop rows they return: equal to planning here. The shared memory is gone
    once released."""
    jobs = JOBS * 3  # 12 worlds: 6 chunks over 2 workers, each planning its cases anew
    control, initial, starts, rows = planned_here(robot, jobs)
    shared = HostArray(control.shape, shared=True)
    try:
        assert our_shared_memory() == [shared.name]
        got_initial = initial_arrays(robot.model, len(jobs))
        got_starts, got_rows = pool.plan(jobs, FRAMES, shared, got_initial)
        assert np.array_equal(shared.array, control)
    finally:
        shared.release()
    assert our_shared_memory() == []
    for name, values in initial.items():
        assert np.array_equal(got_initial[name], values), name
    for a, b in zip(got_starts, starts, strict=True):
        assert np.array_equal(a.state, b.state) and np.array_equal(a.ctrl, b.ctrl)
        assert (a.phase, a.standing_height_m) == (b.phase, b.standing_height_m)
    assert sorted(got_rows) == sorted(rows) == [2, 6, 10]
    assert all(np.array_equal(got_rows[w], rows[w]) for w in rows)


def frame_ends(robot, jobs, control, starts):
    """Each world's frame-end qpos and sensordata (FRAMES, worlds, ...) float32, rolled out by
    MuJoCo from its float32 controls (no push): world 3 made to fall at frame 20 and world 1
    to blow up at frame 40, so that worlds end in different segments."""
    model = robot.model
    qpos = np.empty((FRAMES, len(jobs), model.nq), np.float32)
    sensors = np.empty((FRAMES, len(jobs), model.nsensordata), np.float32)
    ends = np.arange(STEPS - 1, FRAMES * STEPS, STEPS)
    at = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_TIME)
    for w, (world, start) in enumerate(zip(varied_robots(robot, jobs, {}), starts, strict=True)):
        data = mujoco.MjData(world.model)
        states, rows = rollout.rollout(world.model, data, start.state, control[w].astype(float))
        qpos[:, w] = states[0, ends, at : at + model.nq]
        sensors[:, w] = rows[0, ends]
    qpos[20:, 3, 2] = 0.05  # the trunk on the floor
    qpos[40:, 1] = np.nan
    return qpos, sensors


def ended_and_measured(robot, jobs, starts, qpos, sensors, pool):
    """`WorldEnds` over segments of 25 frames: what `ready` handed on after each segment."""
    ends = WorldEnds(robot, jobs, starts, FRAMES, pool)
    try:
        assert (ends.pool is not None) == (pool is not None)  # the frame ends in shared memory
        handed = []
        for first in range(0, FRAMES, 25):
            part = slice(first, min(first + 25, FRAMES))
            ends.qpos[part], ends.sensors[part] = qpos[part], sensors[part]
            ends.test(first, part.stop - first)
            ends.measure(0.3, with_traces=True)
            handed.append(list(ends.ready()))
        return handed, ends.counted.tolist()
    finally:
        ends.release()
        assert our_shared_memory() == []


def test_two_workers_measure_to_the_bit_of_this_process(robot, pool):
    """The same worlds end in the same segments and measure to the same metrics and traces,
    handed on in job order, whether the workers or this process measure them."""
    control, _initial, starts, _rows = planned_here(robot, JOBS)
    qpos, sensors = frame_ends(robot, JOBS, control, starts)
    here, counted = ended_and_measured(robot, JOBS, starts, qpos, sensors, None)
    there, counted_there = ended_and_measured(robot, JOBS, starts, qpos, sensors, pool)
    assert counted == counted_there == [FRAMES, 41, FRAMES, 21]
    assert [[i for i, *_ in seg] for seg in here] == [[], [], [0, 1, 2, 3]]
    assert [[i for i, *_ in seg] for seg in there] == [[], [], [0, 1, 2, 3]]
    got = [m for seg in there for _i, m, _t in seg]
    want = [m for seg in here for _i, m, _t in seg]
    assert same_results(got, want) and got == want
    assert [m["fell"] for m in got] == [False, True, False, True] and got[1]["blew_up"]
    traces: list[Trace] = [t for seg in there for _i, _m, t in seg]
    assert_same_traces(traces, [t for seg in here for _i, _m, t in seg])


def test_a_killed_worker_is_a_clear_error_and_the_next_call_starts_new_ones(robot):
    """Both workers killed (and waited for) before a call: WorkerDied saying so, the call's
    shared memory unlinked; the next call plans on new workers, to the same bits."""
    host = HostPool(robot, 2)
    try:
        first = plan_batch(robot, JOBS, 5, STEPS, host, None)  # two workers up
        want = first.controls.array.copy()
        first.controls.release()
        workers = list(host._executor._processes.values())
        assert len(workers) == 2
        for process in workers:  # the pool may end the other itself once one is gone
            process.kill()
            process.join()
        with pytest.raises(WorkerDied, match=r"a host worker process .* ended while planning"):
            plan_batch(robot, JOBS, 5, STEPS, host, None)
        assert our_shared_memory() == [] and not host.started
        again = plan_batch(robot, JOBS, 5, STEPS, host, None)
        try:
            assert host.started and np.array_equal(again.controls.array, want)
        finally:
            again.controls.release()
    finally:
        host.close()
    assert our_shared_memory() == []


# -- a Warp batch on Warp's CPU device ---------------------------------------------------------

DURATION_S, WARMUP_S = 1.5, 0.5


def warp_call(robot, processes: int, jobs, cancel=None, **options):
    """`jobs` on a WarpEvaluator (`options`) of `processes` host processes, its pool used from
    one world, `cancel` set by the first result: (metrics, traces, the evaluator's pool, our
    shared memory seen at each result)."""
    evaluator = WarpEvaluator(
        robot, device="cpu", host_processes=processes, host_min_worlds=1, **options
    )
    traces: list[Trace] = []
    seen: list[list[str]] = []

    def on_result(_index, _metrics):
        seen.append(our_shared_memory())
        if cancel is not None:
            cancel.set()

    try:
        metrics = evaluator.evaluate(
            jobs,
            duration_s=DURATION_S,
            warmup_s=WARMUP_S,
            traces=traces,
            cancel=cancel,
            on_result=on_result,
        )
        return metrics, traces, evaluator.host_pool, seen
    finally:
        close_evaluator(evaluator)


@pytest.mark.slow
def test_a_warp_batch_over_two_processes_gives_the_bits_of_one(robot):
    """Varied, closed-loop (`robust`'s laws) and pushed worlds: the same metrics and traces to
    the bit with the planning and measuring on two workers as in the calling process; the
    controls and the frame ends were in shared memory during the call and are gone after it;
    closing the evaluator stops its workers."""
    alone, alone_traces, no_pool, _seen = warp_call(robot, 1, JOBS)
    assert no_pool is None
    pooled, pooled_traces, pool, seen = warp_call(robot, 2, JOBS)
    assert same_results(pooled, alone)
    assert_same_traces(pooled_traces, alone_traces)
    assert [m["fell"] for m in pooled] == [False, False, False, True]  # the pushed world fell
    # its controls, qpos and sensors frame ends, while they were used
    assert seen and all(len(names) == 3 for names in seen)
    assert our_shared_memory() == []
    assert pool is not None and not pool.started  # close_evaluator stopped the workers


@pytest.mark.slow
def test_a_cancelled_warp_call_leaves_no_shared_memory(robot):
    """The pushed world falls in the first segment; its result sets `cancel`; Cancelled, and
    the call's shared memory is gone."""
    cancel = threading.Event()
    falls = Job(GaitParams(), Motion(), variation=parse_variation("push_n_s=3,push_time_s=0.02"))
    with pytest.raises(Cancelled, match="after 1 of 2 runs"):
        warp_call(robot, 2, [falls, JOBS[0]], cancel=cancel, segment_frames=5)
    assert our_shared_memory() == []
