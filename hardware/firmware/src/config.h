/* config.h -- board wiring and timing choices of the ArtRo firmware (docs/DESIGN.md §5).
 *
 * Everything a board builder may want to change lives here; the gait constants, servo
 * calibration and channel map come from the generated artro_params.h / artro_schema.h.
 */
#ifndef ARTRO_CONFIG_H
#define ARTRO_CONFIG_H

#include <avr/io.h>

/* Demultiplexer select lines S0..S2 (shared by the six demultiplexers): PORTC bits 0..2. */
#define SEL_PORT PORTC
#define SEL_DDR DDRC
#define SEL_SHIFT 0
#define SEL_MASK (0x07u << SEL_SHIFT)

/* UART0 (PE0 = RXD0, PE1 = TXD0): 57600 baud with U2X, UBRR = 34, -0.8 % error at 16 MHz. */
#define UART_BAUD 57600UL
#define UART_UBRR 34u

/* Timer2 is the walking-clock tick (CTC, clk/64, OCR2 = 124: every 500 us = 1000 timer1 ticks,
 * five ticks per TDM slot). Its compare interrupt at tick 4848 of each slot opens the guard
 * (first match after OCR2 - TIMER2_START + 1 = 106 counts = 848 timer1 ticks). */
#define TIMER2_OCR 124u
#define TIMER2_START 19u
#define TIMER2_TICKS_PER_SLOT 5u
/* The guard routine starts no earlier than this tick (it waits for the low byte of
 * ARTRO_SELECT_CHANGE_TICKS, which repeats every 256 ticks). */
#define GUARD_EARLIEST_TICKS (ARTRO_SELECT_CHANGE_TICKS - 255u)

/* The next frame's plan is computed in the idle slots 5..7 of the current frame: the guard of
 * slot 4 raises the request (tick 24900), the guard of slot 7 latches the plan (tick 39900). */
#define COMPUTE_SLOT 5u

/* State after reset: 0 = walking (as the simulation does from its first frame),
 * 1 = stopped (pose held at the start phase), 2 = torque off (no pulses). */
#ifndef ARTRO_BOOT_STATE
#define ARTRO_BOOT_STATE 0
#endif

/* A message whose bytes stop arriving for this many slots (2.5 ms each) is dropped with a NAK. */
#define RX_TIMEOUT_SLOTS 8u

#endif /* ARTRO_CONFIG_H */
