"""Lateral support (gait/motion_params.py `LateralParams`, decision 0061): the support leg's
roll leaned, weighted by how much it carries, more with |a_r|; nothing else moves, and with both
fields 0 the gait is today's to the bit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gait import GaitParams, Motion
from gait.motion_params import LateralParams
from gait.phases import LEG_ROLL, leg_parameters

PHASES = np.linspace(-np.pi, np.pi, 64, endpoint=False)


def with_lateral(**fields) -> GaitParams:
    return dataclasses.replace(GaitParams(), lateral=LateralParams(**fields))


@pytest.mark.parametrize("motion", [Motion(), Motion(a_r=0.1), Motion(a_p=0.07, a_y=0.2)])
def test_off_is_the_gait_to_the_bit(motion):
    assert LateralParams() == LateralParams(support_roll_rad=0.0, sway_per_a_r=0.0)
    got = leg_parameters(with_lateral(), motion, PHASES)
    assert got.tobytes() == leg_parameters(GaitParams(), motion, PHASES).tobytes()


def test_the_support_leg_leans_and_the_swing_leg_does_not():
    base = leg_parameters(GaitParams(), Motion(a_r=0.1), PHASES)
    leaned = leg_parameters(with_lateral(support_roll_rad=0.03), Motion(a_r=0.1), PHASES)
    change = leaned - base
    assert not np.delete(change, LEG_ROLL, axis=-1).any()  # the roll alone, the foot kept level
    roll = change[..., LEG_ROLL]  # (phase, leg)
    # the left leg carries about phi_Trunk = 0 (the right swings), the right about +-pi
    assert roll[32, 0] == pytest.approx(0.03) and roll[32, 1] == 0.0
    assert roll[0, 1] == pytest.approx(0.03) and roll[0, 0] == pytest.approx(0.0, abs=1e-12)
    assert (roll >= 0.0).all() and (roll.sum(axis=-1) > 0.0).sum() >= 60  # one leg at a time


def test_the_lean_grows_with_the_side_step():
    params = with_lateral(sway_per_a_r=0.5)
    on_the_spot = leg_parameters(params, Motion(), PHASES) - leg_parameters(
        GaitParams(), Motion(), PHASES
    )
    assert not on_the_spot.any()
    for a_r in (0.1, -0.1):
        change = leg_parameters(params, Motion(a_r=a_r), PHASES) - leg_parameters(
            GaitParams(), Motion(a_r=a_r), PHASES
        )
        assert change[..., LEG_ROLL].max() == pytest.approx(0.05)
