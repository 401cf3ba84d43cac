"""Servo torque sizing, equation (1) of seed 000 (section 2; docs/DESIGN.md §5).

tau = (1 + sf) * W * l * max(sin alpha) over the joint's range (`required_torque_nm`), refined, as
the paper does, from simulated joint torques (`required_torque_from_loads`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: sf of eq (1): a servo should give (1 + sf) x the torque asked of it, as seed 000 sizes them
SAFETY_FACTOR = 0.2


def max_sin(alpha_min_rad: ArrayLike, alpha_max_rad: ArrayLike) -> NDArray[np.float64]:
    """Maximum of sin(alpha) over [alpha_min, alpha_max]. Vectorised (broadcasts).

    It is 1 if the interval contains pi/2 + 2k*pi for some integer k, else the larger of the two
    endpoint values (sin has no other maximum inside the interval).

    Raises:
        ValueError: if alpha_min > alpha_max anywhere, or on non-finite angles.
    """
    lo, hi = np.broadcast_arrays(
        np.asarray(alpha_min_rad, dtype=np.float64), np.asarray(alpha_max_rad, dtype=np.float64)
    )
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError("alpha_min_rad and alpha_max_rad must be finite")
    if np.any(lo > hi):
        raise ValueError("alpha_min_rad must be <= alpha_max_rad (the joint's range of motion)")
    # The first peak pi/2 + 2k*pi at or above lo; the interval contains a peak if it is <= hi.
    k = np.ceil((lo - np.pi / 2) / (2 * np.pi))
    contains_peak = np.pi / 2 + 2 * np.pi * k <= hi
    return np.where(contains_peak, 1.0, np.maximum(np.sin(lo), np.sin(hi)))


def _check_safety_factor(safety_factor: ArrayLike) -> NDArray[np.float64]:
    sf = np.asarray(safety_factor, dtype=np.float64)
    if not np.all(np.isfinite(sf)) or np.any(sf < 0):
        raise ValueError(f"safety_factor must be >= 0 (0.2 = 20 % margin), got {sf.tolist()}")
    return sf


def required_torque_nm(
    weight_n: ArrayLike,
    lever_m: ArrayLike,
    alpha_min_rad: ArrayLike,
    alpha_max_rad: ArrayLike,
    safety_factor: ArrayLike,
) -> NDArray[np.float64]:
    """Required servo torque by eq (1): (1 + sf) * W * l * max(sin alpha). Vectorised (broadcasts).

    Args:
        weight_n: load weight W in newtons (>= 0).
        lever_m: distance l from the joint axle to the load's centre of mass in metres (>= 0).
        alpha_min_rad: lower end of the joint's range of motion, in rad; alpha is the angle
            between the lever (joint -> load centre of mass) and the vertical, so the load torque
            peaks at alpha = pi/2 (lever horizontal).
        alpha_max_rad: upper end (>= alpha_min_rad).
        safety_factor: sf >= 0, e.g. 0.3 for a 30 % margin.

    Returns:
        The torque in N·m. As in the paper, it is negative if sin(alpha) < 0 over the whole range.

    Raises:
        ValueError: on a negative or non-finite weight, lever or safety factor, or a bad range.
    """
    weight = np.asarray(weight_n, dtype=np.float64)
    lever = np.asarray(lever_m, dtype=np.float64)
    if np.any(~np.isfinite(weight) | (weight < 0)):
        raise ValueError(f"weight_n must be finite and >= 0 N, got {weight.tolist()}")
    if np.any(~np.isfinite(lever) | (lever < 0)):
        raise ValueError(f"lever_m must be finite and >= 0 m, got {lever.tolist()}")
    sf = _check_safety_factor(safety_factor)
    return (1 + sf) * weight * lever * max_sin(alpha_min_rad, alpha_max_rad)


def required_torque_from_loads(
    joint_torques_nm: ArrayLike, safety_factor: ArrayLike
) -> NDArray[np.float64]:
    """Required torque per joint from simulated loads: (1 + sf) * max over time of |tau|.

    The paper refines eq (1) with "mechanical simulation software"; this is that refinement: the
    peak of the joint torques measured in our simulation, with the same safety factor.

    Args:
        joint_torques_nm: simulated joint torques, shape (T, n): T samples of n joints.
        safety_factor: sf >= 0, a scalar or one per joint (n,).

    Returns:
        shape (n,), in N·m.

    Raises:
        ValueError: not (T >= 1, n) finite samples, or a negative safety factor.
    """
    torques = np.asarray(joint_torques_nm, dtype=np.float64)
    if torques.ndim != 2 or torques.shape[0] == 0:
        raise ValueError(
            f"joint_torques_nm must have shape (T, n) with T >= 1 samples, got {torques.shape}"
        )
    if not np.all(np.isfinite(torques)):
        raise ValueError("joint_torques_nm must be finite (no NaN or inf samples)")
    sf = _check_safety_factor(safety_factor)
    return (1 + sf) * np.max(np.abs(torques), axis=0)
