"""The differential-drive predictor of seed 004 against numerical integration of the unicycle."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gait import Pose2D, curve_amount_for, predict_path, turn_radius_m, turn_rate_rad_s


def integrate_unicycle(start: Pose2D, speed: float, omega: float, t_end: float, n: int):
    """Classic RK4 on x' = V cos(yaw), y' = V sin(yaw), yaw' = omega."""
    state = np.array(start, dtype=float)
    h = t_end / n

    def f(s):
        return np.array([speed * np.cos(s[2]), speed * np.sin(s[2]), omega])

    for _ in range(n):
        k1 = f(state)
        k2 = f(state + 0.5 * h * k1)
        k3 = f(state + 0.5 * h * k2)
        k4 = f(state + h * k3)
        state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return state


@settings(max_examples=50, deadline=None)
@given(
    x0=st.floats(-2, 2),
    y0=st.floats(-2, 2),
    yaw0=st.floats(-np.pi, np.pi),
    speed=st.floats(-0.1, 0.1),
    ca=st.floats(-0.2, 0.2),
    axle=st.floats(0.05, 0.2),
    t_end=st.floats(0.1, 60.0),
)
def test_exact_solution_matches_numerical_integration(x0, y0, yaw0, speed, ca, axle, t_end):
    start = Pose2D(x0, y0, yaw0)
    omega = float(turn_rate_rad_s(ca, speed, axle))
    expected = integrate_unicycle(start, speed, omega, t_end, n=2000)
    t, x, y, yaw = predict_path(start, speed, ca, axle, t_end)
    assert t == t_end
    np.testing.assert_allclose([x, y, yaw], expected, atol=1e-6)


def test_straight_when_ca_is_zero_and_vectorised_over_time():
    rows = predict_path(Pose2D(1.0, 2.0, np.pi / 2), 0.04, 0.0, 0.1, np.array([0.0, 1.0, 10.0]))
    np.testing.assert_allclose(rows[:, 1], 1.0, atol=1e-15)
    np.testing.assert_allclose(rows[:, 2], [2.0, 2.04, 2.4])
    np.testing.assert_allclose(rows[:, 3], np.pi / 2)


def test_positive_ca_turns_clockwise_on_radius_b_over_2ca():
    axle, ca, speed = 0.1, 0.058, 0.05
    omega = float(turn_rate_rad_s(ca, speed, axle))
    assert omega < 0  # clockwise
    assert turn_radius_m(ca, axle) == pytest.approx(-axle / (2 * ca))
    period = 2 * np.pi / abs(omega)
    rows = predict_path(Pose2D(0, 0, 0), speed, ca, axle, np.linspace(0, period, 400))
    # a full circle of radius b/(2 CA), centred on the right of the start
    centre = np.array([0.0, turn_radius_m(ca, axle)])
    radii = np.hypot(rows[:, 1] - centre[0], rows[:, 2] - centre[1])
    np.testing.assert_allclose(radii, axle / (2 * ca), rtol=1e-9)
    np.testing.assert_allclose(rows[-1, 1:3], [0, 0], atol=1e-9)
    assert turn_radius_m(0.0, axle) == float("inf")


def test_printed_closed_form_is_wrong():
    """Seed 004 eq (14)-(15) as printed: radius b/CA (twice too large) and theta0 missing."""
    axle, ca, speed, yaw0, t = 0.1, 0.05, 0.05, 0.7, 20.0
    printed_x = 0.0 - axle / ca * (np.sin(-2 * ca * speed * t / axle) - np.sin(yaw0))
    printed_y = 0.0 + axle / ca * (np.cos(-2 * ca * speed * t / axle) - np.cos(yaw0))
    exact = integrate_unicycle(Pose2D(0, 0, yaw0), speed, -2 * ca * speed / axle, t, 4000)
    assert np.hypot(printed_x - exact[0], printed_y - exact[1]) > 0.1
    ours = predict_path(Pose2D(0, 0, yaw0), speed, ca, axle, t)
    np.testing.assert_allclose(ours[1:3], exact[:2], atol=1e-9)


def test_eq_13_round_trip_and_bad_inputs():
    assert float(curve_amount_for(turn_rate_rad_s(0.07, 0.04, 0.1), 0.04, 0.1)) == pytest.approx(
        0.07
    )
    with pytest.raises(ValueError, match="axle"):
        turn_rate_rad_s(0.1, 0.1, 0.0)
    with pytest.raises(ValueError, match="zero walking speed"):
        curve_amount_for(0.1, 0.0, 0.1)
