"""The frame loop on the real ArtRo model: timing of set-points, quantisation, resets, falls."""

import math

import mujoco
import numpy as np
import pytest

from app.robots.model import lowest_sole_z
from app.sim.frame_loop import FrameLoop
from app.sim.planning import FRAME_S, plan_frames
from gait import GaitParams, Motion, joint_angles
from hardware import SLOT_TICKS, TICK_US, ServoCalibration, TdmConfig, pulses_to_angles_rad


def test_each_set_point_takes_effect_at_its_pulse_falling_edge():
    sim = FrameLoop(motion=Motion(a_p=0.1, a_y=0.2))
    for _ in range(3):
        sim.step_frame()
    plan = sim._plan
    k = plan.next_index  # the frame about to run
    frame_start = sim.data.time
    before = sim.data.ctrl[sim.robot.actuator_ids].copy()
    control_log: list[tuple[float, np.ndarray]] = []  # (time, ctrl) at every physics step

    def record(model, data):
        if data is sim.data:  # the callback is global: other threads' simulations call it too
            control_log.append((data.time, data.ctrl.copy()))

    mujoco.set_mjcb_control(record)
    try:
        sim.step_frame()
    finally:
        mujoco.set_mjcb_control(None)
    assert len(control_log) == sim.steps_per_frame
    cmap = sim.hardware.tdm.channel_map
    changed = 0
    for servo, actuator in enumerate(sim.robot.actuator_ids):
        slot = cmap.slot_index[servo]
        edge_s = (slot * SLOT_TICKS + plan.ocr[k, cmap.channel_index[servo], slot] + 1) * TICK_US
        edge_s *= 1e-6
        for t, ctrl in control_log:
            expected = (
                plan.setpoint[k, servo] if t - frame_start >= edge_s - 1e-9 else before[servo]
            )
            assert ctrl[actuator] == expected, (servo, t - frame_start, edge_s)
        changed += plan.setpoint[k, servo] != before[servo]
    assert changed >= 10  # most set-points changed in this frame: the test saw both values


def test_servos_receive_the_quantised_pulse_not_the_gait_angle():
    params, motion = GaitParams(), Motion(a_p=0.07)
    hardware = FrameLoop(params=params, motion=motion).hardware
    plan = plan_frames(params, motion, hardware, 0.3, 10, 20, 0.001)
    exact = joint_angles(params, motion, plan.phase)
    pulse = (
        plan.ocr[:, hardware.tdm.channel_map.channel_index, hardware.tdm.channel_map.slot_index] + 1
    ) * TICK_US
    np.testing.assert_array_equal(plan.setpoint, pulses_to_angles_rad(pulse, hardware.calibration))
    error = np.abs(plan.setpoint - exact)
    assert error.max() <= math.radians(0.5 * TICK_US / 10.0) + 1e-12  # half a tick: 0.025 deg
    assert error.max() > 0  # quantisation is really there


def test_calibration_limits_saturate_and_are_flagged():
    cal = ServoCalibration.default()
    knee_limited = ServoCalibration(
        cal.direction, cal.trim_us, cal.min_rad, np.where(np.arange(12) == 2, 0.05, cal.max_rad)
    )
    from hardware import HardwareSetup

    hw = HardwareSetup(calibration=knee_limited, tdm=TdmConfig())
    plan = plan_frames(GaitParams(), Motion(), hw, 0.0, 50, 20, 0.001)
    assert plan.saturated[:, 2].any() and not plan.saturated[:, 3].any()
    assert plan.setpoint[:, 2].max() <= 0.05 + 1e-9


@pytest.mark.parametrize("ramp", [False, True])
def test_a_parameter_change_reaches_the_servos_in_the_next_frame(ramp):
    """With the motion ramp off the new motion arrives whole; with it on, its first step."""
    params = GaitParams.from_dict({"ramp": {"enabled": ramp}})
    sim = FrameLoop(params=params, motion=Motion())
    for _ in range(5):
        sim.step_frame()
    phase = sim.phase
    sim.set_gait(motion=Motion(a_p=0.2))
    sim.step_frame()
    applied = Motion(a_p=0.05 * 0.02) if ramp else Motion(a_p=0.2)
    assert sim.motion_now == applied
    expected = joint_angles(sim.params, applied, phase)
    ctrl = sim.data.ctrl[sim.robot.actuator_ids]
    np.testing.assert_allclose(ctrl, expected, atol=math.radians(0.03))


def test_reset_stands_the_robot_on_the_floor_at_rest():
    sim = FrameLoop(motion=Motion(a_p=0.07))
    lowest = min(lowest_sole_z(sim.data, side) for side in "lr")
    assert lowest == pytest.approx(1e-4, abs=1e-9)  # resting on the floor, 0.1 mm above
    assert sim.time_s == 0.0 and not sim.fell
    start_height = sim.data.qpos[2]
    for _ in range(25):
        sim.step_frame()
    # no violent start: half a second later the trunk has only settled into the compliant servos
    assert abs(sim.data.qpos[2] - start_height) < 0.01 and not sim.fell


def test_same_inputs_give_the_same_numbers():
    runs = []
    for _ in range(2):
        sim = FrameLoop(motion=Motion(a_p=0.07, ca=0.05))
        for _ in range(100):
            sim.step_frame()
        runs.append(sim.data.qpos.copy())
    np.testing.assert_array_equal(runs[0], runs[1])


def test_a_tilted_start_is_detected_as_a_fall():
    sim = FrameLoop()
    half = math.radians(70) / 2
    sim.data.qpos[3:7] = (math.cos(half), math.sin(half), 0.0, 0.0)  # rolled 70 degrees
    frames = 0
    while not sim.fell and frames < 100:
        sim.step_frame()
        frames += 1
    assert sim.fell and not sim.blew_up


def test_a_blow_up_is_reported_not_raised():
    sim = FrameLoop()
    sim.data.qvel[:] = np.nan
    sim.step_frame()
    assert sim.blew_up and sim.fell
    sim.reset()
    sim.step_frame()
    assert not sim.fell and np.all(np.isfinite(sim.data.qpos))


def test_frame_is_twenty_milliseconds_of_physics():
    sim = FrameLoop()
    for _ in range(50):
        sim.step_frame()
    assert sim.data.time == pytest.approx(50 * FRAME_S)
    assert sim.time_s == pytest.approx(1.0)
