"""Seed 004's own gait (docs/DESIGN.md §4): per joint C + A*sin(2*pi*t/T + phi), eqs (1)–(2), the
right leg pi later, CA scaling each leg's whole joint function, eqs (10)–(11), and the start-up
phase of its Fig. 3; mapped onto ArtRo's 12 joints (`pfs_joint_angles_with_flags`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gait.params import GaitParams, Motion
from gait.phases import CA_SIGN

LEG_SIGN = np.array([-1.0, 1.0])  # I_s of seed 000 eq (32): left, right
#: The right leg runs pi later, eq (11) (left leg first).
LEG_PHASE_SHIFT = np.array([0.0, np.pi])
HIP_YAW, HIP_ROLL, HIP_PITCH, KNEE, ANKLE_PITCH, ANKLE_ROLL = range(6)
#: The joints with an oscillator of their own: (index in the leg, field prefix in `pfs`).
OSCILLATORS = (
    (HIP_ROLL, "hip_roll"),
    (HIP_PITCH, "hip_pitch"),
    (KNEE, "knee"),
    (ANKLE_PITCH, "ankle_pitch"),
    (ANKLE_ROLL, "ankle_roll"),
)


def startup_gain(params: GaitParams, time_s: ArrayLike) -> NDArray[np.float64]:
    """Seed 004's start-up phase (Fig. 3): the oscillation gain `time_s` after a start, rising
    linearly from 0 to 1 over `pfs.startup_s` (1 at once if that is 0)."""
    t = np.asarray(time_s, dtype=float)
    duration = params.pfs.startup_s
    if duration <= 0.0:
        return np.ones_like(t)
    return np.minimum(np.maximum(t / duration, 0.0), 1.0)


def pfs_joint_angles_with_flags(
    params: GaitParams, motion: Motion, phi_trunk: ArrayLike, startup: ArrayLike = 1.0
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Joint angles (..., 12) of seed 004's oscillator gait at trunk phase(s) `phi_trunk`, and per
    leg (..., 2) whether the knee had to be clamped to 0.

    Every joint follows f_x(t) = C_x + A_x sin(2 pi t/T + phi_x), eq (2). Seed 004 alternates the
    feet "by adding a shift of pi for pitch joints of the right foot"; in the per-leg convention
    used here (roll > 0 outwards, pitch > 0 forwards, knee <= 0) the lateral sway is anti-phase
    too, so the whole right leg runs pi later, as eq (11) writes it for any joint x. CA scales
    each leg's *whole* joint function, offset and oscillation alike, as eqs (10)–(11) print it:

        f_xL = (C_x + A_x sin(2 pi t/T + phi_x)) (1 + CA)
        f_xR = (C_x + A_x sin(2 pi t/T + phi_x + pi)) (1 - CA)

    What is ArtRo's, not the paper's (which lists Nao's joints and gives no values):

    - 2 pi t/T is the walking clock phi_Trunk (T = 1/`clock.freq_hz`), shared with behnke; the
      left leg's oscillators run at phi_Trunk + phi_x.
    - Hip roll, hip pitch, knee, ankle pitch and ankle roll have oscillators (`pfs` group); the
      hip yaw has none.
    - The motion vector drives stride oscillators s = g sin(phi_leg + phi_s) (g: `stride_gain`)
      with the signs of the swing, seed 000 eqs (27)–(29): hip pitch += a_p s, ankle pitch
      -= a_p s (the sole keeps its pitch; a_p > 0 walks forward, < 0 backward); hip roll
      += I_s a_r s, ankle roll -= I_s a_r s;
      hip yaw += I_s a_y,eff s with the steering term a_y,eff = a_y + K CA s(a_p). I_s = -1 left, +1
      right. Sines of one period add up to one sine, so each joint keeps the form of eq (2).
    - `startup` is the start-up gain of Fig. 3 (`startup_gain`) on every sine term; it broadcasts
      against `phi_trunk`. The offsets C hold from the first frame.
    - A knee above 0 (C + A > 0 lies inside the ranges) is clamped to 0 and reported.

    Eq (3), the joint speed control Speed (theta_target - theta_current), is the position
    servos' job here, not the gait's.
    """
    p = params.pfs
    phi, gain = np.broadcast_arrays(np.asarray(phi_trunk, float), np.asarray(startup, float))
    phi, gain = phi[..., None], gain[..., None]  # (..., 1) against the leg axis
    phi_leg = phi + LEG_PHASE_SHIFT  # (..., 2): 2*pi*t/T, the right leg + pi, eqs (10)–(11)
    joints = np.zeros((*phi_leg.shape, 6))
    for index, name in OSCILLATORS:
        c, a, phase = (getattr(p, f"{name}_{part}") for part in ("c", "a", "phi"))
        joints[..., index] = c + gain * a * np.sin(phi_leg + phase)  # eq (2)
    stride = gain * p.stride_gain * np.sin(phi_leg + p.stride_phi)
    a_y_eff = motion.a_y + params.steer.yaw_amplitude(motion.a_p, motion.ca)  # steering term
    joints[..., HIP_PITCH] += motion.a_p * stride  # cf. eq (28)
    joints[..., ANKLE_PITCH] -= motion.a_p * stride
    joints[..., HIP_ROLL] += LEG_SIGN * motion.a_r * stride  # cf. eq (27)
    joints[..., ANKLE_ROLL] -= LEG_SIGN * motion.a_r * stride
    joints[..., HIP_YAW] += LEG_SIGN * a_y_eff * stride  # cf. eq (29)
    ca_scale = 1.0 + motion.ca * CA_SIGN  # eqs (10)–(11)
    joints *= ca_scale[..., None]
    knee_clamped = joints[..., KNEE] > 0.0
    joints[..., KNEE] = np.minimum(joints[..., KNEE], 0.0)
    return joints.reshape(*joints.shape[:-2], 12), knee_clamped
