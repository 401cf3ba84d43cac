"""Closed-loop runs of one walk stepped in lockstep, a group in a lane: the calls' tasks
(`lane_tasks`), their progress and stop (`Tally`), and a group's frames (`roll_out_group`:
sensors, laws and plans of all at once, then each run's own `rollout`; docs/DESIGN.md §9)."""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence

import mujoco
import numpy as np
from mujoco import rollout

from app.evaluation._api import Cancelled, Job
from app.evaluation._frames import STATE_SPEC, ClosedLoops, Push, Start, step_by_hand, walk_of
from app.evaluation._measure import end_checks
from app.robots.model import RobotModel
from gait import feedback

#: closed-loop runs of one walk step in lockstep in groups of up to this many (decision 0050)
GROUP_RUNS = 128


class Tally:
    """One `evaluate` call's work as its lanes do it: each task's frames stepped (a run's once
    it ended, a group's as it steps; each written by its task's lane alone), for the call's
    progress; and the call's stop, which a group looks at between frames."""

    def __init__(self, tasks: int, n_frames: int, cancel: threading.Event | None) -> None:
        self.frames = [0] * tasks
        self.n_frames = n_frames
        self.stop = threading.Event()
        self.cancel = cancel

    def stopped(self) -> bool:
        return self.stop.is_set() or (self.cancel is not None and self.cancel.is_set())

    def runs_worth(self) -> int:
        """The frames stepped so far, in whole runs."""
        return sum(self.frames) // self.n_frames


class GroupEnds:
    """A group's frame ends: each run's state (K, frames, state size) and sensordata (K,
    frames, nsensordata) after each frame's last physics step."""

    def __init__(self, runs: int, n_frames: int, state_size: int, nsensordata: int) -> None:
        self.states = np.empty((runs, n_frames, state_size))
        self.sensors = np.empty((runs, n_frames, nsensordata))


def lane_tasks(jobs: Sequence[Job], lanes: int, open_per_task: int = 1) -> list[list[int]]:
    """The jobs' indices cut into tasks, in order of their first job: open-loop runs
    `open_per_task` at a time, in job order; closed-loop runs of one walk (`walk_of`: one gait,
    one start) in groups of up to `GROUP_RUNS`, stepped in lockstep (`roll_out_group`), as many
    groups as a multiple of `lanes` (a lane is a thread here, a worker for the executors that
    send tasks away: a group of K runs shares the Python of a frame, so a task takes a whole
    one, and the lanes get as many each)."""
    open_runs: list[int] = []
    walks: dict[tuple, list[int]] = {}
    for i, job in enumerate(jobs):
        if feedback.any_law_on(job.params):
            walks.setdefault(walk_of(job), []).append(i)
        else:
            open_runs.append(i)
    tasks = [open_runs[i : i + open_per_task] for i in range(0, len(open_runs), open_per_task)]
    for runs in walks.values():
        groups = min(len(runs), lanes * math.ceil(len(runs) / (lanes * GROUP_RUNS)))
        size = math.ceil(len(runs) / groups)
        tasks += [runs[first : first + size] for first in range(0, len(runs), size)]
    return sorted(tasks)


def roll_out_group(
    robots: list[RobotModel],
    datas: list[mujoco.MjData],
    jobs: list[Job],
    starts: list[Start],
    n_frames: int,
    steps: int,
    ends: GroupEnds,
    runner: rollout.Rollout,
    tally: Tally,
    task: int,
) -> np.ndarray:
    """The group's frames of `steps` physics steps, each run to the frame it fell or blew up
    in: its frame ends into `ends`, the frames stepped into `tally` as they go (a run that ended
    counts all). Returns each run's frames rolled out (K,); Cancelled when the call stops."""
    model0 = robots[0].model
    start_s = np.array([start.state[0] for start in starts])
    heights = np.array([start.standing_height_m for start in starts])
    first_rows = np.stack([data.sensordata for data in datas])
    loops = ClosedLoops(robots, jobs, starts, steps, first_rows)
    pushes = [Push(robot, job) for robot, job in zip(robots, jobs, strict=True)]
    state_out = np.empty((len(jobs), steps, ends.states.shape[2]))
    sensor_out = np.empty((len(jobs), steps, model0.nsensordata))
    initial = np.stack([start.state for start in starts])[:, None, :]  # (K, 1, state)
    warm = np.zeros((len(jobs), 1, model0.nv))  # zeros: `rollout`'s cold start
    push_frame = [push.step // steps if push.step >= 0 else -1 for push in pushes]
    # each run's `rollout` arguments and output rows made once: a frame's Python per run
    # is then the call itself
    runs = [
        ([robot.model], data, [data], initial[k], warm[k], data.qacc_warmstart)
        for k, (robot, data) in enumerate(zip(robots, datas, strict=True))
    ]
    outs = [(state_out[j : j + 1], sensor_out[j : j + 1]) for j in range(len(jobs))]
    planned, controls = None, []
    frames = np.full(len(jobs), n_frames)
    live = np.arange(len(jobs))  # the runs still in the group, in the loops' order
    rows: slice | np.ndarray = slice(None)  # their rows in the group's arrays (all: a view)
    for frame in range(n_frames):
        if tally.stopped():
            raise Cancelled("cancelled")
        control = loops.plan(frame, [datas[k] for k in live])
        if control is not planned:  # the loops' array: new only when runs left the group
            planned, controls = control, [control[j : j + 1] for j in range(len(control))]
        for j, k in enumerate(live.tolist()):
            model, data, data_list, first, warm_k, warm_after = runs[k]
            if push_frame[k] == frame:
                mujoco.mj_setState(model[0], data, first[0], STATE_SPEC)
                if frame:
                    data.qacc_warmstart[:] = warm_k[0]
                step_by_hand(
                    robots[k], data, control[j], frame * steps, pushes[k], state_out[j],
                    sensor_out[j],
                )  # fmt: skip
            else:
                runner.rollout(
                    model, data_list, first, controls[j], initial_warmstart=warm_k,
                    state=outs[j][0], sensordata=outs[j][1], nstep=steps, skip_checks=True,
                )  # fmt: skip
            warm_k[0] = warm_after
        n = len(live)
        loops.record(sensor_out[:n])
        ends.states[rows, frame] = state_out[:n, -1]
        ends.sensors[rows, frame] = sensor_out[:n, -1]
        initial[rows, 0] = state_out[:n, -1]
        checks = end_checks(model0, state_out[:n, -1], (frame + 1) * steps - 1, start_s, heights)
        stopped = checks.bad | checks.down
        tally.frames[task] += n
        if stopped.any():
            tally.frames[task] += int(stopped.sum()) * (n_frames - frame - 1)
            frames[live[stopped]] = frame + 1
            live = rows = live[~stopped]
            if not len(live):
                break
            start_s, heights = start_s[~stopped], heights[~stopped]
            loops.keep(~stopped)
    return frames
