"""Hobby-servo model, seed 000 §3.B (Figure 7a): joint angle <-> control pulse width.

20 ms period, 0.6–2.4 ms pulse, 1.5 ms = 0 rad, 10 µs per degree, a calibration per servo;
saturation is flagged, never silent (docs/DESIGN.md §5). Arrays are (..., n), one servo a column.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

PULSE_CENTER_US = 1500.0  # pulse for 0 rad
US_PER_DEG = 10.0  # pulse change per degree of axle rotation
PULSE_MIN_US = 600.0  # shortest pulse a servo accepts (-90°)
PULSE_MAX_US = 2400.0  # longest pulse a servo accepts (+90°)
PERIOD_US = 20000.0  # PWM period T = 20 ms

LIMIT_RAD = np.pi / 2  # widest angle limit a calibration may set (±90°)
TRIM_MAX_US = 200.0  # largest trim magnitude a calibration may set
DEFAULT_SERVO_COUNT = 12  # ArtRo: 6 joints per leg


def _frozen_array(values: ArrayLike, dtype: type, name: str) -> NDArray:
    """Copy `values` into a 1-D read-only array of `dtype`."""
    array: NDArray = np.array(values, dtype=dtype)
    if array.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array (one entry per servo), got {array.shape}")
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class ServoCalibration:
    """Per-servo calibration, arrays of shape (n,) in servo order.

    Attributes:
        direction: +1 if a positive joint angle lengthens the pulse, -1 if the servo is mounted
            mirrored.
        trim_us: pulse offset in µs added after the angle mapping (within ±200 µs).
        min_rad: lower angle limit in rad (>= -pi/2).
        max_rad: upper angle limit in rad (<= +pi/2, > min_rad).

    Raises:
        ValueError: on unequal lengths, a direction not +-1, or a trim or limit out of range.
    """

    direction: NDArray[np.int64]
    trim_us: NDArray[np.float64]
    min_rad: NDArray[np.float64]
    max_rad: NDArray[np.float64]

    def __post_init__(self) -> None:
        direction = np.asarray(self.direction)
        if not np.all(np.isin(direction, (-1, 1))):
            raise ValueError(
                f"direction must be +1 or -1 for every servo, got {direction.tolist()}"
            )
        object.__setattr__(self, "direction", _frozen_array(direction, np.int64, "direction"))
        for name in ("trim_us", "min_rad", "max_rad"):
            object.__setattr__(self, name, _frozen_array(getattr(self, name), np.float64, name))

        lengths = {len(self.direction), len(self.trim_us), len(self.min_rad), len(self.max_rad)}
        if len(lengths) != 1:
            raise ValueError(
                "direction, trim_us, min_rad and max_rad must have one entry per servo (equal "
                f"lengths), got {len(self.direction)}, {len(self.trim_us)}, "
                f"{len(self.min_rad)}, {len(self.max_rad)}"
            )
        for name in ("trim_us", "min_rad", "max_rad"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ValueError(f"{name} must be finite numbers")
        if np.any(np.abs(self.trim_us) > TRIM_MAX_US):
            raise ValueError(
                f"trim_us must be within ±{TRIM_MAX_US:g} µs, got {self.trim_us.tolist()}"
            )
        if np.any(self.min_rad < -LIMIT_RAD) or np.any(self.max_rad > LIMIT_RAD):
            raise ValueError(
                "angle limits must be within ±pi/2 rad (±90°, the 0.6–2.4 ms pulse range), got "
                f"min_rad={self.min_rad.tolist()}, max_rad={self.max_rad.tolist()}"
            )
        if np.any(self.min_rad >= self.max_rad):
            bad = np.flatnonzero(self.min_rad >= self.max_rad).tolist()
            raise ValueError(f"min_rad must be < max_rad for every servo; violated at {bad}")

    @classmethod
    def default(cls, n: int = DEFAULT_SERVO_COUNT) -> ServoCalibration:
        """`n` servos, direction +1, no trim, limits ±pi/2."""
        if n < 1:
            raise ValueError(f"n must be >= 1 servo, got {n}")
        return cls(
            direction=np.ones(n, dtype=np.int64),
            trim_us=np.zeros(n),
            min_rad=np.full(n, -LIMIT_RAD),
            max_rad=np.full(n, LIMIT_RAD),
        )

    @property
    def n(self) -> int:
        """Number of servos."""
        return len(self.direction)


def _check_last_axis(values: NDArray, cal: ServoCalibration, name: str) -> None:
    if values.ndim == 0 or values.shape[-1] != cal.n:
        raise ValueError(
            f"{name} must have shape (..., {cal.n}) (one column per calibrated servo), "
            f"got shape {values.shape}"
        )


def angles_to_pulses_us(
    angles_rad: ArrayLike, cal: ServoCalibration
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Joint angles -> servo pulse widths, with saturation flags. Vectorised.

    The axle angle is linear in the pulse width: after clipping the angle to the servo's limits,

        pulse_us = PULSE_CENTER_US + direction * degrees(angle) * US_PER_DEG + trim_us

    and the pulse is clipped to [600, 2400] µs; either clip is reported, never silent.

    Args:
        angles_rad: joint angles, shape (..., n).
        cal: the calibration of the n servos.

    Returns:
        (pulse_us, saturated): pulse widths in µs within [600, 2400], and a bool array of the same
        shape that is True where the angle limit or the pulse range clipped the value.

    Raises:
        ValueError: on a wrong last dimension or a NaN/infinite angle.
    """
    angles = np.asarray(angles_rad, dtype=np.float64)
    _check_last_axis(angles, cal, "angles_rad")
    if not np.all(np.isfinite(angles)):
        raise ValueError("angles_rad must be finite; got NaN or inf (no pulse can encode it)")

    limited = np.minimum(np.maximum(angles, cal.min_rad), cal.max_rad)
    saturated = limited != angles
    pulse = PULSE_CENTER_US + cal.direction * np.degrees(limited) * US_PER_DEG + cal.trim_us
    clipped = np.minimum(np.maximum(pulse, PULSE_MIN_US), PULSE_MAX_US)
    saturated |= clipped != pulse
    return clipped, saturated


def pulses_to_angles_rad(pulse_us: ArrayLike, cal: ServoCalibration) -> NDArray[np.float64]:
    """Servo pulse widths -> the joint angles the servos move to (inverse mapping, no clipping).

    Args:
        pulse_us: pulse widths in µs, shape (..., n). NaN (no pulse decoded) gives NaN.
        cal: the calibration of the n servos.

    Returns:
        Joint angles in rad, shape (..., n).

    Raises:
        ValueError: on a wrong last dimension.
    """
    pulse = np.asarray(pulse_us, dtype=np.float64)
    _check_last_axis(pulse, cal, "pulse_us")
    degrees = (pulse - PULSE_CENTER_US - cal.trim_us) * cal.direction / US_PER_DEG
    return np.radians(degrees)
