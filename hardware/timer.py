"""ATmega128 16-bit Timer1/Timer3 as ArtRo's TDM-PWM generator, seed 000 §3.A–3.B (Figure 7b).

Fast PWM mode 14, prescaler 8 (0.5 µs tick), ICRn = 4999: one timer period is one 2.5 ms slot,
8 slots one 20 ms frame; high time = (OCR + 1) ticks (docs/DESIGN.md §5).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

# The paper says only that the two 16-bit timers (three output compare units each: OC1A/B/C,
# OC3A/B/C) generate six PWM signals, each carrying 5 servo pulses per 20 ms (Figure 7b). We model
# the faithful set-up that makes one timer period equal one 2.5 ms TDM slot.
F_CPU_HZ = 16_000_000  # ATmega128 system clock
PRESCALER = 8  # clk_I/O / 8
TICK_US = 0.5  # 1e6 * PRESCALER / F_CPU_HZ
WGM_MODE = 14  # fast PWM, TOP = ICRn, OCRnx latched at BOTTOM
ICR_TOP = 4999  # ICRn: counter runs 0..4999
SLOT_TICKS = ICR_TOP + 1  # 5000 ticks = 2.5 ms, one TDM slot
SLOTS_PER_FRAME = 8  # 8 x 2.5 ms = 20 ms servo period
FRAME_TICKS = SLOT_TICKS * SLOTS_PER_FRAME  # 40000 ticks = 20 ms
SLOTS_USED = 5  # the paper multiplexes 5 servos per channel (Figure 7b)
# Non-inverting compare output (COMnx1:0 = 10): the pin goes high at BOTTOM (slot start) and low on
# the compare match TCNTn == OCRnx, so the high time is (OCRnx + 1) ticks. OCRnx is double-buffered
# in PWM modes: a value written during a slot is latched at the next BOTTOM, so the firmware writes
# slot k+1's value during slot k. An idle slot has its compare output disconnected (COMnx1:0 = 00)
# so the line stays low; OCR = TOP would hold the line high for the whole slot.
OCR_IDLE = -1  # idle slot: compare output disconnected, line low
OCR_MAX = ICR_TOP - 1  # longest pulse that still ends inside its slot (4999 ticks)

# TCCRnA bits (ATmega128 datasheet, "16-bit Timer/Counter (Timer/Counter1 and Timer/Counter3)").
COMNA1, COMNA0, COMNB1, COMNB0, COMNC1, COMNC0, WGMN1, WGMN0 = 7, 6, 5, 4, 3, 2, 1, 0
# TCCRnB bits (bit 5 is reserved).
ICNCN, ICESN, WGMN3, WGMN2, CSN2, CSN1, CSN0 = 7, 6, 4, 3, 2, 1, 0

# Mode 14 = WGMn3:0 = 0b1110: WGMn1 lives in TCCRnA, WGMn3 and WGMn2 in TCCRnB.
# All three compare outputs non-inverting (COMnx1:0 = 0b10).
TCCRNA = (1 << COMNA1) | (1 << COMNB1) | (1 << COMNC1) | (1 << WGMN1)  # 0xAA
# Clock select CSn2:0 = 0b010: clk/8.
TCCRNB = (1 << WGMN3) | (1 << WGMN2) | (1 << CSN1)  # 0x1A


def pulse_us_to_ocr(pulse_us: ArrayLike) -> NDArray[np.int32]:
    """Pulse width in µs -> OCRnx value: round(pulse_us / TICK_US) - 1. Vectorised.

    Rounds to the nearest tick with halves rounded up, floor(x + 0.5), as firmware fixed-point
    code does: 1500.25 µs -> 3001 ticks -> OCR 3000 (numpy's round-half-even would give 2999).

    Raises:
        ValueError: on NaN, or a pulse outside 0.5..2499.5 µs (OCR outside 0..OCR_MAX), which no
            single slot can carry.
    """
    pulse = np.asarray(pulse_us, dtype=np.float64)
    if np.any(np.isnan(pulse)):
        raise ValueError("pulse_us must not be NaN")
    ticks = np.floor(pulse / TICK_US + 0.5)
    ocr = ticks - 1
    if np.any(ocr < 0) or np.any(ocr > OCR_MAX):
        raise ValueError(
            f"pulse_us must round to 1..{OCR_MAX + 1} ticks ({TICK_US:g}.."
            f"{(OCR_MAX + 1) * TICK_US:g} µs) to fit one {SLOT_TICKS}-tick slot; got values in "
            f"[{pulse.min():g}, {pulse.max():g}] µs"
        )
    return ocr.astype(np.int32)


def ocr_to_pulse_us(ocr: ArrayLike) -> NDArray[np.float64]:
    """OCRnx value -> high time in µs: (OCR + 1) * TICK_US (exact in float64). Vectorised."""
    return ((np.asarray(ocr, dtype=np.int64) + 1) * TICK_US).astype(np.float64, copy=False)


def timer_registers() -> dict[str, int]:
    """Register values for Timer1 and Timer3 (identical), e.g. for a firmware header.

    Returns:
        {"ICR": 4999, "TCCRnA": 0xAA, "TCCRnB": 0x1A}. Write ICRn before TCCRnB starts the clock.
    """
    return {"ICR": ICR_TOP, "TCCRnA": TCCRNA, "TCCRnB": TCCRNB}


def timer_period_us() -> float:
    """One timer period (= one TDM slot) in µs: (ICR + 1) * PRESCALER / F_CPU."""
    return SLOT_TICKS * PRESCALER * 1e6 / F_CPU_HZ
