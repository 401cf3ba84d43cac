/* gait.c -- walking phases, eqs (10)-(39), and leg interface, eqs (2)-(9) and (40)-(45).
 *
 * The same arithmetic as the project's Python gait (docs/DESIGN.md §4), one leg at a time and
 * in float32. CA (curve amount) scales the left leg's sagittal swing terms by (1 + CA) and the
 * right leg's by (1 - CA), and feeds eq (29) through a_y + K*CA*s(a_p) (frame_terms). Each
 * phase can be switched off; `leg.paper_signs` selects the printed signs of eqs (30), (31), (39)
 * or their mirror-symmetric form.
 */
#include "gait.h"

#include <math.h>

#include "artro_schema.h"
#include "laws.h"
#include "params.h"
#include "ramp.h"

#define PI_F 3.14159265358979f
#define TWO_PI_F 6.28318530717959f
#define HALF_PI_F 1.57079632679490f

enum { LEG_ROLL, LEG_PITCH, LEG_YAW, FOOT_ROLL, FOOT_PITCH, GAMMA, LEG_VALUES };

float gait_phase_rad(int32_t phase_acc)
{
    return (float)phase_acc * GAIT_RAD_PER_COUNT;
}

uint32_t gait_phase_step(float freq_hz)
{
    /* 2*pi*f*dt with dt = 20 ms is f * 2^32 / 50 counts. With freq_hz = m * 2^(E - 150)
     * (24-bit mantissa m, biased exponent E) that is m * 2^k / 25 with k = E - 119: computed
     * exactly in 32-bit integers and rounded to the nearest count (25 is odd: no ties). */
    union {
        float f;
        uint32_t u;
    } bits = {freq_hz};
    uint32_t m = (bits.u & 0x7FFFFFUL) | 0x800000UL;
    int16_t k = (int16_t)((bits.u >> 23) & 0xFFu) - 119;
    if (k < 0 || k > 12)
        return (uint32_t)(freq_hz * 85899345.92f + 0.5f); /* outside the schema's range */
    uint32_t q = m / 25u, r = m % 25u;
    return (q << k) + (((r << k) + 12u) / 25u);
}

/* piCut: map to [-pi, pi) by adding multiples of 2*pi */
static float pi_cut(float x)
{
    while (x >= PI_F)
        x -= TWO_PI_F;
    while (x < -PI_F)
        x += TWO_PI_F;
    return x;
}

/* -0.5 * a * (cos(phase) + 1) inside [-pi, pi), else 0: the shape of eqs (19), (21), (35) */
static float raised_cosine(float phase, float amplitude)
{
    if (phase < -PI_F || phase >= PI_F)
        return 0.0f;
    return -0.5f * amplitude * (cosf(phase) + 1.0f);
}

/* theta_Swing, eq (25): a sine swing, then a linear reverse at speed b of eq (26) */
static float swing_profile(float phi, float b)
{
    if (phi >= HALF_PI_F)
        return b * (phi - HALF_PI_F) + 1.0f;
    if (phi >= -HALF_PI_F)
        return sinf(phi);
    return b * (phi + HALF_PI_F) - 1.0f;
}

/* What eqs (12)-(39) share between the legs in one frame: amplitudes that depend on the motion
 * vector only, and the cosines that the half-cycle offset of the legs relates (phi_R = phi_L - pi,
 * eqs 10-11: cos(phi_R + x) = -cos(phi_L + x) and cos(2 phi_R + x) = cos(2 phi_L + x)). */
typedef struct {
    float a_r, a_p, a_y, ca;
    float a_y_eff;           /* a_y plus the steering term, eq (29) */
    float theta_shift_left;  /* eqs (12)-(13) for the left leg */
    float a_short;           /* eq (20) */
    float b_swing;           /* eq (26) */
    float a_load;            /* eq (36) */
    float load_offset;       /* -pi / v_short + o_short, eq (33) */
    float roll_cos_left;     /* cos(phi_L + balance phase), eq (37) */
    float pitch_balance;     /* eq (38), the same for both legs */
} frame_terms_t;

static void frame_terms(float phi_left, frame_terms_t *t)
{
    t->theta_shift_left = t->roll_cos_left = t->pitch_balance = 0.0f;
    t->a_r = g_motion[RAMP_A_R]; /* the motion as the ramp lets it through (ramp.h) */
    t->a_p = g_motion[RAMP_A_P];
    t->a_y = laws_a_y(g_motion[RAMP_A_Y]); /* with the yaw-rate loop's change (laws.h) */
    t->ca = g_motion[RAMP_CA];
    /* the steering term of eq (29), docs/DESIGN.md §4: K * CA * clip(a_p / full_at_a_p, -1, 1)
     * with the forward or the backward K, so that CA turns the robot as eq (13) says both ways */
    float steer = t->a_p / P(STEER_FULL_AT_A_P);
    steer = steer > 1.0f ? 1.0f : (steer < -1.0f ? -1.0f : steer);
    const float k = t->a_p >= 0.0f ? P(STEER_YAW_PER_CA) : P(STEER_YAW_PER_CA_BACKWARD);
    t->a_y_eff = t->a_y + k * t->ca * steer;
    const float speed = sqrtf(t->a_r * t->a_r + t->a_p * t->a_p); /* ||(a_r, a_p)|| */
    if (SWITCH(SHIFT_ENABLED)) {
        float a_shift = P(SHIFT_AMP_BASE) + P(SHIFT_AMP_SPEED) * speed
            + P(SHIFT_AMP_LATERAL) * fabsf(t->a_r);                      /* eq (13) */
        t->theta_shift_left = a_shift * cosf(phi_left + HALF_PI_F);     /* eq (12) */
    }
    t->a_short = P(SHORT_AMP_BASE) + P(SHORT_AMP_SPEED) * speed;        /* eq (20) */
    t->b_swing = -2.0f / (TWO_PI_F * P(SWING_V) - PI_F);                /* eq (26) */
    t->a_load = P(LOAD_AMP_BASE) + P(LOAD_AMP_PITCH) * (1.0f - cosf(fabsf(t->a_p))); /* (36) */
    t->load_offset = -PI_F / P(SHORT_V) + P(SHORT_O);                   /* eq (33) */
    if (SWITCH(BALANCE_ENABLED)) {
        t->roll_cos_left = cosf(phi_left + P(BALANCE_FOOT_ROLL_PHASE)); /* eq (37) */
        t->pitch_balance = P(BALANCE_FOOT_PITCH_OFFSET) + P(BALANCE_FOOT_PITCH_SPEED) * t->a_p
            - P(BALANCE_FOOT_PITCH_AMP) * t->a_p
                * cosf(2.0f * phi_left + P(BALANCE_FOOT_PITCH_PHASE));  /* eq (38) */
    }
}

/* Leg parameters of one leg, eqs (12)-(39) summed as in (40)-(45).
 * i_s: I_s of eq (32), -1 left, +1 right; it also flips the cosines related between the legs.
 * ca_scale: 1 + CA left, 1 - CA right. */
static void leg_parameters(float phi_leg, float i_s, float ca_scale, const frame_terms_t *t,
                           float *leg)
{
    const float a_r = t->a_r, a_p = t->a_p, a_y = t->a_y;
    const float mirror = -i_s; /* +1 left, -1 right: cos(phi_R + x) = -cos(phi_L + x) */
    const uint8_t paper_signs = SWITCH(LEG_PAPER_SIGNS);
    for (uint8_t i = 0; i < LEG_VALUES; i++)
        leg[i] = 0.0f;

    if (SWITCH(SHIFT_ENABLED)) {
        float theta_shift = mirror * t->theta_shift_left;              /* eq (12) */
        leg[LEG_ROLL] += theta_shift;                                   /* eq (14) */
        leg[FOOT_ROLL] += -P(SHIFT_FOOT_RATIO) * theta_shift;           /* eq (15) */
    }

    if (SWITCH(SHORT_ENABLED)) {
        float phi_short = P(SHORT_V) * (phi_leg + HALF_PI_F + P(SHORT_O));  /* eq (16) */
        float shape = raised_cosine(phi_short, 1.0f);               /* eqs (19), (21) */
        leg[GAMMA] += shape * t->a_short;                           /* eq (19) */
        leg[FOOT_PITCH] += shape * (2.0f * P(SHORT_FOOT_LIFT) * a_p);   /* eq (21) */
    }

    if (SWITCH(SWING_ENABLED)) {
        float phi_swing = P(SWING_V) * (phi_leg + HALF_PI_F + P(SWING_O)); /* eq (22) */
        float theta_swing = swing_profile(phi_swing, t->b_swing);          /* eqs (25)-(26) */
        float roll_sign = paper_signs ? 1.0f : i_s;
        float pitch_sign = paper_signs ? i_s : 1.0f;
        leg[LEG_ROLL] += i_s * a_r * theta_swing;                          /* eq (27) */
        leg[LEG_PITCH] += P(SWING_PITCH_GAIN) * ca_scale * a_p * theta_swing; /* eq (28) */
        leg[LEG_YAW] += i_s * t->a_y_eff * theta_swing;                    /* eq (29) */
        leg[FOOT_ROLL] += roll_sign * P(SWING_FOOT_ROLL) * a_r * theta_swing;  /* eq (30) */
        leg[FOOT_PITCH] +=
            ca_scale * pitch_sign * P(SWING_FOOT_PITCH) * a_p * theta_swing; /* eq (31) */
    }

    if (SWITCH(LOAD_ENABLED)) {
        float phi_load = P(LOAD_V) * pi_cut(phi_leg + HALF_PI_F + t->load_offset) - PI_F; /* (33) */
        leg[GAMMA] += raised_cosine(phi_load, t->a_load);                  /* eq (35) */
    }

    if (SWITCH(BALANCE_ENABLED)) {
        leg[FOOT_ROLL] += P(BALANCE_FOOT_ROLL_AMP) * i_s * a_r
            * (mirror * t->roll_cos_left);                                 /* eq (37) */
        leg[FOOT_PITCH] += t->pitch_balance;                               /* eq (38) */
        float yaw_term = paper_signs ? a_y : fabsf(a_y);
        const float side = P(BALANCE_LEG_ROLL_SIDE);    /* the paper's 1: as printed, to the bit */
        leg[LEG_ROLL] += P(BALANCE_LEG_ROLL_OFFSET) + side * i_s * a_r + side * fabsf(a_r)
            + P(BALANCE_LEG_ROLL_YAW) * yaw_term;                          /* eq (39) */
    }

    /* lateral support (decision 0061): the support leg's roll leaned, weighted by sin(phi_Leg) */
    if (P(LATERAL_SUPPORT_ROLL_RAD) != 0.0f || P(LATERAL_SWAY_PER_A_R) != 0.0f) {
        const float lean = P(LATERAL_SUPPORT_ROLL_RAD) + P(LATERAL_SWAY_PER_A_R) * fabsf(a_r);
        const float share = sinf(phi_leg);
        if (share > 0.0f)
            leg[LEG_ROLL] += lean * share;
    }
}

/* Leg interface, eqs (2)-(9): leg parameters -> the six joint angles of one leg.
 *
 * The knee triangle (eqs 3-6) is solved through the knee bend beta = pi - alpha1 with
 * sin(beta/2) = sqrt(((L_UL+L_LL)^2 - L^2) / (4 L_UL L_LL)), where (L_UL+L_LL)^2 - L^2 =
 * (L_UL+L_LL)^2 (1 - eta)(1 + eta) and 1 - eta = -(1 - eta_min) gamma carries no cancellation.
 * This is eq (4) rearranged; in float32 arccos of eq (4) itself would lose ~3e-4 rad near the
 * stretched leg, which is several timer ticks. */
static void leg_to_joints(const float *leg, float *joint)
{
    const float lu = ARTRO_GEOM_UPPER_LEG_M, ll = ARTRO_GEOM_LOWER_LEG_M;
    const float one_minus_eta = -(1.0f - P(LEG_ETA_MIN)) * leg[GAMMA];  /* eq (2) */
    const float eta = 1.0f - one_minus_eta;
    const float length = eta * (lu + ll);                               /* eq (3) */
    float s2 = (lu + ll) * (lu + ll) * one_minus_eta * (1.0f + eta) / (4.0f * lu * ll);
    if (s2 < 0.0f)
        s2 = 0.0f;
    if (s2 > 1.0f)
        s2 = 1.0f;
    const float s = sqrtf(s2);                    /* sin(beta/2) = cos(alpha1/2) */
    const float half_beta = asinf(s);
    const float beta = 2.0f * half_beta;          /* pi - alpha1, eq (4) */
    float alpha2;
    if (lu == ll) {
        alpha2 = half_beta; /* eq (5) for equal thigh and shank: the triangle is isosceles */
    } else {
        float sin_a2 = ll / length * 2.0f * s * sqrtf(1.0f - s2); /* sin alpha1 = sin beta */
        alpha2 = asinf(sin_a2 > 1.0f ? 1.0f : sin_a2);            /* eq (5) */
    }
    const float alpha3 = beta - alpha2;           /* pi - (alpha1 + alpha2), eq (6) */

    joint[0] = leg[LEG_YAW];                                /* hip yaw, eq (7) */
    joint[1] = leg[LEG_ROLL];                               /* hip roll, eq (7) */
    joint[2] = leg[LEG_PITCH] + alpha2;                     /* hip pitch, eq (7) */
    joint[3] = -beta;                                       /* knee = alpha1 - pi, eq (8) */
    joint[4] = alpha3 + leg[FOOT_PITCH] - leg[LEG_PITCH];   /* ankle pitch, eq (9) */
    joint[5] = leg[FOOT_ROLL] - leg[LEG_ROLL];              /* ankle roll, eq (9) */
}

void gait_joint_angles(int32_t phase_acc, gait_output_t *out)
{
    float leg[LEG_VALUES];
    frame_terms_t terms;
    const float ca = g_motion[RAMP_CA];
    frame_terms(gait_phase_rad((int32_t)((uint32_t)phase_acc + GAIT_PHASE_QUARTER)), &terms);
    out->gamma_clamped = 0;
    for (uint8_t side = 0; side < 2; side++) {
        /* phi_L = phi_Trunk + pi/2, phi_R = phi_Trunk - pi/2, wrapped (eqs 10-11): the int32
         * addition wraps exactly like piCut */
        int32_t acc = side == 0 ? (int32_t)((uint32_t)phase_acc + GAIT_PHASE_QUARTER)
                                : (int32_t)((uint32_t)phase_acc - GAIT_PHASE_QUARTER);
        float i_s = side == 0 ? -1.0f : 1.0f;                  /* eq (32) */
        float ca_scale = side == 0 ? 1.0f + ca : 1.0f - ca;    /* CA on the sagittal swing */
        leg_parameters(gait_phase_rad(acc), i_s, ca_scale, &terms, leg);
        if (leg[GAMMA] < -1.0f) {                              /* eq (45): gamma in [-1, 0] */
            leg[GAMMA] = -1.0f;
            out->gamma_clamped |= (uint8_t)(1u << side);
        }
        if (leg[GAMMA] > 0.0f)
            leg[GAMMA] = 0.0f;
        leg_to_joints(leg, &out->angle[6 * side]);
    }
}
