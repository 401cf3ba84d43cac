/* tdm.c -- Timer1/Timer3 TDM-PWM, select lines and the Timer2 guard interrupt.
 *
 * docs/DESIGN.md §5. Time base: Timer1, Timer2 and Timer3 share the prescaler and are
 * started together (SFIOR.TSM), so Timer2 (CTC, clk/64, 1000 Timer1 ticks per period) ticks at
 * fixed Timer1 counts: 848, 1848, ..., 4848 of every slot. Timer2 is the walking-clock tick; its
 * fifth tick in a slot opens the guard:
 *
 *   1. wait for Timer1 to reach ARTRO_SELECT_CHANGE_TICKS and switch the select lines then, so
 *      they change at that tick exactly (the wait polls TCNT1L in a 4-cycle loop, twice per
 *      8-cycle tick, and the store follows 3 cycles after the read that saw it);
 *   2. at the end of slot 7, latch the next frame's plan (a frame boundary);
 *   3. write the next slot's OCR values -- double-buffered, the timers take them at the end of
 *      this period -- and its compare-output modes: an idle slot has its output disconnected
 *      (COMnx = 00) so the pin stays low, every line being low by now (pulses end by tick 4800);
 *   4. in slot COMPUTE_SLOT ask the main loop for the next frame's plan.
 */
#include "tdm.h"

#include <avr/interrupt.h>
#include <avr/io.h>

#include "artro_params.h"
#include "config.h"
#include "sensors.h"

plan_t g_plan[2];
volatile uint8_t g_active;
volatile uint8_t g_next_ready;
volatile uint32_t g_frame;
volatile uint8_t g_slot;
volatile uint16_t g_slot_count;
volatile uint8_t g_compute_due;
volatile uint8_t g_tdm_flags;

static uint8_t s_tick_in_slot;

#if (ARTRO_SELECT_CHANGE_TICKS < ARTRO_SERVO_PULSE_MAX_TICKS) \
    || (ARTRO_SELECT_CHANGE_TICKS >= ARTRO_SLOT_TICKS - 16u)
#error "the select change must lie in the guard, after 4800 ticks and before the slot ends"
#endif
#if GUARD_EARLIEST_TICKS > 4848u
#error "the Timer2 guard tick (4848) must not come before GUARD_EARLIEST_TICKS"
#endif

/* Store `value` to the select port in the tick ARTRO_SELECT_CHANGE_TICKS of Timer1. */
static inline __attribute__((always_inline)) void select_at_change_tick(uint8_t value)
{
    uint8_t count;
    __asm__ __volatile__(
        "1: in %[count], %[tcnt1l]\n\t"
        "cpi %[count], %[target]\n\t"
        "brne 1b\n\t"
        "out %[port], %[value]\n\t"
        : [count] "=&d"(count)
        : [tcnt1l] "I"(_SFR_IO_ADDR(TCNT1L)),
          [target] "M"(ARTRO_SELECT_CHANGE_TICKS & 0xFFu),
          [port] "I"(_SFR_IO_ADDR(SEL_PORT)),
          [value] "r"(value));
}

static inline __attribute__((always_inline)) void load_slot(const plan_t *plan, uint8_t slot)
{
    if (slot < ARTRO_SLOTS_USED) {
        OCR1A = plan->ocr[0][slot];
        OCR1B = plan->ocr[1][slot];
        OCR1C = plan->ocr[2][slot];
        OCR3A = plan->ocr[3][slot];
        OCR3B = plan->ocr[4][slot];
        OCR3C = plan->ocr[5][slot];
    }
    TCCR1A = plan->tccra[0][slot];
    TCCR3A = plan->tccra[1][slot];
}

static inline __attribute__((always_inline)) void guard(void)
{
    uint8_t next = (uint8_t)((g_slot + 1u) & (ARTRO_SLOTS_PER_FRAME - 1u));
    uint8_t select = (uint8_t)((SEL_PORT & (uint8_t)~SEL_MASK) | (uint8_t)(next << SEL_SHIFT));
    uint16_t now = TCNT1;
    if (now >= GUARD_EARLIEST_TICKS && now < ARTRO_SELECT_CHANGE_TICKS - 1u) {
        select_at_change_tick(select);
    } else {
        SEL_PORT = select; /* late or early: switch now and say so */
        g_tdm_flags |= TDM_SYNC_LOST;
    }

    if (next == 0) { /* frame boundary: slot 0 of the next frame follows */
        if (g_next_ready) {
            g_active ^= 1u;
            g_next_ready = 0;
        } else {
            g_tdm_flags |= TDM_OVERRUN; /* repeat the frame rather than send half a plan */
        }
        g_frame++;
    }
    load_slot(&g_plan[g_active], next);
    g_slot = next;
    g_slot_count++;
    if (next == SENSE_SLOT)
        sensors_start();
    if (next == COMPUTE_SLOT)
        g_compute_due = 1;
}

/* Timer2 compare match: five per slot, the fifth in each slot is the guard. */
ISR(TIMER2_COMP_vect)
{
    if (++s_tick_in_slot < TIMER2_TICKS_PER_SLOT)
        return;
    s_tick_in_slot = 0;
    guard();
}

void tdm_start(void)
{
    const plan_t *plan = &g_plan[g_active];

    SEL_PORT &= (uint8_t)~SEL_MASK; /* slot 0 */
    SEL_DDR |= SEL_MASK;
    PORTB &= (uint8_t)~(_BV(PB5) | _BV(PB6) | _BV(PB7));
    PORTE &= (uint8_t)~(_BV(PE3) | _BV(PE4) | _BV(PE5));
    DDRB |= _BV(PB5) | _BV(PB6) | _BV(PB7); /* OC1A, OC1B, OC1C */
    DDRE |= _BV(PE3) | _BV(PE4) | _BV(PE5); /* OC3A, OC3B, OC3C */

    /* hold the shared prescaler of Timer1/2/3 in reset while the timers are set up */
    SFIOR = _BV(TSM) | _BV(PSR321);
    ICR1 = ARTRO_TIMER_ICR_TOP; /* TOP before the mode that uses it */
    ICR3 = ARTRO_TIMER_ICR_TOP;
    load_slot(plan, 0);
    OCR2 = TIMER2_OCR;
    TIMSK |= _BV(OCIE2);
    g_slot = 0;
    s_tick_in_slot = 0;

    TCCR1B = ARTRO_TIMER_TCCRNB; /* fast PWM mode 14, clk/8 */
    TCCR3B = ARTRO_TIMER_TCCRNB;
    TCCR2 = _BV(WGM21) | _BV(CS21) | _BV(CS20); /* CTC, clk/64 */
    TCNT2 = TIMER2_START;
    SFIOR = 0; /* release: the three timers count in step from here */
}
