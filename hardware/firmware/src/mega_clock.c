/* mega_clock.c -- the frame clock of the Arduino Mega 2560 + PCA9685 board (docs/BOARDS.md):
 * tdm.h's interface without the TDM. Timer1 (CTC, clk/8, OCR1A = 4999) interrupts every 2.5 ms
 * slot as the ATmega128's guard does: at each frame's start it latches the next plan and starts
 * the PCA9685 write of its pulses; in slot SENSE_SLOT the IMU burst (the bus is free by then:
 * the write takes 1.1 ms at 400 kHz); in slot COMPUTE_SLOT it asks for the next plan.
 */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "artro_params.h"
#include "config.h"
#include "pca9685.h"
#include "sensors.h"
#include "tdm.h"

#define SLOT_TOP (ARTRO_SLOT_TICKS - 1u) /* 4999: 5000 ticks of 0.5 us */

plan_t g_plan[2];
volatile uint8_t g_active;
volatile uint8_t g_next_ready;
volatile uint32_t g_frame;
volatile uint8_t g_slot;
volatile uint16_t g_slot_count;
volatile uint8_t g_compute_due;
volatile uint8_t g_tdm_flags;

ISR(TIMER1_COMPA_vect)
{
    uint8_t next = (uint8_t)((g_slot + 1u) & (ARTRO_SLOTS_PER_FRAME - 1u));
    if (next == 0) { /* frame boundary */
        if (g_next_ready) {
            g_active ^= 1u;
            g_next_ready = 0;
        } else {
            g_tdm_flags |= TDM_OVERRUN; /* the PCA9685 keeps its pulses: the frame repeats */
        }
        g_frame++;
        if (pca9685_write(&g_plan[g_active]) != 0)
            g_tdm_flags |= TDM_SYNC_LOST; /* the bus was taken: these pulses were not sent */
    }
    g_slot = next;
    g_slot_count++;
    if (next == SENSE_SLOT)
        sensors_start();
    if (next == COMPUTE_SLOT)
        g_compute_due = 1;
}

void tdm_start(void)
{
    pca9685_boot(); /* a PCA9685 that does not answer leaves the servos without pulses */
    if (pca9685_write(&g_plan[g_active]) != 0) /* frame 0 */
        g_tdm_flags |= TDM_SYNC_LOST;
    g_slot = 0;
    OCR1A = SLOT_TOP;
    TIMSK1 = _BV(OCIE1A);
    TCNT1 = 0;
    TCCR1A = 0;
    TCCR1B = _BV(WGM12) | _BV(CS11); /* CTC, TOP = OCR1A, clk/8: counting from here */
}
