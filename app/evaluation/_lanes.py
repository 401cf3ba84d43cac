"""Batch evaluation of parameter sets with `mujoco.rollout`, metrics identical to `artro run`.

The open-loop gait is planned up front and rolled out in C, a run at a time in a lane per core,
with the frame loop's timing, fall test and metrics: `BatchEvaluator` (docs/DESIGN.md §6, §9).
"""

from __future__ import annotations

import math
import os
import queue
import threading
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor, wait

import mujoco
import numpy as np
from mujoco import rollout

from app.evaluation._api import Cancelled, Job, OnResult, Progress
from app.evaluation._frames import Push, Start, start_at_rest, step_by_hand
from app.evaluation._groups import GroupEnds, Tally, lane_tasks, roll_out_group
from app.evaluation._lane_kit import LaneKit, check_rollout_arrays
from app.evaluation._measure import FrameEnds, end_checks, measure_frames
from app.evaluation._open_loop import plan_open_loop
from app.robots.model import RobotModel
from app.sim.metrics import RunMetrics, Trace
from app.sim.planning import FRAME_S, frame_steps
from app.worlds.variations import Variation, varied_robot
from gait import feedback

#: a run rolls out this many frames per `rollout` call and stops after the call it fell in
SEGMENT_FRAMES = 50
POLL_S = 0.2  # how often a waiting `evaluate` shows a group's progress and looks at its cancel
VARIED_CACHE = 64  # varied models kept (a robust study reuses each variation for every case)


class BatchEvaluator:
    """Evaluates many (parameters, motion) runs in parallel on one model.

    The gait is open loop: a run's servo set-points are a pure function of the parameters and time.
    So the whole run is planned up front (`plan_frames`, vectorised), turned into the control of
    every physics step -- each servo switching to its new set-point at its pulse's falling edge,
    exactly as `FrameLoop` does (`control_sequence`) -- and rolled out by `mujoco.rollout` in C.
    The states are sampled once per 20 ms frame, in whole arrays (the distance between the feet
    from the model's sole-position sensors, no Python per frame), and measured with the same fall
    test and the same `compute_metrics` as `artro run`; a test checks both give the same numbers,
    to the bit.

    Runs go to `threads` lanes: each lane plans a run, rolls it out (one MuJoCo thread, the GIL
    released; 1 s per call, stopping after the call it fell in), measures it, and takes the
    next, so no lane waits for another at a call's end (docs/DESIGN.md §9). A run of a varied
    robot rolls out on its varied model.

    Args:
        robot: the model (default: the built-in one).
        threads: lanes, each one MuJoCo thread (default: the CPU count, at most 8).
    """

    def __init__(self, robot: RobotModel | None = None, threads: int | None = None) -> None:
        self.robot = robot or RobotModel.load()
        self.model = self.robot.model
        self.threads = threads or min(os.cpu_count() or 1, 8)
        self.steps_per_frame = frame_steps(self.model)  # variations keep the timestep
        #: one lane's kit at a time: its MjData and its kept rollout output arrays (a run's
        #: states, reused run after run rather than fresh arrays to page-fault, decision 0027)
        self._kits: queue.SimpleQueue[LaneKit] = queue.SimpleQueue()
        for _ in range(self.threads):
            self._kits.put(LaneKit(self.model))
        self._lock = threading.Lock()  # guards the varied cache, stage_s, frames_rolled
        self._varied_cache: dict[Variation, RobotModel] = {}
        #: seconds spent per stage since creation, summed over the lanes (bench/bench_batch.py
        #: reports them)
        self.stage_s = {"plan": 0.0, "rollout": 0.0, "measure": 0.0}
        #: frames rolled out since creation (a run that falls stops at the end of its call)
        self.frames_rolled = 0

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
        """Metrics of each job, in order, as `artro run` would print them (wall time aside).
        Pass a list as `traces` to also get each run's trunk trace (one sample per frame).

        Args:
            jobs: the runs; each starts standing at the frame loop's start phase.
            duration_s: simulated time per run in s (a fall ends a run early, `fell` says so).
            warmup_s: the first seconds, left out of the motion metrics.
            progress: called with (runs done, runs in all) after each run, in job order, and
                while a group of closed-loop runs steps, with the frames it has stepped in
                whole runs' worth (its runs end together); never twice with one count.
            traces: if given, each run's `Trace` is appended to it, in job order.
            cancel: when set, no further run starts (open-loop runs under way finish, a group
                of closed-loop runs stops at its next frame): Cancelled.
            on_result: called with (job index, metrics) as each run's result is known, in job
                order, so a caller can keep what finished before a crash or a cancel.

        The callbacks are called in the calling thread.
        """
        n_frames = math.ceil(duration_s / FRAME_S - 1e-9)
        results: list[RunMetrics] = []
        if not jobs:
            return results
        tasks = self._tasks(jobs)
        tally = Tally(len(tasks), n_frames, cancel)
        shown = 0

        def show(done: int) -> None:
            nonlocal shown
            if progress is not None and done > shown:
                shown = done
                progress(done, len(jobs))

        def worth() -> int:  # the frames stepped, in runs, short of the last until it is in
            return min(tally.runs_worth(), len(jobs) - 1)

        pool = ThreadPoolExecutor(max_workers=min(self.threads, len(tasks)))
        try:
            futures = [
                pool.submit(self._run_task, [jobs[i] for i in task], n_frames, warmup_s, tally, t)
                for t, task in enumerate(tasks)
            ]
            where = {i: (t, k) for t, task in enumerate(tasks) for k, i in enumerate(task)}
            for i in range(len(jobs)):
                t, k = where[i]
                while True:  # a group's runs end together: its frames so far show it going
                    if cancel is not None and cancel.is_set():
                        raise Cancelled(f"cancelled after {len(results)} of {len(jobs)} runs")
                    if wait([futures[t]], timeout=POLL_S).done:
                        break
                    show(worth())
                metrics, trace = futures[t].result()[k]
                if on_result is not None:
                    on_result(len(results), metrics)
                results.append(metrics)
                if traces is not None:
                    traces.append(trace)
                show(len(jobs) if len(results) == len(jobs) else max(len(results), worth()))
        finally:
            tally.stop.set()  # a group under way ends at its next frame
            pool.shutdown(wait=True, cancel_futures=True)
        return results

    def _tasks(self, jobs: Sequence[Job]) -> list[list[int]]:
        """The jobs' indices as the lanes take them (`lane_tasks`): an open-loop run alone."""
        return lane_tasks(jobs, self.threads)

    def _run_task(
        self, jobs: list[Job], n_frames: int, warmup_s: float, tally: Tally, task: int
    ) -> list[tuple[RunMetrics, Trace]]:
        if feedback.any_law_on(jobs[0].params):
            return self._run_group(jobs, n_frames, warmup_s, tally, task)
        done = [self._run(job, n_frames, warmup_s) for job in jobs]
        tally.frames[task] = len(jobs) * n_frames
        return done

    def _run(self, job: Job, n_frames: int, warmup_s: float) -> tuple[RunMetrics, Trace]:
        """One open-loop run in a lane: plan (standing it in the lane's MjData), roll out into
        the lane's kept arrays, measure."""
        kit = self._kits.get()
        try:
            t0 = time.perf_counter()
            robot, start, control = self._plan_run(job, n_frames, kit.data)
            t1 = time.perf_counter()
            state_out, sensor_out = kit.output(control.shape[0])
            frames = self._roll_out(
                kit.rollout, robot, kit.data, start, control, state_out, sensor_out,
                Push(robot, job),
            )  # fmt: skip
            t2 = time.perf_counter()
            metrics, trace = self._measure(
                state_out[0], sensor_out[0], start, job, frames, warmup_s
            )
        finally:
            self._kits.put(kit)
        t3 = time.perf_counter()
        metrics["wall_s"] = t2 - t1
        metrics["rtf"] = metrics["sim_s"] / metrics["wall_s"]
        with self._lock:
            self.stage_s["plan"] += t1 - t0
            self.stage_s["rollout"] += t2 - t1
            self.stage_s["measure"] += t3 - t2
            self.frames_rolled += frames
        return metrics, trace

    def _run_group(
        self, jobs: list[Job], n_frames: int, warmup_s: float, tally: Tally, task: int
    ) -> list[tuple[RunMetrics, Trace]]:
        """Closed-loop runs of one walk in a lane, in lockstep (`ClosedLoops`): per frame the
        sensors, laws and plans of all at once, then each run's frame by its own `rollout` call
        from its own state and warm start (its push's frame stepped by hand); a run that falls
        or blows up leaves the group. Only each frame's last state and sensor row are kept."""
        kit = self._kits.get()
        try:
            t0 = time.perf_counter()
            datas = kit.datas(len(jobs))
            standing = [self._standing(job, data) for job, data in zip(jobs, datas, strict=True)]
            robots = [robot for robot, _start in standing]
            starts = [start for _robot, start in standing]
            t1 = time.perf_counter()
            ends = GroupEnds(len(jobs), n_frames, starts[0].state.size, self.model.nsensordata)
            frames = roll_out_group(
                robots, datas, jobs, starts, n_frames, self.steps_per_frame, ends, kit.rollout,
                tally, task,
            )  # fmt: skip
            t2 = time.perf_counter()
            done = []
            for k, job in enumerate(jobs):
                rows = np.arange(1, frames[k] + 1) * self.steps_per_frame - 1
                start = starts[k]
                checks = end_checks(
                    self.model, ends.states[k, : frames[k]], rows, start.state[0],
                    start.standing_height_m,
                )  # fmt: skip
                done.append(
                    measure_frames(
                        self.robot, job, checks.qpos, ends.sensors[k, : frames[k]].copy(),
                        checks.bad, checks.down, warmup_s,
                    )
                )  # fmt: skip
        finally:
            self._kits.put(kit)
        t3 = time.perf_counter()
        for metrics, _trace in done:
            metrics["wall_s"] = (t2 - t1) / len(jobs)  # the run's share of the group's
            metrics["rtf"] = metrics["sim_s"] / metrics["wall_s"]
        with self._lock:
            self.stage_s["plan"] += t1 - t0
            self.stage_s["rollout"] += t2 - t1
            self.stage_s["measure"] += t3 - t2
            self.frames_rolled += int(frames.sum())
        return done

    def _roll_out(
        self,
        runner: rollout.Rollout,
        robot: RobotModel,
        data: mujoco.MjData,
        start: Start,
        control: np.ndarray,
        state_out: np.ndarray,
        sensor_out: np.ndarray,
        push: Push | None = None,
    ) -> int:
        """Roll the run out in calls of `SEGMENT_FRAMES` frames, each from the last one's state
        and solver warm start (the same bits as one call), until a call's frames show a fall or
        a blow-up: the frames after it are never measured. The frame with a push is stepped by
        hand (`step_by_hand`). Returns the frames rolled out."""
        model, steps = robot.model, self.steps_per_frame
        n_frames = control.shape[0] // steps
        check_rollout_arrays(model, start, control, state_out, sensor_out)
        done, initial, warmstart = 0, start.state[None, :], None
        push_frame = push.step // steps if push is not None and push.step >= 0 else -1
        while done < n_frames:
            frames = min(SEGMENT_FRAMES, n_frames - done)
            if done == push_frame:
                frames = 1  # by hand
            elif done < push_frame < done + frames:
                frames = push_frame - done  # up to the push's frame
            part = slice(done * steps, (done + frames) * steps)
            if push is not None and done == push_frame:
                step_by_hand(
                    robot, data, control[part], part.start, push, state_out[0, part],
                    sensor_out[0, part],
                )  # fmt: skip
            else:
                runner.rollout(
                    [model], [data], initial, control[None, part], initial_warmstart=warmstart,
                    state=state_out[:, part], sensordata=sensor_out[:, part],
                    nstep=frames * steps, skip_checks=True,  # checked once above: ~20 us less
                )  # fmt: skip
            ends = self._frame_ends(state_out[0], start, done, done + frames)
            done += frames
            if ends.bad.any() or ends.down.any():
                break
            initial, warmstart = state_out[:, part.stop - 1], data.qacc_warmstart[None].copy()
        return done

    def _frame_ends(self, states: np.ndarray, start: Start, first: int, end: int) -> FrameEnds:
        """Frames first..end-1 of a run as `FrameLoop` checks them after each frame: the state
        after the frame's last step (`end_checks`)."""
        rows = np.arange(first + 1, end + 1) * self.steps_per_frame - 1
        return end_checks(self.model, states[rows], rows, start.state[0], start.standing_height_m)

    def _varied(self, variation: Variation) -> RobotModel:
        variation = variation.physics  # the sensors' errors leave the model as it is
        if variation.is_nominal:
            return self.robot
        with self._lock:
            if variation not in self._varied_cache:
                if len(self._varied_cache) >= VARIED_CACHE:
                    self._varied_cache.pop(next(iter(self._varied_cache)))
                self._varied_cache[variation] = varied_robot(self.robot, variation)
            return self._varied_cache[variation]

    def _standing(self, job: Job, data: mujoco.MjData) -> tuple[RobotModel, Start]:
        """A run's (varied) robot and its start, made in `data`."""
        robot = self._varied(job.variation)
        start_motion = job.motion if job.start_motion is None else job.start_motion
        return robot, start_at_rest(robot, data, job.params, start_motion)

    def _plan_run(
        self, job: Job, n_frames: int, data: mujoco.MjData
    ) -> tuple[RobotModel, Start, np.ndarray]:
        """A run's (varied) robot, its start (made in `data`), and the control of every step."""
        robot = self._varied(job.variation)
        return robot, *plan_open_loop(robot, job, n_frames, data)

    def _plan(
        self, chunk: Sequence[Job], n_frames: int
    ) -> tuple[list[Start], np.ndarray, np.ndarray, mujoco.MjModel | list[mujoco.MjModel]]:
        """Several runs planned for one `rollout` call (tests and benches): their starts,
        controls, initial states, and model -- one for nominal runs, else one per run."""
        data = mujoco.MjData(self.model)
        planned = [self._plan_run(job, n_frames, data) for job in chunk]
        starts = [start for _robot, start, _control in planned]
        controls = np.stack([control for _robot, _start, control in planned])
        nominal = all(j.variation.physics.is_nominal for j in chunk)
        models = self.model if nominal else [robot.model for robot, _start, _c in planned]
        return starts, controls, np.stack([st.state for st in starts]), models

    def _measure(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        start: Start,
        job: Job,
        n_frames: int,
        warmup_s: float,
    ) -> tuple[RunMetrics, Trace]:
        """The run's first `n_frames` frames (those rolled out) as `FrameLoop` samples them, in
        whole arrays: the state after each frame's last physics step, and the sensors of that
        step -- whose sole positions MuJoCo computed from the state one step earlier, as
        `FrameLoop` reads the sites after it."""
        rows, qpos, bad, down = self._frame_ends(states, start, 0, n_frames)
        # sensors[rows] is a copy: the trace keeps none of the lane's arrays alive
        return measure_frames(self.robot, job, qpos, sensors[rows], bad, down, warmup_s)
