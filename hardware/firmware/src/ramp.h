/* ramp.h -- the motion ramp (seed 004's start-up phase, docs/DESIGN.md §4): the motion vector and
 * CA the gait gets move toward the requested ones (the motion parameters) by at most the `ramp`
 * group's rate times 20 ms per frame, and land on them exactly; with `ramp.enabled` off at once.
 */
#ifndef ARTRO_RAMP_H
#define ARTRO_RAMP_H

#include <stdint.h>

enum { RAMP_A_R, RAMP_A_P, RAMP_A_Y, RAMP_CA, RAMP_COUNT };

/* The motion the gait gets in the frame being planned: a_r, a_p, a_y, CA. */
extern float g_motion[RAMP_COUNT];

/* Start at the requested motion, nothing to ramp (at boot the robot stands in its pose). */
void ramp_init(void);
/* One frame's step toward the requested motion, for the plan of `frame`; planning the same
 * frame again does not step again. */
void ramp_step(uint32_t frame);

#endif /* ARTRO_RAMP_H */
