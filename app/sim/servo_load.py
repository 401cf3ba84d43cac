"""The servo load budget: per joint, torque and speed against the servo's limits, and eq (1).
Sampled once per 20 ms frame (docs/DESIGN.md §5): peak and RMS |torque| against the stall torque,
peak speed against the no-load speed, saturated frames, eq (1)'s (1 + sf) x peak |tau|, and where
the servo in place gives less, the lightest servo of the table (or the robot's own) that does."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots.model import RobotModel
from app.robots.swap import ServoChoice, lightest_servo
from gait import JOINT_NAMES
from hardware import SAFETY_FACTOR, required_torque_from_loads

WARN_MARGIN = 0.3  # below 30 % of the limit left: a warning
CRITICAL_MARGIN = 0.1  # below 10 %: critical


@dataclass(frozen=True)
class ServoLimits:
    """What each servo can do, from the model: stall torque (the actuator's force limit) and
    no-load speed (stall torque / joint damping: the DC motor's torque-speed line)."""

    stall_torque_nm: NDArray[np.float64]  # (12,)
    no_load_speed_rad_s: NDArray[np.float64]  # (12,)

    @classmethod
    def of(cls, robot: RobotModel) -> ServoLimits:
        m = robot.model
        stall = np.abs(m.actuator_forcerange[robot.actuator_ids, 1]).astype(np.float64)
        damping = m.dof_damping[robot.dof_adr].astype(np.float64)
        speed = np.where(damping > 0, stall / np.where(damping > 0, damping, 1.0), np.inf)
        return cls(stall, speed)


@dataclass(frozen=True)
class JointLoad:
    """One servo's row of the budget; margins are the share of the limit left (1 = idle)."""

    joint: str
    peak_torque_nm: float
    rms_torque_nm: float
    stall_torque_nm: float
    required_torque_nm: float  # eq (1): (1 + sf) * peak |tau|
    torque_margin: float  # 1 - required / stall
    peak_speed_rad_s: float
    no_load_speed_rad_s: float
    speed_margin: float  # 1 - peak speed / no-load speed
    saturated_frames: int
    servo: str  # the servo in place (the robot's description)
    #: the lightest servo of the table (or the robot's file) whose stall torque at the robot's
    #: supply is at least eq (1)'s required torque, where the one in place gives less (None where
    #: it meets eq (1), or where no servo of the table does: `eq1_met` tells the two apart)
    eq1_servo: ServoChoice | None
    eq1_met: bool  # stall torque >= eq (1)'s required torque: the margin is not below sf
    torque_level: str  # "ok", "warn" or "critical" for the torque margin (`level`)
    speed_level: str  # the same for the speed margin
    level: str  # the worse of the two


@dataclass(frozen=True)
class ServoLoadReport:
    frames: int  # frames measured since the meter was last cleared
    safety_factor: float
    joints: tuple[JointLoad, ...]
    supply_voltage_v: float  # the robot's supply, at which the servos' figures are taken


def level(margin: float) -> str:
    if margin < CRITICAL_MARGIN:
        return "critical"
    return "warn" if margin < WARN_MARGIN else "ok"


class ServoLoadMeter:
    """Accumulates the budget frame by frame; the owner of the MjData calls `add`."""

    def __init__(self, robot: RobotModel) -> None:
        self.robot = robot
        self.limits = ServoLimits.of(robot)
        self.servos = [robot.description.joint_servo(j) for j in JOINT_NAMES]
        self.clear()

    def clear(self) -> None:
        n = len(JOINT_NAMES)
        self.frames = 0
        self._peak = np.zeros(n)
        self._sum_sq = np.zeros(n)
        self._speed = np.zeros(n)
        self._saturated = np.zeros(n, dtype=np.int64)

    def add(self, data: mujoco.MjData, saturated_servos: NDArray[np.bool_]) -> None:
        """One frame's sample: the actuator forces and joint speeds now, the frame's saturation."""
        torque = np.abs(data.actuator_force[self.robot.actuator_ids])
        np.maximum(self._peak, torque, out=self._peak)
        self._sum_sq += torque**2
        np.maximum(self._speed, np.abs(data.qvel[self.robot.dof_adr]), out=self._speed)
        self._saturated += saturated_servos.astype(np.int64)
        self.frames += 1

    def eq1_servo(self, i: int, required_nm: float) -> ServoChoice | None:
        """The lightest servo of joint i's kind (PWM or bus) that gives `required_nm` at the
        robot's supply (None: none does), as `artro robot check --suggest` chooses one."""
        desc = self.robot.description
        catalogue = desc.servo_catalogue()
        signal = catalogue[self.servos[i]].signal
        return lightest_servo(required_nm, desc.supply_voltage_v, signal, servos=catalogue)

    @property
    def peak_torque_nm(self) -> NDArray[np.float64]:
        return self._peak.copy()

    def report(self) -> ServoLoadReport:
        """The budget so far (zeros before the first frame)."""
        lim = self.limits
        rms = np.sqrt(self._sum_sq / max(self.frames, 1))
        required = required_torque_from_loads(self._peak[None, :], SAFETY_FACTOR)
        torque_margin = 1.0 - required / lim.stall_torque_nm
        speed_margin = 1.0 - self._speed / lim.no_load_speed_rad_s
        met = required <= lim.stall_torque_nm
        rows = tuple(
            JointLoad(
                joint=name,
                peak_torque_nm=float(self._peak[i]),
                rms_torque_nm=float(rms[i]),
                stall_torque_nm=float(lim.stall_torque_nm[i]),
                required_torque_nm=float(required[i]),
                torque_margin=float(torque_margin[i]),
                peak_speed_rad_s=float(self._speed[i]),
                no_load_speed_rad_s=float(lim.no_load_speed_rad_s[i]),
                speed_margin=float(speed_margin[i]),
                saturated_frames=int(self._saturated[i]),
                servo=self.servos[i],
                eq1_servo=None if met[i] else self.eq1_servo(i, float(required[i])),
                eq1_met=bool(met[i]),
                torque_level=level(float(torque_margin[i])),
                speed_level=level(float(speed_margin[i])),
                level=level(min(float(torque_margin[i]), float(speed_margin[i]))),
            )
            for i, name in enumerate(JOINT_NAMES)
        )
        return ServoLoadReport(
            self.frames, SAFETY_FACTOR, rows, self.robot.description.supply_voltage_v
        )
