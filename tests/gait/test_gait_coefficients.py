"""Eq (28)'s stride coefficient (`swing.pitch_gain`) and eq (39)'s side-step spread
(`balance.leg_roll_side`), both 1 in the paper (decision 0071): at 1 the gait is the printed
one to the bit; otherwise each scales its own term and nothing else."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gait import GaitParams, Motion
from gait.phases import (
    CA_SIGN,
    HALF_PI,
    LEG_PITCH,
    LEG_ROLL,
    LEG_SIGN,
    leg_parameters,
    leg_phases,
    swing_profile,
)

PHASE_GROUPS = ("shift", "short", "swing", "load", "balance")
PHASES = np.linspace(-np.pi, np.pi, 64, endpoint=False)
MOTIONS = [
    Motion(),
    Motion(a_r=0.003, a_p=-0.03),
    Motion(a_p=0.07, ca=0.1),
    Motion(a_r=-0.1),
    Motion(a_r=0.1, a_y=0.2),
]


def with_fields(swing: float = 1.0, side: float = 1.0) -> GaitParams:
    p = GaitParams()
    return dataclasses.replace(
        p,
        swing=dataclasses.replace(p.swing, pitch_gain=swing),
        balance=dataclasses.replace(p.balance, leg_roll_side=side),
    )


def only(group: str) -> GaitParams:
    """The default gait with every phase but `group` off."""
    p = GaitParams()
    off = {g: dataclasses.replace(getattr(p, g), enabled=g == group) for g in PHASE_GROUPS}
    return dataclasses.replace(p, **off)


@pytest.mark.parametrize("motion", MOTIONS)
def test_the_paper_coefficients_give_the_printed_sums_to_the_bit(motion):
    p = GaitParams()
    assert p.swing.pitch_gain == 1.0 and p.balance.leg_roll_side == 1.0
    phi_leg = leg_phases(PHASES)
    i_s, a_r, a_p = LEG_SIGN, motion.a_r, motion.a_p
    bl = p.balance
    roll = leg_parameters(only("balance"), motion, PHASES)[..., LEG_ROLL]
    printed = bl.leg_roll_offset + i_s * a_r + abs(a_r) + bl.leg_roll_yaw * abs(motion.a_y)
    assert roll.tobytes() == (np.zeros_like(phi_leg) + printed).tobytes()  # eq (39)
    sw = p.swing
    pitch = leg_parameters(only("swing"), motion, PHASES)[..., LEG_PITCH]
    theta = swing_profile(sw.v * (phi_leg + HALF_PI + sw.o), sw.v)
    ca_scale = 1.0 + motion.ca * CA_SIGN
    assert pitch.tobytes() == (np.zeros_like(phi_leg) + ca_scale * a_p * theta).tobytes()  # (28)


def test_the_stride_coefficient_scales_the_leg_pitch_swing_alone():
    motion = Motion(a_p=0.07, ca=0.1)
    base = leg_parameters(GaitParams(), motion, PHASES)
    longer = leg_parameters(with_fields(swing=1.3), motion, PHASES)
    change = longer - base
    assert not np.delete(change, LEG_PITCH, axis=-1).any()
    swing_term = change[..., LEG_PITCH] / 0.3  # eq (28)'s term, CA's scale included
    on_the_spot = leg_parameters(with_fields(swing=1.3), Motion(), PHASES)
    assert on_the_spot.tobytes() == leg_parameters(GaitParams(), Motion(), PHASES).tobytes()
    # the left leg's stride is (1 + CA) times the right's (seed 004 eqs (10)-(11)), half a cycle on
    assert np.abs(swing_term[:, 0]).max() == pytest.approx(
        1.1 / 0.9 * np.abs(swing_term[:, 1]).max()
    )
    assert np.abs(swing_term).max() == pytest.approx(1.1 * 0.07, rel=0.05)


@pytest.mark.parametrize("a_r", [0.1, -0.1])
def test_the_side_coefficient_scales_the_leading_legs_spread_alone(a_r):
    base = leg_parameters(GaitParams(), Motion(a_r=a_r), PHASES)
    narrow = leg_parameters(with_fields(side=0.25), Motion(a_r=a_r), PHASES)
    change = narrow - base
    assert not np.delete(change, LEG_ROLL, axis=-1).any()
    leading = 1 if a_r > 0 else 0  # I_s a_r + |a_r| is 2 |a_r| on the leg of the step's side
    roll = change[..., LEG_ROLL]  # (phase, leg)
    assert roll[:, leading] == pytest.approx(np.full(len(PHASES), -0.75 * 2 * abs(a_r)))
    assert not roll[:, 1 - leading].any()
    on_the_spot = leg_parameters(with_fields(side=0.25), Motion(a_p=0.07), PHASES)
    assert on_the_spot.tobytes() == leg_parameters(GaitParams(), Motion(a_p=0.07), PHASES).tobytes()
