/* main.c -- ArtRo servo biped firmware for the ATmega128 at 16 MHz (docs/DESIGN.md §5).
 *
 * Interrupts drive the servos (tdm.c: Timer1/Timer3 TDM-PWM, Timer2 walking-clock tick and guard)
 * and move UART bytes (uart.c). The main loop handles messages (protocol.c), plans each next
 * frame when the TDM asks (control.c: gait eqs 2-45, servo calibration, TDM table), sends
 * telemetry once per frame, and otherwise sleeps.
 */
#include <avr/interrupt.h>
#include <avr/sleep.h>

#include "config.h"
#include "control.h"
#include "params.h"
#include "protocol.h"
#include "tdm.h"
#include "uart.h"

int main(void)
{
    uint32_t last_frame = 0;

    params_reset();
    control_init(ARTRO_BOOT_STATE);
    uart_init();
    tdm_start();
    set_sleep_mode(SLEEP_MODE_IDLE);
    sei();

    for (;;) {
        protocol_poll();
        control_poll();
        uint32_t frame = control_frame();
        if (frame != last_frame) {
            last_frame = frame;
            protocol_frame();
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
