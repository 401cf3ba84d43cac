"""The loop closed in the frame loop (docs/DESIGN.md §15): every law off walks the open-loop gait
to the bit; the tilt trim moves the stance by an IMU tilt it cannot tell from a lean (it reads
only the sensor); a noisy run repeats to the bit; a push changes the momentum by its impulse."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from app.evaluation import BatchEvaluator, Job
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.sim.headless import run
from app.worlds.variations import NOMINAL, Variation, parse_variation
from gait import GaitParams, Motion
from gait.feedback_params import (
    CopParams,
    DampingParams,
    TiltParams,
    TimingParams,
    YawRateParams,
)

ROBOT = RobotModel.load()
TUNED = builtin_presets()["tuned"].gait
#: the tuned stance leans 4.5° back on the spot: the trim holds that (expected) tilt; no dead
#: band, so the integral settles on the error's zero, not on the band's edge
TRIMMED = dataclasses.replace(
    TUNED,
    tilt=TiltParams(
        enabled=True, pitch_offset_rad=math.radians(-4.5), ki_per_s=0.5, deadband_rad=0.0
    ),
)


def trunk_pitch_deg(data: mujoco.MjData) -> float:
    """The trunk's true pitch (forward > 0) from its orientation, not from any sensor."""
    w, x, y, z = data.qpos[3:7]
    return math.degrees(math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x)))))


def mean_pitch_deg(params: GaitParams, variation: Variation, seconds: float = 16.0) -> float:
    loop = FrameLoop(ROBOT, params, Motion(), variation=variation)
    pitches = []
    for _ in range(round(seconds / 0.02)):
        loop.step_frame()
        pitches.append(trunk_pitch_deg(loop.data))
        assert not loop.fell
    return float(np.mean(pitches[-300:]))  # the last 6 s, the trim settled


def test_every_law_off_is_the_open_loop_gait_to_the_bit():
    """Switches off, gains anything: the same run as before the laws existed."""
    gains = dataclasses.replace(
        TUNED,
        tilt=TiltParams(enabled=False, ki_per_s=3.0),
        damping=DampingParams(enabled=False, ankle_pitch=0.05),
    )
    world = parse_variation("friction=0.6,latency_ms=20,gyro_noise_deg_s=0.1,imu_delay_ms=10")
    a = run(TUNED, Motion(a_p=0.07), duration_s=4.0, warmup_s=1.0, variation=world)
    b = run(gains, Motion(a_p=0.07), duration_s=4.0, warmup_s=1.0, variation=world)
    strip = ("wall_s", "rtf")
    assert {k: v for k, v in a.metrics.items() if k not in strip} == {
        k: v for k, v in b.metrics.items() if k not in strip
    }


@pytest.mark.slow
def test_a_tilt_bias_moves_the_trimmed_stance_by_that_bias():
    """The IMU tilted 1° forward reads a 1° forward lean the trunk does not have: the trim,
    which sees only the sensor, leans the robot 1° back."""
    level = mean_pitch_deg(TRIMMED, NOMINAL)
    assert level == pytest.approx(-4.5, abs=0.3)  # the trim holds the expected tilt
    biased = mean_pitch_deg(TRIMMED, Variation(imu_tilt_bias_deg=1.0, imu_tilt_direction_deg=0.0))
    assert biased - level == pytest.approx(-1.0, abs=0.25)
    # without the trim the same bias changes nothing: the open-loop gait reads no sensor
    assert mean_pitch_deg(TUNED, Variation(imu_tilt_bias_deg=1.0), 6.0) == pytest.approx(
        mean_pitch_deg(TUNED, NOMINAL, 6.0), abs=1e-12
    )


def test_a_seeded_noisy_closed_loop_run_repeats_to_the_bit_and_another_world_differs():
    params = dataclasses.replace(
        TUNED, damping=DampingParams(enabled=True), yaw_rate=YawRateParams(enabled=True)
    )
    noisy = parse_variation("gyro_noise_deg_s=0.1,gyro_bias_deg_s=0.3,imu_delay_ms=12")
    first = run(params, Motion(a_p=0.07), duration_s=3.0, warmup_s=1.0, variation=noisy)
    again = run(params, Motion(a_p=0.07), duration_s=3.0, warmup_s=1.0, variation=noisy)
    assert first.trace.yaw_rad == again.trace.yaw_rad
    assert first.metrics["gyro_rms"] == again.metrics["gyro_rms"]
    other = dataclasses.replace(noisy, gyro_noise_deg_s=0.09)
    third = run(params, Motion(a_p=0.07), duration_s=3.0, warmup_s=1.0, variation=other)
    assert third.trace.yaw_rad != first.trace.yaw_rad


def momentum(loop: FrameLoop) -> np.ndarray:
    """The whole robot's linear momentum, N·s."""
    model, data = loop.model, loop.data
    mujoco.mj_forward(model, data)
    mujoco.mj_subtreeVel(model, data)
    trunk = loop.robot.trunk_id
    return model.body_subtreemass[trunk] * data.subtree_linvel[trunk].copy()


@pytest.mark.parametrize("direction_deg", [0.0, 135.0])
def test_a_push_changes_the_trunks_momentum_by_its_impulse(direction_deg):
    """Two robots alike to the push's step; after it their momenta differ by the impulse, in
    its direction (within what friction gives back in that one step; the feet's vertical
    answer to the tipping it starts is the floor's, not the push's)."""
    push = Variation(push_n_s=0.5, push_time_s=1.0, push_direction_deg=direction_deg)
    pushed = FrameLoop(ROBOT, TUNED, Motion(), variation=push)
    still = FrameLoop(ROBOT, TUNED, Motion())
    for _ in range(50):  # to t = 1.0 s: the push is in the next step
        pushed.step_frame()
        still.step_frame()
    assert np.array_equal(pushed.data.qvel, still.data.qvel)  # nothing yet
    pushed._advance(1)  # the push's step
    still._advance(1)
    change = momentum(pushed) - momentum(still)
    d = math.radians(direction_deg)
    np.testing.assert_allclose(change[:2], [0.5 * math.cos(d), 0.5 * math.sin(d)], atol=0.03)
    assert abs(change[2]) < 0.1
    assert not pushed.data.xfrc_applied.any()  # for one step only


def test_watching_the_sensors_changes_nothing_the_robot_does():
    """The dashboard's loop reads the sensors and estimates the attitude every frame with every
    law off: the same bits as a loop that reads nothing, in a varied world too."""
    world = parse_variation("latency_ms=20,backlash_deg=0.5,gyro_noise_deg_s=0.1,imu_delay_ms=10")
    watched = FrameLoop(ROBOT, TUNED, Motion(a_p=0.07), variation=world)
    watched.watch_sensors = True
    plain = FrameLoop(ROBOT, TUNED, Motion(a_p=0.07), variation=world)
    for _ in range(100):
        record = watched.step_frame()
        assert plain.step_frame().reading is None
    assert record.reading is not None and record.feedback is not None
    assert not record.feedback.joint_delta_rad.any()  # no law on: no correction
    assert np.array_equal(watched.data.qpos, plain.data.qpos)
    assert np.array_equal(watched.data.qvel, plain.data.qvel)


def test_a_live_push_is_the_worlds_push_turned_with_the_robot():
    """`push_now` (the dashboard's Push, relative to where the trunk faces) acts in the next
    physics step as a world push of the same impulse in the world's direction does."""
    loop = FrameLoop(ROBOT, TUNED, Motion(a_p=0.07, a_y=0.1))
    for _ in range(50):
        loop.step_frame()
    yaw_deg = math.degrees(loop.trunk_pose()[2])
    assert abs(yaw_deg) > 1.0  # the robot has turned: the two frames differ
    world = Variation(push_n_s=0.4, push_time_s=1.0, push_direction_deg=(yaw_deg + 90.0) % 360.0)
    pushed = FrameLoop(ROBOT, TUNED, Motion(a_p=0.07, a_y=0.1), variation=world)
    for _ in range(50):
        pushed.step_frame()
    loop.push_now(0.4, 90.0)
    for _ in range(25):
        loop.step_frame()
        pushed.step_frame()
    np.testing.assert_allclose(loop.data.qpos, pushed.data.qpos, atol=1e-9)


def test_two_pushes_before_the_next_step_both_act():
    """Two pushes in one frame (the P key twice, two clients): the second had taken the place
    of the first, answered 200 all the same. Their impulses now add."""
    loops = [FrameLoop(ROBOT, TUNED, Motion(a_p=0.07)) for _ in range(2)]
    for loop in loops:
        for _ in range(30):
            loop.step_frame()
    assert loops[0].push_now(0.4, 90.0) is None  # alone
    assert loops[1].push_now(0.25, 90.0) is None
    twice = loops[1].push_now(0.15, 90.0)  # due in the same step: the sum acts
    assert twice is not None and math.hypot(*twice) == pytest.approx(0.4)
    for _ in range(25):
        for loop in loops:
            loop.step_frame()
    np.testing.assert_allclose(loops[1].data.qpos, loops[0].data.qpos, atol=1e-9)


def test_the_sole_sensors_carry_the_robots_weight():
    """Stepping on the spot, the force sensors of both soles read, on average over whole gait
    cycles, the robot's weight (gain 1, the floor level)."""
    loop = FrameLoop(ROBOT, TUNED, Motion())
    loop.watch_sensors = True
    loads = []
    for k in range(200):
        record = loop.step_frame()
        if k >= 50:
            loads.append(record.reading.fsr_n.sum())
    weight = ROBOT.total_mass_kg() * 9.81
    assert abs(np.mean(loads) - weight) < 0.1 * weight


def closed(**groups) -> GaitParams:
    return dataclasses.replace(TUNED, **groups)


LOOPS = [
    # (laws, motion, world): each walked by `artro run` and by a lane, to the same bits
    (closed(tilt=TiltParams(enabled=True, pitch_offset_rad=-0.08, ki_per_s=0.5)), Motion(a_p=0.07),
     "friction=0.6,latency_ms=20,backlash_deg=0.6,imu_tilt_bias_deg=0.8,imu_delay_ms=14"),
    (closed(yaw_rate=YawRateParams(enabled=True), damping=DampingParams(enabled=True)),
     Motion(a_p=0.07, ca=0.1), "gyro_bias_deg_s=0.4,gyro_noise_deg_s=0.1,imu_delay_ms=6"),
    (closed(cop=CopParams(enabled=True)), Motion(a_r=0.1), "fsr_gain=0.9,tilt_deg=1.5"),
    (closed(damping=DampingParams(enabled=True)), Motion(),
     "push_n_s=0.3,push_time_s=1.51,push_direction_deg=200,kp_scale=0.9"),
    (TUNED, Motion(a_p=0.07), "push_n_s=0.15,push_time_s=2.0,push_direction_deg=90"),
    # the clock at the timing law's rate (decision 0061)
    (closed(timing=TimingParams(enabled=True, swing_rad=0.07, swing_phase_rad=0.5)),
     Motion(a_r=0.1), "imu_delay_ms=10,tilt_deg=1.0"),
]  # fmt: skip


@pytest.mark.parametrize(("params", "motion", "world"), LOOPS)
def test_a_lane_walks_the_closed_loop_and_a_push_as_artro_run_does_to_the_bit(
    params, motion, world
):
    variation = parse_variation(world)
    live = run(params, motion, duration_s=3.0, warmup_s=1.0, robot=ROBOT, variation=variation)
    traces: list = []
    (batch,) = BatchEvaluator(ROBOT, threads=1).evaluate(
        [Job(params, motion, variation=variation)], duration_s=3.0, warmup_s=1.0, traces=traces
    )
    strip = ("wall_s", "rtf", "flags", "blew_up")  # the lanes say blew_up beside the flags
    assert not batch["fell"]
    assert {k: v for k, v in batch.items() if k not in strip} == {
        k: v for k, v in live.metrics.items() if k not in strip
    }
    assert traces[0].x_m == live.trace.x_m and traces[0].yaw_rad == live.trace.yaw_rad


def test_a_law_switched_on_mid_walk_reads_the_robot_as_it_is_now():
    """The sensors are not read while every law is off and the Sensors panel is closed: a law
    switched on then once read the rows of the last reset (a robot at rest, gyro 0, while it
    turned). It now reads the state as it is, its law state started anew."""
    loop = FrameLoop(ROBOT, TUNED, Motion(a_p=0.05, a_y=0.2))
    for _ in range(50):
        loop.step_frame()
    gyro = slice(ROBOT.gyro_adr, ROBOT.gyro_adr + 3)
    now = loop.data.sensordata[gyro].copy()
    damped = dataclasses.replace(TUNED, damping=DampingParams(enabled=True))
    loop.set_gait(damped)
    record = loop.step_frame()
    assert abs(now[2]) > 0.1  # turning: what a stale row would miss
    np.testing.assert_allclose(record.reading.gyro_rad_s, now, atol=2e-4)  # a count: 1.3e-4


def test_another_set_of_laws_starts_them_anew_keeping_the_attitude():
    """As the firmware (laws.c): a law switched on or off zeroes every law's filter and
    integral (`feedback.restarted`); the attitude estimate, current, carries on."""
    loop = FrameLoop(ROBOT, TRIMMED, Motion())
    for _ in range(100):
        loop.step_frame()
    before = loop._law_state
    assert before.started and before.tilt_integral.any()
    both = dataclasses.replace(TRIMMED, damping=DampingParams(enabled=True))
    loop.set_gait(both)
    after = loop._law_state
    assert not after.tilt_integral.any() and not after.tilt_error.any()
    assert (after.pitch_rad, after.roll_rad) == (before.pitch_rad, before.roll_rad)
    loop.set_gait(both)  # the same laws: nothing restarts
    assert loop._law_state is after
