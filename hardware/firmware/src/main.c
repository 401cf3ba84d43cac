/* main.c -- ArtRo servo biped firmware for the ATmega128 at 16 MHz (docs/DESIGN.md §5).
 *
 * Interrupts drive the servos (tdm.c: Timer1/Timer3 TDM-PWM, Timer2 walking-clock tick and guard)
 * and move UART bytes (uart.c), the TWI and ADC read the balance sensors (sensors.c). The main
 * loop plans each next frame when the TDM asks (control.c: sensors, feedback laws, gait eqs 2-45,
 * servo calibration, TDM table), handles messages (protocol.c), sends telemetry once per frame,
 * and otherwise sleeps.
 */
#include <avr/interrupt.h>
#include <avr/sleep.h>

#include "config.h"
#include "control.h"
#include "params.h"
#include "protocol.h"
#include "sensors.h"
#include "tdm.h"
#include "uart.h"

int main(void)
{
    uint32_t last_frame = 0;

    params_reset();
    uart_init();
    sei();
    sensors_boot(); /* the IMU calibrated at rest (128 ms) before the servos get pulses */
    control_init(ARTRO_BOOT_STATE);
    tdm_start();
    set_sleep_mode(SLEEP_MODE_IDLE);

    for (;;) {
        control_poll(); /* the plan first: a message waits while the next frame is planned */
        g_main_part = PART_MESSAGES;
        protocol_poll();
        g_main_part = PART_OTHER;
        uint32_t frame = control_frame();
        if (frame != last_frame) {
            last_frame = frame;
            g_main_part = PART_TELEMETRY;
            protocol_frame();
            g_main_part = PART_OTHER;
        }
        cli();
        if (!g_compute_due && !uart_rx_pending() && g_frame == last_frame) {
            sleep_enable();
            sei();
            sleep_cpu(); /* the next interrupt wakes us */
            sleep_disable();
        }
        sei();
    }
}
