"""Step-timing feedback (NimbRo's lateral stabiliser, Allgeuer and Behnke 2016; docs/SENSORS.md):
the gait's frequency changed by the filtered trunk roll's deviation from the gait's expected roll
swing, faster when the trunk falls toward the swing foot, slower when it leans out over the
support foot. Pure numpy in float32, as the firmware's laws.c computes it; and the fit of the
expected swing to a nominal walk's roll."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gait.feedback_params import TimingParams

F32 = np.float32


def expected_roll(
    timing: TimingParams, a_r: ArrayLike, phase_rad: ArrayLike
) -> NDArray[np.float32]:
    """The trunk roll (right > 0) the gait is expected to have at phi_Trunk `phase_rad`
    walking a_r: offset + roll_per_a_r a_r + (swing + swing_per_a_r |a_r|) cos(phi_Trunk +
    swing phase), in float32."""
    phase, side = np.asarray(phase_rad, dtype=F32), np.asarray(a_r, dtype=F32)
    amplitude = F32(timing.swing_rad) + F32(timing.swing_per_a_r) * np.abs(side)
    swing = amplitude * np.cos(phase + F32(timing.swing_phase_rad))
    still = F32(timing.roll_offset_rad) + F32(timing.roll_per_a_r) * side
    return (still + swing).astype(F32)


def support_weight(phase_rad: ArrayLike) -> NDArray[np.float32]:
    """cos(phi_Trunk): +1 while the left foot carries alone (the right swings about
    phi_Trunk = 0), -1 while the right does, 0 at each change of support: smooth, so that the
    firmware's and the host's phases, a count apart, weigh alike."""
    return np.cos(np.asarray(phase_rad, dtype=F32)).astype(F32)


def timing_step(
    timing: TimingParams,
    error: NDArray[np.float32],
    roll_rad: NDArray[np.float32],
    a_r: ArrayLike,
    phase_rad: ArrayLike,
    freq_hz: float,
    dt_s: float,
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """One frame of the law for K runs: (the new filtered roll deviation, the change of the gait
    frequency, Hz). The deviation (roll - `expected_roll`) low-passed and past the dead band,
    times minus the support weight, is how far the trunk leans out over the support foot beyond
    its swing: > 0 slows the clock (slow_down_hz_per_rad), < 0 (falling toward the swing foot)
    speeds it up (speed_up_hz_per_rad); within +-clamp_share * freq_hz."""
    deviation = (roll_rad - expected_roll(timing, a_r, phase_rad)).astype(F32)
    filtered = (error + (deviation - error) * F32(dt_s / (timing.filter_s + dt_s))).astype(F32)
    past = np.sign(filtered) * np.maximum(np.abs(filtered) - F32(timing.deadband_rad), F32(0.0))
    outward = (-support_weight(phase_rad) * past).astype(F32)
    gain = np.where(outward > 0, F32(timing.slow_down_hz_per_rad), F32(timing.speed_up_hz_per_rad))
    limit = F32(timing.clamp_share * freq_hz)
    change = np.minimum(np.maximum(-gain * outward, -limit), limit).astype(F32)
    return filtered, change


def fit_roll_swing(phase_rad: ArrayLike, roll_rad: ArrayLike) -> tuple[float, float, float]:
    """(roll_offset_rad, swing_rad, swing_phase_rad) of the least-squares fit
    roll = offset + swing cos(phi_Trunk + phase) to a walk's frames (whole gait cycles), with
    swing >= 0: the expected swing `TimingParams` takes from the nominal walk."""
    phase, roll = np.asarray(phase_rad, dtype=float), np.asarray(roll_rad, dtype=float)
    basis = np.stack([np.ones_like(phase), np.cos(phase), -np.sin(phase)], axis=1)
    (offset, c, s), *_ = np.linalg.lstsq(basis, roll, rcond=None)
    # swing cos(phi + d) = swing cos d cos phi - swing sin d sin phi
    return float(offset), float(np.hypot(c, s)), float(np.arctan2(s, c))
