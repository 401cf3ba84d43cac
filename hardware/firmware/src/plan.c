/* plan.c -- walking clock, gait, servo model and TDM table of one frame (docs/DESIGN.md §5).
 *
 * Walking clock (eqs 10-11): phi_Trunk advances by 2*pi*f*20 ms per frame, the step of the
 * frequency in force when the frame was planned (as the simulation's frame loop does; plus the
 * timing law's change, laws.c), kept in
 * [-pi, pi) by the int32 wrap-around of the phase accumulator.
 */
#include "plan.h"

#include "laws.h"
#include "params.h"
#include "servo.h"

/* COMnx1 bit of the compare outputs A, B, C in TCCRnA (non-inverting fast PWM: COMnx1:0 = 10) */
static const uint8_t COM_BIT[3] = {0x80u, 0x20u, 0x08u};
#define TCCRNA_WGM_BITS (ARTRO_TIMER_TCCRNA & 0x03u) /* WGMn1:0 of mode 14 */

/* servo on (channel, slot), 0xFF where the slot is idle */
static uint8_t s_servo_at[TDM_CHANNELS][ARTRO_SLOTS_USED];

void plan_init_channel_map(void)
{
    for (uint8_t c = 0; c < TDM_CHANNELS; c++)
        for (uint8_t s = 0; s < ARTRO_SLOTS_USED; s++)
            s_servo_at[c][s] = 0xFFu;
    for (uint8_t i = 0; i < ARTRO_NUM_SERVOS; i++)
        s_servo_at[ARTRO_SERVO_CHANNEL[i]][ARTRO_SERVO_SLOT[i]] = i;
}

void plan_compute(plan_t *plan, uint32_t frame, int32_t phase_acc, uint8_t state)
{
    gait_output_t gait;
    gait_joint_angles(phase_acc, &gait);

    plan->frame = frame;
    plan->phase_acc = phase_acc;
    plan->next_phase_acc = state == RUN_WALK
        ? (int32_t)((uint32_t)phase_acc + gait_phase_step(laws_freq_hz(P(CLOCK_FREQ_HZ))))
        : phase_acc;
    plan->state = state;
    plan->flags = gait.gamma_clamped ? PLAN_GAMMA_CLAMPED : 0u;
    plan->saturated = 0;
    if (laws_any_on()) /* the feedback's corrections (laws.c); all off: the open-loop gait */
        for (uint8_t i = 0; i < GAIT_NUM_JOINTS; i++)
            gait.angle[i] += g_law_output.joint_delta[i];
    for (uint8_t i = 0; i < ARTRO_NUM_SERVOS; i++) {
        uint8_t clipped;
        plan->angle[i] = gait.angle[i];
        plan->servo_ocr[i] = servo_ocr(i, gait.angle[i], &clipped);
        if (clipped) {
            plan->saturated |= (uint16_t)(1u << i);
            plan->flags |= PLAN_SATURATED;
        }
    }

    /* The TDM table: each line carries slot k's servo; slots with no servo (and every slot
     * when the torque is off) have their compare output disconnected, so the line stays low. */
    for (uint8_t slot = 0; slot < ARTRO_SLOTS_PER_FRAME; slot++) {
        plan->tccra[0][slot] = TCCRNA_WGM_BITS;
        plan->tccra[1][slot] = TCCRNA_WGM_BITS;
    }
    for (uint8_t c = 0; c < TDM_CHANNELS; c++) {
        for (uint8_t slot = 0; slot < ARTRO_SLOTS_USED; slot++) {
            uint8_t servo = s_servo_at[c][slot];
            plan->ocr[c][slot] = servo == 0xFFu ? 0u : plan->servo_ocr[servo];
            if (servo != 0xFFu && state != RUN_TORQUE_OFF)
                plan->tccra[c / 3u][slot] |= COM_BIT[c % 3u];
        }
    }
}
