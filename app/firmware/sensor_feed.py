"""The balance sensors as the firmware meets them (docs/DESIGN.md §15): the emulated MPU-6050's
registers and the ADC's inputs for a sensor reading (`raw_of`, `sample_of`), and the float32
reading the firmware decodes from them (`decoded`), as `sensors.c` does."""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from app.sim.sensors import ACCEL_M_S2_PER_COUNT, COUNT_RANGE, GYRO_RAD_S_PER_COUNT, SensorReading
from gait import feedback
from hardware.fsr import ADC_FULL, FSR_DIVIDER_N, adc_counts

# The part and the board, stated: the IMU's raw gyro carries a zero-rate offset (well inside the
# MPU-6050's ±20 °/s tolerance) that the firmware's calibration at rest removes; what a world
# calls gyro bias is what remains after it, as in the simulation. Each force sensor sits in a
# divider the chip converts (`hardware.fsr`: R_FSR = 10 kΩ·N / F over R_M = 2 kΩ: an FSR 402
# follows 1/F within its part-to-part spread from 0.2 to 20 N).
F32 = np.float32
VREF_MV = 5000
#: the emulated part's raw gyro at rest (x, y, z), counts: +1.5, -0.8, +0.4 °/s
GYRO_ZERO_RATE_COUNTS = (197, -105, 52)
ONE_G_COUNTS = 16384


@dataclass(frozen=True)
class SensorSample:
    """One frame's sensor inputs of the emulated MCU."""

    imu_registers: bytes  # 14 bytes from ACCEL_XOUT_H (0x3B), big-endian
    adc_mv: tuple[int, ...]  # ADC0..ADC7 (left foot fl, fr, bl, br, then right), millivolts


@dataclass(frozen=True)
class RawSample:
    """What the firmware reads: counts."""

    accel: tuple[int, int, int]
    gyro: tuple[int, int, int]  # the part's raw rate, offset included
    adc: tuple[int, ...]  # 8 conversions


def _counts(values: NDArray[np.float64], per_count: float) -> tuple[int, ...]:
    lo, hi = COUNT_RANGE
    return tuple(int(min(max(round(v / per_count), lo), hi)) for v in values)


def simavr_millivolts(count: int) -> int:
    """The input millivolts that make simavr's ADC (count = mV * 1023 / Vref) give `count`."""
    return math.ceil(count * VREF_MV / (ADC_FULL - 1))


def raw_of(reading: SensorReading) -> RawSample:
    """The counts a sensor reading (`app.sim.sensors`) shows the firmware."""
    gyro = _counts(reading.gyro_rad_s, GYRO_RAD_S_PER_COUNT)
    gyro = tuple(
        min(max(g + o, COUNT_RANGE[0]), COUNT_RANGE[1])
        for g, o in zip(gyro, GYRO_ZERO_RATE_COUNTS, strict=True)
    )
    accel = _counts(reading.accel_m_s2, ACCEL_M_S2_PER_COUNT)
    adc = tuple(int(c) for c in adc_counts(np.asarray(reading.fsr_n).reshape(8)))
    return RawSample(accel, gyro, adc)  # type: ignore[arg-type]  # 3 and 3 counts (zip of 3)


def at_rest() -> RawSample:
    """Level and still: what the IMU shows during the calibration at boot, no load on the feet."""
    return RawSample((0, 0, ONE_G_COUNTS), GYRO_ZERO_RATE_COUNTS, (0,) * 8)


def sample_of(raw: RawSample) -> SensorSample:
    """The emulated MCU's inputs that the firmware reads as `raw`."""
    registers = struct.pack(">7h", *raw.accel, 0, *raw.gyro)  # temperature register: 0
    return SensorSample(registers, tuple(simavr_millivolts(c) for c in raw.adc))


def decoded(raw: RawSample, gyro_offset: tuple[int, ...]) -> feedback.Reading:
    """The float32 reading the firmware makes of `raw` (sensors.c `sensors_take`)."""
    counts = np.array(raw.gyro, dtype=np.int32) - np.array(gyro_offset, dtype=np.int32)
    gyro = counts.astype(F32) * F32(GYRO_RAD_S_PER_COUNT)  # 32 bits: a rail less the offset
    accel = np.array(raw.accel, dtype=F32) * F32(ACCEL_M_S2_PER_COUNT)
    adc = np.array(raw.adc, dtype=F32)
    fsr = F32(FSR_DIVIDER_N) * adc / (F32(ADC_FULL) - adc)
    return feedback.Reading(gyro_rad_s=gyro, accel_m_s2=accel, fsr_n=fsr.reshape(2, 4))
