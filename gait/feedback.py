"""The balance feedback laws on top of the open-loop gait, once per 20 ms frame: sensor readings
in (gyro, accelerometer, the soles' forces -- nothing else), corrections of the 12 joint angles
and of a_y out. Pure numpy in float32, as the firmware computes them (docs/DESIGN.md §4)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gait.attitude import accel_tilt, complementary_step, starts_attitude
from gait.feedback_params import TiltParams, YawRateParams
from gait.params import LAW_GROUPS, GaitParams, Motion

F32 = np.float32
#: joint indices in `gait.JOINT_NAMES` order, per leg (left, right)
HIP_ROLL, HIP_PITCH, ANKLE_PITCH, ANKLE_ROLL = (1, 7), (2, 8), (4, 10), (5, 11)
OUTWARD = np.array([1.0, -1.0], dtype=F32)  # +y is outward for the left foot, inward for the right


def any_law_on(params: GaitParams) -> bool:
    """False: the open-loop gait, to the bit."""
    return any(getattr(params, group).enabled for group in LAW_GROUPS)


def laws_on(params: GaitParams) -> list[str]:
    """The groups of the laws `params` switches on."""
    return [group for group in LAW_GROUPS if getattr(params, group).enabled]


@dataclass(frozen=True)
class Reading:
    """What the laws read: the IMU in its axes (ROS: x forward, y left, z up; pitch rate > 0
    leans forward, roll rate > 0 lowers the right side) and each sole's four forces."""

    gyro_rad_s: NDArray[np.float32]  # (3,)
    accel_m_s2: NDArray[np.float32]  # (3,)
    fsr_n: NDArray[np.float32]  # (2, 4) left foot first, corners fl, fr, bl, br


@dataclass(frozen=True)
class State:
    """A run's law state (float32): the attitude estimate and each law's filter and integral."""

    started: bool = False
    pitch_rad: np.float32 = field(default_factory=F32)
    roll_rad: np.float32 = field(default_factory=F32)
    tilt_error: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))
    tilt_integral: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))
    yaw_error: np.float32 = field(default_factory=F32)
    yaw_integral: np.float32 = field(default_factory=F32)
    cop_integral: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))
    cop_last: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))


@dataclass(frozen=True)
class Output:
    """One frame's corrections, and each law's share (for the dashboard and the tests)."""

    joint_delta_rad: NDArray[np.float32]  # (12,) added to the gait's joint angles
    a_y_delta: np.float32  # added to the (ramped) a_y
    tilt_rad: NDArray[np.float32]  # (2,) pitch and roll trim
    damping_rad: NDArray[np.float32]  # (12,)
    cop_rad: NDArray[np.float32]  # (2,) the support foot's ankle pitch and roll (outward)
    support: int  # the support foot (0 left, 1 right), -1: neither carries min_load_n
    attitude_rad: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))  # estimate


def _zeros(n: int) -> NDArray[np.float32]:
    return np.zeros(n, dtype=F32)


def _low_pass(value: NDArray[np.float32], target: NDArray[np.float32], dt_s: float, tau_s: float):
    return value + (target - value) * F32(dt_s / (tau_s + dt_s))


def _clip(value: NDArray[np.float32] | np.float32, limit: np.float32) -> NDArray[np.float32]:
    """`value` within [-limit, limit]: np.clip's bits, without its wrapper's cost per frame."""
    return np.minimum(np.maximum(value, -limit), limit)


def _dead_band(error: NDArray[np.float32], width: float) -> NDArray[np.float32]:
    return np.sign(error) * np.maximum(np.abs(error) - F32(width), F32(0.0))


def expected_tilt(tilt: TiltParams, motion: Motion) -> NDArray[np.float32]:
    """(pitch, roll) the trunk is expected to have walking `motion`, rad."""
    pitch = tilt.pitch_offset_rad + tilt.pitch_per_a_p * motion.a_p
    return np.array([pitch, tilt.roll_per_a_r * motion.a_r], dtype=F32)


def commanded_turn_rate(yaw: YawRateParams, motion: Motion) -> np.float32:
    """The turn rate a_y and CA command, rad/s counter-clockwise: turn_per_a_y * a_y plus eq
    (13)'s -2 CA V / b with V = speed_per_a_p * a_p."""
    speed = yaw.speed_per_a_p * motion.a_p
    return F32(yaw.turn_per_a_y * motion.a_y - 2.0 * motion.ca * speed / yaw.axle_m)


def support_cop(
    fsr_n: NDArray[np.float32], positions_m: NDArray[np.float32], min_load_n: float
) -> tuple[int, NDArray[np.float32]]:
    """The foot that carries more (-1 if neither carries `min_load_n`) and its centre of
    pressure (x forward, y outward) from the sole centre, m."""
    load = fsr_n.sum(axis=1)
    foot = int(np.argmax(load))
    if not load[foot] > 0 or load[foot] < F32(min_load_n):  # with min_load_n 0, no 0 / 0
        return -1, _zeros(2)
    cop = (fsr_n[foot] @ positions_m) / load[foot]
    return foot, np.array([cop[0], cop[1] * OUTWARD[foot]], dtype=F32)


def step(
    laws: GaitParams,
    state: State,
    reading: Reading,
    motion: Motion,
    fsr_positions_m: NDArray[np.float32],
    dt_s: float,
) -> tuple[State, Output]:
    """One frame of every law that is on (the feedback groups of `laws`), from `reading` and
    the motion the gait gets.

    Attitude: the complementary filter, started from the accelerometer's tilt at the first
    reading of about 1 g (`starts_attitude`); until then there is no estimate and the tilt trim
    waits (its state unchanged, no trim), the other laws act. Tilt trim: the
    tilt error (estimate - `expected_tilt`), low-passed, past the dead band, integrated (ki) plus
    kp times it, each clamped; pitch trim on both ankles' pitch (toes down for a forward lean),
    roll trim, times `roll_share`, on the hips' roll (left out, right in for a lean to the
    right). Yaw rate: the
    error of the gyro's rate against `commanded_turn_rate`, low-passed, PI, clamped, on a_y
    (a_y > 0 turns clockwise). Damping: ankles and hips against the trunk's pitch and roll
    rates. CoP: the support foot's ankle pitch and roll against its centre of pressure (PID)."""
    gyro, accel = reading.gyro_rad_s.astype(F32), reading.accel_m_s2.astype(F32)
    started = state.started or starts_attitude(accel)
    if state.started:
        pitch, roll = complementary_step(
            state.pitch_rad, state.roll_rad, gyro, accel, dt_s, laws.attitude.tau_s
        )
    elif started:
        pitch, roll = (F32(a) for a in accel_tilt(accel))
    else:  # falling or jolted: no estimate yet
        pitch, roll = F32(0.0), F32(0.0)
    delta = _zeros(12)
    new = {"started": started, "pitch_rad": F32(pitch), "roll_rad": F32(roll)}  # the new State

    tilt = _zeros(2)
    if laws.tilt.enabled and started:
        t = laws.tilt
        error = np.array([pitch, roll], dtype=F32) - expected_tilt(t, motion)
        filtered = _low_pass(state.tilt_error, error, dt_s, t.filter_s)
        past = _dead_band(filtered, t.deadband_rad)
        limit = F32(t.clamp_rad)
        integral = _clip(state.tilt_integral + F32(t.ki_per_s * dt_s) * past, limit)
        tilt = _clip(integral + F32(t.kp) * past, limit).astype(F32)
        tilt[1] *= F32(t.roll_share)  # 1: the same bits as without the share
        new.update(tilt_error=filtered, tilt_integral=integral)
        delta[list(ANKLE_PITCH)] -= tilt[0]  # toes down against a forward lean
        delta[list(HIP_ROLL)] += tilt[1] * OUTWARD

    a_y_delta = F32(0.0)
    if laws.yaw_rate.enabled:
        y = laws.yaw_rate
        error = commanded_turn_rate(y, motion) - gyro[2]
        filtered = _low_pass(state.yaw_error, error, dt_s, y.filter_s)
        limit = F32(y.clamp)
        integral = _clip(state.yaw_integral + F32(y.ki_per_s * dt_s) * filtered, limit)
        a_y_delta = F32(_clip(-(integral + F32(y.kp) * filtered), limit))
        new.update(yaw_error=F32(filtered), yaw_integral=F32(integral))

    damping = _zeros(12)
    if laws.damping.enabled:
        d = laws.damping
        # measured on ArtRo: against a forward pitch rate, toes down and legs back both calm
        # the trunk; against a rate lowering the right side, left out and right in
        damping[list(ANKLE_PITCH)] = -F32(d.ankle_pitch) * gyro[1]
        damping[list(HIP_PITCH)] = -F32(d.hip_pitch) * gyro[1]
        damping[list(ANKLE_ROLL)] = F32(d.ankle_roll) * gyro[0] * OUTWARD
        damping[list(HIP_ROLL)] = F32(d.hip_roll) * gyro[0] * OUTWARD
        delta += damping

    cop_out, support = _zeros(2), -1
    if laws.cop.enabled:
        c = laws.cop
        support, cop = support_cop(reading.fsr_n.astype(F32), fsr_positions_m, c.min_load_n)
        if support >= 0:
            limit = F32(c.clamp_rad)
            integral = _clip(state.cop_integral + F32(c.ki_per_s * dt_s) * cop, limit)
            rate = (cop - state.cop_last) / F32(dt_s)
            cop_out = _clip(F32(c.kp) * cop + integral + F32(c.kd_s) * rate, limit).astype(F32)
            new.update(cop_integral=integral, cop_last=cop)
            delta[ANKLE_PITCH[support]] += cop_out[0]
            delta[ANKLE_ROLL[support]] += cop_out[1]
    attitude = np.array([pitch, roll], dtype=F32)
    out = Output(delta, a_y_delta, tilt, damping, cop_out, support, attitude)
    return dataclasses.replace(state, **new), out
