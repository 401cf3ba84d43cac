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

/* The sensors are read in slot SENSE_SLOT (the guard of slot 2 starts the IMU burst and the
 * ADC sweep at tick 14900; both are done within 1 ms), and the next frame's plan is computed from
 * slot COMPUTE_SLOT on: the guard of slot 3 raises the request (tick 19900), the guard of slot 7
 * latches the plan (tick 39900): a window of 20000 ticks, 160000 cycles. */
#define SENSE_SLOT 3u
#define COMPUTE_SLOT 4u

/* ---- balance sensors (sensors.c, docs/DESIGN.md §15) ---- */
/* TWI at 400 kHz: SCL = F_CPU / (16 + 2 TWBR), prescaler 1 */
#define TWI_TWBR 12u
/* MPU-6050 digital low-pass filter: DLPF_CFG 3, 44 Hz gyro bandwidth, 4.8 ms delay */
#define IMU_DLPF_CFG 3u
/* at boot, held still: 64 gyro readings 2 ms apart (128 ms) average to its offsets */
#define CALIBRATION_SAMPLES 64u
#define CALIBRATION_SPACING_MS 2u
/* MPU-6050 at ±250 °/s and ±2 g: rad/s and m/s² per count (the host's app/sim/sensors.py) */
#define IMU_GYRO_RAD_S_PER_COUNT ((float)0.00013323124061025415)
#define IMU_ACCEL_M_S2_PER_COUNT ((float)0.0005985504150390625)
/* An FSR under each sole corner in a divider to ground: R_FSR = 10 kOhm N / F (FSR 402, within
 * its part-to-part spread from 0.2 to 20 N) over R_M = 2 kOhm, 5 V: V / 5 V = F / (F + 5 N). */
#define FSR_DIVIDER_N 5.0f

/* State after reset: 0 = walking (as the simulation does from its first frame),
 * 1 = stopped (pose held at the start phase), 2 = torque off (no pulses). */
#ifndef ARTRO_BOOT_STATE
#define ARTRO_BOOT_STATE 0
#endif

/* A message whose bytes stop arriving for this many slots (2.5 ms each) is dropped with a NAK. */
#define RX_TIMEOUT_SLOTS 8u

#endif /* ARTRO_CONFIG_H */
