"""The step-timing law (gait/timing.py, decision 0061): slower while the trunk leans out over
the support foot beyond its expected swing, faster while it falls toward the swing foot, each by
its own gain, nothing within the dead band, within its clamp; the fit of the expected swing."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gait import GaitParams, Motion
from gait.feedback import Reading, State, step
from gait.feedback_params import TimingParams
from gait.timing import expected_roll, fit_roll_swing, timing_step

F32 = np.float32
DT = 0.02
CORNERS = np.array([[0.03, 0.02], [0.03, -0.02], [-0.03, 0.02], [-0.03, -0.02]], dtype=F32)
#: no filter to speak of: the deviation is the reading's
QUICK = TimingParams(enabled=True, filter_s=0.02, deadband_rad=0.02)
LEFT_CARRIES, RIGHT_CARRIES = 0.0, math.pi  # cos(phi_Trunk) +1 and -1


def leaning(roll: float = 0.0) -> Reading:
    """A reading at rest, the trunk rolled `roll` (> 0 to the right)."""
    accel = [0.0, 9.80665 * math.sin(roll), 9.80665 * math.cos(roll)]
    return Reading(np.zeros(3, F32), np.array(accel, F32), np.full((2, 4), 2.0, F32))


def change(timing: TimingParams, roll: float, phase: float, frames: int = 40) -> float:
    """The frequency change after `frames` frames of a steady roll at a fixed phase."""
    error = np.zeros(1, F32)
    for _ in range(frames):
        error, out = timing_step(timing, error, np.array([roll], F32), 0.0, phase, 1.0, DT)
    return float(out[0])


def test_leaning_out_over_the_support_foot_slows_the_clock_and_falling_inward_speeds_it():
    # roll > 0 leans right: out over the right foot when it carries, toward it when it swings
    assert change(QUICK, 0.05, RIGHT_CARRIES) == pytest.approx(-10.0 * 0.03, rel=1e-4)
    assert change(QUICK, 0.05, LEFT_CARRIES) == pytest.approx(5.0 * 0.03, rel=1e-4)
    assert change(QUICK, -0.05, LEFT_CARRIES) == pytest.approx(-10.0 * 0.03, rel=1e-4)
    assert change(QUICK, -0.05, RIGHT_CARRIES) == pytest.approx(5.0 * 0.03, rel=1e-4)


def test_the_dead_band_the_expected_swing_and_the_clamp():
    assert change(QUICK, 0.019, RIGHT_CARRIES) == 0.0
    swinging = dataclasses.replace(QUICK, swing_rad=0.05, swing_phase_rad=0.3)
    expected = float(expected_roll(swinging, 0.0, RIGHT_CARRIES))
    assert expected == pytest.approx(0.05 * math.cos(math.pi + 0.3), rel=1e-6)
    assert change(swinging, expected + 0.015, RIGHT_CARRIES) == 0.0  # its own swing: nothing
    assert change(QUICK, 0.5, RIGHT_CARRIES) == pytest.approx(-0.3, rel=1e-6)  # 0.3 of 1 Hz
    wider = dataclasses.replace(QUICK, swing_rad=0.05, swing_per_a_r=0.5, roll_per_a_r=0.2)
    assert float(expected_roll(wider, -0.1, 0.0)) == pytest.approx(-0.02 + 0.1, rel=1e-6)


def test_at_the_change_of_support_the_law_waits():
    assert abs(change(QUICK, 0.1, math.pi / 2)) < 1e-6


def test_the_law_steps_with_the_others_and_needs_the_phase():
    laws = dataclasses.replace(GaitParams(), timing=QUICK)
    state, out = State(), None
    for _ in range(30):
        state, out = step(laws, state, leaning(roll=0.06), Motion(), CORNERS, DT, phase_rad=3.0)
    assert out is not None and float(out.freq_delta_hz) < -0.1  # right carries: slower
    assert not out.joint_delta_rad.any() and out.a_y_delta == 0.0  # the joints are untouched
    with pytest.raises(ValueError, match="phase"):
        step(laws, State(), leaning(), Motion(), CORNERS, DT)
    _, off = step(GaitParams(), State(), leaning(roll=0.06), Motion(), CORNERS, DT)
    assert off.freq_delta_hz == 0.0


@given(
    offset=st.floats(-0.1, 0.1),
    swing=st.floats(0.001, 0.2),
    phase=st.floats(-3.1, 3.1),
)
def test_the_fit_finds_the_swing_of_a_walk(offset, swing, phase):
    phi = np.linspace(-math.pi, math.pi, 200, endpoint=False)
    got = fit_roll_swing(phi, offset + swing * np.cos(phi + phase))
    assert got[0] == pytest.approx(offset, abs=1e-9) and got[1] == pytest.approx(swing, rel=1e-6)
    assert math.remainder(got[2] - phase, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
