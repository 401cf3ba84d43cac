"""Leg interface of the ArtRo gait, seed 000 eqs (2)–(9): leg parameters -> the 12 joint angles.

The one-line axis design needs no rotation matrices (see `leg_to_joint_angles`); joint order and
angle signs: docs/DESIGN.md §3, the gait: §4.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gait.params import GaitParams, Motion
from gait.phases import (
    FOOT_PITCH,
    FOOT_ROLL,
    GAMMA,
    LEG_PITCH,
    LEG_ROLL,
    LEG_YAW,
    leg_parameters_with_flags,
)

JOINTS_PER_LEG = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
JOINT_NAMES = tuple(f"{side}_{j}" for side in ("l", "r") for j in JOINTS_PER_LEG)


@dataclass(frozen=True)
class LegGeometry:
    """Leg segment lengths: hip (roll/pitch crossing) -> knee -> ankle (roll/pitch crossing)."""

    upper_m: float  # L_UL
    lower_m: float  # L_LL

    @property
    def max_length_m(self) -> float:
        """L_max = L_UL + L_LL in m, the leg length at eta = 1 (eq 3)."""
        return self.upper_m + self.lower_m  # L_max


#: The built-in ArtRo robot (`models/robots/artro.yaml`): the default of the pure gait API; the app
#: passes the loaded robot's legs. A test checks the description against these lengths.
ARTRO_LEG = LegGeometry(upper_m=0.09, lower_m=0.09)


class JointAngles(NamedTuple):
    """Joint angles and where the leg-extension limit was clamped (`joint_angles_with_flags`)."""

    values: NDArray[np.float64]  # (..., 12) in JOINT_NAMES order, rad
    #: (..., 2) per leg: the leg-extension limit was hit and clamped -- gamma of eq (45) outside
    #: [-1, 0] (behnke), the knee above 0 (pfs)
    gamma_clamped: NDArray[np.bool_]


def knee_triangle(
    eta: ArrayLike, geometry: LegGeometry = ARTRO_LEG
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """alpha1 (at the knee), alpha2 (at the hip), alpha3 (at the ankle) for relative length eta.

    Eq (5) takes alpha2 from an arcsin, which is right while alpha2 <= pi/2, i.e. while
    L_UL^2 + L^2 >= L_LL^2: always so for ArtRo's equal thigh and shank.
    """
    lu, ll = geometry.upper_m, geometry.lower_m
    length = np.asarray(eta, dtype=float) * geometry.max_length_m  # eq (3)
    cos_a1 = (lu * lu + ll * ll - length * length) / (2.0 * lu * ll)
    alpha1 = np.arccos(np.minimum(np.maximum(cos_a1, -1.0), 1.0))  # eq (4)
    alpha2 = np.arcsin(np.minimum(np.maximum(ll / length * np.sin(alpha1), -1.0), 1.0))  # eq (5)
    alpha3 = np.pi - (alpha1 + alpha2)  # eq (6)
    return alpha1, alpha2, alpha3


def leg_to_joint_angles(
    legs: ArrayLike, eta_min: float, geometry: LegGeometry = ARTRO_LEG
) -> NDArray[np.float64]:
    """Leg parameters -> joint angles, eqs (2)–(9).

    ArtRo's hip-yaw servo sits above the crossed hip roll/pitch axes and all leg axes meet one line
    when standing (the "one-line axis design"), so the joint angles follow from the leg angle, foot
    angle and leg extension without rotation matrices, with alpha1..alpha3 the angles of the
    hip-knee-ankle triangle for the leg length eta * (L_UL + L_LL) (`knee_triangle`):

        hip   = (leg_roll, leg_pitch + alpha2, leg_yaw)                  eq (7)
        knee  = alpha1 - pi  (<= 0)                                       eq (8)
        ankle = (foot_roll - leg_roll, alpha3 + foot_pitch - leg_pitch)   eq (9)

    Args:
        legs: leg parameters (..., 2, 6) as `leg_parameters` gives them (rad; gamma in [-1, 0]).
        eta_min: relative leg length at gamma = -1 (`LegParams.eta_min`).
        geometry: thigh and shank lengths.

    Returns:
        (..., 12) joint angles in rad, JOINT_NAMES order (left leg first).
    """
    legs = np.asarray(legs, dtype=float)
    eta = 1.0 + (1.0 - eta_min) * legs[..., GAMMA]  # eq (2)
    alpha1, alpha2, alpha3 = knee_triangle(eta, geometry)
    leg_roll, leg_pitch = legs[..., LEG_ROLL], legs[..., LEG_PITCH]
    per_leg = np.empty((*leg_roll.shape, 6))  # (..., 2, 6), JOINT_NAMES order per leg
    per_leg[..., 0] = legs[..., LEG_YAW]  # hip yaw, eq (7)
    per_leg[..., 1] = leg_roll  # hip roll, eq (7)
    per_leg[..., 2] = leg_pitch + alpha2  # hip pitch, eq (7)
    per_leg[..., 3] = alpha1 - np.pi  # knee, eq (8)
    per_leg[..., 4] = alpha3 + legs[..., FOOT_PITCH] - leg_pitch  # ankle pitch, eq (9)
    per_leg[..., 5] = legs[..., FOOT_ROLL] - leg_roll  # ankle roll, eq (9)
    return per_leg.reshape(*per_leg.shape[:-2], 12)


def behnke_joint_angles_with_flags(
    params: GaitParams,
    motion: Motion,
    phi_trunk: ArrayLike,
    geometry: LegGeometry = ARTRO_LEG,
) -> JointAngles:
    """The `behnke` engine's 12 joint angles at trunk phase(s) `phi_trunk`, eqs (2)–(45), with
    the gamma flags (`gait.joint_angles_with_flags` dispatches here for engine "behnke").

    Args:
        params: the gait constants; motion: the motion vector with CA.
        phi_trunk: trunk phase in rad, a scalar or any array of shape S.
        geometry: the leg lengths (default: the built-in model's).

    Returns:
        `JointAngles`: `values` (*S, 12) in rad, JOINT_NAMES order; `gamma_clamped` (*S, 2), per
        leg, True where eq (45) summed below -1 and was clamped.
    """
    legs = leg_parameters_with_flags(params, motion, phi_trunk)
    return JointAngles(
        leg_to_joint_angles(legs.values, params.leg.eta_min, geometry), legs.gamma_clamped
    )
