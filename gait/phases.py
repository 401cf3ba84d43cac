"""Walking-phase layer of the ArtRo gait, seed 000 eqs (10)–(45): motion vector -> leg parameters.

Vectorised over the trunk phase (shapes: `LegParameters`); CA scales each leg's sagittal swing
terms, seed 004 eqs (10)–(11), and feeds eq (29) through a_y + K*CA (docs/DESIGN.md §4).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gait.params import GaitParams, Motion

TWO_PI = 2.0 * np.pi
HALF_PI = 0.5 * np.pi

#: I_s of eq (32): -1 for the left leg, +1 for the right leg.
LEG_SIGN = np.array([-1.0, 1.0])
#: seed 004 eqs (10)–(11): the left leg's stride scales by 1 + CA, the right's by 1 - CA
#: (1 + CA * -1 is 1 - CA to the bit); a motion's fields may be numbers or arrays (..., 1)
CA_SIGN = np.array([1.0, -1.0])
#: Leg phase offsets of eqs (10)–(11): phi_L = phi_Trunk + pi/2, phi_R = phi_Trunk - pi/2.
LEG_PHASE_OFFSET = np.array([HALF_PI, -HALF_PI])

LEG_ROLL, LEG_PITCH, LEG_YAW, FOOT_ROLL, FOOT_PITCH, GAMMA = range(6)


class LegParameters(NamedTuple):
    """Leg parameters for both legs, and where gamma had to be clamped.

    For a trunk phase of shape S, `values` is (*S, 2, 6): per leg (left first) `[leg_roll,
    leg_pitch, leg_yaw, foot_roll, foot_pitch, gamma]` (eqs 40–45), angles in rad in the per-leg
    convention of docs/DESIGN.md §3 (roll > 0 outwards, pitch > 0 forwards / toe up, yaw > 0 foot
    outwards), gamma in [-1, 0].
    """

    values: NDArray[np.float64]
    gamma_clamped: NDArray[np.bool_]  # (..., 2): eq (45) summed below -1 and was clamped


def pi_cut(x: ArrayLike) -> NDArray[np.float64]:
    """Map angles to [-pi, pi) by adding multiples of 2*pi (the paper's piCut)."""
    wrapped = np.mod(np.asarray(x, dtype=float) + np.pi, TWO_PI) - np.pi
    # np.mod can round up to exactly 2*pi for tiny negative inputs; keep the interval half-open.
    return np.where(wrapped >= np.pi, wrapped - TWO_PI, wrapped)


def advance_phase(phi_trunk: ArrayLike, freq_hz: float, dt_s: float) -> NDArray[np.float64]:
    """The walking clock: phi_Trunk += 2*pi*f*dt, kept in [-pi, pi)."""
    return pi_cut(np.asarray(phi_trunk) + TWO_PI * freq_hz * dt_s)


def leg_phases(phi_trunk: ArrayLike) -> NDArray[np.float64]:
    """phi_Leg for (left, right), eqs (10)–(11); shape (..., 2)."""
    return pi_cut(np.asarray(phi_trunk, dtype=float)[..., None] + LEG_PHASE_OFFSET)


def _raised_cosine(phase: NDArray[np.float64], amplitude: ArrayLike) -> NDArray[np.float64]:
    """-0.5 * a * (cos(phase) + 1) inside [-pi, pi), else 0: the shape of eqs (19), (21), (35)."""
    active = (phase >= -np.pi) & (phase < np.pi)
    return np.where(active, -0.5 * np.asarray(amplitude) * (np.cos(phase) + 1.0), 0.0)


def swing_profile(phi_swing: ArrayLike, v_swing: float) -> NDArray[np.float64]:
    """theta_Swing of eq (25): a sine swing, then a linear reverse at speed b of eq (26)."""
    phi = np.asarray(phi_swing, dtype=float)
    b = -2.0 / (TWO_PI * v_swing - np.pi)  # eq (26)
    return np.where(
        phi >= HALF_PI,
        b * (phi - HALF_PI) + 1.0,
        np.where(phi >= -HALF_PI, np.sin(phi), b * (phi + HALF_PI) - 1.0),
    )


def leg_parameters_with_flags(
    params: GaitParams, motion: Motion, phi_trunk: ArrayLike
) -> LegParameters:
    """Eqs (10)–(45) for both legs at every given trunk phase (rad, any shape): `LegParameters`."""
    a_r, a_p, a_y, ca = motion.a_r, motion.a_p, motion.a_y, motion.ca
    speed = np.hypot(a_r, a_p)  # ||(a_r, a_p)||
    phi_leg = leg_phases(phi_trunk)  # (..., 2)
    i_s = LEG_SIGN  # eq (32), broadcasts against the leg axis
    ca_scale = 1.0 + ca * CA_SIGN  # seed 004, eqs (10)–(11)
    paper_signs = params.leg.paper_signs
    zero = np.zeros_like(phi_leg)

    leg_roll = zero.copy()
    foot_roll = zero.copy()
    foot_pitch = zero.copy()
    leg_pitch = zero.copy()
    leg_yaw = zero.copy()
    gamma = zero.copy()

    sh = params.shift
    if sh.enabled:
        a_shift = sh.amp_base + sh.amp_speed * speed + sh.amp_lateral * abs(a_r)  # eq (13)
        theta_shift = a_shift * np.cos(phi_leg + HALF_PI)  # eq (12)
        leg_roll += theta_shift  # eq (14)
        foot_roll += -sh.foot_ratio * theta_shift  # eq (15)

    st = params.short
    if st.enabled:
        phi_short = st.v * (phi_leg + HALF_PI + st.o)  # eq (16)
        a_short = st.amp_base + st.amp_speed * speed  # eq (20)
        gamma += _raised_cosine(phi_short, a_short)  # eq (19)
        foot_pitch += _raised_cosine(phi_short, 2.0 * st.foot_lift * a_p)  # eq (21)

    sw = params.swing
    if sw.enabled:
        phi_swing = sw.v * (phi_leg + HALF_PI + sw.o)  # eq (22)
        theta_swing = swing_profile(phi_swing, sw.v)  # eqs (25)–(26)
        leg_roll += i_s * a_r * theta_swing  # eq (27)
        leg_pitch += sw.pitch_gain * ca_scale * a_p * theta_swing  # eq (28)
        a_y_eff = a_y + params.steer.yaw_amplitude(a_p, ca)  # eq (29) with the steering term
        leg_yaw += i_s * a_y_eff * theta_swing  # eq (29)
        roll_sign = 1.0 if paper_signs else i_s
        pitch_sign = i_s if paper_signs else 1.0
        foot_roll += roll_sign * sw.foot_roll * a_r * theta_swing  # eq (30)
        foot_pitch += ca_scale * pitch_sign * sw.foot_pitch * a_p * theta_swing  # eq (31)

    ld = params.load
    if ld.enabled:
        phi_load = ld.v * pi_cut(phi_leg + HALF_PI - np.pi / st.v + st.o) - np.pi  # eq (33)
        a_load = ld.amp_base + ld.amp_pitch * (1.0 - np.cos(abs(a_p)))  # eq (36)
        gamma += _raised_cosine(phi_load, a_load)  # eq (35)

    bl = params.balance
    if bl.enabled:
        foot_roll += bl.foot_roll_amp * i_s * a_r * np.cos(phi_leg + bl.foot_roll_phase)  # (37)
        foot_pitch += (
            bl.foot_pitch_offset
            + bl.foot_pitch_speed * a_p
            - bl.foot_pitch_amp * a_p * np.cos(2.0 * phi_leg + bl.foot_pitch_phase)
        )  # eq (38)
        yaw_term = a_y if paper_signs else abs(a_y)
        side = bl.leg_roll_side  # the paper's 1: the sum below as printed, to the bit
        leg_roll += (
            bl.leg_roll_offset + side * i_s * a_r + side * abs(a_r) + bl.leg_roll_yaw * yaw_term
        )  # (39)

    lat = params.lateral
    if lat.support_roll_rad or lat.sway_per_a_r:  # none: not a bit changes
        lean = lat.support_roll_rad + lat.sway_per_a_r * abs(a_r)
        leg_roll += lean * np.maximum(np.sin(phi_leg), 0.0)  # the support leg (decision 0061)

    gamma_clamped = gamma < -1.0
    gamma = np.minimum(np.maximum(gamma, -1.0), 0.0)  # eq (45), the leg interface's range
    values = np.empty((*phi_leg.shape, 6))  # eqs (40)-(45), in `LegParameters` order
    for column, value in enumerate((leg_roll, leg_pitch, leg_yaw, foot_roll, foot_pitch, gamma)):
        values[..., column] = value
    return LegParameters(values, gamma_clamped)


def leg_parameters(params: GaitParams, motion: Motion, phi_trunk: ArrayLike) -> NDArray[np.float64]:
    """Leg parameters (..., 2, 6): per leg [leg_roll, leg_pitch, leg_yaw, foot_roll, foot_pitch,
    gamma], left leg first (eqs 40–45, gamma clamped to [-1, 0])."""
    return leg_parameters_with_flags(params, motion, phi_trunk).values
