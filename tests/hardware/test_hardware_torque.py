"""Servo torque sizing, eq (1) of seed 000 (hardware.torque)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from hardware import max_sin, required_torque_from_loads, required_torque_nm

PI = np.pi


@pytest.mark.parametrize(
    ("lo", "hi", "expected"),
    [
        (-PI / 2, PI / 2, 1.0),  # contains pi/2
        (0.0, PI / 6, 0.5),  # increasing: the upper end
        (2 * PI / 3, PI, np.sin(2 * PI / 3)),  # decreasing: the lower end
        (PI / 2, PI / 2, 1.0),  # a single point at the peak
        (-PI / 2, 0.0, 0.0),
        (-PI, -PI / 2, 0.0),  # sin <= 0 throughout: the larger end value, -0 at -pi
        (2 * PI, 2 * PI + PI / 2, 1.0),  # the peak at pi/2 + 2*pi
        (-2 * PI, -3 * PI / 2, 1.0),  # the peak at pi/2 - 2*pi
        (PI, 2 * PI, 0.0),
        (PI / 6, 5 * PI / 6, 1.0),
    ],
)
def test_max_sin_table(lo: float, hi: float, expected: float) -> None:
    assert max_sin(lo, hi) == pytest.approx(expected, abs=1e-12)


def test_required_torque_paper_example() -> None:
    # 10 N at 5 cm over -90°..+90° with 20 % margin: 1.2 * 10 * 0.05 * 1 = 0.6 N·m.
    assert required_torque_nm(10.0, 0.05, -PI / 2, PI / 2, 0.2) == pytest.approx(0.6)
    # Range 0..30° only: max sin = 0.5.
    assert required_torque_nm(10.0, 0.05, 0.0, PI / 6, 0.2) == pytest.approx(0.3)


def test_required_torque_vectorised() -> None:
    torque = required_torque_nm(
        weight_n=np.array([10.0, 20.0, 5.0]),
        lever_m=0.1,
        alpha_min_rad=np.array([-PI / 2, 0.0, 0.0]),
        alpha_max_rad=np.array([PI / 2, PI / 6, PI / 2]),
        safety_factor=np.array([0.0, 0.5, 1.0]),
    )
    np.testing.assert_allclose(torque, [1.0, 1.5, 1.0])


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((10.0, 0.05, 1.0, 0.5, 0.2), "alpha_min_rad must be <= alpha_max_rad"),
        ((10.0, 0.05, 0.0, 1.0, -0.1), "safety_factor must be >= 0"),
        ((-1.0, 0.05, 0.0, 1.0, 0.2), "weight_n must be finite and >= 0"),
        ((10.0, -0.05, 0.0, 1.0, 0.2), "lever_m must be finite and >= 0"),
        ((10.0, 0.05, np.nan, 1.0, 0.2), "finite"),
    ],
)
def test_required_torque_validation(args: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        required_torque_nm(*args)


def test_required_torque_from_loads() -> None:
    loads = np.array([[0.1, -0.4, 0.0], [-0.3, 0.2, 0.0], [0.25, 0.1, 0.0]])
    np.testing.assert_allclose(required_torque_from_loads(loads, 0.5), [0.45, 0.6, 0.0])
    np.testing.assert_allclose(
        required_torque_from_loads(loads, np.array([0.0, 1.0, 0.0])), [0.3, 0.8, 0.0]
    )


@pytest.mark.parametrize(
    ("loads", "sf", "message"),
    [
        (np.zeros(5), 0.2, r"shape \(T, n\)"),
        (np.zeros((0, 12)), 0.2, "T >= 1"),
        (np.array([[0.1, np.nan]]), 0.2, "finite"),
        (np.zeros((3, 2)), -1.0, "safety_factor"),
    ],
)
def test_required_torque_from_loads_validation(loads: np.ndarray, sf: float, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        required_torque_from_loads(loads, sf)


@given(lo=st.floats(-10.0, 10.0), width=st.floats(0.0, 7.0))
def test_max_sin_bounds_the_sampled_maximum(lo: float, width: float) -> None:
    hi = lo + width
    samples = np.sin(np.linspace(lo, hi, 2001))
    peak = max_sin(lo, hi)
    assert peak >= samples.max() - 1e-12
    # The sampled maximum approaches it (grid spacing <= 3.5e-3 rad -> error <= 1.6e-6).
    assert peak - samples.max() <= 2e-6
