"""Differential steering of a biped, seed 004 eqs (9), (12)–(13): CA -> heading rate and path.

V_L,R = (1 ± CA)·V on an axle b gives θ̇ = −2·CA·V/b (CA > 0 turns clockwise); `predict_path` is
the exact unicycle, not the printed closed forms (7)–(8), (14)–(15) (docs/DESIGN.md §4).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray


class Pose2D(NamedTuple):
    """A pose in the world's ground plane (docs/DESIGN.md §3): x, y in m, yaw in rad."""

    x_m: float
    y_m: float
    yaw_rad: float  # counter-clockwise positive


def turn_rate_rad_s(ca: ArrayLike, speed_m_s: ArrayLike, axle_m: float) -> NDArray[np.float64]:
    """Heading rate -2 CA V / b in rad/s, counter-clockwise positive (eq 13 solved for it).

    `ca` and `speed_m_s` (V, m/s, > 0 forward) broadcast; `axle_m` is b in m. ValueError if b <= 0.
    """
    if axle_m <= 0:
        raise ValueError(f"axle length must be > 0 m, got {axle_m}")
    return -2.0 * np.asarray(ca, dtype=float) * np.asarray(speed_m_s, dtype=float) / axle_m


def curve_amount_for(turn_rate: ArrayLike, speed_m_s: float, axle_m: float) -> NDArray[np.float64]:
    """The CA that gives a heading rate at a speed: eq (13), CA = -b * theta_dot / (2 V)."""
    if speed_m_s == 0:
        raise ValueError("CA is undefined at zero walking speed")
    return -axle_m * np.asarray(turn_rate, dtype=float) / (2.0 * speed_m_s)


def turn_radius_m(ca: float, axle_m: float) -> float:
    """Signed turn radius -b / (2 CA) in m (b = `axle_m`): > 0 turns left, inf when CA = 0."""
    if ca == 0:
        return float("inf")
    return -axle_m / (2.0 * ca)


def predict_path(
    start: Pose2D, speed_m_s: float, ca: float, axle_m: float, t_s: ArrayLike
) -> NDArray[np.float64]:
    """Exact differential-drive poses at times t after `start`: rows [t, x, y, yaw].

    The solution of the unicycle x' = V cos(theta), y' = V sin(theta), theta' = omega with
    omega = `turn_rate_rad_s(ca, V, b)`, written with sinc so that it stays exact and finite at
    omega = 0; a test checks it against numerical integration.

    Args:
        start: the anchor pose (m, m, rad). speed_m_s: V in m/s (> 0 forward). ca: curve amount.
        axle_m: b in m (> 0). t_s: times in s after the anchor, a scalar or any array of shape S.

    Returns:
        (*S, 4) array of [t_s, x_m, y_m, yaw_rad] (yaw not wrapped). ValueError if b <= 0.
    """
    t = np.asarray(t_s, dtype=float)
    omega = float(turn_rate_rad_s(ca, speed_m_s, axle_m))
    half_turn = 0.5 * omega * t
    mid_heading = start.yaw_rad + half_turn
    chord = speed_m_s * t * np.sinc(half_turn / np.pi)  # np.sinc(x) = sin(pi x) / (pi x)
    x = start.x_m + chord * np.cos(mid_heading)
    y = start.y_m + chord * np.sin(mid_heading)
    yaw = start.yaw_rad + omega * t
    return np.stack(np.broadcast_arrays(t, x, y, yaw), axis=-1)
