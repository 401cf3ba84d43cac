"""Servo angle <-> pulse mapping (hardware.servo): exact tables, saturation flags, validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from hardware import (
    ServoCalibration,
    angles_to_pulses_us,
    pulse_us_to_ocr,
    pulses_to_angles_rad,
)


def one_servo(
    direction: int = 1, trim_us: float = 0.0, lo: float = -np.pi / 2, hi: float = np.pi / 2
):
    return ServoCalibration(direction=[direction], trim_us=[trim_us], min_rad=[lo], max_rad=[hi])


@pytest.mark.parametrize(
    ("angle_deg", "direction", "trim_us", "pulse_us", "ocr"),
    [
        (0.0, 1, 0.0, 1500.0, 2999),
        (90.0, 1, 0.0, 2400.0, 4799),
        (-90.0, 1, 0.0, 600.0, 1199),
        (45.0, 1, 0.0, 1950.0, 3899),
        (45.0, -1, 20.0, 1070.0, 2139),  # 1500 - 450 + 20
        (45.0, -1, -20.0, 1030.0, 2059),  # 1500 - 450 - 20
        (-30.0, -1, 0.0, 1800.0, 3599),
        (10.0, 1, 150.0, 1750.0, 3499),
    ],
)
def test_angle_to_pulse_table(
    angle_deg: float, direction: int, trim_us: float, pulse_us: float, ocr: int
) -> None:
    pulse, saturated = angles_to_pulses_us([np.radians(angle_deg)], one_servo(direction, trim_us))
    assert pulse[0] == pytest.approx(pulse_us, abs=1e-9)
    assert not saturated[0]
    assert pulse_us_to_ocr(pulse)[0] == ocr


def test_pulse_range_clip_is_flagged() -> None:
    # -90° with -20 µs trim would be 580 µs: clipped to 600 µs and flagged.
    pulse, saturated = angles_to_pulses_us([-np.pi / 2], one_servo(trim_us=-20.0))
    assert pulse[0] == 600.0
    assert saturated[0]
    pulse, saturated = angles_to_pulses_us([np.pi / 2], one_servo(trim_us=5.0))
    assert pulse[0] == 2400.0
    assert saturated[0]


def test_exactly_at_limit_is_not_saturated() -> None:
    pulse, saturated = angles_to_pulses_us([-np.pi / 2], one_servo())
    assert pulse[0] == 600.0
    assert not saturated[0]


def test_angle_limit_clip_is_flagged() -> None:
    cal = one_servo(lo=-np.radians(30), hi=np.radians(60))
    pulse, saturated = angles_to_pulses_us([[np.radians(-45)], [np.radians(70)], [0.0]], cal)
    np.testing.assert_allclose(pulse[:, 0], [1200.0, 2100.0, 1500.0], atol=1e-9)
    assert saturated[:, 0].tolist() == [True, True, False]


def test_vectorised_over_leading_dims() -> None:
    cal = ServoCalibration.default()
    angles = np.zeros((4, 50, 12))
    angles[2, 7, 3] = 3.0  # beyond +90°
    pulse, saturated = angles_to_pulses_us(angles, cal)
    assert pulse.shape == saturated.shape == (4, 50, 12)
    assert pulse[2, 7, 3] == 2400.0
    assert np.count_nonzero(saturated) == 1 and saturated[2, 7, 3]
    pulse[2, 7, 3] = 1500.0
    assert np.all(pulse == 1500.0)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_angle_rejected(bad: float) -> None:
    angles = np.zeros(12)
    angles[4] = bad
    with pytest.raises(ValueError, match="finite"):
        angles_to_pulses_us(angles, ServoCalibration.default())


def test_wrong_servo_count_rejected() -> None:
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 12\)"):
        angles_to_pulses_us(np.zeros(11), ServoCalibration.default())
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 12\)"):
        pulses_to_angles_rad(np.full((3, 6), 1500.0), ServoCalibration.default())


def test_default_calibration() -> None:
    cal = ServoCalibration.default()
    assert cal.n == 12
    assert cal.direction.tolist() == [1] * 12
    assert cal.trim_us.tolist() == [0.0] * 12
    assert np.all(cal.min_rad == -np.pi / 2) and np.all(cal.max_rad == np.pi / 2)
    assert ServoCalibration.default(3).n == 3


def test_calibration_arrays_are_read_only() -> None:
    trim = np.zeros(12)
    cal = ServoCalibration(trim_us=trim, **_fields_except("trim_us"))
    trim[0] = 100.0  # the caller's array is copied, not shared
    assert cal.trim_us[0] == 0.0
    with pytest.raises(ValueError, match="read-only"):
        cal.trim_us[0] = 50.0
    with pytest.raises(ValueError, match="read-only"):
        cal.direction[0] = -1


def _fields_except(name: str) -> dict[str, np.ndarray]:
    cal = ServoCalibration.default()
    fields = {
        "direction": cal.direction,
        "trim_us": cal.trim_us,
        "min_rad": cal.min_rad,
        "max_rad": cal.max_rad,
    }
    del fields[name]
    return fields


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("direction", [1] * 11 + [0], r"\+1 or -1"),
        ("direction", [1] * 11 + [2], r"\+1 or -1"),
        ("trim_us", [0.0] * 11 + [201.0], "±200 µs"),
        ("trim_us", [0.0] * 11 + [-250.0], "±200 µs"),
        ("min_rad", [-np.pi / 2] * 11 + [-1.6], r"±pi/2"),
        ("max_rad", [np.pi / 2] * 11 + [1.6], r"±pi/2"),
        ("max_rad", [np.pi / 2] * 11 + [-np.pi / 2], "min_rad must be < max_rad"),
        ("trim_us", [0.0] * 10, "equal lengths"),
        ("trim_us", [0.0] * 11 + [np.nan], "finite"),
        ("trim_us", np.zeros((2, 6)), "1-D"),
    ],
)
def test_calibration_validation(name: str, value: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ServoCalibration(**{name: value}, **_fields_except(name))


def test_inverse_table() -> None:
    cal = ServoCalibration(direction=[1, -1], trim_us=[0.0, 20.0], min_rad=[-1, -1], max_rad=[1, 1])
    angles = pulses_to_angles_rad([[1500.0, 1070.0], [2400.0, 1520.0]], cal)
    np.testing.assert_allclose(np.degrees(angles), [[0.0, 45.0], [90.0, 0.0]], atol=1e-12)
    assert np.isnan(pulses_to_angles_rad([np.nan, 1500.0], cal)[0])


@given(
    angles=hnp.arrays(np.float64, (5, 12), elements=st.floats(-np.pi / 2 + 0.01, np.pi / 2 - 0.01)),
    directions=st.lists(st.sampled_from([-1, 1]), min_size=12, max_size=12),
    trims=st.lists(st.floats(-0.5, 0.5), min_size=12, max_size=12),
)
def test_round_trip_in_range(angles: np.ndarray, directions: list[int], trims: list[float]) -> None:
    # Trims this small keep every pulse of an angle 0.01 rad inside the limits within 600..2400 µs.
    cal = ServoCalibration(
        direction=directions,
        trim_us=trims,
        min_rad=np.full(12, -np.pi / 2),
        max_rad=np.full(12, np.pi / 2),
    )
    pulse, saturated = angles_to_pulses_us(angles, cal)
    assert not saturated.any()
    np.testing.assert_allclose(pulses_to_angles_rad(pulse, cal), angles, atol=1e-12)


@given(angles=hnp.arrays(np.float64, 12, elements=st.floats(-10.0, 10.0)))
def test_output_always_in_pulse_range_and_flag_matches_clip(angles: np.ndarray) -> None:
    cal = ServoCalibration.default()
    pulse, saturated = angles_to_pulses_us(angles, cal)
    assert np.all((pulse >= 600.0) & (pulse <= 2400.0))
    assert np.array_equal(saturated, np.abs(angles) > np.pi / 2)
