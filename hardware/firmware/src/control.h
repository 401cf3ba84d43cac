/* control.h -- run state and frame planning of the main loop (docs/DESIGN.md §5). */
#ifndef ARTRO_CONTROL_H
#define ARTRO_CONTROL_H

#include <stdint.h>

#include "plan.h"

/* What the main loop is doing, for a debugger or a profiler (the emulator's bench counts
 * cycles by it, docs/DESIGN.md §5): one store per part, nothing reads it. */
enum main_part {
    PART_OTHER = 0,
    PART_SENSORS = 1,  /* sensors_take: the sample decoded */
    PART_LAWS = 2,     /* laws_step */
    PART_PLAN = 3,     /* ramp, gait, servos, TDM table */
    PART_MESSAGES = 4, /* protocol_poll */
    PART_TELEMETRY = 5,
};
extern volatile uint8_t g_main_part;

/* Plan frame 0 at the start phase (before the timers start). */
void control_init(uint8_t state);
/* Plan the next frame if the TDM asked for it; returns 1 if it did. */
uint8_t control_poll(void);
void control_set_state(uint8_t state);
uint8_t control_state(void);
/* The first frame a change made now reaches: the next frame still to be planned. */
uint32_t control_effective_frame(void);
/* Frame being output. */
uint32_t control_frame(void);
/* The plan being output (main loop only; the interrupt swaps plans only at frame ends). */
const plan_t *control_current_plan(void);

#endif /* ARTRO_CONTROL_H */
