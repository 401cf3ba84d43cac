"""The servo load budget: the meter on the real model, and its route on a real server."""

from __future__ import annotations

import numpy as np
import pytest

from app.sim.frame_loop import FrameLoop
from app.sim.servo_load import ServoLimits, ServoLoadMeter, level
from gait import JOINT_NAMES, GaitParams, Motion
from hardware import SAFETY_FACTOR


def test_the_limits_come_from_the_model():
    loop = FrameLoop()
    limits = ServoLimits.of(loop.robot)
    # models/servos.yaml: the MG996R's 11 kgf·cm (1.0787 N m) and 0.14 s / 60° (7.48 rad/s) at 6 V
    np.testing.assert_allclose(limits.stall_torque_nm, 11 * 0.0980665)
    np.testing.assert_allclose(limits.no_load_speed_rad_s, (np.pi / 3) / 0.14)


def test_the_meter_follows_the_frames_it_is_given():
    loop = FrameLoop(params=GaitParams(), motion=Motion(a_p=0.07))
    meter = ServoLoadMeter(loop.robot)
    peaks, speeds, saturated = [], [], np.zeros(12, int)
    for _ in range(50):
        record = loop.step_frame()
        forced = record.saturated_servos.copy()
        forced[3] = True  # count a saturated knee pulse in every frame
        meter.add(loop.data, forced)
        peaks.append(np.abs(loop.data.actuator_force[loop.robot.actuator_ids]))
        speeds.append(np.abs(loop.data.qvel[loop.robot.dof_adr]))
        saturated += forced
    report = meter.report()
    assert report.frames == 50 and [j.joint for j in report.joints] == list(JOINT_NAMES)
    peak = np.max(peaks, axis=0)
    for i, j in enumerate(report.joints):
        assert j.peak_torque_nm == pytest.approx(peak[i])
        assert j.rms_torque_nm == pytest.approx(np.sqrt(np.mean(np.square(peaks)[:, i])))
        assert j.rms_torque_nm <= j.peak_torque_nm + 1e-12
        assert j.required_torque_nm == pytest.approx((1 + SAFETY_FACTOR) * peak[i])
        assert j.torque_margin == pytest.approx(1 - j.required_torque_nm / j.stall_torque_nm)
        assert j.peak_speed_rad_s == pytest.approx(np.max(speeds, axis=0)[i])
        assert j.saturated_frames == saturated[i]
        assert (j.torque_level, j.speed_level) == (level(j.torque_margin), level(j.speed_margin))
        assert j.level == level(min(j.torque_margin, j.speed_margin))
    assert report.joints[3].saturated_frames == 50
    assert max(j.peak_torque_nm for j in report.joints) > 0.05  # walking loads the legs
    meter.clear()
    assert meter.report().frames == 0 and meter.report().joints[0].peak_torque_nm == 0.0


LEVELS = [
    (0.5, "ok"),
    (0.3, "ok"),
    (0.29, "warn"),
    (0.1, "warn"),
    (0.09, "critical"),
    (-1, "critical"),
]


@pytest.mark.parametrize(("margin", "expected"), LEVELS)
def test_levels(margin, expected):
    assert level(margin) == expected


def test_a_servo_short_of_eq1_is_named_with_the_lightest_that_meets_it():
    """Issue 56, item 17: the budget says which servo would meet eq (1), as `robot check
    --suggest` chooses one (the lightest of models/servos.yaml at the robot's supply)."""
    loop = FrameLoop(params=GaitParams(), motion=Motion(a_p=0.07))
    meter = ServoLoadMeter(loop.robot)
    assert meter.servos == ["MG996R"] * 12  # ArtRo's servo on every joint
    knee = list(JOINT_NAMES).index("l_knee")
    choice = meter.eq1_servo(knee, 1.22)  # the `robust` knees' need (1.2 x 1.02 N·m)
    assert choice is not None and choice.name == "DS3218" and choice.mass_kg == 0.06
    assert meter.eq1_servo(knee, 50.0) is None  # no hobby servo of the table gives 50 N·m
    for _ in range(50):
        loop.step_frame()
        meter.add(loop.data, np.zeros(12, bool))
    report = meter.report()
    assert report.supply_voltage_v == 6.0
    for j in report.joints:
        assert j.servo == "MG996R"
        assert j.eq1_met == (j.required_torque_nm <= j.stall_torque_nm)
        assert (j.eq1_servo is None) == j.eq1_met  # every need here is within the table


def test_the_route_reports_the_live_gait(http):
    report = http.get("/api/servos/load").json()
    assert [j["joint"] for j in report["joints"]] == list(JOINT_NAMES)
    assert report["safety_factor"] == SAFETY_FACTOR
    for j in report["joints"]:
        assert j["level"] in ("ok", "warn", "critical")
        assert j["stall_torque_nm"] == pytest.approx(11 * 0.0980665)
        assert j["servo"] == "MG996R" and isinstance(j["eq1_met"], bool)
        assert j["eq1_met"] or j["eq1_servo"]["stall_torque_nm"] >= j["required_torque_nm"]
    assert report["supply_voltage_v"] == 6.0
