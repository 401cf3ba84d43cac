"""Run metrics on hand-made trajectories with known answers."""

import math

import numpy as np
import pytest

from app.sim.metrics import Trace, compute_metrics, whole_cycles
from gait import Pose2D, predict_path


def make_trace(t, x, y, yaw, gyro=None, feet=0.1) -> Trace:
    trace = Trace()
    for i in range(len(t)):
        g = np.zeros(3) if gyro is None else gyro[i]
        trace.append(t[i], (x[i], y[i], yaw[i]), g, feet)
    return trace


T = np.arange(0, 20.0001, 0.02)


def test_straight_walk_in_a_rotated_heading():
    heading = math.radians(30)
    v = 0.038
    trace = make_trace(T, v * T * math.cos(heading), v * T * math.sin(heading), [heading] * len(T))
    m = compute_metrics(trace, ca=0.0, freq_hz=1.0, warmup_s=5.0)
    assert m["forward_cm_s"] == pytest.approx(3.8)
    assert m["lateral_cm_s"] == pytest.approx(0.0, abs=1e-9)
    assert m["turn_deg_s"] == pytest.approx(0.0, abs=1e-9)
    assert m["path_error_cm"] == pytest.approx(0.0, abs=1e-9)


def test_sidestep_to_the_right_is_negative_lateral():
    trace = make_trace(T, 0 * T, -0.035 * T, [0.0] * len(T))
    m = compute_metrics(trace, ca=0.0, freq_hz=1.0, warmup_s=5.0)
    assert m["lateral_cm_s"] == pytest.approx(-3.5)
    assert m["forward_cm_s"] == pytest.approx(0.0, abs=1e-9)


def test_turn_on_the_spot_through_the_wrap():
    rate = math.radians(-12.1)  # clockwise
    yaw = np.angle(np.exp(1j * (3.0 + rate * T)))  # wrapped as a sensor would give it
    m = compute_metrics(make_trace(T, 0 * T, 0 * T, yaw), ca=0.0, freq_hz=1.0, warmup_s=5.0)
    assert m["turn_deg_s"] == pytest.approx(-12.1)


def test_curve_walk_on_the_predicted_circle_has_no_path_error():
    v, ca, axle = 0.04, 0.058, 0.1
    rows = predict_path(Pose2D(0.3, -0.2, 1.0), v, ca, axle, T)
    trace = make_trace(T, rows[:, 1], rows[:, 2], np.angle(np.exp(1j * rows[:, 3])), feet=axle)
    m = compute_metrics(trace, ca=ca, freq_hz=1.0, warmup_s=5.0)
    assert m["forward_cm_s"] == pytest.approx(4.0, rel=1e-4)
    assert m["turn_deg_s"] == pytest.approx(math.degrees(-2 * ca * v / axle), rel=1e-4)
    assert m["predicted_turn_deg_s"] == pytest.approx(m["turn_deg_s"], rel=1e-3)
    assert m["path_error_cm"] < 0.01
    # the same walk judged against the wrong CA is off the path
    wrong = compute_metrics(trace, ca=0.0, freq_hz=1.0, warmup_s=5.0)
    assert wrong["path_error_cm"] > 5.0


def test_sway_within_a_cycle_averages_out_over_whole_cycles():
    f = 1.25
    x = 0.02 * T + 0.01 * np.sin(2 * math.pi * f * T)
    m = compute_metrics(make_trace(T, x, 0 * T, [0.0] * len(T)), ca=0, freq_hz=f, warmup_s=5.0)
    assert m["forward_cm_s"] == pytest.approx(2.0, abs=1e-6)


def test_gyro_rms_and_the_measurement_window():
    gyro = np.tile([0.3, 0.0, 0.4], (len(T), 1))
    gyro[T < 5.0] = 100.0  # the warm-up is not measured
    m = compute_metrics(make_trace(T, 0 * T, 0 * T, 0 * T, gyro), ca=0, freq_hz=1, warmup_s=5.0)
    assert m["gyro_rms"] == pytest.approx(0.5)
    window = whole_cycles(T, 5.0, 0.8)
    assert T[window.start] == pytest.approx(5.0)
    assert (T[window.stop - 1] - T[window.start]) * 0.8 == pytest.approx(12.0)


def test_a_run_shorter_than_the_warmup_has_no_metrics():
    m = compute_metrics(
        make_trace(T[:10], T[:10], T[:10] * 0, T[:10] * 0), ca=0, freq_hz=1, warmup_s=5
    )
    assert m["forward_cm_s"] is None and m["gyro_rms"] is None


def test_yaw_wobble_in_step_with_the_sway_does_not_count_as_speed():
    # the trunk yaws left while it sways left: read frame by frame in the momentary heading this
    # rectifies 0.39 cm/s of the sway into forward speed; per cycle it is exactly 2 cm/s
    f = 1.25
    w = 2 * math.pi * f
    x, y, yaw = 0.02 * T, 0.01 * np.sin(w * T), 0.1 * np.cos(w * T)
    m = compute_metrics(make_trace(T, x, y, yaw), ca=0, freq_hz=f, warmup_s=5.0)
    assert m["forward_cm_s"] == pytest.approx(2.0, abs=1e-6)
    assert m["lateral_cm_s"] == pytest.approx(0.0, abs=1e-6)
