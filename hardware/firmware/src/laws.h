/* laws.h -- the balance feedback on top of the open-loop gait, once per frame (docs/DESIGN.md
 * §15): the attitude estimate (a complementary filter) and the four laws -- tilt trim, yaw-rate
 * loop, gyro damping, centre-of-pressure loop, step timing -- in float32, the same arithmetic as the host's
 * gait/feedback.py, with their switches and gains in the parameter table (ids after the gait's).
 */
#ifndef ARTRO_LAWS_H
#define ARTRO_LAWS_H

#include <stdint.h>

#include "gait.h"
#include "sensors.h"

typedef struct {
    uint8_t switches; /* the laws that stepped last (LAW_* bits): another set restarts them */
    uint8_t started;
    float pitch, roll;
    float tilt_error[2], tilt_integral[2];
    float yaw_error, yaw_integral;
    float cop_integral[2], cop_last[2];
    float timing_error; /* the roll's deviation from its expected swing, filtered */
} law_state_t;

typedef struct {
    float joint_delta[GAIT_NUM_JOINTS]; /* added to the gait's joint angles */
    float a_y_delta;                    /* added to the ramped a_y, within its range */
    float tilt[2];                      /* pitch and roll trim */
    float cop[2];                       /* the support foot's ankle pitch and roll */
    int8_t support;                     /* 0 left, 1 right, -1 neither carries min_load_n */
    float attitude[2];                  /* pitch, roll estimate */
    float freq_delta_hz;                /* added to the clock's frequency (timing) */
} law_output_t;

extern law_state_t g_law_state;
extern law_output_t g_law_output; /* the corrections of the frame planned last */
extern uint32_t g_law_frame;       /* that frame */

/* 1 if a law is switched on (else the plan is the open-loop gait's, to the bit). */
uint8_t laws_any_on(void);
/* One frame of the attitude estimate and, while the robot walks (`walking`), every law that is
 * on, from `reading`, the motion the gait got in the frame before (g_motion, ramp.h) and the
 * phase of the frame planned next (`phase_acc`, for the timing law); fills
 * g_law_output. Without the IMU (`imu_present` 0) only the centre-of-pressure loop runs. The
 * laws restart (their filters and integrals zeroed, the attitude kept: gait/feedback.py
 * `restarted`) whenever the set of laws that step changes: a law switched on or off, and
 * STOP, TORQUE_OFF and START, since no law steps while the robot does not walk. */
void laws_step(const sensor_reading_t *reading, uint8_t imu_present, uint8_t walking,
               int32_t phase_acc);
/* the clock's frequency, Hz: the gait's plus the timing law's change */
float laws_freq_hz(float freq_hz);
/* a_y as the gait gets it: the ramped a_y plus the yaw-rate loop's change, within a_y's range */
float laws_a_y(float ramped_a_y);

#endif /* ARTRO_LAWS_H */
