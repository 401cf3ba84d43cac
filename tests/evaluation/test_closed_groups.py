"""Closed-loop runs stepped in lockstep groups (docs/DESIGN.md §9, decision 0050): sensors, laws,
the frame's plan and the servo paths of many runs at once give each run the bits it gets alone;
the lanes cut the jobs into groups of one walk; a cancel stops a group between frames."""

from __future__ import annotations

import dataclasses
import itertools
import math
import threading

import numpy as np
import pytest

from app.evaluation import BatchEvaluator, Cancelled, Job, _frames
from app.evaluation._groups import GROUP_RUNS
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.planning import MotionOfRuns, frame_steps, plan_frame_of_runs, plan_frames
from app.worlds.sampling import VariationRanges, sample
from app.worlds.servo_path import FramePaths, ServoPath, ServoPaths, latency_steps
from app.worlds.variations import NOMINAL, parse_variation
from gait import Motion, feedback
from gait.params import LAW_GROUPS

ROBOT = RobotModel.load()
ROBUST = builtin_presets()["robust"].gait
EVERY_LAW = dataclasses.replace(
    ROBUST, **{g: dataclasses.replace(getattr(ROBUST, g), enabled=True) for g in LAW_GROUPS}
)
STRIP = ("wall_s", "rtf")  # a group's wall time is shared out among its runs


def bits(a) -> bytes:
    return np.ascontiguousarray(a).tobytes()


@pytest.mark.parametrize("params", [ROBUST, EVERY_LAW], ids=["robust", "every law"])
def test_runs_stepped_in_one_group_equal_each_run_alone_to_the_bit(params):
    worlds = [
        NOMINAL,
        parse_variation("push_n_s=0.3,push_time_s=1.01,push_direction_deg=200,kp_scale=0.9"),
        parse_variation("push_n_s=2.5,push_time_s=0.5,push_direction_deg=0"),  # falls
        *sample(VariationRanges(), 2, seed=7),
    ]
    motions = [Motion(a_p=0.07, a_y=0.1), Motion(a_r=-0.05, ca=0.1)]
    jobs = [Job(params, m, variation=v) for v in worlds for m in motions]
    jobs.append(Job(params, Motion(a_p=0.07), start_motion=Motion(), variation=worlds[3]))
    evaluator = BatchEvaluator(ROBOT, threads=1)
    assert len(evaluator._tasks(jobs)) == 2  # the walks in one group, the ramp in its own
    traces: list = []
    together = evaluator.evaluate(jobs, duration_s=2.0, warmup_s=0.5, traces=traces)
    assert [m["fell"] for m in together].count(True) >= 2  # the shove throws both walks
    for job, got, trace in zip(jobs, together, traces, strict=True):
        alone: list = []
        (want,) = evaluator.evaluate([job], duration_s=2.0, warmup_s=0.5, traces=alone)
        assert {k: v for k, v in got.items() if k not in STRIP} == {
            k: v for k, v in want.items() if k not in STRIP
        }
        assert trace.x_m == alone[0].x_m and bits(trace.gyro_rad_s) == bits(alone[0].gyro_rad_s)


def test_the_lanes_cut_the_jobs_into_groups_of_one_walk():
    ramp = Job(ROBUST, Motion(a_p=0.07), start_motion=Motion())
    other_ramp = Job(ROBUST, Motion(a_p=-0.05), start_motion=Motion())
    jobs = [Job(ROBUST, Motion(a_p=0.07, ca=c), variation=NOMINAL) for c in (-0.1, 0.0, 0.1)]
    jobs += [ramp, other_ramp, Job(builtin_presets()["tuned"].gait, Motion(a_p=0.07))]
    jobs += [Job(EVERY_LAW, Motion())] * (2 * GROUP_RUNS + 1)
    tasks = BatchEvaluator(ROBOT, threads=2)._tasks(jobs)
    assert sorted(i for task in tasks for i in task) == list(range(len(jobs)))
    assert [0, 1, 2] not in tasks and [[0, 1], [2]] == [t for t in tasks if t[0] < 3]  # 2 lanes
    assert [3] in tasks and [4] in tasks and [5] in tasks  # ramps apart, open loop alone
    big = [t for t in tasks if t[0] >= 6]
    # 2 GROUP_RUNS + 1 runs: more than two groups, so four (the lanes get as many each)
    assert len(big) == 4 and all(len(t) <= GROUP_RUNS for t in big)
    tasks = BatchEvaluator(ROBOT, threads=2)._tasks(jobs[:6] + jobs[6 : 6 + GROUP_RUNS])
    assert [len(t) for t in tasks if t[0] >= 6] == [GROUP_RUNS // 2] * 2  # a group each lane


def test_a_cancel_stops_a_group_between_frames(monkeypatch):
    cancel = threading.Event()
    planned = []
    real_plan = _frames.ClosedLoops.plan

    def plan(self, frame, datas):
        planned.append(frame)
        if frame == 5:
            cancel.set()
        return real_plan(self, frame, datas)

    monkeypatch.setattr(_frames.ClosedLoops, "plan", plan)
    jobs = [Job(ROBUST, Motion(a_p=0.07), variation=v) for v in sample(VariationRanges(), 3, 1)]
    with pytest.raises(Cancelled):
        BatchEvaluator(ROBOT, threads=1).evaluate(jobs, duration_s=2.0, cancel=cancel)
    assert planned == list(range(6))  # of 100 frames


def test_a_group_shows_its_progress_while_it_steps(monkeypatch):
    """Its runs end together; meanwhile the frames it has stepped show, in whole runs."""
    halfway, seen = threading.Event(), []
    real_plan = _frames.ClosedLoops.plan

    def plan(self, frame, datas):
        if frame == 60 and not halfway.wait(timeout=60):  # of 100: 4 x 60 frames, 2 runs' worth
            raise AssertionError("no progress was shown while the group stepped")
        return real_plan(self, frame, datas)

    def progress(done, total):
        seen.append(done)
        halfway.set()

    monkeypatch.setattr(_frames.ClosedLoops, "plan", plan)
    jobs = [Job(ROBUST, Motion(a_p=0.07), variation=v) for v in sample(VariationRanges(), 4, 2)]
    BatchEvaluator(ROBOT, threads=1).evaluate(jobs, duration_s=2.0, progress=progress)
    assert seen[0] <= 2 and seen[-1] == 4 and seen == sorted(set(seen))


def test_the_laws_of_many_runs_equal_each_run_stepped_alone():
    rng = np.random.default_rng(1)
    positions = ROBOT.fsr_positions_m.astype(np.float32)
    motions = MotionOfRuns.of([Motion(a_p=0.07), Motion(a_r=0.05, ca=0.1), Motion(a_y=-0.2)])
    states, alone = feedback.States.fresh(3), [feedback.State()] * 3
    for frame in range(30):
        gyro = (rng.normal(size=(3, 3)) * 0.5).astype(np.float32)
        accel = (rng.normal(size=(3, 3)) + np.array([0.0, 0.0, 9.8])).astype(np.float32)
        if frame < 2:
            accel[0] *= 0.1  # no estimate yet for run 0
        fsr = (np.abs(rng.normal(size=(3, 2, 4))) * [[[3.0]], [[0.0]], [[0.2]]]).astype(np.float32)
        phase = rng.uniform(-np.pi, np.pi, size=3)  # each run's own (the timing law's)
        states, outs = feedback.step_many(
            EVERY_LAW, states, gyro, accel, fsr, motions, positions, 0.02, phase_rad=phase
        )
        for k in range(3):
            motion = Motion(*(float(field[k]) for field in motions))
            reading = feedback.Reading(gyro[k], accel[k], fsr[k])
            alone[k], want = feedback.step(
                EVERY_LAW, alone[k], reading, motion, positions, 0.02, phase_rad=float(phase[k])
            )
            got = outs.run(k)
            assert all(
                bits(getattr(got, f.name)) == bits(getattr(want, f.name))
                for f in dataclasses.fields(want)
            ), frame
            assert all(
                bits(getattr(states.run(k), f.name)) == bits(getattr(alone[k], f.name))
                for f in dataclasses.fields(alone[k])
            ), frame
    assert outs.run(1).support == -1  # the unloaded run has no support foot


def test_servo_paths_equal_each_runs_servo_path_chunk_by_chunk():
    rng = np.random.default_rng(3)
    worlds = [NOMINAL, *sample(VariationRanges(), 6, seed=5)]
    start = rng.normal(size=(len(worlds), 12)) * 0.3
    alone = [ServoPath(v, 0.001, start[k]) for k, v in enumerate(worlds)]
    together = ServoPaths(worlds, 0.001, start)
    assert together.delay_steps.max() > 20  # a latency longer than a frame
    sent = start.copy()
    for n in (20, 20, 7, 1, 33, 20):
        switch = rng.integers(0, n + 1, size=sent.shape)
        new = sent + rng.normal(size=sent.shape) * rng.choice([0.001, 0.02], size=(len(sent), 1))
        later = np.arange(n)[None, :, None] >= switch[:, None]
        chunk = np.where(later, new[:, None], sent[:, None])
        sent = np.where(switch < n, new, sent)
        got = together(chunk)
        for k, path in enumerate(alone):
            assert bits(got[k]) == bits(path(chunk[k]))


def by_definition(variation, initial: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The servo path of one run as DESIGN §8 defines it, step by step in its order: latency,
    then calibration, then the play (which `ServoPaths` runs before the delay)."""
    delay = latency_steps(variation.latency_ms, 0.001)
    offset = np.radians(np.array(variation.calibration_deg, dtype=np.float64))
    calibrated = bool(np.any(offset != 0.0))
    half = 0.5 * math.radians(variation.deadband_deg + variation.backlash_deg)
    out = initial + offset if calibrated else initial.copy()
    got = np.empty_like(x)
    for t in range(len(x)):
        command = x[t - delay] if t >= delay else initial
        command = command + offset if calibrated else command
        out = np.minimum(np.maximum(out, command - half), command + half) if half else command
        got[t] = out
    return got


@pytest.mark.parametrize("mixed", [True, False], ids=["mixed", "all varied"])
def test_servo_paths_from_switches_equal_the_path_of_every_step_to_the_bit(mixed):
    rng = np.random.default_rng(8)
    worlds = list(sample(VariationRanges(), 6, seed=9))  # each with play and calibration
    if mixed:
        worlds += [NOMINAL, parse_variation("deadband_deg=1")]
    start = rng.normal(size=(len(worlds), 12)) * 0.3
    steps = 20
    switches, stepped = FramePaths(worlds, 0.001, start, steps), ServoPaths(worlds, 0.001, start)
    assert switches.delay_steps.max() > steps  # a latency longer than a frame
    sent, frames, inputs = start.copy(), [], []
    for _frame in range(14):
        setpoint = sent + rng.normal(size=sent.shape) * rng.choice([0.001, 0.03], (len(sent), 1))
        substep = rng.integers(0, steps + 1, size=sent.shape)
        substep[rng.random(sent.shape) < 0.2] = rng.choice([0, steps])  # the edges
        step_level = np.where(
            np.arange(steps)[None, :, None] >= substep[:, None], setpoint[:, None], sent[:, None]
        )
        got = np.full((len(worlds), steps, 12), np.nan)
        switches(sent, setpoint, substep, got)
        assert bits(got) == bits(stepped(step_level))
        frames.append(got)
        inputs.append(step_level)
        sent = setpoint
    every_step, fed = np.concatenate(frames, axis=1), np.concatenate(inputs, axis=1)
    for k, world in enumerate(worlds):
        assert bits(every_step[k]) == bits(by_definition(world, start[k], fed[k]))


def test_frame_paths_go_on_with_the_runs_they_keep():
    rng = np.random.default_rng(12)
    worlds = [*sample(VariationRanges(), 5, seed=13), NOMINAL]
    start = rng.normal(size=(len(worlds), 12)) * 0.3
    kept = np.array([True, False, True, True, False, True])
    group = FramePaths(worlds, 0.001, start, 20)
    alone = FramePaths([w for w, k in zip(worlds, kept, strict=True) if k], 0.001, start[kept], 20)
    sent, runs = start.copy(), np.ones(len(worlds), dtype=bool)  # the runs `group` steps
    for frame in range(6):
        setpoint = sent + rng.normal(size=sent.shape) * 0.02
        substep = rng.integers(0, 21, size=sent.shape)
        got = np.empty((int(runs.sum()), 20, 12))
        group(sent[runs], setpoint[runs], substep[runs], got)
        want = np.empty((int(kept.sum()), 20, 12))
        alone(sent[kept], setpoint[kept], substep[kept], want)
        assert bits(got[kept[runs]]) == bits(want), frame
        if frame == 2:  # the others fell: the group goes on with the kept runs
            group.keep(kept)
            runs = kept
        sent = setpoint


def test_a_frame_of_runs_is_each_runs_one_frame_plan():
    hardware, steps = ROBOT.hardware(), frame_steps(ROBOT.model)
    timestep_s = float(ROBOT.model.opt.timestep)
    rng = np.random.default_rng(4)
    delta = (rng.normal(size=(4, 12)) * 0.02).astype(np.float32)
    a_y_delta = np.array([0.0, 0.05, -0.3, 0.0], dtype=np.float32)  # -0.3 beyond a_y's range
    each = [Motion(a_p=0.07), Motion(a_r=0.05), Motion(a_p=-0.05, ca=0.1), Motion(a_y=-0.25)]
    own_phases = np.array([1.3, -0.4, 3.0, 1.3])  # each run's clock (the timing law's)
    for motion, phase0 in itertools.product(
        (Motion(a_p=0.07, ca=-0.1), MotionOfRuns.of(each)), (1.3, own_phases)
    ):
        runs = plan_frame_of_runs(
            ROBUST, motion, hardware, phase0, steps, timestep_s, motion_now=motion, frame0=7,
            geometry=ROBOT.geometry, joint_delta_rad=delta, a_y_delta=a_y_delta,
        )  # fmt: skip
        for k in range(4):
            own = motion if isinstance(motion, Motion) else each[k]
            phase = float(np.broadcast_to(phase0, 4)[k])
            one = plan_frames(
                ROBUST, own, hardware, phase, 1, steps, timestep_s, frame0=7,
                geometry=ROBOT.geometry, joint_delta_rad=delta[k], a_y_delta=float(a_y_delta[k]),
            )  # fmt: skip
            for name in ("setpoint", "substep"):
                assert bits(getattr(runs, name)[k]) == bits(getattr(one, name)[0]), (k, name)
            assert bits(np.broadcast_to(runs.phase, 4)[k]) == bits(one.phase[0])
    with pytest.raises(ValueError, match="do not ramp"):
        plan_frame_of_runs(
            ROBUST, MotionOfRuns.of(each), hardware, 1.3, steps, timestep_s, motion_now=Motion(),
            frame0=0, geometry=ROBOT.geometry, joint_delta_rad=delta, a_y_delta=a_y_delta,
        )  # fmt: skip
    with pytest.raises(ValueError, match="motion_now must be a Motion"):
        plan_frame_of_runs(
            ROBUST, Motion(), hardware, 1.3, steps, timestep_s, motion_now=MotionOfRuns.of(each),
            frame0=0, geometry=ROBOT.geometry, joint_delta_rad=delta, a_y_delta=a_y_delta,
        )  # fmt: skip
