/* gait.h -- the ArtRo gait in float32: walking phases (eqs 10-39), leg interface (40-45, 2-9).
 *
 * A stateless function of the parameters (params.h) and the trunk phase, as in the project's
 * Python gait (docs/DESIGN.md §4, §5). The trunk phase is a 32-bit phase accumulator:
 * 2^32 counts are one gait cycle, so phi_Leg = phi_Trunk +- pi/2 and piCut are exact integer
 * wrap-arounds and the walking clock keeps no rounding drift.
 */
#ifndef ARTRO_GAIT_H
#define ARTRO_GAIT_H

#include <stdint.h>

#define GAIT_NUM_JOINTS 12
/* phi = acc * GAIT_RAD_PER_COUNT, acc in [-2^31, 2^31) <=> phi in [-pi, pi) */
#define GAIT_RAD_PER_COUNT 1.46291807926715968e-9f /* pi / 2^31 */
#define GAIT_PHASE_QUARTER 0x40000000L              /* pi/2 */

/* Joint order per leg (left leg first): hip_yaw, hip_roll, hip_pitch, knee, ankle_pitch,
 * ankle_roll. Angles in rad in the paper's convention. */
typedef struct {
    float angle[GAIT_NUM_JOINTS];
    uint8_t gamma_clamped; /* bit 0 left, bit 1 right: eq (45) summed below -1 */
} gait_output_t;

/* The 12 joint angles at trunk phase acc (eqs 2-45). */
void gait_joint_angles(int32_t phase_acc, gait_output_t *out);

/* Phase accumulator counts per 20 ms frame: 2^32 * f * 0.02 s, rounded (walking clock). */
uint32_t gait_phase_step(float freq_hz);

/* phi as float, in [-pi, pi). */
float gait_phase_rad(int32_t phase_acc);

#endif /* ARTRO_GAIT_H */
