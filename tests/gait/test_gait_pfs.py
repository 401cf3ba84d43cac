"""Seed 004's oscillator gait, eqs (1)–(3) and (10)–(11), and the engine switch."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gait import (
    ENGINES,
    GaitParams,
    Motion,
    PfsParams,
    behnke_joint_angles_with_flags,
    engine_groups,
    joint_angles,
    joint_angles_with_flags,
    pfs_joint_angles_with_flags,
    startup_gain,
)
from gait.params import SteerParams, describe_fields, merge, parse_settings
from gait.phases import leg_phases, swing_profile

LEFT, RIGHT = slice(0, 6), slice(6, 12)
HIP_YAW, HIP_ROLL, HIP_PITCH, KNEE, ANKLE_PITCH, ANKLE_ROLL = range(6)
PITCH = [HIP_PITCH, KNEE, ANKLE_PITCH]
PFS = GaitParams(engine="pfs")
phases = st.floats(-np.pi, np.pi, allow_nan=False, exclude_max=True)


def motions(max_amp: float = 0.3, max_ca: float = 0.5) -> st.SearchStrategy[Motion]:
    amp = st.floats(-max_amp, max_amp)
    return st.builds(Motion, a_r=amp, a_p=amp, a_y=amp, ca=st.floats(-max_ca, max_ca))


@st.composite
def pfs_params(draw: st.DrawFn) -> GaitParams:
    """Random oscillator sets inside the declared ranges, and a random steering term."""
    values = {
        name: draw(st.floats(meta["min"], meta["max"]))
        for name, _default, meta in describe_fields(PfsParams)
    }
    k = draw(st.floats(-1.0, 1.0))
    return dataclasses.replace(PFS, pfs=PfsParams(**values), steer=SteerParams(yaw_per_ca=k))


def legs(q: np.ndarray) -> np.ndarray:
    return q.reshape(*q.shape[:-1], 2, 6)


# --- the engine switch ---------------------------------------------------------------------------


def test_a_parameter_set_names_its_engine_and_joint_angles_follow_it() -> None:
    phi = np.linspace(-np.pi, np.pi, 50, endpoint=False)
    m = Motion(a_r=0.02, a_p=0.07, a_y=-0.1, ca=0.05)
    assert GaitParams().engine == "behnke" and ENGINES == ("behnke", "pfs")
    behnke = behnke_joint_angles_with_flags(GaitParams(), m, phi)
    np.testing.assert_array_equal(joint_angles(GaitParams(), m, phi), behnke.values)
    pfs, knee_clamped = pfs_joint_angles_with_flags(PFS, m, phi)
    out = joint_angles_with_flags(PFS, m, phi)
    np.testing.assert_array_equal(out.values, pfs)
    np.testing.assert_array_equal(out.gamma_clamped, knee_clamped)
    assert out.values.shape == (50, 12) and out.gamma_clamped.shape == (50, 2)
    assert not np.allclose(pfs, behnke.values)


def test_the_engine_is_validated_and_round_trips() -> None:
    with pytest.raises(ValueError, match="allowed: behnke, pfs"):
        GaitParams(engine="zmp")
    with pytest.raises(ValueError, match="allowed: behnke, pfs"):
        GaitParams.from_dict({"engine": 1})
    p = GaitParams.from_dict({"engine": "pfs", "pfs": {"knee_a": 0.2}})
    assert p.engine == "pfs" and p.pfs.knee_a == 0.2
    assert GaitParams.from_dict(p.to_dict()) == p
    flat = p.flat()
    assert flat["engine"] == "pfs" and flat["pfs.knee_a"] == 0.2 and flat["swing.v"] == 2.0


def test_a_setting_can_name_the_engine() -> None:
    patch = parse_settings(["engine=pfs", "pfs.knee_a=0.2"])
    assert merge(GaitParams(), patch) == GaitParams.from_dict(
        {"engine": "pfs", "pfs": {"knee_a": 0.2}}
    )
    with pytest.raises(ValueError, match="allowed: behnke, pfs"):
        merge(GaitParams(), parse_settings(["engine=zmp"]))


def test_engine_groups_list_what_each_engine_reads() -> None:
    feedback = ("attitude", "tilt", "yaw_rate", "damping", "cop", "timing")  # either engine
    assert engine_groups("pfs") == ("clock", "steer", "ramp", "pfs", *feedback)
    assert engine_groups("behnke") == (
        "clock", "shift", "short", "swing", "load", "balance", "leg", "lateral", "steer", "ramp",
        *feedback,
    )  # fmt: skip
    with pytest.raises(ValueError, match="allowed"):
        engine_groups("walk")
    # the pfs engine reads no behnke group: switching every behnke phase off changes nothing
    off = {g: {"enabled": False} for g in ("shift", "short", "swing", "load", "balance")}
    bare = dataclasses.replace(GaitParams.from_dict(off), engine="pfs")
    phi = np.linspace(-3, 3, 9)
    np.testing.assert_array_equal(
        joint_angles(bare, Motion(a_p=0.1), phi), joint_angles(PFS, Motion(a_p=0.1), phi)
    )


# --- eqs (2), (10), (11) ------------------------------------------------------------------------


def test_each_joint_is_an_offset_sine_and_the_right_leg_runs_pi_later() -> None:
    phi = np.linspace(-np.pi, np.pi, 64, endpoint=False)
    q = legs(joint_angles(PFS, Motion(), phi))
    p = PFS.pfs
    for index, name in ((HIP_ROLL, "hip_roll"), (KNEE, "knee"), (ANKLE_PITCH, "ankle_pitch")):
        c, a, phase = (getattr(p, f"{name}_{part}") for part in ("c", "a", "phi"))
        np.testing.assert_allclose(q[:, 0, index], c + a * np.sin(phi + phase), atol=1e-12)
        np.testing.assert_allclose(q[:, 1, index], c + a * np.sin(phi + phase + np.pi), atol=1e-12)
    np.testing.assert_array_equal(q[..., HIP_YAW], 0.0)


@settings(max_examples=60, deadline=None)
@given(params=pfs_params(), motion=motions(0.1), phi=phases)
def test_ca_scales_each_legs_whole_joint_function(
    params: GaitParams, motion: Motion, phi: float
) -> None:
    """Eqs (10)–(11): offset and oscillation alike, left by (1 + CA), right by (1 - CA); the
    steering term enters as the a_y it stands for."""
    term = params.steer.yaw_amplitude(motion.a_p, motion.ca)
    straight = Motion(motion.a_r, motion.a_p, motion.a_y + term, 0.0)
    curved = joint_angles(params, motion, phi)
    base = joint_angles(params, straight, phi)
    base[[KNEE, 6 + KNEE]] = np.minimum(base[[KNEE, 6 + KNEE]], 0.0)
    np.testing.assert_allclose(curved[LEFT], (1 + motion.ca) * base[LEFT], atol=1e-12)
    np.testing.assert_allclose(curved[RIGHT], (1 - motion.ca) * base[RIGHT], atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(motion=motions(), phi=phases)
def test_ca_is_antisymmetric(motion: Motion, phi: float) -> None:
    """Without the steering term, +CA and -CA bend each joint function equally the two ways."""
    plus = joint_angles(PFS, motion, phi)
    minus = joint_angles(PFS, dataclasses.replace(motion, ca=-motion.ca), phi)
    zero = joint_angles(PFS, dataclasses.replace(motion, ca=0.0), phi)
    np.testing.assert_allclose(plus - zero, zero - minus, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(params=pfs_params(), motion=motions(), phi=phases)
def test_mirror_symmetry(params: GaitParams, motion: Motion, phi: float) -> None:
    """Mirroring the motion (a_r, a_y, CA change sign) swaps the legs, half a cycle later."""
    mirrored = Motion(-motion.a_r, motion.a_p, -motion.a_y, -motion.ca)
    q = joint_angles(params, motion, phi)
    m = joint_angles(params, mirrored, phi + np.pi)
    np.testing.assert_allclose(m[LEFT], q[RIGHT], atol=1e-12)
    np.testing.assert_allclose(m[RIGHT], q[LEFT], atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(params=pfs_params(), motion=motions(), phi=phases)
def test_periodic_in_the_trunk_phase(params: GaitParams, motion: Motion, phi: float) -> None:
    a = joint_angles(params, motion, phi)
    np.testing.assert_allclose(joint_angles(params, motion, phi + 2 * np.pi), a, atol=1e-9)
    np.testing.assert_allclose(joint_angles(params, motion, phi - 6 * np.pi), a, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(params=pfs_params(), motion=motions())
def test_continuous(params: GaitParams, motion: Motion) -> None:
    """No joint moves faster than its sines allow: |d/dphi| <= (1 + |CA|) * sum of amplitudes
    (a stride oscillator's amplitude is stride_gain times its motion component)."""
    phi = np.linspace(-np.pi, 3 * np.pi, 20_001)
    q = joint_angles(params, motion, phi)
    p = params.pfs
    amplitude = max(p.hip_pitch_a, p.ankle_pitch_a, p.knee_a, p.hip_roll_a, p.ankle_roll_a)
    # a_y,eff <= 0.3 + 1 * 0.5; the stride oscillators are stride_gain * a * sin(...)
    stride = p.stride_gain * max(abs(motion.a_p), abs(motion.a_r), 2 * 0.8)
    bound = (1 + abs(motion.ca)) * (amplitude + stride) * (phi[1] - phi[0])
    assert np.abs(np.diff(q, axis=0)).max() <= bound * (1 + 1e-9)


@settings(max_examples=60, deadline=None)
@given(params=pfs_params(), motion=motions(), phi=phases, gain=st.floats(0.0, 1.0))
def test_the_knee_never_overstretches_and_a_clamp_is_reported(
    params: GaitParams, motion: Motion, phi: float, gain: float
) -> None:
    q, clamped = pfs_joint_angles_with_flags(params, motion, phi, gain)
    assert np.all(legs(q)[..., KNEE] <= 0.0)
    p = params.pfs
    raw = p.knee_c + gain * p.knee_a * np.sin(phi + p.knee_phi + np.array([0.0, np.pi]))
    np.testing.assert_array_equal(clamped, raw > 0.0)


def test_the_defaults_keep_every_joint_inside_its_limits_and_never_clamp() -> None:
    """Over the whole motion range and |CA| <= 0.5, at the corners: inside the servos' +-90 deg
    and the model's knee range [-90 deg, 0]."""
    phi = np.linspace(-np.pi, np.pi, 720, endpoint=False)
    for a_r in (-0.3, 0.3):
        for a_p in (-0.3, 0.3):
            for a_y in (-0.6, 0.6):
                for ca in (-0.5, 0.5):
                    q, clamped = pfs_joint_angles_with_flags(PFS, Motion(a_r, a_p, a_y, ca), phi)
                    assert not clamped.any()
                    assert np.abs(q).max() < np.pi / 2
                    assert legs(q)[..., KNEE].max() <= 0.0


# --- what the motion vector does ----------------------------------------------------------------


@pytest.mark.parametrize("a_p", [0.07, -0.07])
def test_a_p_swings_the_lifted_leg_forward_or_backward_and_keeps_the_sole_level(a_p: float) -> None:
    """Where the knee bends most (the foot in the air), the hip pitch grows for a_p > 0 (the leg
    swings forward) and shrinks for a_p < 0; the sole's pitch, the sum of the pitch joints
    (docs/DESIGN.md §3), is that of the gait on the spot."""
    phi = np.linspace(-np.pi, np.pi, 3600, endpoint=False)
    q = legs(joint_angles(PFS, Motion(a_p=a_p), phi))
    still = legs(joint_angles(PFS, Motion(), phi))
    for leg in (0, 1):
        lifted = np.argmin(q[:, leg, KNEE])
        velocity = np.gradient(q[:, leg, HIP_PITCH] - still[:, leg, HIP_PITCH])[lifted]
        assert np.sign(velocity) == np.sign(a_p)
    np.testing.assert_allclose(q[..., PITCH].sum(-1), still[..., PITCH].sum(-1), atol=1e-12)


def test_a_r_and_a_y_swing_roll_and_yaw_with_the_signs_of_eqs_27_and_29() -> None:
    phi = np.linspace(-np.pi, np.pi, 64, endpoint=False)
    still = legs(joint_angles(PFS, Motion(), phi))
    side = legs(joint_angles(PFS, Motion(a_r=0.1), phi)) - still
    turn = legs(joint_angles(PFS, Motion(a_y=0.2), phi))
    stride = np.sin(phi[:, None] + PFS.pfs.stride_phi + np.array([0.0, np.pi]))
    i_s = np.array([-1.0, 1.0])
    np.testing.assert_allclose(side[..., HIP_ROLL], i_s * 0.1 * stride, atol=1e-12)
    np.testing.assert_allclose(side[..., ANKLE_ROLL], -i_s * 0.1 * stride, atol=1e-12)
    np.testing.assert_allclose(turn[..., HIP_YAW], i_s * 0.2 * stride, atol=1e-12)


def test_trunk_over_the_left_foot_while_the_right_leg_is_lifted_at_phase_zero() -> None:
    """As in the behnke engine: at phi_Trunk = 0 the right knee is bent, the left nearly
    straight, and the left leg rolls inwards, the right outwards (trunk over the left foot)."""
    q = legs(joint_angles(PFS, Motion(), 0.0))
    assert q[1, KNEE] < -0.25 and q[0, KNEE] > -0.02
    assert q[0, HIP_ROLL] < 0 < q[1, HIP_ROLL]


# --- the start-up phase (seed 004 Fig. 3) -------------------------------------------------------


def test_startup_grows_the_oscillation_from_the_mean_pose() -> None:
    phi = np.linspace(-np.pi, np.pi, 64, endpoint=False)
    m = Motion(a_p=0.07, ca=0.1)
    assert PFS.pfs.startup_s == 2.0
    np.testing.assert_array_equal(startup_gain(PFS, [0.0, 0.5, 2.0, 5.0]), [0.0, 0.25, 1.0, 1.0])
    at_rest = joint_angles(PFS, m, phi, startup=0.0)
    np.testing.assert_allclose(at_rest, np.broadcast_to(at_rest[0], at_rest.shape), atol=1e-15)
    full = joint_angles(PFS, m, phi)
    half = joint_angles(PFS, m, phi, startup=0.5)
    np.testing.assert_allclose(half, 0.5 * (at_rest + full), atol=1e-12)
    # a gain per phase (a run's frames) is the same as one at a time
    gains = np.linspace(0, 1, 64)
    pairs = zip(phi, gains, strict=True)
    one_by_one = np.stack([joint_angles(PFS, m, x, startup=g) for x, g in pairs])
    np.testing.assert_allclose(joint_angles(PFS, m, phi, startup=gains), one_by_one, atol=1e-15)
    instant = GaitParams.from_dict({"engine": "pfs", "pfs": {"startup_s": 0.0}})
    np.testing.assert_array_equal(startup_gain(instant, [0.0, 1.0]), [1.0, 1.0])
    # the behnke engine starts through the motion ramp and has no start-up gain
    np.testing.assert_array_equal(startup_gain(GaitParams(), [0.0, 1.0]), [1.0, 1.0])


# --- the defaults --------------------------------------------------------------------------------


def first_harmonic(y: np.ndarray, phi: np.ndarray) -> tuple[float, float, float]:
    """(C, A, phi) with y ~ C + A sin(phi + phase)."""
    s, c = 2 * np.mean(y * np.sin(phi)), 2 * np.mean(y * np.cos(phi))
    return float(y.mean()), float(np.hypot(s, c)), float(np.arctan2(c, s))


def test_the_defaults_are_the_first_harmonic_of_the_paper_gait_stepping_on_the_spot() -> None:
    """The documented origin of the `pfs` defaults (gait/params.py): roll joints, the knee's
    phase, and the stride phase from the swing of eq (25), to the slider step."""
    phi = np.linspace(-np.pi, np.pi, 4096, endpoint=False)
    behnke = legs(joint_angles(GaitParams(), Motion(), phi))[:, 0]
    p = PFS.pfs
    for index, name in ((HIP_ROLL, "hip_roll"), (ANKLE_ROLL, "ankle_roll")):
        c, a, phase = first_harmonic(behnke[:, index], phi)
        assert (c, a) == pytest.approx((getattr(p, f"{name}_c"), getattr(p, f"{name}_a")), abs=1e-3)
        assert phase == pytest.approx(getattr(p, f"{name}_phi"), abs=0.005)
    _c, _a, knee_phase = first_harmonic(behnke[:, KNEE], phi)
    assert knee_phase == pytest.approx(p.knee_phi, abs=0.005)
    assert p.hip_pitch_phi == pytest.approx(p.knee_phi - np.pi, abs=0.005)
    assert p.knee_c == -p.knee_a and p.hip_pitch_a == p.ankle_pitch_a == p.knee_a / 2
    assert p.ankle_pitch_c == pytest.approx(p.hip_pitch_c + GaitParams().balance.foot_pitch_offset)
    sw = GaitParams().swing
    theta = swing_profile(sw.v * (leg_phases(phi)[:, 0] + np.pi / 2 + sw.o), sw.v)
    assert first_harmonic(theta, phi)[2] == pytest.approx(p.stride_phi, abs=0.005)
