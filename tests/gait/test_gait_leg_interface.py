"""The leg interface, eqs (2)–(9): leg parameters -> joint angles."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gait import ARTRO_LEG, JOINT_NAMES, GaitParams, Motion, joint_angles, knee_triangle
from gait.leg_interface import LegGeometry, leg_to_joint_angles

HIP_YAW, HIP_ROLL, HIP_PITCH, KNEE, ANKLE_PITCH, ANKLE_ROLL = range(6)


def test_joint_order():
    assert JOINT_NAMES[:6] == (
        "l_hip_yaw",
        "l_hip_roll",
        "l_hip_pitch",
        "l_knee",
        "l_ankle_pitch",
        "l_ankle_roll",
    )
    assert JOINT_NAMES[6] == "r_hip_yaw" and len(JOINT_NAMES) == 12


@settings(max_examples=80, deadline=None)
@given(eta=st.floats(0.6, 1.0), upper=st.floats(0.05, 0.15), lower=st.floats(0.05, 0.15))
def test_triangle_closes_to_the_requested_length(eta, upper, lower):
    geometry = LegGeometry(upper, lower)
    length = eta * geometry.max_length_m
    if length < abs(upper - lower) + 1e-6 or upper**2 + length**2 < lower**2:
        return  # unreachable, or alpha2 > pi/2 where eq (5)'s arcsin does not apply
    a1, a2, a3 = knee_triangle(eta, geometry)
    assert a1 + a2 + a3 == pytest.approx(np.pi)
    # place the knee and ankle in the sagittal plane: the ankle lands eta*L_max below the hip
    knee = upper * np.array([np.sin(a2), -np.cos(a2)])
    ankle = knee + lower * np.array([np.sin(a2 + a1 - np.pi), -np.cos(a2 + a1 - np.pi)])
    np.testing.assert_allclose(ankle, [0.0, -eta * geometry.max_length_m], atol=1e-9)


def test_straight_leg_and_full_shortening():
    legs = np.zeros((2, 6))
    straight = leg_to_joint_angles(legs, 0.875)
    np.testing.assert_allclose(straight, 0.0, atol=1e-7)  # arccos(-1) = pi exactly: knee 0
    legs[:, 5] = -1.0  # gamma = -1 -> eta = eta_min
    bent = leg_to_joint_angles(legs, 0.875).reshape(2, 6)
    a1, a2, a3 = knee_triangle(0.875)
    assert bent[0, KNEE] == pytest.approx(a1 - np.pi) and bent[0, KNEE] < -0.9
    assert bent[0, HIP_PITCH] == pytest.approx(a2)
    assert bent[0, ANKLE_PITCH] == pytest.approx(a3)
    # equal segments: the thigh and shank lean by the same angle
    assert a2 == pytest.approx(a3)


def test_leg_and_foot_angles_pass_through_as_eqs_7_and_9_say():
    leg = np.array([0.1, 0.2, 0.3, -0.05, 0.04, 0.0])  # roll, pitch, yaw, foot roll, foot pitch, g
    q = leg_to_joint_angles(np.stack([leg, leg]), 0.875)[:6]
    np.testing.assert_allclose(q, [0.3, 0.1, 0.2, 0.0, 0.04 - 0.2, -0.05 - 0.1], atol=1e-7)


def test_knee_never_overstretches_over_a_walk():
    phi = np.linspace(-np.pi, np.pi, 500)
    q = joint_angles(GaitParams(), Motion(0.1, 0.1, 0.2), phi)
    assert q.shape == (500, 12)
    assert np.all(q[:, [3, 9]] <= 1e-7)
    assert ARTRO_LEG.max_length_m == pytest.approx(0.18)
