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


class ClosedLoop:
    """A run's loop between frames, as `FrameLoop._step_closed_loop` runs it: from the sensor
    rows of the steps so far (`record`), the laws and one frame planned into the ctrl of its
    steps (`plan`). Any stepper uses it: the lanes' `rollout` calls, a Warp batch's worlds.

    Args:
        robot, job, start: the run's (varied) robot, job and `Start`.
        steps: physics steps per frame.
        first_row: MuJoCo's sensordata standing at the start (the IMU's delay reads back into it).
    """

    def __init__(
        self, robot: RobotModel, job: Job, start: Start, steps: int, first_row: np.ndarray
    ) -> None:
        self.robot, self.job, self.steps = robot, job, steps
        self.sensors = Sensors(robot, job.variation)
        needed = self.sensors.steps_needed
        self.rows = deque([first_row.copy()] * needed, maxlen=needed)
        physics, model = job.variation.physics, robot.model
        self.timestep_s = float(model.opt.timestep)
        self.sent = start.ctrl[robot.actuator_ids].copy()
        self.path = (
            None if physics.is_nominal else ServoPath(job.variation, self.timestep_s, self.sent)
        )
        self.positions = robot.fsr_positions_m.astype(np.float32)
        self.law_state = feedback.State()
        self.motion_now = job.motion if job.start_motion is None else job.start_motion
        self.phase = start.phase
        self.step_rad = 2.0 * math.pi * job.params.clock.freq_hz * FRAME_S
        self.within = np.arange(steps)[:, None]
        self.control = np.empty((steps, model.nu))
        self.control[:] = start.ctrl

    def plan(self, frame: int, data: mujoco.MjData | None) -> np.ndarray:
        """The ctrl of frame `frame`'s steps (steps, nu; the loop's own array, overwritten by
        the next call): sensors read from the rows recorded so far (the force sensors from
        `data` as the last step left it, when the CoP law is on), the laws stepped, the frame
        planned with their corrections, through the servo path."""
        params, act = self.job.params, self.robot.actuator_ids
        forces = params.cop.enabled
        if forces and data is None:
            raise ValueError("the CoP law reads the force sensors: plan needs the step's MjData")
        reading = self.sensors.read(np.array(self.rows), data, forces=forces)
        self.law_state, out = feedback.step(
            params, self.law_state, law_reading(reading), self.motion_now, self.positions, FRAME_S
        )
        plan = plan_frames(
            params, self.job.motion, self.robot.hardware(), self.phase, 1, self.steps,
            self.timestep_s, motion_now=self.motion_now, frame0=frame,
            geometry=self.robot.geometry, joint_delta_rad=out.joint_delta_rad,
            a_y_delta=float(out.a_y_delta),
        )  # fmt: skip
        held = np.where(
            self.within >= plan.substep[0][None, :], plan.setpoint[0][None, :], self.sent
        )
        self.sent = plan.setpoint[0].copy()
        self.control[:, act] = held if self.path is None else self.path(held)
        self.motion_now = plan.motions[0]
        next_phase = float(plan.phase[0]) + self.step_rad
        self.phase = (next_phase + math.pi) % (2.0 * math.pi) - math.pi  # as FrameLoop, in floats
        return self.control

    def record(self, rows: np.ndarray) -> None:
        """The sensordata after each step of the frame just stepped (steps, nsensordata)."""
        self.rows.extend(rows)


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
    model = robot.model
    loop = ClosedLoop(robot, job, start, steps, data.sensordata)
    push = Push(robot, job)
    initial, warmstart = start.state[None, :], None
    for frame in range(n_frames):
        control = loop.plan(frame, data)
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
        loop.record(sensor_out[0, part])
        if stopped(frame):
            return frame + 1
        initial, warmstart = state_out[:, part.stop - 1], data.qacc_warmstart[None].copy()
    return n_frames
