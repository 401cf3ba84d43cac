/* tdm.h -- TDM-PWM on Timer1/Timer3 with the demultiplexer select lines (docs/DESIGN.md §5).
 *
 * Timer1 and Timer3 run fast PWM mode 14 (TOP = ICRn = 4999, clk/8): one period = one 2.5 ms slot,
 * eight slots = one 20 ms frame. Each of the six compare outputs (OC1A/B/C = PB5/6/7,
 * OC3A/B/C = PE3/4/5) carries slot k's servo pulse, high for OCR + 1 ticks from the slot start.
 * The select lines (config.h) switch to slot k+1 at ARTRO_SELECT_CHANGE_TICKS of slot k, inside
 * the guard between the longest pulse (4800 ticks) and the slot end; right after, the next slot's
 * OCR values (latched by the timer at the period end) and compare-output modes are written.
 */
#ifndef ARTRO_TDM_H
#define ARTRO_TDM_H

#include <stdint.h>

#include "plan.h"

/* tdm flags (sticky until read by telemetry) */
#define TDM_OVERRUN 0x01u   /* a frame repeated: the next plan was not ready at the end of slot 7 */
#define TDM_SYNC_LOST 0x02u /* the guard interrupt came outside its window */

extern plan_t g_plan[2];
extern volatile uint8_t g_active;        /* index of the plan being output */
extern volatile uint8_t g_next_ready;    /* the spare plan holds frame g_frame + 1 */
extern volatile uint32_t g_frame;        /* frame being output */
extern volatile uint8_t g_slot;          /* slot being output, 0..7 */
extern volatile uint16_t g_slot_count;   /* free-running count of slots (2.5 ms clock) */
extern volatile uint8_t g_compute_due;   /* set in slot COMPUTE_SLOT: plan frame g_frame + 1 */
extern volatile uint8_t g_tdm_flags;

/* Configure the pins and timers for g_plan[g_active] (frame 0) and start them together. */
void tdm_start(void);

#endif /* ARTRO_TDM_H */
