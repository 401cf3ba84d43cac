"""The balance feedback laws (gait/feedback.py) against values computed by hand: each law alone,
its filter, dead band, integral and clamp, the joints it moves and their signs, float32 through
and through; every law off moves nothing."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gait import GaitParams, Motion
from gait.attitude import starts_attitude
from gait.feedback import (
    ANKLE_PITCH,
    ANKLE_ROLL,
    HIP_PITCH,
    HIP_ROLL,
    Reading,
    State,
    any_law_on,
    commanded_turn_rate,
    expected_tilt,
    step,
    support_cop,
)
from gait.feedback_params import CopParams, DampingParams, TiltParams, YawRateParams

G = 9.80665
DT = 0.02
F32 = np.float32
#: the force sensors' positions on a sole (fl, fr, bl, br), m
CORNERS = np.array([[0.03, 0.02], [0.03, -0.02], [-0.03, 0.02], [-0.03, -0.02]], dtype=F32)


def leaning(pitch: float = 0.0, roll: float = 0.0, gyro=(0.0, 0.0, 0.0), fsr=None) -> Reading:
    """A reading at rest, the trunk pitched and rolled so (the accelerometer's specific force)."""
    accel = [
        -G * math.sin(pitch),
        G * math.cos(pitch) * math.sin(roll),
        G * math.cos(pitch) * math.cos(roll),
    ]
    forces = np.full((2, 4), 2.0) if fsr is None else fsr
    return Reading(np.array(gyro, F32), np.array(accel, F32), np.array(forces, F32))


def run(laws: GaitParams, reading: Reading, frames: int, motion: Motion | None = None):
    motion = motion or Motion()
    state, out = State(), None
    for _ in range(frames):
        state, out = step(laws, state, reading, motion, CORNERS, DT)
    return state, out


def test_every_law_off_corrects_nothing_but_the_attitude_is_still_estimated():
    state, out = run(GaitParams(), leaning(pitch=0.1, gyro=(0.3, -0.2, 0.5)), 3)
    assert not any_law_on(GaitParams())
    assert not out.joint_delta_rad.any() and out.a_y_delta == 0.0
    assert state.started and state.pitch_rad != 0.0


def test_the_first_reading_starts_the_attitude_at_the_accelerometers_tilt():
    state, _ = run(GaitParams(), leaning(pitch=0.1, roll=-0.05), 1)
    assert state.pitch_rad == pytest.approx(0.1, abs=1e-6)
    assert state.roll_rad == pytest.approx(-0.05, abs=1e-6)


def test_a_reading_far_from_1_g_starts_no_attitude_and_the_tilt_trim_waits():
    """A robot dropped onto the floor reads ~0 g (it would start at a roll of 180°), one landing
    reads more than 1.1 g: no estimate, no trim; the damping still acts; the first reading
    within 10 % of g starts the attitude at its tilt."""
    laws = GaitParams(
        tilt=TiltParams(enabled=True, ki_per_s=5.0, kp=1.0, deadband_rad=0.0),
        damping=DampingParams(enabled=True, ankle_pitch=0.02, ankle_roll=0.0),
    )
    falling = Reading(np.array([0.0, -1.0, 0.0], F32), np.zeros(3, F32), np.zeros((2, 4), F32))
    state, out = step(laws, State(), falling, Motion(), CORNERS, DT)
    assert not state.started and (state.pitch_rad, state.roll_rad) == (0.0, 0.0)
    assert not out.tilt_rad.any() and not state.tilt_error.any() and not state.tilt_integral.any()
    assert out.joint_delta_rad[ANKLE_PITCH[0]] == pytest.approx(0.02)  # damping: -0.02 * -1.0
    landing = leaning(pitch=0.1)
    landing = dataclasses.replace(landing, accel_m_s2=landing.accel_m_s2 * F32(1.15))
    state, out = step(laws, state, landing, Motion(), CORNERS, DT)
    assert not state.started and not out.tilt_rad.any()
    state, out = step(laws, state, leaning(pitch=0.1, roll=-0.05), Motion(), CORNERS, DT)
    assert state.started and state.pitch_rad == pytest.approx(0.1, abs=1e-6)
    assert state.roll_rad == pytest.approx(-0.05, abs=1e-6)
    assert out.tilt_rad[0] > 0.0  # and the trim acts from this frame


def test_the_start_band_by_hand():
    for share, starts in ((0.89, False), (0.91, True), (1.0, True), (1.09, True), (1.11, False)):
        accel = np.array([0.6, -0.8, 0.0]) * G * share  # |a| = share * g, tilted 90°
        assert bool(starts_attitude(accel)) is starts, share


def test_tilt_trim_by_hand():
    """Leaning 0.05 forward against an expected 0.02: error 0.03; the filter (tau 0.5) passes
    dt / (tau + dt) of it per frame, the dead band 0.005 takes its share, ki 0.5 integrates."""
    tilt = TiltParams(enabled=True, pitch_offset_rad=0.02, filter_s=0.5, deadband_rad=0.005,
                      ki_per_s=0.5, kp=0.2, clamp_rad=0.1)  # fmt: skip
    laws = GaitParams(tilt=tilt)
    state, out = run(laws, leaning(pitch=0.05), 1)
    filtered = 0.03 * DT / (0.5 + DT)
    assert state.tilt_error[0] == pytest.approx(filtered, rel=1e-5)
    past = max(filtered - 0.005, 0.0)
    assert past == 0.0  # one frame: still inside the dead band
    assert out.tilt_rad[0] == 0.0
    state, out = run(laws, leaning(pitch=0.05), 60)
    filtered = 0.03 * (1 - (0.5 / 0.52) ** 60)
    assert state.tilt_error[0] == pytest.approx(filtered, rel=1e-4)
    assert out.tilt_rad[0] > 0.2 * (filtered - 0.005)  # the integral adds to kp's share
    # a forward lean lowers both toes by the pitch trim, nothing else moves
    np.testing.assert_array_equal(out.joint_delta_rad[list(ANKLE_PITCH)], [-out.tilt_rad[0]] * 2)
    others = np.delete(out.joint_delta_rad, list(ANKLE_PITCH))
    assert not others.any()


def test_tilt_trim_rolls_the_hips_against_a_lean_and_stops_at_its_clamp():
    laws = GaitParams(tilt=TiltParams(enabled=True, ki_per_s=5.0, kp=1.0, clamp_rad=0.04))
    state, out = run(laws, leaning(roll=0.1), 400)  # leaning right (roll > 0)
    assert out.tilt_rad[1] == pytest.approx(0.04)  # clamped
    assert state.tilt_integral[1] == pytest.approx(0.04)  # no wind-up beyond the clamp
    left, right = out.joint_delta_rad[list(HIP_ROLL)]
    assert left == pytest.approx(0.04) and right == pytest.approx(-0.04)  # left out, right in


@pytest.mark.parametrize("share", [0.0, 0.5])
def test_the_roll_share_scales_the_hips_roll_trim_and_leaves_the_pitch_trim(share):
    lean = leaning(pitch=0.08, roll=0.1)
    whole = TiltParams(enabled=True, ki_per_s=0.5, kp=0.2, clamp_rad=0.1)
    _, full = run(GaitParams(tilt=whole), lean, 30)
    state, out = run(GaitParams(tilt=dataclasses.replace(whole, roll_share=share)), lean, 30)
    assert 0.0 < full.tilt_rad[1] < 0.1  # the law's roll trim, not clamped
    assert out.tilt_rad[0] == full.tilt_rad[0]  # pitch as before, to the bit
    assert out.tilt_rad[1] == pytest.approx(share * full.tilt_rad[1], rel=1e-6)
    left, right = out.joint_delta_rad[list(HIP_ROLL)]
    assert left == pytest.approx(share * full.tilt_rad[1]) and right == -left
    assert state.tilt_integral[1] > 0.0  # the law runs on: the share scales what the hips get


def test_the_expected_tilt_follows_the_motion():
    tilt = TiltParams(pitch_offset_rad=0.03, pitch_per_a_p=0.5, roll_per_a_r=-0.2)
    np.testing.assert_allclose(
        expected_tilt(tilt, Motion(a_r=0.1, a_p=0.07)), [0.03 + 0.035, -0.02], rtol=1e-6
    )


def test_yaw_rate_loop_by_hand():
    yaw = YawRateParams(enabled=True, turn_per_a_y=-1.0, speed_per_a_p=0.5, axle_m=0.1,
                        filter_s=0.0 + 0.02, kp=0.1, ki_per_s=0.2, clamp=0.15)  # fmt: skip
    motion = Motion(a_p=0.07, ca=0.1)
    want = -2.0 * 0.1 * (0.5 * 0.07) / 0.1  # eq (13): -0.07 rad/s, clockwise
    assert commanded_turn_rate(yaw, motion) == pytest.approx(want)
    state, out = run(GaitParams(yaw_rate=yaw), leaning(gyro=(0.0, 0.0, 0.0)), 1, motion)
    error = want - 0.0
    filtered = error * DT / (0.02 + DT)
    integral = 0.2 * DT * filtered
    assert state.yaw_error == pytest.approx(filtered, rel=1e-5)
    assert out.a_y_delta == pytest.approx(-(integral + 0.1 * filtered), rel=1e-5)
    assert out.a_y_delta > 0  # turning too little clockwise: more a_y (clockwise)
    assert not out.joint_delta_rad.any()


def test_gyro_damping_by_hand():
    damping = DampingParams(enabled=True, ankle_pitch=0.02, ankle_roll=0.03, hip_pitch=0.01,
                            hip_roll=0.04)  # fmt: skip
    _, out = run(GaitParams(damping=damping), leaning(gyro=(0.5, -1.0, 2.0)), 1)
    d = out.joint_delta_rad
    np.testing.assert_allclose(d[list(ANKLE_PITCH)], [0.02, 0.02], rtol=1e-6)  # pitching back
    np.testing.assert_allclose(d[list(HIP_PITCH)], [0.01, 0.01], rtol=1e-6)
    np.testing.assert_allclose(d[list(ANKLE_ROLL)], [0.015, -0.015], rtol=1e-6)
    np.testing.assert_allclose(d[list(HIP_ROLL)], [0.02, -0.02], rtol=1e-6)
    np.testing.assert_array_equal(d, out.damping_rad)


def test_the_support_foots_centre_of_pressure():
    forces = np.array([[1.0, 1.0, 1.0, 1.0], [4.0, 0.0, 4.0, 0.0]], F32)  # right foot, inner edge
    foot, cop = support_cop(forces, CORNERS, 1.0)
    assert foot == 1
    np.testing.assert_allclose(cop, [0.0, -0.02], atol=1e-7)  # y inward for the right foot
    assert support_cop(forces * 0.1, CORNERS, 1.0)[0] == -1  # neither carries 1 N
    # feet in the air with a minimum load of 0: no foot carries, no 0 / 0 (the firmware alike)
    foot, cop = support_cop(forces * 0.0, CORNERS, 0.0)
    assert foot == -1 and np.all(cop == 0.0)


def test_cop_loop_by_hand():
    cop = CopParams(enabled=True, kp=0.5, ki_per_s=2.0, kd_s=0.01, clamp_rad=0.05)
    forces = np.array([[3.0, 3.0, 1.0, 1.0], [0.0, 0.0, 0.0, 0.0]], F32)  # left toes
    _, out = run(GaitParams(cop=cop), leaning(fsr=forces), 1)
    x = (3 * 0.03 + 3 * 0.03 - 0.03 - 0.03) / 8  # 0.015 m forward
    want = 0.5 * x + 2.0 * DT * x + 0.01 * x / DT
    assert out.support == 0
    assert out.cop_rad[0] == pytest.approx(want, rel=1e-5)
    assert out.joint_delta_rad[ANKLE_PITCH[0]] == pytest.approx(want, rel=1e-5)  # toes up
    assert out.joint_delta_rad[ANKLE_PITCH[1]] == 0.0  # the swing foot is left alone


def test_the_laws_compute_in_float32():
    laws = GaitParams(
        tilt=TiltParams(enabled=True, kp=0.5),
        yaw_rate=YawRateParams(enabled=True),
        damping=DampingParams(enabled=True),
        cop=CopParams(enabled=True),
    )
    state, out = run(laws, leaning(pitch=0.1, roll=0.02, gyro=(0.1, 0.2, 0.3)), 5, Motion(a_y=0.1))
    for value in (out.joint_delta_rad, out.tilt_rad, out.cop_rad, out.a_y_delta, state.pitch_rad):
        assert np.asarray(value).dtype == np.float32
    for f in dataclasses.fields(state):
        value = getattr(state, f.name)
        assert isinstance(value, bool) or np.asarray(value).dtype == np.float32, f.name
