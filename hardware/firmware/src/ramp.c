/* ramp.c -- the motion ramp, as the project's Python `gait.ramp_motion` does it (docs/DESIGN.md
 * §4): each component moves by at most rate * 20 ms toward its target and snaps onto it once
 * within (1 + 1e-6) of a step. a_r and a_p share ramp.amp_rad_s, a_y has ramp.yaw_rad_s, CA
 * ramp.ca_per_s.
 */
#include "ramp.h"

#include <math.h>

#include "params.h"

#define FRAME_S 0.02f
#define SNAP_FRACTION 1e-6f

float g_motion[RAMP_COUNT];
static uint32_t s_stepped_frame;
/* per component: the rate the step was computed from, the step, and the snap distance -- kept,
 * so that a frame in a ramp costs no float multiplication (a soft-float mul is ~150 cycles) */
static float s_rate[RAMP_COUNT], s_step[RAMP_COUNT], s_snap[RAMP_COUNT];

static float requested(uint8_t i)
{
    switch (i) {
    case RAMP_A_R: return P(MOTION_A_R);
    case RAMP_A_P: return P(MOTION_A_P);
    case RAMP_A_Y: return P(MOTION_A_Y);
    default: return P(MOTION_CA);
    }
}

static float rate(uint8_t i)
{
    switch (i) {
    case RAMP_A_R:
    case RAMP_A_P: return P(RAMP_AMP_RAD_S);
    case RAMP_A_Y: return P(RAMP_YAW_RAD_S);
    default: return P(RAMP_CA_PER_S);
    }
}

void ramp_init(void)
{
    for (uint8_t i = 0; i < RAMP_COUNT; i++) {
        g_motion[i] = requested(i);
        s_rate[i] = -1.0f; /* no rate is negative: the step is computed at first use */
    }
    s_stepped_frame = 0;
}

void ramp_step(uint32_t frame)
{
    if (frame <= s_stepped_frame)
        return;
    s_stepped_frame = frame;
    for (uint8_t i = 0; i < RAMP_COUNT; i++) {
        const float target = requested(i);
        if (g_motion[i] == target)
            continue; /* the usual case: nothing to ramp */
        if (rate(i) != s_rate[i]) {
            s_rate[i] = rate(i);
            s_step[i] = s_rate[i] * FRAME_S;
            s_snap[i] = s_step[i] * (1.0f + SNAP_FRACTION);
        }
        const float delta = target - g_motion[i];
        if (!SWITCH(RAMP_ENABLED) || fabsf(delta) <= s_snap[i])
            g_motion[i] = target;
        else
            g_motion[i] += delta > 0.0f ? s_step[i] : -s_step[i];
    }
}
