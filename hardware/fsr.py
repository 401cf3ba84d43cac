"""A sole's force sensor as the MCU reads it (docs/DESIGN.md §15): an FSR 402 in a divider to
ground, V / 5 V = F / (F + 5 N), converted by the ATmega128's 10-bit ADC, floor(1024 V / 5 V)
at most 1023, and the force the firmware decodes from the count (sensors.c)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

ADC_FULL = 1024
FSR_DIVIDER_N = 5.0  # the divider's force at half the supply (config.h)
#: a force decoded from a count gives that count back, not one less by a rounding of the last bit
_EXACT = 1e-9


def adc_counts(forces_n: ArrayLike) -> NDArray[np.int64]:
    """The chip's conversion of each force's divider (0..1023); a negative force reads 0."""
    force = np.maximum(np.asarray(forces_n, dtype=np.float64), 0.0)
    counts = np.floor(ADC_FULL * force / (force + FSR_DIVIDER_N) + _EXACT)
    return np.minimum(counts, ADC_FULL - 1).astype(np.int64)


def decoded_forces(counts: ArrayLike) -> NDArray[np.float64]:
    """The force each count stands for: F = 5 N · adc / (1024 - adc)."""
    adc = np.asarray(counts, dtype=np.float64)
    return FSR_DIVIDER_N * adc / (ADC_FULL - adc)


def as_read(forces_n: ArrayLike) -> NDArray[np.float64]:
    """The forces the firmware reads for `forces_n`: converted and decoded, in ADC steps."""
    return decoded_forces(adc_counts(forces_n))
