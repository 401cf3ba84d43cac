"""A lane's run rolled out frame by frame, as `FrameLoop` walks it, to the bit: the closed loop
(sensors -> laws -> one frame planned -> its rollout) and a push, the one step a force acts on
the trunk (docs/DESIGN.md §9, §15)."""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout

from app.evaluation._api import Job
from app.robots.model import RobotModel
from app.sim.frame_loop import law_reading, stand
from app.sim.planning import FRAME_S, START_PHASE_RAD, plan_frames
from app.sim.sensors import Sensors
from app.worlds.servo_path import ServoPath
from gait import GaitParams, Motion, feedback

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS


@dataclass(frozen=True)
class Start:
    """A run's initial physics state and set-points, and the standing height for the fall test."""

    state: np.ndarray
    ctrl: np.ndarray
    phase: float
    standing_height_m: float


def start_at_rest(
    robot: RobotModel, data: mujoco.MjData, params: GaitParams, motion: Motion
) -> Start:
    """The rollout start of a run, as `FrameLoop(robot, params, start_motion=motion)` stands
    after its reset, made in `data` (which it overwrites)."""
    phase = float(START_PHASE_RAD)
    stand(robot, data, params, motion, phase)
    state = np.empty(mujoco.mj_stateSize(robot.model, STATE_SPEC))
    mujoco.mj_getState(robot.model, data, state, STATE_SPEC)
    return Start(state, data.ctrl.copy(), phase, float(data.qpos[2]))


class Push:
    """A variation's push as the lane applies it: the step it acts in and its force."""

    def __init__(self, robot: RobotModel, job: Job) -> None:
        self.step, self.force = job.variation.push(float(robot.model.opt.timestep))
        self.trunk = robot.trunk_id

    def within(self, first: int, end: int) -> bool:
        return first <= self.step < end


def step_by_hand(
    robot: RobotModel,
    data: mujoco.MjData,
    control: np.ndarray,
    first_step: int,
    push: Push,
    state_out: np.ndarray,
    sensor_out: np.ndarray,
) -> None:
    """Steps first_step.. of `control` (rows: steps) with `mj_step` from `data` as it is, the
    push in its step, each step's state and sensors into the rows of the outputs (`rollout`
    gives the same bits)."""
    act = robot.actuator_ids
    for k, row in enumerate(control):
        step = first_step + k
        data.ctrl[act] = row[act]
        if step == push.step:
            data.xfrc_applied[push.trunk, :3] = push.force
        mujoco.mj_step(robot.model, data)
        if step == push.step:
            data.xfrc_applied[push.trunk, :3] = 0.0
        mujoco.mj_getState(robot.model, data, state_out[step], STATE_SPEC)
        sensor_out[step] = data.sensordata


def roll_out_closed(
    runner: rollout.Rollout,
    robot: RobotModel,
    data: mujoco.MjData,
    job: Job,
    start: Start,
    n_frames: int,
    steps: int,
    state_out: np.ndarray,
    sensor_out: np.ndarray,
    stopped: Callable[[int], bool],
) -> int:
    """The closed loop of `FrameLoop._step_closed_loop`, frame by frame from `start` (a lane's
    `Start`, standing in `data`), one `rollout` call of `steps` steps per frame (the frame with
    the push stepped by hand), until `stopped(frame)` says the frame fell or blew up. Returns
    the frames rolled out."""
    params, model, act = job.params, robot.model, robot.actuator_ids
    sensors = Sensors(robot, job.variation)
    rows = deque([data.sensordata.copy()], maxlen=sensors.steps_needed)
    rows.extend([rows[0]] * (sensors.steps_needed - 1))
    physics = job.variation.physics
    timestep_s = float(model.opt.timestep)
    sent = start.ctrl[act].copy()
    path = None if physics.is_nominal else ServoPath(job.variation, timestep_s, sent)
    push = Push(robot, job)
    positions = robot.fsr_positions_m.astype(np.float32)
    law_state = feedback.State()
    motion_now = job.motion if job.start_motion is None else job.start_motion
    phase = start.phase
    step_rad = 2.0 * math.pi * params.clock.freq_hz * FRAME_S
    within = np.arange(steps)[:, None]
    control = np.empty((steps, model.nu))
    control[:] = start.ctrl
    initial, warmstart = start.state[None, :], None
    for frame in range(n_frames):
        reading = sensors.read(np.array(rows), data, forces=params.cop.enabled)
        law_state, out = feedback.step(
            params, law_state, law_reading(reading), motion_now, positions, FRAME_S
        )
        plan = plan_frames(
            params, job.motion, robot.hardware(), phase, 1, steps, timestep_s,
            motion_now=motion_now, frame0=frame, geometry=robot.geometry,
            joint_delta_rad=out.joint_delta_rad, a_y_delta=float(out.a_y_delta),
        )  # fmt: skip
        held = np.where(within >= plan.substep[0][None, :], plan.setpoint[0][None, :], sent)
        sent = plan.setpoint[0].copy()
        control[:, act] = held if path is None else path(held)
        part = slice(frame * steps, (frame + 1) * steps)
        if push.within(part.start, part.stop):
            mujoco.mj_setState(model, data, initial[0], STATE_SPEC)
            if warmstart is not None:
                data.qacc_warmstart[:] = warmstart[0]
            step_by_hand(robot, data, control, part.start, push, state_out[0], sensor_out[0])
        else:
            runner.rollout(
                [model], [data], initial, control[None], initial_warmstart=warmstart,
                state=state_out[:, part], sensordata=sensor_out[:, part], nstep=steps,
                skip_checks=True,
            )  # fmt: skip
        rows.extend(sensor_out[0, part])
        motion_now = plan.motions[0]
        next_phase = float(plan.phase[0]) + step_rad
        phase = (next_phase + math.pi) % (2.0 * math.pi) - math.pi  # as FrameLoop, in floats
        if stopped(frame):
            return frame + 1
        initial, warmstart = state_out[:, part.stop - 1], data.qacc_warmstart[None].copy()
    return n_frames
