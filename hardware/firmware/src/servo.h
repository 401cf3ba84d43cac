/* servo.h -- joint angle -> servo pulse -> timer OCR ticks (docs/DESIGN.md §5).
 *
 * pulse_us = 1500 + direction * degrees(angle) * 10 + trim_us, the angle first limited to the
 * servo's calibrated range and the pulse to 600..2400 us; both clips are reported. OCR is the
 * pulse in 0.5 us ticks rounded half up, minus one (fast PWM: high time = OCR + 1 ticks).
 */
#ifndef ARTRO_SERVO_H
#define ARTRO_SERVO_H

#include <stdint.h>

/* OCR value for servo `servo` at `angle_rad`; sets *saturated to 1 if a limit clipped it. */
uint16_t servo_ocr(uint8_t servo, float angle_rad, uint8_t *saturated);

#endif /* ARTRO_SERVO_H */
