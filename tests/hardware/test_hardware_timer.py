"""ATmega128 timer model (hardware.timer): tick arithmetic and register bytes, exact values."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from hardware import (
    FRAME_TICKS,
    ICR_TOP,
    SLOT_TICKS,
    TICK_US,
    ocr_to_pulse_us,
    pulse_us_to_ocr,
    timer_registers,
)
from hardware.timer import F_CPU_HZ, PRESCALER, timer_period_us


def test_timing_constants() -> None:
    assert TICK_US == 1e6 * PRESCALER / F_CPU_HZ == 0.5
    assert SLOT_TICKS == ICR_TOP + 1 == 5000
    assert timer_period_us() == 2500.0
    assert FRAME_TICKS * TICK_US == 20000.0


@pytest.mark.parametrize(
    ("pulse_us", "ocr"),
    [
        (1500.0, 2999),
        (2400.0, 4799),
        (600.0, 1199),
        (0.5, 0),
        (2499.5, 4998),
        (1500.2, 2999),  # 3000.4 ticks -> 3000
        (1500.25, 3000),  # exactly half a tick: rounds up to 3001 ticks
        (1500.3, 3000),  # 3000.6 ticks -> 3001
        (1499.75, 2999),  # 2999.5 ticks: rounds up to 3000
    ],
)
def test_pulse_to_ocr_table(pulse_us: float, ocr: int) -> None:
    assert pulse_us_to_ocr(pulse_us) == ocr


def test_pulse_to_ocr_vectorised_int32() -> None:
    ocr = pulse_us_to_ocr(np.array([[600.0, 1500.0], [2400.0, 1000.0]]))
    assert ocr.dtype == np.int32
    assert ocr.tolist() == [[1199, 2999], [4799, 1999]]


@pytest.mark.parametrize(("ocr", "pulse_us"), [(2999, 1500.0), (0, 0.5), (4799, 2400.0), (-1, 0.0)])
def test_ocr_to_pulse_table(ocr: int, pulse_us: float) -> None:
    assert ocr_to_pulse_us(ocr) == pulse_us


@pytest.mark.parametrize("bad", [0.0, 0.2, 2500.0, 3000.0, -5.0, np.inf])
def test_pulse_that_does_not_fit_a_slot_is_rejected(bad: float) -> None:
    with pytest.raises(ValueError, match=r"0\.5\.\.2499\.5 µs"):
        pulse_us_to_ocr([1500.0, bad])


def test_nan_pulse_rejected() -> None:
    with pytest.raises(ValueError, match="NaN"):
        pulse_us_to_ocr([1500.0, np.nan])


def test_register_bytes() -> None:
    assert timer_registers() == {"ICR": 4999, "TCCRnA": 0xAA, "TCCRnB": 0x1A}


def test_register_bits_decode_to_mode_14_prescaler_8_non_inverting() -> None:
    regs = timer_registers()
    a, b = regs["TCCRnA"], regs["TCCRnB"]
    # TCCRnA: COMnA1:0 bits 7:6, COMnB1:0 bits 5:4, COMnC1:0 bits 3:2, WGMn1:0 bits 1:0.
    assert [(a >> shift) & 0b11 for shift in (6, 4, 2)] == [0b10, 0b10, 0b10]
    # TCCRnB: WGMn3:2 bits 4:3, CSn2:0 bits 2:0, ICNCn/ICESn (7, 6) and reserved bit 5 clear.
    wgm = ((b >> 3) & 0b11) << 2 | (a & 0b11)
    assert wgm == 14
    assert b & 0b111 == 0b010  # clk/8
    assert b & 0b1110_0000 == 0


@given(st.integers(0, 4998))
def test_ocr_round_trip(ocr: int) -> None:
    assert pulse_us_to_ocr(ocr_to_pulse_us(ocr)) == ocr


@given(st.floats(600.0, 2400.0))
def test_quantisation_error_at_most_half_a_tick(pulse_us: float) -> None:
    assert abs(ocr_to_pulse_us(pulse_us_to_ocr(pulse_us)) - pulse_us) <= TICK_US / 2
