/* control.c -- the main loop's side of the frame pipeline (docs/DESIGN.md §5).
 *
 * Frame F+1 is planned in the idle slots of frame F with the parameters in force then, so a
 * parameter message handled before that point reaches the servos in frame F+1, one handled after
 * it in frame F+2; the ACK names that frame (control_effective_frame).
 */
#include "control.h"

#include <util/atomic.h>

#include "laws.h"
#include "ramp.h"
#include "sensors.h"
#include "tdm.h"

volatile uint8_t g_main_part;
static uint8_t s_state;
static uint32_t s_planned; /* the last frame planned */

void control_init(uint8_t state)
{
    s_state = state;
    plan_init_channel_map();
    ramp_init();
    plan_compute(&g_plan[0], 0, PLAN_START_PHASE_ACC, state);
    g_active = 0;
    g_next_ready = 0;
    g_frame = 0;
    s_planned = 0;
}

uint8_t control_poll(void)
{
    uint8_t due, active;
    uint32_t frame;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        due = g_compute_due;
        g_compute_due = 0;
        frame = g_frame;
        active = g_active;
    }
    if (!due)
        return 0;
    const plan_t *current = &g_plan[active];
    sensor_reading_t reading;
    g_main_part = PART_SENSORS;
    sensors_take(&reading); /* started in slot SENSE_SLOT of this frame */
    g_main_part = PART_LAWS;
    /* on the motion of frame F; the laws rest while the robot does not walk */
    laws_step(&reading, g_sensor_status & SENSE_IMU_PRESENT, s_state == RUN_WALK,
              current->next_phase_acc);
    g_law_frame = frame + 1u;
    g_main_part = PART_PLAN;
    ramp_step(frame + 1u);
    plan_compute(&g_plan[active ^ 1u], frame + 1u, current->next_phase_acc, s_state);
    g_main_part = PART_OTHER;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        /* only if frame F is still on: else the plan came too late and the guard has
         * repeated the frame; plan again at the next request */
        if (g_frame == frame) {
            g_next_ready = 1;
            s_planned = frame + 1u;
        }
    }
    return 1;
}

void control_set_state(uint8_t state)
{
    s_state = state;
}

uint8_t control_state(void)
{
    return s_state;
}

uint32_t control_effective_frame(void)
{
    return s_planned + 1u;
}

uint32_t control_frame(void)
{
    uint32_t frame;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        frame = g_frame;
    }
    return frame;
}

const plan_t *control_current_plan(void)
{
    uint8_t active;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        active = g_active;
    }
    return &g_plan[active];
}
