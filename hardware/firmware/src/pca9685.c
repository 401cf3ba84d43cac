/* pca9685.c -- the PCA9685's set-up at boot and each frame's write of the pulses (pca9685.h). */
#include "pca9685.h"

#include <util/delay.h>

#include "twi.h"

static uint8_t s_frame[PCA9685_FRAME_BYTES]; /* LED0_ON_L .. LED11_OFF_H, sent by the TWI */

static uint8_t write_register(uint8_t reg, uint8_t value)
{
    return twi_blocking(PCA9685_TWI_ADDRESS, reg, &value, 1, 0, 0);
}

uint8_t pca9685_boot(void)
{
    /* PRESCALE is written only while the oscillator sleeps (datasheet §7.3.5) */
    uint8_t result = write_register(PCA9685_MODE1, PCA9685_MODE1_SLEEP | PCA9685_MODE1_AI);
    if (result == 0)
        result = write_register(PCA9685_PRE_SCALE, PCA9685_PRESCALE);
    if (result == 0)
        result = write_register(PCA9685_MODE1, PCA9685_MODE1_AI); /* wake */
    _delay_us(500); /* the oscillator starts */
    for (uint8_t i = 0; i < PCA9685_FRAME_BYTES; i += 4u) {
        s_frame[i] = s_frame[i + 1u] = s_frame[i + 2u] = 0;
        s_frame[i + 3u] = 0x10u; /* full OFF until the first frame */
    }
    if (result == 0)
        result = twi_blocking(PCA9685_TWI_ADDRESS, PCA9685_LED0_ON_L, s_frame,
                              PCA9685_FRAME_BYTES, 0, 0);
    return result;
}

uint8_t pca9685_write(const plan_t *plan)
{
    if (twi_result() == TWI_BUSY)
        return TWI_BUSY; /* s_frame may still be on the wire */
    for (uint8_t i = 0; i < ARTRO_NUM_SERVOS; i++) {
        uint8_t *led = &s_frame[4u * i];
        uint16_t off = 0x1000u; /* full OFF: the torque is off */
        if (plan->state != RUN_TORQUE_OFF) {
            const uint32_t high_ticks = (uint32_t)plan->servo_ocr[i] + 1u;
            off = (uint16_t)((high_ticks * PCA9685_STEPS_PER_TICK_Q16 + 0x8000UL) >> 16);
        }
        led[0] = 0; /* ON = 0: the pulse rises as the counter wraps */
        led[1] = 0;
        led[2] = (uint8_t)off;
        led[3] = (uint8_t)(off >> 8);
    }
    return twi_begin(PCA9685_TWI_ADDRESS, PCA9685_LED0_ON_L, s_frame, PCA9685_FRAME_BYTES, 0, 0);
}
