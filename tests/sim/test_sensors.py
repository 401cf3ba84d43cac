"""The sensors as the robot has them (app/sim/sensors.py) and the attitude estimate
(gait/attitude.py): a standing robot's soles carry its weight, the IMU's tilt reads as a lean
by that tilt, the gyro's noise repeats to the bit for a variation, the delay picks the older
step, the parts' quantisation; the filter's angles against hand-computed ones."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from app.robots import build_spec
from app.robots.model import RobotModel
from app.robots.model_parts import FSR_CORNERS
from app.sim.force_sensors import fsr_forces
from app.sim.frame_loop import FrameLoop
from app.sim.planning import START_PHASE_RAD
from app.sim.robot_pose import stand
from app.sim.sensors import (
    ACCEL_M_S2_PER_COUNT,
    GRAVITY_M_S2,
    GYRO_RAD_S_PER_COUNT,
    Sensors,
    mount_rotation,
    quantised,
)
from app.worlds.servo_path import latency_steps
from app.worlds.variations import NOMINAL, Variation, parse_variation
from gait import GaitParams, Motion
from gait.attitude import PITCH_LIMIT_RAD, accel_tilt, complementary_step

ROBOT = RobotModel.load()


@pytest.fixture(scope="module")
def standing() -> tuple[np.ndarray, mujoco.MjData]:
    """1 s standing still in the gait's stance: the sensor rows, one per physics step, and the
    data as the last step left it."""
    data = mujoco.MjData(ROBOT.model)
    stand(ROBOT, data, GaitParams(), Motion(), START_PHASE_RAD)
    rows = []
    for _ in range(1000):
        mujoco.mj_step(ROBOT.model, data)
        rows.append(data.sensordata.copy())
    return np.array(rows), data


def read(sensors: Sensors, standing: tuple[np.ndarray, mujoco.MjData]):
    return sensors.read(*standing)


def test_the_soles_of_a_standing_robot_carry_its_weight_on_all_eight_sensors(standing):
    reading = read(Sensors(ROBOT), standing)
    weight_n = ROBOT.total_mass_kg() * GRAVITY_M_S2
    assert reading.fsr_n.sum() == pytest.approx(weight_n, rel=0.01)
    assert np.all(reading.fsr_n > 0.1 * weight_n / 8)  # every corner touches
    cop = reading.centre_of_pressure_m(ROBOT.fsr_positions_m)
    half = ROBOT.fsr_positions_m.max(axis=0)
    assert np.all(np.abs(cop) < half)  # inside the sensors' box, near the sole centre
    gained = read(Sensors(ROBOT, Variation(fsr_gain=1.2)), standing)
    np.testing.assert_allclose(gained.fsr_n, 1.2 * reading.fsr_n, atol=0.015)  # an ADC step


def test_a_foot_in_the_air_has_no_centre_of_pressure(standing):
    reading = read(Sensors(ROBOT), standing)
    lifted = type(reading)(reading.gyro_rad_s, reading.accel_m_s2, reading.fsr_n * [[1], [0]])
    cop = lifted.centre_of_pressure_m(ROBOT.fsr_positions_m)
    assert np.all(np.isfinite(cop[0])) and np.all(np.isnan(cop[1]))


@pytest.mark.parametrize(
    ("direction_deg", "pitch_deg", "roll_deg"),
    [(0.0, 1.5, 0.0), (180.0, -1.5, 0.0), (90.0, 0.0, -1.5), (270.0, 0.0, 1.5)],
)
def test_the_imu_tilt_reads_as_a_lean_by_that_tilt(standing, direction_deg, pitch_deg, roll_deg):
    """Forward (0°) leans the nose down (pitch +), toward the left (90°) lowers the left side
    (roll -): the ROS axes of docs/DESIGN.md §3."""
    true_pitch, true_roll = accel_tilt(read(Sensors(ROBOT), standing).accel_m_s2)
    tilted = Variation(imu_tilt_bias_deg=1.5, imu_tilt_direction_deg=direction_deg)
    pitch, roll = accel_tilt(read(Sensors(ROBOT, tilted), standing).accel_m_s2)
    assert math.degrees(pitch - true_pitch) == pytest.approx(pitch_deg, abs=0.02)
    assert math.degrees(roll - true_roll) == pytest.approx(roll_deg, abs=0.02)


def test_gyro_bias_and_seeded_noise(standing):
    still = read(Sensors(ROBOT), standing).gyro_rad_s
    biased = read(Sensors(ROBOT, Variation(gyro_bias_deg_s=0.5)), standing).gyro_rad_s
    np.testing.assert_allclose(biased - still, math.radians(0.5), atol=GYRO_RAD_S_PER_COUNT)
    noisy = parse_variation("gyro_noise_deg_s=0.1,friction=0.8")
    first, again = Sensors(ROBOT, noisy), Sensors(ROBOT, noisy)
    a = [read(first, standing).gyro_rad_s for _ in range(50)]
    b = [read(again, standing).gyro_rad_s for _ in range(50)]
    assert np.array_equal(a, b)  # the same variation reads the same noise, to the bit
    spread = np.std(np.array(a) - still, axis=0)
    assert np.all(spread > 0.5 * math.radians(0.1)) and np.all(spread < 2 * math.radians(0.1))
    other = Sensors(ROBOT, parse_variation("gyro_noise_deg_s=0.1,friction=0.7"))
    assert not np.array_equal(a, [read(other, standing).gyro_rad_s for _ in range(50)])


def test_the_delay_reads_the_imu_that_many_steps_before(standing):
    rows = np.zeros((30, ROBOT.model.nsensordata))
    rows[:, ROBOT.accel_adr + 2] = np.arange(30.0)  # a ramp: row k reads k m/s²
    sensors = Sensors(ROBOT, Variation(imu_delay_ms=12.0))
    assert sensors.delay_steps == 12 and sensors.steps_needed == 13
    reading = sensors.read(rows, standing[1])
    assert reading.accel_m_s2[2] == pytest.approx(29 - 12, abs=ACCEL_M_S2_PER_COUNT)
    with pytest.raises(ValueError, match="last 13 steps"):
        sensors.read(rows[-12:], standing[1])


@pytest.mark.parametrize("delay_ms", [0.5, 2.5, 12.5, 24.5])
def test_the_imu_delay_rounds_as_the_servos_latency(delay_ms):
    """Whole steps, half up for both (`latency_steps`); the IMU's once rounded half to even."""
    steps = Sensors(ROBOT, Variation(imu_delay_ms=delay_ms)).delay_steps
    assert steps == latency_steps(delay_ms, ROBOT.model.opt.timestep) == math.ceil(delay_ms)


def test_the_force_sensors_read_what_mujoco_touch_sensors_read_to_the_bit():
    """The same model with a MuJoCo touch sensor on every zone site, walking: `fsr_forces` after
    each step equals the sensors' data, to the bit (MuJoCo's own rule, from the step's data)."""
    spec = build_spec(ROBOT.description)
    for side in ("l", "r"):
        for corner in FSR_CORNERS:
            name = f"{side}_fsr_{corner}"
            spec.add_sensor(
                name=f"touch_{name}",
                type=mujoco.mjtSensor.mjSENS_TOUCH,
                objtype=mujoco.mjtObj.mjOBJ_SITE,
                objname=name,
            )
    robot = RobotModel.of_model(ROBOT.description, spec.compile())
    touch = [robot.model.sensor(f"touch_{s}_fsr_{c}").adr[0] for s in "lr" for c in FSR_CORNERS]
    loop = FrameLoop(robot, GaitParams(), Motion(a_p=0.07))
    seen = 0.0
    for _ in range(100):
        loop.step_frame()
        want = loop.data.sensordata[touch].reshape(2, 4)
        assert np.array_equal(fsr_forces(robot, loop.data), want)
        seen += want.sum()
    assert seen > 100.0  # the feet carried the robot


def test_the_parts_quantise_to_their_counts_within_16_bits():
    assert quantised(np.array([0.4 * GYRO_RAD_S_PER_COUNT]), GYRO_RAD_S_PER_COUNT)[0] == 0.0
    full = quantised(np.array([10.0, -10.0]), GYRO_RAD_S_PER_COUNT)  # beyond ±250 °/s
    np.testing.assert_allclose(np.degrees(full), [32767 / 131, -32768 / 131])
    g = quantised(np.array([GRAVITY_M_S2]), ACCEL_M_S2_PER_COUNT)[0]
    assert g == pytest.approx(16384 * ACCEL_M_S2_PER_COUNT)


def test_the_nominal_variation_reads_ideal_sensors_but_for_the_parts(standing):
    reading = read(Sensors(ROBOT, NOMINAL), standing)
    true = standing[0][-1]
    gyro = true[ROBOT.gyro_adr : ROBOT.gyro_adr + 3]
    np.testing.assert_allclose(reading.gyro_rad_s, gyro, atol=GYRO_RAD_S_PER_COUNT / 2)


@given(tilt_deg=st.floats(0.0, 10.0), direction_deg=st.floats(0.0, 359.9))
def test_a_mount_rotation_is_a_rotation_by_its_tilt(tilt_deg, direction_deg):
    r = mount_rotation(tilt_deg, direction_deg)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    angle = math.degrees(math.acos(min(1.0, (np.trace(r) - 1.0) / 2.0)))
    assert angle == pytest.approx(tilt_deg, abs=1e-5)
    assert r[2, 2] == pytest.approx(math.cos(math.radians(tilt_deg)))  # z tilts by it


def test_accel_tilt_against_hand_computed_angles():
    g = GRAVITY_M_S2
    pitch, roll = accel_tilt(np.array([-g * math.sin(0.1), 0.0, g * math.cos(0.1)]))
    assert pitch == pytest.approx(0.1) and roll == pytest.approx(0.0)
    pitch, roll = accel_tilt(np.array([0.0, g * math.sin(-0.2), g * math.cos(-0.2)]))
    assert pitch == pytest.approx(0.0) and roll == pytest.approx(-0.2)


def test_the_complementary_filter_blends_gyro_and_accelerometer():
    """One step by hand: tau 0.5 s, dt 0.02 s -> the gyro path weighs 0.5 / 0.52."""
    g = GRAVITY_M_S2
    accel = np.array([-g * math.sin(0.05), 0.0, g * math.cos(0.05)])  # at rest, pitched 0.05
    gyro = np.array([0.0, 0.3, 0.0])  # pitching forward at 0.3 rad/s
    pitch, roll = complementary_step(0.0, 0.0, gyro, accel, 0.02, 0.5)
    keep = 0.5 / 0.52
    assert pitch == pytest.approx(keep * 0.3 * 0.02 + (1 - keep) * 0.05)
    assert roll == pytest.approx(0.0)
    # at rest it converges on the accelerometer's tilt, with the time constant
    p, r = np.float64(0.0), np.float64(0.0)
    for _ in range(250):  # 5 s = 10 tau
        p, r = complementary_step(p, r, np.zeros(3), accel, 0.02, 0.5)
    assert p == pytest.approx(0.05, abs=1e-5)


def test_the_estimate_rolls_over_within_pi_and_its_pitch_stays_off_the_singularity():
    """A robot rolled over: the roll goes on past π as -π + ..., never blended to 0 across the
    wrap; pitched past the vertical, the pitch stops at PITCH_LIMIT_RAD (tan(pitch) is finite)."""
    g = GRAVITY_M_S2
    roll, rolls = np.float64(0.0), []
    for k in range(1, 160):  # 2.5 rad/s about x for 3.2 s: 8 rad, past π
        angle = 0.05 * k
        accel = np.array([0.0, g * math.sin(angle), g * math.cos(angle)])
        _, roll = complementary_step(0.0, roll, np.array([2.5, 0.0, 0.0]), accel, 0.02, 0.5)
        rolls.append(float(roll))
        wrapped = math.remainder(angle, 2 * math.pi)
        assert abs(math.remainder(float(roll) - wrapped, 2 * math.pi)) < 0.05, (k, roll)
    assert all(-math.pi < r <= math.pi for r in rolls) and min(rolls) < -3.0
    pitch, pitches = np.float64(0.0), []
    for k in range(1, 60):  # 2.5 rad/s about y: over the top
        accel = np.array([-g * math.sin(0.05 * k), 0.0, g * math.cos(0.05 * k)])
        pitch, _ = complementary_step(pitch, 0.0, np.array([0.0, 2.5, 0.0]), accel, 0.02, 0.5)
        pitches.append(float(pitch))
    assert max(pitches) == PITCH_LIMIT_RAD and min(pitches) >= 0.0


def test_the_filter_keeps_float32():
    """The firmware runs it in float32: float32 in, float32 out."""
    f = np.float32
    accel = np.array([0.5, -0.3, 9.7], dtype=f)
    gyro = np.array([0.01, -0.02, 0.1], dtype=f)
    pitch, roll = complementary_step(f(0.01), f(-0.02), gyro, accel, 0.02, 0.5)
    assert pitch.dtype == np.float32 and roll.dtype == np.float32
    wide = complementary_step(0.01, -0.02, gyro.astype(float), accel.astype(float), 0.02, 0.5)
    assert pitch == pytest.approx(wide[0], rel=1e-5) and roll == pytest.approx(wide[1], rel=1e-5)
