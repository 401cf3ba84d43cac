/* servo.c -- the servo model of the hardware layer in the firmware (docs/DESIGN.md §5). */
#include "servo.h"

#include "artro_params.h"

/* pulse ticks per rad: 10 us per degree, 2 ticks per us */
#define TICKS_PER_RAD (2.0f * ARTRO_SERVO_US_PER_DEG * 57.2957795130823f)
#define PULSE_MIN_TICKS (2.0f * ARTRO_SERVO_PULSE_MIN_US)
#define PULSE_MAX_TICKS (2.0f * ARTRO_SERVO_PULSE_MAX_US)
#define CENTER_TICKS (2.0f * ARTRO_SERVO_CENTER_US)

uint16_t servo_ocr(uint8_t servo, float angle_rad, uint8_t *saturated)
{
    float limited = angle_rad;
    *saturated = 0;
    if (!(limited >= ARTRO_SERVO_MIN_RAD[servo])) { /* also catches NaN */
        limited = ARTRO_SERVO_MIN_RAD[servo];
        *saturated = 1;
    } else if (limited > ARTRO_SERVO_MAX_RAD[servo]) {
        limited = ARTRO_SERVO_MAX_RAD[servo];
        *saturated = 1;
    }
    float ticks = CENTER_TICKS + (float)ARTRO_SERVO_DIRECTION[servo] * limited * TICKS_PER_RAD
        + 2.0f * ARTRO_SERVO_TRIM_US[servo];
    if (ticks < PULSE_MIN_TICKS) {
        ticks = PULSE_MIN_TICKS;
        *saturated = 1;
    } else if (ticks > PULSE_MAX_TICKS) {
        ticks = PULSE_MAX_TICKS;
        *saturated = 1;
    }
    /* rounded half up (ticks > 0: truncation is floor), then high time - 1 */
    return (uint16_t)(ticks + 0.5f) - 1u;
}
