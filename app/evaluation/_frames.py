"""A lane's run rolled out frame by frame, as `FrameLoop` walks it, to the bit: the closed loop
(sensors -> laws -> one frame planned -> its rollout) and a push, the one step a force acts on
the trunk (docs/DESIGN.md §9, §15)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from app.evaluation._api import Job
from app.robots.model import RobotModel
from app.sim.planning import FRAME_S, START_PHASE_RAD, MotionOfRuns, plan_frame_of_runs
from app.sim.robot_pose import stand
from app.sim.sensors import SensorBank
from app.worlds.servo_path import FramePaths
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
    push in its step, each step's state and sensors into the outputs' rows (one per row of
    `control`; `rollout` gives the same bits)."""
    act = robot.actuator_ids
    for k, row in enumerate(control):
        step = first_step + k
        data.ctrl[act] = row[act]
        if step == push.step:
            data.xfrc_applied[push.trunk, :3] = push.force
        mujoco.mj_step(robot.model, data)
        if step == push.step:
            data.xfrc_applied[push.trunk, :3] = 0.0
        mujoco.mj_getState(robot.model, data, state_out[k], STATE_SPEC)
        sensor_out[k] = data.sensordata


class ClosedLoops:
    """K runs' loops between frames in lockstep, each as `FrameLoop._step_closed_loop` runs it
    alone, to the bit: from the sensor rows of each run's steps so far (`record`), the laws
    and one frame planned into the ctrl of its steps (`plan`), every stage over the K runs at
    once (docs/DESIGN.md §9). The runs share their gait, motion and start motion (so their
    phase and motion ramp) and their robot's description (geometry, servos, force sensors);
    their physics, sensor errors and servo paths are each their own. Any stepper uses it: a
    lane's group of `rollout` calls, a Warp batch's worlds (`WorldLoops`).

    Args:
        robots, jobs, starts: each run's (varied) robot, job and `Start`.
        steps: physics steps per frame.
        first_rows: (K, nsensordata) MuJoCo's sensordata standing at each run's start (the
            IMU's delay reads back into it).
    """

    def __init__(
        self,
        robots: Sequence[RobotModel],
        jobs: Sequence[Job],
        starts: Sequence[Start],
        steps: int,
        first_rows: np.ndarray,
    ) -> None:
        job, robot = jobs[0], robots[0]
        _check_one_walk(robots, jobs)
        self.robot, self.job, self.steps = robot, job, steps
        self.sensors = SensorBank(robots, [j.variation for j in jobs])
        needed, self.columns = self.sensors.steps_needed, self.sensors.imu_columns
        first = np.asarray(first_rows, dtype=np.float64)[:, None, : self.columns]
        self.rows = np.repeat(first, needed, axis=1)  # the IMU's columns only
        self.timestep_s = float(robot.model.opt.timestep)
        act = robot.actuator_ids
        self.sent = np.stack([start.ctrl[act] for start in starts])
        self.path = FramePaths([j.variation for j in jobs], self.timestep_s, self.sent, steps)
        self.positions = robot.fsr_positions_m.astype(np.float32)
        self.law_state = feedback.States.fresh(len(jobs))
        self.motion: Motion | MotionOfRuns = job.motion
        if any(j.motion != job.motion for j in jobs):  # each its own, never ramped
            self.motion = MotionOfRuns.of([j.motion for j in jobs])
        self.motion_now = self.motion if job.start_motion is None else job.start_motion
        self.phase: float | np.ndarray = starts[0].phase  # each run's (K,) once timing acts
        self.step_rad = 2.0 * math.pi * job.params.clock.freq_hz * FRAME_S
        self.control = np.stack([np.broadcast_to(s.ctrl, (steps, len(s.ctrl))) for s in starts])
        # the servos' columns of the control: written in place when they are all of it, in order
        self._servos_are_ctrl = np.array_equal(act, np.arange(self.control.shape[2]))
        self._servos = self.control if self._servos_are_ctrl else self.control[:, :, act]

    def plan(self, frame: int, datas: Sequence[mujoco.MjData] | None) -> np.ndarray:
        """The ctrl of frame `frame`'s steps of every run (K, steps, nu; the loops' own array,
        overwritten by the next call): each run's sensors read from its rows recorded so far
        (the force sensors from its `datas` entry as its last step left it, when the CoP law is
        on), the laws stepped, the frame planned with their corrections, through each run's
        servo path."""
        params, act = self.job.params, self.robot.actuator_ids
        gyro, accel = self.sensors.read_imu(self.rows)
        if params.cop.enabled:
            if datas is None:
                raise ValueError("the CoP law reads the force sensors: plan needs the MjData")
            fsr = self.sensors.fsr_all(datas)
        else:
            fsr = np.zeros((len(gyro), 2, 4))
        self.law_state, out = feedback.step_many(
            params, self.law_state, gyro, accel, fsr,
            self.motion_now,  # type: ignore[arg-type]  # a MotionOfRuns: (K,) fields broadcast
            self.positions, FRAME_S, phase_rad=self.phase,
        )  # fmt: skip
        plan = plan_frame_of_runs(
            params, self.motion, self.robot.hardware(), self.phase, self.steps,
            self.timestep_s, motion_now=self.motion_now, frame0=frame,
            geometry=self.robot.geometry, joint_delta_rad=out.joint_delta_rad,
            a_y_delta=out.a_y_delta,
        )  # fmt: skip
        self.path(self.sent, plan.setpoint, plan.substep, self._servos)
        if not self._servos_are_ctrl:
            self.control[:, :, act] = self._servos
        self.sent = plan.setpoint
        self.motion_now = plan.motion
        if params.timing.enabled:  # each run's clock at its own rate (gait/timing.py)
            freq = params.clock.freq_hz + out.freq_delta_hz.astype(np.float64)
            next_phase: float | np.ndarray = plan.phase + 2.0 * math.pi * freq * FRAME_S
        else:
            next_phase = plan.phase + self.step_rad
        self.phase = (next_phase + math.pi) % (2.0 * math.pi) - math.pi  # as FrameLoop, in floats
        return self.control

    def keep(self, runs: np.ndarray) -> None:
        """Go on with the runs where `runs` (K,) is True (the others fell or blew up)."""
        self.sensors.keep(runs)
        self.path.keep(runs)
        self.law_state = self.law_state.take(runs)
        if np.ndim(self.phase):
            self.phase = np.asarray(self.phase)[runs]
        if isinstance(self.motion, MotionOfRuns):
            self.motion = self.motion_now = self.motion.take(runs)
        self.rows, self.sent, self.control = self.rows[runs], self.sent[runs], self.control[runs]
        self._servos = self.control if self._servos_are_ctrl else self._servos[runs]

    def record(self, rows: np.ndarray) -> None:
        """The sensordata after each step of the frame just stepped (K, steps, nsensordata)."""
        kept = self.rows.shape[1]
        self.rows = np.concatenate([self.rows, rows[:, :, : self.columns]], axis=1)[:, -kept:]


def _check_one_walk(robots: Sequence[RobotModel], jobs: Sequence[Job]) -> None:
    """ValueError unless the runs walk one gait from one start motion on one robot description,
    and one motion too when they ramp from that start (`walk_of`)."""
    if len({walk_of(job) for job in jobs}) > 1:
        raise ValueError(
            "the runs of one ClosedLoops must share params and start motion, and the motion "
            "when they start from another"
        )
    robot = robots[0]
    if any(other.description != robot.description for other in robots[1:]):
        raise ValueError("the runs of one ClosedLoops must share the robot's description")


def walk_of(job: Job) -> tuple:
    """What runs must share to step in one `ClosedLoops`: the gait, the start motion, and the
    motion when the run ramps from that start to it."""
    ramps = job.start_motion is not None and job.start_motion != job.motion
    return (job.params, job.start_motion, job.motion if ramps else None)
