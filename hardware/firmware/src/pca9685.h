/* pca9685.h -- the twelve servo pulses on a PCA9685 over the TWI (docs/BOARDS.md).
 *
 * NXP PCA9685: 16 PWM channels, a 12-bit counter clocked at 25 MHz / (PRESCALE + 1). PRESCALE =
 * round(25 MHz / (4096 * 50 Hz)) - 1 = 121: one step is 122 / 25 MHz = 4.88 us, one period
 * 4096 steps = 19.988 ms. Servo i is on channel i; its pulse is ON = 0, OFF = the pulse in steps.
 */
#ifndef ARTRO_PCA9685_H
#define ARTRO_PCA9685_H

#include <stdint.h>

#include "plan.h"

#define PCA9685_TWI_ADDRESS 0x40u /* A5..A0 low */
#define PCA9685_OSC_HZ 25000000UL
#define PCA9685_PRESCALE 121u
/* registers (datasheet §7.3) */
#define PCA9685_MODE1 0x00u
#define PCA9685_MODE2 0x01u
#define PCA9685_LED0_ON_L 0x06u /* LEDn_ON_L = 0x06 + 4 n, then ON_H, OFF_L, OFF_H */
#define PCA9685_PRE_SCALE 0xFEu
#define PCA9685_MODE1_RESTART 0x80u
#define PCA9685_MODE1_AI 0x20u /* register auto-increment */
#define PCA9685_MODE1_SLEEP 0x10u
#define PCA9685_FRAME_BYTES (4u * ARTRO_NUM_SERVOS)

/* A pulse in steps from a servo's OCR (high time OCR + 1 ticks of 0.5 us): round(h / 9.76)
 * as (h * 6715 + 2^15) >> 16 (6715 / 2^16 = 1 / 9.7596; the same as rounding but within
 * 0.02 steps of a half). */
#define PCA9685_STEPS_PER_TICK_Q16 6715UL

/* Sleep, PRESCALE, wake with auto-increment, wait for the oscillator (500 us), outputs off;
 * blocking (boot, interrupts on). Returns TWI_OK if the part answered every write. */
uint8_t pca9685_boot(void);
/* Start writing `plan`'s twelve pulses (one transaction from LED0_ON_L, 48 bytes); they take
 * effect at its STOP, from the PCA9685's next period on. TWI_BUSY if the bus was taken. */
uint8_t pca9685_write(const plan_t *plan);

#endif /* ARTRO_PCA9685_H */
