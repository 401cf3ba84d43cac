"""The robot simulated in real time with bus servos (docs/BUS.md): the goals come through a
`Handoff` from the bus's thread, each acting from the first 1 ms step that starts at or after
the time its packet's last byte arrived; this thread alone touches `MjData` and publishes what
the servos measure as one frozen value (docs/DESIGN.md §10)."""

from __future__ import annotations

import copy
import math
import threading
import time
from collections import deque
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots.model import RobotModel
from app.sim.robot_pose import stand, trunk_yaw
from gait import GaitParams, Motion

TICK_S = 0.002  # the simulation catches up with the wall clock this often
LATE_S = 0.1  # further behind than this: the debt is dropped and counted (not real time)


@dataclass(frozen=True)
class Goals:
    """What the servos act on from `effect_s` (monotonic clock): goal (rad) and torque on, per
    joint in the gait's order."""

    effect_s: float
    goal_rad: tuple[float, ...]
    torque_on: tuple[bool, ...]


@dataclass(frozen=True)
class Measured:
    """What the simulation last published: sim time (s), and per joint position (rad),
    velocity (rad/s), load (fraction of stall torque); the trunk's x, y (m) and yaw (rad) in
    the world (docs/DESIGN.md §3), what a run's metrics are taken from."""

    time_s: float
    position_rad: tuple[float, ...]
    velocity_rad_s: tuple[float, ...]
    load: tuple[float, ...]
    trunk: tuple[float, float, float] = (0.0, 0.0, 0.0)


def measured_of(robot: RobotModel, d: mujoco.MjData, stall_nm: NDArray[np.float64]) -> Measured:
    """What `robot`'s servos measure in `d` now (load: force over `stall_nm`, per joint)."""
    force = d.actuator_force[robot.actuator_ids]
    return Measured(
        time_s=float(d.time),
        position_rad=tuple(d.qpos[robot.qpos_adr].tolist()),
        velocity_rad_s=tuple(d.qvel[robot.dof_adr].tolist()),
        load=tuple((force / stall_nm).tolist()),
        trunk=(float(d.qpos[0]), float(d.qpos[1]), trunk_yaw(d.qpos[3:7])),
    )


class Handoff:
    """Goals from the bus thread to the simulation thread, in order, under a lock; the
    measured state back as one frozen value replaced whole."""

    def __init__(self, measured: Measured) -> None:
        self._lock = threading.Lock()
        self._goals: deque[Goals] = deque()
        self.measured = measured

    def put(self, goals: Goals) -> None:
        with self._lock:
            self._goals.append(goals)

    def take(self) -> list[Goals]:
        with self._lock:
            taken = list(self._goals)
            self._goals.clear()
        return taken


@dataclass
class SimStats:
    """How the simulation kept up: steps done, the debt dropped (s) and how often, the largest
    lag behind the wall clock (s), goals applied late (after their step)."""

    steps: int = 0
    dropped_s: float = 0.0
    drops: int = 0
    lag_max_s: float = 0.0
    late_goals: int = 0


class BusSimulation:
    """The robot in MuJoCo in real time, its leg actuators' targets the bus servos' goals (the
    goal angle is the joint's ctrl, the joint angle the servo's position, 2048 = 0 rad); a
    servo with its torque off is limp (no position gain; the joint's damping stays)."""

    def __init__(self, robot: RobotModel, torque_on: bool = False) -> None:
        self.robot = robot
        self.model = copy.copy(robot.model)  # its own: the torque switch changes gains in it
        self.data = mujoco.MjData(self.model)
        self.pose = stand(robot, self.data, GaitParams(), Motion(), 0.0)
        act = robot.actuator_ids
        self._kp = self.model.actuator_gainprm[act, 0].copy()
        self._stall_nm = np.abs(self.model.actuator_forcerange[act, 1])
        self.torque = np.full(12, torque_on)
        self._set_torque(self.torque)
        self.goal_rad = np.array(self.pose, dtype=np.float64)
        self.stats = SimStats()
        self.handoff = Handoff(self.measured())
        self.timestep_s = float(self.model.opt.timestep)
        self.anchor_s = 0.0  # monotonic time of step 0's start (`serve` sets it)
        self._pending: deque[Goals] = deque()

    def _set_torque(self, on: NDArray[np.bool_]) -> None:
        act = self.robot.actuator_ids
        kp = np.where(on, self._kp, 0.0)
        self.model.actuator_gainprm[act, 0] = kp
        self.model.actuator_biasprm[act, 1] = -kp

    def measured(self) -> Measured:
        return measured_of(self.robot, self.data, self._stall_nm)

    def _apply(self, goals: Goals) -> None:
        self.goal_rad = np.array(goals.goal_rad[:12])
        on = np.array(goals.torque_on[:12])
        if not np.array_equal(on, self.torque):
            self.torque = on
            self._set_torque(on)
        self.data.ctrl[self.robot.actuator_ids] = np.where(on, self.goal_rad, 0.0)

    def advance(self, due_step: int) -> None:
        """Step physics up to step `due_step` (since the start), each goal taken from the
        handoff acting from the first step that starts at or after its `effect_s` (the steps'
        times: `anchor_s` + step × timestep); then publish what the servos measure."""
        self._pending.extend(self.handoff.take())
        dt = self.timestep_s
        pending = self._pending
        while self.stats.steps < due_step:
            step_start_s = self.anchor_s + self.stats.steps * dt
            while pending and pending[0].effect_s <= step_start_s:
                goals = pending.popleft()
                self.stats.late_goals += goals.effect_s < step_start_s - dt
                self._apply(goals)
            mujoco.mj_step(self.model, self.data)
            self.stats.steps += 1
        self.handoff.measured = self.measured()

    def serve(self, stop: threading.Event) -> None:
        """Keep the physics at the wall clock, catching up every `TICK_S`; a debt over `LATE_S`
        is dropped and counted."""
        dt = self.timestep_s
        self.anchor_s = time.monotonic() - self.stats.steps * dt
        while not stop.is_set():
            due = math.floor((time.monotonic() - self.anchor_s) / dt + 1e-9)
            lag = (due - self.stats.steps) * dt
            self.stats.lag_max_s = max(self.stats.lag_max_s, lag)
            if lag > LATE_S:  # too far behind: drop the debt, say so
                self.stats.dropped_s += lag
                self.stats.drops += 1
                self.anchor_s += lag
                due = self.stats.steps
            self.advance(due)
            wake = self.anchor_s + self.stats.steps * dt + TICK_S
            stop.wait(max(0.0, wake - time.monotonic()))

    @property
    def real_time_factor(self) -> float:
        """Simulated over wall time since the start, the dropped debt counted as not run."""
        run_s = self.stats.steps * float(self.model.opt.timestep)
        return run_s / (run_s + self.stats.dropped_s) if run_s else 1.0
