"""The trunk's attitude from its IMU, as the firmware estimates it: pitch and roll from the
accelerometer's specific force, fused with the integrated gyro by a complementary filter (a
time constant per step). Pure numpy: float32 in, float32 out (docs/DESIGN.md §4)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def accel_tilt(accel: NDArray[np.floating]) -> tuple[NDArray[np.floating], NDArray[np.floating]]:
    """(pitch, roll), rad, of a body at rest whose accelerometer reads `accel` (..., 3), m/s²
    (the specific force: +g up). ROS axes: pitch > 0 leans forward (nose down), roll > 0 lowers
    the right side."""
    a = np.asarray(accel)
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    pitch = np.arctan2(-ax, np.sqrt(ay * ay + az * az))
    roll = np.arctan2(ay, az)
    return pitch, roll


#: the estimate's pitch is held within ± this, rad (86°): the Euler rates need tan(pitch),
#: which grows without bound toward ±π/2, where the robot has long fallen; its roll is kept in
#: (-π, π] (a robot rolled over would otherwise count on past π)
PITCH_LIMIT_RAD = 1.5
#: standard gravity, m/s²
G_M_S2 = 9.80665
#: the attitude starts only from an accelerometer reading within this share of g: at rest, not
#: falling (a robot dropped onto the floor reads ~0 and would start at a roll of 180°) nor
#: landing (docs/DESIGN.md §15)
START_G_BAND = (0.9, 1.1)


def starts_attitude(accel: NDArray[np.floating]) -> NDArray[np.bool_]:
    """Whether `accel` (..., 3), m/s², may start the attitude: its squared magnitude, in
    float32 as the firmware computes it, within `START_G_BAND` of g squared (..., bool)."""
    a = np.asarray(accel, dtype=np.float32)
    squared = a[..., 0] * a[..., 0] + a[..., 1] * a[..., 1] + a[..., 2] * a[..., 2]
    g = np.float32(G_M_S2)
    low, high = (np.float32(b) * g for b in START_G_BAND)
    return (low * low <= squared) & (squared <= high * high)


def euler_rates(
    pitch: NDArray[np.floating], roll: NDArray[np.floating], gyro: NDArray[np.floating]
) -> tuple[NDArray[np.floating], NDArray[np.floating]]:
    """d(pitch)/dt and d(roll)/dt of Z-Y-X Euler angles from body rates `gyro` (..., 3), rad/s."""
    w = np.asarray(gyro)
    wx, wy, wz = w[..., 0], w[..., 1], w[..., 2]
    sin_r, cos_r = np.sin(roll), np.cos(roll)
    pitch_rate = cos_r * wy - sin_r * wz
    roll_rate = wx + np.tan(pitch) * (sin_r * wy + cos_r * wz)
    return pitch_rate, roll_rate


def complementary_step(
    pitch: NDArray[np.floating],
    roll: NDArray[np.floating],
    gyro: NDArray[np.floating],
    accel: NDArray[np.floating],
    dt_s: float,
    tau_s: float,
    tilt: tuple[NDArray[np.floating], NDArray[np.floating]] | None = None,
) -> tuple[NDArray[np.floating], NDArray[np.floating]]:
    """One step of the complementary filter: the last estimate advanced by the gyro's Euler
    rates over dt_s, blended with the accelerometer's tilt, weight tau / (tau + dt) on the gyro
    path: the accelerometer corrects slowly (time constant tau_s), the gyro carries the fast
    motion. tau_s = 0 takes the accelerometer alone. `tilt`: `accel_tilt(accel)` when the
    caller has it. Across ±π the accelerometer's roll is taken on the gyro path's side (the
    blend of π and -π is not 0), the roll kept in (-π, π], the pitch within ±PITCH_LIMIT_RAD;
    while the robot stands none of these acts, nor changes a bit."""
    dtype = np.result_type(pitch, gyro, accel)
    keep = dtype.type(tau_s / (tau_s + dt_s))
    dt = dtype.type(dt_s)
    pi, two_pi = dtype.type(np.pi), dtype.type(2) * dtype.type(np.pi)
    pitch_rate, roll_rate = euler_rates(pitch, roll, gyro)
    acc_pitch, acc_roll = accel_tilt(accel) if tilt is None else tilt
    one = dtype.type(1.0)
    pitch_path = pitch + pitch_rate * dt
    roll_path = roll + roll_rate * dt
    apart = acc_roll - roll_path
    acc_roll = np.where(
        apart > pi, acc_roll - two_pi, np.where(apart < -pi, acc_roll + two_pi, acc_roll)
    )
    new_pitch = keep * pitch_path + (one - keep) * acc_pitch
    new_roll = keep * roll_path + (one - keep) * acc_roll
    new_roll = np.where(
        new_roll > pi, new_roll - two_pi, np.where(new_roll <= -pi, new_roll + two_pi, new_roll)
    )
    limit = dtype.type(PITCH_LIMIT_RAD)
    new_pitch = np.minimum(np.maximum(new_pitch, -limit), limit)
    return new_pitch.astype(dtype), new_roll.astype(dtype)
