"""Differential steering of a biped (seed 004): curve amount CA -> heading rate and predicted path.

The legs are the wheels of a differential drive: V_L = (1 + CA) V, V_R = (1 - CA) V, axle b = the
distance between the feet, so the centre moves at V and turns at

    theta_dot = (V_R - V_L) / b = -2 CA V / b          (eq 9 with eqs 12–13)

i.e. CA > 0 turns clockwise, on a circle of signed radius R = V / theta_dot = -b / (2 CA).

The closed forms printed in seed 004, eqs (7)–(8) and (14)–(15), are wrong: their radius lacks a
factor 1/2 and theta_0 is missing inside the sine and cosine. `predict_path` is the exact solution
of the unicycle x' = V cos(theta), y' = V sin(theta), theta' = omega, written with sinc so that it
stays exact and finite at omega = 0; a test checks it against numerical integration.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray


class Pose2D(NamedTuple):
    x_m: float
    y_m: float
    yaw_rad: float  # counter-clockwise positive


def turn_rate_rad_s(ca: ArrayLike, speed_m_s: ArrayLike, axle_m: float) -> NDArray[np.float64]:
    """Heading rate of the differential-drive model, counter-clockwise positive."""
    if axle_m <= 0:
        raise ValueError(f"axle length must be > 0 m, got {axle_m}")
    return -2.0 * np.asarray(ca, dtype=float) * np.asarray(speed_m_s, dtype=float) / axle_m


def curve_amount_for(turn_rate: ArrayLike, speed_m_s: float, axle_m: float) -> NDArray[np.float64]:
    """The CA that gives a heading rate at a speed: eq (13), CA = -b * theta_dot / (2 V)."""
    if speed_m_s == 0:
        raise ValueError("CA is undefined at zero walking speed")
    return -axle_m * np.asarray(turn_rate, dtype=float) / (2.0 * speed_m_s)


def turn_radius_m(ca: float, axle_m: float) -> float:
    """Signed turn radius -b / (2 CA): > 0 turns left (counter-clockwise), inf when straight."""
    if ca == 0:
        return float("inf")
    return -axle_m / (2.0 * ca)


def predict_path(
    start: Pose2D, speed_m_s: float, ca: float, axle_m: float, t_s: ArrayLike
) -> NDArray[np.float64]:
    """Exact differential-drive poses at times t after `start`: rows [t, x, y, yaw]."""
    t = np.asarray(t_s, dtype=float)
    omega = float(turn_rate_rad_s(ca, speed_m_s, axle_m))
    half_turn = 0.5 * omega * t
    mid_heading = start.yaw_rad + half_turn
    chord = speed_m_s * t * np.sinc(half_turn / np.pi)  # np.sinc(x) = sin(pi x) / (pi x)
    x = start.x_m + chord * np.cos(mid_heading)
    y = start.y_m + chord * np.sin(mid_heading)
    yaw = start.yaw_rad + omega * t
    return np.stack(np.broadcast_arrays(t, x, y, yaw), axis=-1)
