"""An open-loop run planned up front, as the frame loop would step it: its start at rest and
the ctrl of every physics step, each servo switching at its pulse's falling edge through the
variation's set-point path (docs/DESIGN.md §2, §9); the lanes and the Warp host plan with it."""

from __future__ import annotations

import pickle
from typing import Any

import mujoco
import numpy as np

from app.evaluation._api import Job
from app.evaluation._frames import Start, start_at_rest
from app.robots.model import RobotModel
from app.sim.planning import FramePlan, frame_steps, plan_frames
from app.worlds.servo_path import acting_setpoints
from app.worlds.variations import NOMINAL, Variation


def control_sequence(
    robot: RobotModel, start: Start, plan: FramePlan, variation: Variation = NOMINAL
) -> np.ndarray:
    """ctrl of every physics step (frames * steps per frame, nu), as the frame loop applies it:
    each servo switches to its frame's set-point at the step after its pulse's falling edge
    (`plan.substep`), through the variation's set-point path (latency, calibration, play)."""
    act = robot.actuator_ids
    acting = acting_setpoints(
        variation,
        float(robot.model.opt.timestep),
        start.ctrl[act],
        plan.setpoint,
        plan.substep,
        frame_steps(robot.model),
    )
    if len(act) == robot.model.nu and np.array_equal(act, np.arange(len(act))):
        return np.ascontiguousarray(acting)  # every actuator a servo, in order (ArtRo)
    ctrl = np.empty((len(acting), robot.model.nu))
    if len(act) < robot.model.nu:
        ctrl[:] = start.ctrl
    ctrl[:, act] = acting
    return ctrl


def plan_open_loop(
    robot: RobotModel,
    job: Job,
    n_frames: int,
    data: mujoco.MjData,
    plans: dict[tuple, FramePlan] | None = None,
) -> tuple[Start, np.ndarray]:
    """An open-loop run on `robot` (the job's varied robot): its start, made in `data` (which
    it overwrites), and the ctrl of every physics step of `n_frames` frames (`control_sequence`).
    `plans` keeps the gait's frame plans by everything they depend on, for a caller planning
    many runs of few gaits (a robust study: one plan per case, not per variation)."""
    start_motion = job.motion if job.start_motion is None else job.start_motion
    start = start_at_rest(robot, data, job.params, start_motion)
    hardware, steps = robot.hardware(), frame_steps(robot.model)
    timestep_s = float(robot.model.opt.timestep)
    key: tuple[Any, ...] = ()  # plans' key, when there are plans
    plan = None
    if plans is not None:  # by value: a varied robot's hardware is a new object holding arrays
        key = (job.params, job.motion, start_motion, start.phase, pickle.dumps(hardware))
        key += (robot.geometry, n_frames, steps, timestep_s)
        plan = plans.get(key)
    if plan is None:
        plan = plan_frames(
            job.params,
            job.motion,
            hardware,
            start.phase,
            n_frames,
            steps,
            timestep_s,
            motion_now=start_motion,
            geometry=robot.geometry,
        )
        if plans is not None:
            plans[key] = plan
    return start, control_sequence(robot, start, plan, job.variation)
