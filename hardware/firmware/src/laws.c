/* laws.c -- attitude estimate and balance feedback laws in float32 (docs/DESIGN.md §15).
 *
 * Line for line the host's gait/attitude.py and gait/feedback.py: the same order of operations,
 * so the host's model of the firmware computes the same values. Axes of the IMU: x forward, y
 * left, z up; pitch > 0 leans forward, roll > 0 lowers the right side.
 */
#include "laws.h"

#include <math.h>
#include <string.h>

#include "artro_schema.h"
#include "params.h"
#include "ramp.h"

#define FRAME_DT_S 0.02f
/* joint index per leg (left, right) in the gait's order */
static const uint8_t HIP_ROLL[2] = {1, 7}, HIP_PITCH[2] = {2, 8};
static const uint8_t ANKLE_PITCH[2] = {4, 10}, ANKLE_ROLL[2] = {5, 11};
static const float OUTWARD[2] = {1.0f, -1.0f}; /* +y is outward for the left foot */

law_state_t g_law_state;
law_output_t g_law_output;
uint32_t g_law_frame;

enum { LAW_TILT = 1, LAW_YAW_RATE = 2, LAW_DAMPING = 4, LAW_COP = 8, LAW_TIMING = 16 };

static uint8_t laws_switched_on(void)
{
    return (SWITCH(TILT_ENABLED) ? LAW_TILT : 0) | (SWITCH(YAW_RATE_ENABLED) ? LAW_YAW_RATE : 0)
         | (SWITCH(DAMPING_ENABLED) ? LAW_DAMPING : 0) | (SWITCH(COP_ENABLED) ? LAW_COP : 0)
         | (SWITCH(TIMING_ENABLED) ? LAW_TIMING : 0);
}

uint8_t laws_any_on(void)
{
    return laws_switched_on() != 0;
}

/* gait/feedback.py restarted: every law's filter and integral zeroed, the attitude kept */
static void laws_restart(law_state_t *s)
{
    s->tilt_error[0] = s->tilt_error[1] = 0.0f;
    s->tilt_integral[0] = s->tilt_integral[1] = 0.0f;
    s->yaw_error = s->yaw_integral = 0.0f;
    s->cop_integral[0] = s->cop_integral[1] = 0.0f;
    s->cop_last[0] = s->cop_last[1] = 0.0f;
    s->timing_error = 0.0f;
}

static float clampf(float x, float limit)
{
    return x > limit ? limit : (x < -limit ? -limit : x);
}

static float low_pass(float value, float target, float tau_s)
{
    return value + (target - value) * (FRAME_DT_S / (tau_s + FRAME_DT_S));
}

static float dead_band(float error, float width)
{
    float past = fabsf(error) - width;
    if (past < 0.0f)
        past = 0.0f;
    return error > 0.0f ? past : (error < 0.0f ? -past : 0.0f);
}

static void accel_tilt(const float *a, float *pitch, float *roll)
{
    *pitch = atan2f(-a[0], sqrtf(a[1] * a[1] + a[2] * a[2]));
    *roll = atan2f(a[1], a[2]);
}

/* gait/attitude.py starts_attitude: within START_G_BAND of g (not falling, not landing) */
#define G_M_S2 9.80665f
static uint8_t starts_attitude(const float *a)
{
    const float squared = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    const float low = 0.9f * G_M_S2, high = 1.1f * G_M_S2;
    return low * low <= squared && squared <= high * high;
}

/* gait/attitude.py PITCH_LIMIT_RAD: tan(pitch) grows without bound toward +-pi/2 */
#define PITCH_LIMIT_RAD 1.5f
#define PI_F 3.14159265358979f

/* gait/attitude.py complementary_step; no estimate (pitch, roll 0) until a reading starts it */
static void attitude_step(law_state_t *s, const float *gyro, const float *accel)
{
    float acc_pitch, acc_roll;
    accel_tilt(accel, &acc_pitch, &acc_roll);
    if (!s->started) {
        if (!starts_attitude(accel))
            return;
        s->pitch = acc_pitch;
        s->roll = acc_roll;
        s->started = 1;
        return;
    }
    const float tau = P(ATTITUDE_TAU_S);
    const float keep = tau / (tau + FRAME_DT_S);
    const float sin_r = sinf(s->roll), cos_r = cosf(s->roll);
    const float pitch_rate = cos_r * gyro[1] - sin_r * gyro[2];
    const float roll_rate = gyro[0] + tanf(s->pitch) * (sin_r * gyro[1] + cos_r * gyro[2]);
    const float pitch_path = s->pitch + pitch_rate * FRAME_DT_S;
    const float roll_path = s->roll + roll_rate * FRAME_DT_S;
    const float apart = acc_roll - roll_path; /* across +-pi: on the gyro path's side */
    if (apart > PI_F)
        acc_roll -= 2 * PI_F;
    else if (apart < -PI_F)
        acc_roll += 2 * PI_F;
    const float pitch = keep * pitch_path + (1.0f - keep) * acc_pitch;
    float roll = keep * roll_path + (1.0f - keep) * acc_roll;
    if (roll > PI_F)
        roll -= 2 * PI_F;
    else if (roll <= -PI_F)
        roll += 2 * PI_F;
    s->pitch = pitch > PITCH_LIMIT_RAD ? PITCH_LIMIT_RAD
             : pitch < -PITCH_LIMIT_RAD ? -PITCH_LIMIT_RAD : pitch;
    s->roll = roll;
}

static void tilt_trim(law_state_t *s, law_output_t *out)
{
    const float expected[2] = {
        P(TILT_PITCH_OFFSET_RAD) + P(TILT_PITCH_PER_A_P) * g_motion[RAMP_A_P],
        P(TILT_ROLL_PER_A_R) * g_motion[RAMP_A_R],
    };
    const float estimate[2] = {s->pitch, s->roll};
    const float limit = P(TILT_CLAMP_RAD), ki_dt = P(TILT_KI_PER_S) * FRAME_DT_S;
    for (uint8_t k = 0; k < 2; k++) {
        const float filtered =
            low_pass(s->tilt_error[k], estimate[k] - expected[k], P(TILT_FILTER_S));
        const float past = dead_band(filtered, P(TILT_DEADBAND_RAD));
        const float integral = clampf(s->tilt_integral[k] + ki_dt * past, limit);
        out->tilt[k] = clampf(integral + P(TILT_KP) * past, limit);
        s->tilt_error[k] = filtered;
        s->tilt_integral[k] = integral;
    }
    out->tilt[1] *= P(TILT_ROLL_SHARE); /* 1: the roll trim as the law gives it */
    for (uint8_t leg = 0; leg < 2; leg++) {
        out->joint_delta[ANKLE_PITCH[leg]] -= out->tilt[0]; /* toes down against a forward lean */
        out->joint_delta[HIP_ROLL[leg]] += out->tilt[1] * OUTWARD[leg];
    }
}

static void yaw_rate(law_state_t *s, law_output_t *out, float gyro_z)
{
    const float speed = P(YAW_RATE_SPEED_PER_A_P) * g_motion[RAMP_A_P];
    const float commanded = P(YAW_RATE_TURN_PER_A_Y) * g_motion[RAMP_A_Y]
        - 2.0f * g_motion[RAMP_CA] * speed / P(YAW_RATE_AXLE_M); /* seed 004 eq (13) */
    const float limit = P(YAW_RATE_CLAMP);
    const float filtered = low_pass(s->yaw_error, commanded - gyro_z, P(YAW_RATE_FILTER_S));
    const float integral =
        clampf(s->yaw_integral + P(YAW_RATE_KI_PER_S) * FRAME_DT_S * filtered, limit);
    out->a_y_delta = clampf(-(integral + P(YAW_RATE_KP) * filtered), limit);
    s->yaw_error = filtered;
    s->yaw_integral = integral;
}

static void damping(law_output_t *out, const float *gyro)
{
    for (uint8_t leg = 0; leg < 2; leg++) {
        out->joint_delta[ANKLE_PITCH[leg]] += -P(DAMPING_ANKLE_PITCH) * gyro[1];
        out->joint_delta[HIP_PITCH[leg]] += -P(DAMPING_HIP_PITCH) * gyro[1];
        out->joint_delta[ANKLE_ROLL[leg]] += P(DAMPING_ANKLE_ROLL) * gyro[0] * OUTWARD[leg];
        out->joint_delta[HIP_ROLL[leg]] += P(DAMPING_HIP_ROLL) * gyro[0] * OUTWARD[leg];
    }
}

static void cop_loop(law_state_t *s, law_output_t *out, const float fsr[2][4])
{
    static const float POSITION[4][2] = ARTRO_FSR_POSITIONS_M;
    float load[2];
    for (uint8_t foot = 0; foot < 2; foot++)
        load[foot] = fsr[foot][0] + fsr[foot][1] + fsr[foot][2] + fsr[foot][3];
    const uint8_t foot = load[1] > load[0] ? 1u : 0u;
    if (!(load[foot] > 0.0f) || load[foot] < P(COP_MIN_LOAD_N))
        return; /* no foot carries: no centre of pressure (min_load 0 must not divide by 0) */
    float cop[2];
    for (uint8_t k = 0; k < 2; k++) {
        float moment = 0.0f;
        for (uint8_t c = 0; c < 4; c++)
            moment += fsr[foot][c] * POSITION[c][k];
        cop[k] = moment / load[foot];
    }
    cop[1] *= OUTWARD[foot];
    const float limit = P(COP_CLAMP_RAD), ki_dt = P(COP_KI_PER_S) * FRAME_DT_S;
    for (uint8_t k = 0; k < 2; k++) {
        const float integral = clampf(s->cop_integral[k] + ki_dt * cop[k], limit);
        const float rate = (cop[k] - s->cop_last[k]) / FRAME_DT_S;
        out->cop[k] = clampf(P(COP_KP) * cop[k] + integral + P(COP_KD_S) * rate, limit);
        s->cop_integral[k] = integral;
        s->cop_last[k] = cop[k];
    }
    out->support = (int8_t)foot;
    out->joint_delta[ANKLE_PITCH[foot]] += out->cop[0];
    out->joint_delta[ANKLE_ROLL[foot]] += out->cop[1];
}

/* gait/timing.py timing_step: the roll's deviation from its expected swing at the phase planned
 * next, low-passed, past the dead band, times minus the support weight cos(phi_Trunk): > 0 leans
 * out over the support foot (slower), < 0 falls toward the swing foot (faster); clamped */
static void timing(law_state_t *s, law_output_t *out, float phase)
{
    const float side = fabsf(g_motion[RAMP_A_R]);
    const float amplitude = P(TIMING_SWING_RAD) + P(TIMING_SWING_PER_A_R) * side;
    const float swing = amplitude * cosf(phase + P(TIMING_SWING_PHASE_RAD));
    const float still = P(TIMING_ROLL_OFFSET_RAD) + P(TIMING_ROLL_PER_A_R) * g_motion[RAMP_A_R];
    const float deviation = s->roll - (still + swing);
    const float filtered = s->timing_error
        + (deviation - s->timing_error) * (FRAME_DT_S / (P(TIMING_FILTER_S) + FRAME_DT_S));
    const float outward = -cosf(phase) * dead_band(filtered, P(TIMING_DEADBAND_RAD));
    const float gain = outward > 0.0f ? P(TIMING_SLOW_DOWN_HZ_PER_RAD)
                                      : P(TIMING_SPEED_UP_HZ_PER_RAD);
    out->freq_delta_hz = clampf(-gain * outward, P(TIMING_CLAMP_SHARE) * P(CLOCK_FREQ_HZ));
    s->timing_error = filtered;
}

void laws_step(const sensor_reading_t *reading, uint8_t imu_present, uint8_t walking,
               int32_t phase_acc)
{
    law_state_t *s = &g_law_state;
    law_output_t *out = &g_law_output;
    memset(out, 0, sizeof *out);
    out->support = -1;
    const uint8_t on = walking ? laws_switched_on() : 0;
    if (on != s->switches) { /* held, carried or limp, no integral winds up */
        laws_restart(s);
        s->switches = on;
    }
    if (imu_present) { /* without the IMU its laws stay off rather than act on zeros */
        attitude_step(s, reading->gyro_rad_s, reading->accel_m_s2);
        out->attitude[0] = s->pitch;
        out->attitude[1] = s->roll;
        if ((on & LAW_TILT) && s->started)
            tilt_trim(s, out);
        if (on & LAW_YAW_RATE)
            yaw_rate(s, out, reading->gyro_rad_s[2]);
        if (on & LAW_DAMPING)
            damping(out, reading->gyro_rad_s);
        if ((on & LAW_TIMING) && s->started)
            timing(s, out, gait_phase_rad(phase_acc));
    }
    if (on & LAW_COP)
        cop_loop(s, out, reading->fsr_n);
}

float laws_freq_hz(float freq_hz)
{
    return laws_any_on() ? freq_hz + g_law_output.freq_delta_hz : freq_hz;
}

float laws_a_y(float ramped_a_y)
{
    if (!laws_any_on())
        return ramped_a_y;
    const float a_y = ramped_a_y + g_law_output.a_y_delta;
    const float lo = params_min(ARTRO_PID_MOTION_A_Y), hi = params_max(ARTRO_PID_MOTION_A_Y);
    return a_y < lo ? lo : (a_y > hi ? hi : a_y);
}
