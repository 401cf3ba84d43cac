"""The steering term a_y,eff = a_y + K*CA*s(a_p) in eq (29) (docs/DESIGN.md §4)."""

import dataclasses
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gait import GaitParams, LegParams, Motion, joint_angles, leg_parameters
from gait.params import SteerParams
from gait.phases import LEG_YAW

GOLDEN = Path(__file__).parent / "data" / "behnke_golden.npz"
# How far a stored array may lie from today's: numpy's sin, cos, arcsin and arccos are accurate to
# about one ULP but not correctly rounded, and their SIMD paths differ between numpy builds and
# CPUs; a joint angle passes through a few of them. Four ULP of pi (1.8e-15 rad) bounds that with
# room; a real change of the gait moves angles by 1e-6 rad or more.
GOLDEN_ATOL_RAD = 4 * float(np.spacing(np.pi))


def with_k(params: GaitParams, k: float, k_back: float = 0.0) -> GaitParams:
    return dataclasses.replace(params, steer=SteerParams(yaw_per_ca=k, yaw_per_ca_backward=k_back))


def test_k_zero_is_the_gait_before_the_steering_term() -> None:
    """The joint angles of the paper and the symmetric form, as computed before `steer` existed
    (tests/gait/data/behnke_golden.npz, written by the gait of commit d9dc00b), to a few ULP: the
    file was written by another numpy build (see GOLDEN_ATOL_RAD)."""
    gold = np.load(GOLDEN)
    phi = gold["phi"]
    forms = {"paper": GaitParams(), "symmetric": GaitParams(leg=LegParams(paper_signs=False))}
    for name, params in forms.items():
        assert params.steer.yaw_per_ca == 0.0
        now = np.stack([joint_angles(params, Motion(*m), phi) for m in gold["motions"]])
        np.testing.assert_allclose(now, gold[name], rtol=0, atol=GOLDEN_ATOL_RAD, err_msg=name)


@settings(max_examples=60, deadline=None)
@given(
    k=st.floats(-1.0, 1.0),
    k_back=st.floats(-1.0, 1.0),
    ca=st.floats(-0.5, 0.5),
    a_y=st.floats(-0.1, 0.1),  # a_y + K*CA stays inside a_y's range of +-0.6
    a_p=st.floats(-0.3, 0.3),
    phi=st.floats(-np.pi, np.pi, exclude_max=True),
)
def test_ca_turns_the_legs_like_an_a_y_of_k_times_ca(
    k: float, k_back: float, ca: float, a_y: float, a_p: float, phi: float
) -> None:
    """With K != 0, the leg yaw under CA is that of a_y + K*CA*s(a_p) without the term (the
    forward K for a_p >= 0, minus the backward one behind, faded below |a_p| = full_at_a_p);
    nothing else that the steering term could touch changes."""
    params = with_k(GaitParams(), k, k_back)
    s = min(max(a_p / params.steer.full_at_a_p, -1.0), 1.0)
    term = (k if a_p >= 0 else k_back) * ca * s
    assert params.steer.yaw_amplitude(a_p, ca) == term
    steered = leg_parameters(params, Motion(a_p=a_p, a_y=a_y, ca=ca), phi)
    plain = leg_parameters(GaitParams(), Motion(a_p=a_p, a_y=a_y + term, ca=ca), phi)
    np.testing.assert_allclose(steered[..., LEG_YAW], plain[..., LEG_YAW], atol=1e-12)
    # everything but the yaw is the gait without the term, at the same a_y (eq (39) uses a_y)
    unsteered = leg_parameters(GaitParams(), Motion(a_p=a_p, a_y=a_y, ca=ca), phi)
    others = [i for i in range(6) if i != LEG_YAW]
    np.testing.assert_array_equal(steered[..., others], unsteered[..., others])


def test_the_term_turns_the_way_ca_does() -> None:
    """K > 0 and CA > 0 swing the legs' yaw like a_y > 0 (clockwise, as CA > 0 turns)."""
    phi = np.linspace(-np.pi, np.pi, 64, endpoint=False)
    steered = leg_parameters(with_k(GaitParams(), 0.15), Motion(a_p=0.07, ca=0.1), phi)
    turning = leg_parameters(GaitParams(), Motion(a_p=0.07, a_y=0.015), phi)
    np.testing.assert_allclose(steered[..., LEG_YAW], turning[..., LEG_YAW], atol=1e-15)
    assert np.abs(steered[..., LEG_YAW]).max() > 0.01


def test_the_term_follows_eq_13_backward_and_fades_on_the_spot() -> None:
    """Eq (13): theta_dot = -2 CA V / b changes sign with V and is 0 at V = 0."""
    steer = SteerParams(yaw_per_ca=0.15, yaw_per_ca_backward=0.3, full_at_a_p=0.02)
    assert steer.yaw_amplitude(0.07, 0.1) == 0.15 * 0.1  # forward: like a_y = K CA, clockwise
    assert steer.yaw_amplitude(-0.07, 0.1) == -(0.3 * 0.1)  # backward: counter-clockwise
    assert steer.yaw_amplitude(0.0, 0.1) == 0.0  # on the spot: no turn
    assert steer.yaw_amplitude(0.01, 0.1) == 0.5 * 0.15 * 0.1  # half way to full_at_a_p
