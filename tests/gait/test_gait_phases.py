"""Properties of the walking-phase layer, eqs (10)–(45)."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gait import GaitParams, LegParams, Motion, leg_parameters, leg_parameters_with_flags
from gait.params import describe_fields, group_class
from gait.phases import (
    FOOT_PITCH,
    FOOT_ROLL,
    GAMMA,
    LEG_PITCH,
    LEG_ROLL,
    LEG_YAW,
    leg_phases,
    pi_cut,
    swing_profile,
)

LEFT, RIGHT = 0, 1
phases = st.floats(-np.pi, np.pi, allow_nan=False, exclude_max=True)


def motions(max_amp: float = 0.2) -> st.SearchStrategy[Motion]:
    amp = st.floats(-max_amp, max_amp, allow_nan=False)
    return st.builds(Motion, a_r=amp, a_p=amp, a_y=amp, ca=st.floats(-0.2, 0.2))


@st.composite
def gait_params(draw: st.DrawFn) -> GaitParams:
    """Random parameter sets inside the declared ranges, every phase switch random."""
    groups = {}
    for group in ("shift", "short", "swing", "load", "balance", "leg"):
        values = {}
        for name, _default, meta in describe_fields(group_class(group)):
            if meta["unit"] == "bool":
                values[name] = draw(st.booleans())
            else:
                values[name] = draw(st.floats(meta["min"], meta["max"], allow_nan=False))
        groups[group] = values
    return GaitParams.from_dict(groups)


def mirrored(m: Motion) -> Motion:
    return Motion(a_r=-m.a_r, a_p=m.a_p, a_y=-m.a_y, ca=-m.ca)


SYMMETRIC = GaitParams(leg=LegParams(paper_signs=False))


def test_paper_defaults() -> None:
    p = GaitParams().flat()
    assert p["shift.amp_base"] == 0.12 and p["shift.amp_lateral"] == 0.7
    assert p["short.v"] == 3.0 and p["short.o"] == -0.05 and p["short.foot_lift"] == 0.125
    assert p["swing.v"] == 2.0 and p["swing.o"] == -0.15 and p["swing.foot_pitch"] == 0.25
    assert p["load.v"] == 3.0 and p["load.amp_base"] == 0.025 and p["load.amp_pitch"] == 0.5
    assert p["balance.foot_roll_phase"] == 0.35 and p["balance.leg_roll_yaw"] == 0.1
    assert p["leg.eta_min"] == 0.875 and p["leg.paper_signs"] is True


def test_leg_phases_are_half_a_cycle_apart_and_wrapped() -> None:
    phi = np.linspace(-np.pi, np.pi, 101, endpoint=False)
    legs = leg_phases(phi)
    assert np.all((legs >= -np.pi) & (legs < np.pi))
    np.testing.assert_allclose(pi_cut(legs[:, LEFT] - legs[:, RIGHT]), -np.pi)
    np.testing.assert_allclose(legs[:, LEFT], pi_cut(phi + np.pi / 2))


def test_pi_cut_is_half_open() -> None:
    assert pi_cut(np.pi) == -np.pi
    assert pi_cut(-1e-20) <= 0.0
    assert -np.pi <= pi_cut(-np.pi - 1e-17) < np.pi


def test_swing_profile_pieces_meet_and_reverse_speed_closes_the_cycle() -> None:
    v = 2.0
    b = -2.0 / (2 * np.pi * v - np.pi)  # eq (26)
    eps = 1e-9
    for edge, value in ((np.pi / 2, 1.0), (-np.pi / 2, -1.0)):
        assert swing_profile(edge - eps, v) == pytest.approx(value, abs=1e-8)
        assert swing_profile(edge + eps, v) == pytest.approx(value, abs=1e-8)
    # over one cycle the linear reverse brings the swing back to where it started
    start, end = v * (-np.pi / 2), v * (3 * np.pi / 2)
    assert swing_profile(end, v) == pytest.approx(swing_profile(start, v))
    assert swing_profile(2.0, v) == pytest.approx(b * (2.0 - np.pi / 2) + 1)


@settings(max_examples=60, deadline=None)
@given(params=gait_params(), motion=motions(), phi=phases)
def test_periodic_in_the_trunk_phase(params: GaitParams, motion: Motion, phi: float) -> None:
    a = leg_parameters(params, motion, phi)
    b = leg_parameters(params, motion, phi + 2 * np.pi)
    np.testing.assert_allclose(a, b, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(params=gait_params(), motion=motions(0.3))
def test_continuous_where_the_pieces_meet(params: GaitParams, motion: Motion) -> None:
    """Over a fine grid, including the wrap at +-pi, no output jumps more than a smooth curve could.

    The steepest term is the sine swing: |d/dphi| <= v_swing * 2 * max(|a|), well below 40 rad/rad.
    A jump at a piece boundary (e.g. a shortening window cut by the wrap) would be >= 1e-3.
    """
    n = 40_000
    phi = np.linspace(-np.pi, 3 * np.pi, 2 * n + 1)  # two cycles: the wrap is inside
    out = leg_parameters(params, motion, phi)
    jumps = np.abs(np.diff(out, axis=0)).max()
    assert jumps <= 40.0 * (phi[1] - phi[0])


@settings(max_examples=60, deadline=None)
@given(motion=motions(), phi=phases)
def test_mirror_symmetry_of_the_symmetric_form(motion: Motion, phi: float) -> None:
    """Mirroring the motion swaps the legs, half a cycle later (leg angles are per-leg outwards)."""
    legs = leg_parameters(SYMMETRIC, motion, phi)
    mirror = leg_parameters(SYMMETRIC, mirrored(motion), phi + np.pi)
    np.testing.assert_allclose(mirror[LEFT], legs[RIGHT], atol=1e-12)
    np.testing.assert_allclose(mirror[RIGHT], legs[LEFT], atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(motion=motions(), phi=phases)
def test_paper_signs_differ_from_the_symmetric_form_in_exactly_three_terms(
    motion: Motion, phi: float
) -> None:
    """Eqs (30), (31), (39) as printed: foot roll swing without I_s, foot pitch swing with I_s,
    and 0.1*a_y instead of 0.1*|a_y|. Nothing else differs."""
    paper = leg_parameters(GaitParams(), motion, phi)
    symmetric = leg_parameters(SYMMETRIC, motion, phi)
    p = GaitParams()
    theta = swing_profile(p.swing.v * (leg_phases(phi) + np.pi / 2 + p.swing.o), p.swing.v)
    i_s = np.array([-1.0, 1.0])
    ca = np.array([1 + motion.ca, 1 - motion.ca])
    diff = paper - symmetric
    np.testing.assert_allclose(
        diff[:, FOOT_ROLL], 0.25 * motion.a_r * theta * (1 - i_s), atol=1e-12
    )
    np.testing.assert_allclose(
        diff[:, FOOT_PITCH], 0.25 * motion.a_p * theta * ca * (i_s - 1), atol=1e-12
    )
    leg_roll = 0.1 * (motion.a_y - abs(motion.a_y))
    np.testing.assert_allclose(diff[:, LEG_ROLL], [leg_roll, leg_roll], atol=1e-12)
    for k in (LEG_PITCH, LEG_YAW, GAMMA):
        np.testing.assert_array_equal(diff[:, k], 0.0)


@settings(max_examples=40, deadline=None)
@given(params=gait_params(), phi=phases, ca=st.floats(-0.3, 0.3))
def test_zero_motion_walks_on_the_spot_symmetrically(
    params: GaitParams, phi: float, ca: float
) -> None:
    """a = 0: no leg pitch or yaw, and the right leg does what the left did half a cycle before —
    with either sign convention, whatever CA is (CA only scales sagittal swing terms)."""
    legs = leg_parameters(params, Motion(ca=ca), phi)
    later = leg_parameters(params, Motion(ca=ca), phi + np.pi)
    assert np.all(legs[:, LEG_PITCH] == 0.0) and np.all(legs[:, LEG_YAW] == 0.0)
    np.testing.assert_allclose(later[RIGHT], legs[LEFT], atol=1e-12)


def test_ca_scales_only_the_sagittal_swing() -> None:
    phi = np.linspace(-np.pi, np.pi, 64, endpoint=False)
    base = Motion(a_r=0.05, a_p=0.07, a_y=0.1)
    p = GaitParams()
    no_swing = dataclasses.replace(p, swing=dataclasses.replace(p.swing, enabled=False))
    curved = dataclasses.replace(base, ca=0.1)
    # without the swing phase, CA changes nothing
    np.testing.assert_array_equal(
        leg_parameters(no_swing, base, phi), leg_parameters(no_swing, curved, phi)
    )
    straight, bent = leg_parameters(p, base, phi), leg_parameters(p, curved, phi)
    # the left leg's pitch swing is 1.1x, the right one's 0.9x; roll and yaw untouched
    np.testing.assert_allclose(bent[:, LEFT, LEG_PITCH], 1.1 * straight[:, LEFT, LEG_PITCH])
    np.testing.assert_allclose(bent[:, RIGHT, LEG_PITCH], 0.9 * straight[:, RIGHT, LEG_PITCH])
    np.testing.assert_array_equal(bent[..., LEG_YAW], straight[..., LEG_YAW])
    np.testing.assert_array_equal(bent[..., LEG_ROLL], straight[..., LEG_ROLL])


def test_phase_switches_remove_their_terms() -> None:
    p = GaitParams()
    off = {g: {"enabled": False} for g in ("shift", "short", "swing", "load", "balance")}
    still = leg_parameters(GaitParams.from_dict(off), Motion(0.1, 0.1, 0.1), np.linspace(-3, 3, 7))
    np.testing.assert_array_equal(still, 0.0)
    no_short = GaitParams.from_dict({"short": {"enabled": False}, "load": {"enabled": False}})
    assert np.all(
        leg_parameters(no_short, Motion(a_p=0.1), np.linspace(-3, 3, 50))[..., GAMMA] == 0
    )
    assert np.any(leg_parameters(p, Motion(a_p=0.1), np.linspace(-3, 3, 50))[..., GAMMA] < 0)


def test_gamma_is_clamped_and_the_clamp_reported() -> None:
    phi = np.linspace(-np.pi, np.pi, 400, endpoint=False)
    big = GaitParams.from_dict({"short": {"amp_base": 1.0, "amp_speed": 6.0}})
    out = leg_parameters_with_flags(big, Motion(a_p=0.3), phi)
    assert out.values[..., GAMMA].min() == -1.0
    assert out.gamma_clamped.any()
    normal = leg_parameters_with_flags(GaitParams(), Motion(a_p=0.07), phi)
    assert not normal.gamma_clamped.any() and normal.values[..., GAMMA].min() > -1.0


def test_vectorised_equals_one_phase_at_a_time() -> None:
    phi = np.linspace(-np.pi, np.pi, 37)
    m = Motion(0.05, 0.07, -0.1, 0.05)
    batch = leg_parameters(GaitParams(), m, phi.reshape(37, 1))
    one = np.stack([leg_parameters(GaitParams(), m, x) for x in phi])
    assert batch.shape == (37, 1, 2, 6)
    np.testing.assert_array_equal(batch[:, 0], one)


def test_shortening_lifts_the_leg_opposite_to_the_shift() -> None:
    """At phi_Trunk = 0 the trunk is shifted over the left foot and the right leg is shortened."""
    legs = leg_parameters(GaitParams(), Motion(), 0.0)
    assert legs[RIGHT, GAMMA] < -0.15 and legs[LEFT, GAMMA] > -0.001
    # left leg rolled inwards, right outwards: both feet to the right, the trunk to the left
    assert legs[LEFT, LEG_ROLL] < 0 < legs[RIGHT, LEG_ROLL]


@pytest.mark.parametrize(
    ("group", "field", "value", "message"),
    [
        ("swing", "v", 0.5, "out of range"),
        ("swing", "nope", 1.0, "unknown field swing.nope"),
        ("shift", "amp_base", float("nan"), "out of range"),
        ("shift", "enabled", 1, "true or false"),
        ("load", "v", "3", "must be a number"),
    ],
)
def test_bad_parameters_say_what_is_allowed(group, field, value, message) -> None:
    with pytest.raises(ValueError, match=message):
        GaitParams.from_dict({group: {field: value}})
    with pytest.raises(ValueError, match="allowed"):
        GaitParams.from_dict({"walk": {}})
    with pytest.raises(ValueError, match=r"allowed: -0\.3 to 0\.3"):
        Motion(a_p=0.5)
