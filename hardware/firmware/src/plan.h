/* plan.h -- one frame of the servo drive, computed ahead: walking clock, gait, servos, TDM table.
 *
 * The main loop fills the spare plan for frame F+1 during the idle slots of frame F; the Timer2
 * guard interrupt (tdm.c) latches it at the end of slot 7 (docs/DESIGN.md §5).
 */
#ifndef ARTRO_PLAN_H
#define ARTRO_PLAN_H

#include <stdint.h>

#include "artro_params.h"
#include "gait.h"

#define TDM_CHANNELS ARTRO_NUM_CHANNELS /* OC1A, OC1B, OC1C, OC3A, OC3B, OC3C */
#define TDM_TIMERS 2

enum run_state {
    RUN_WALK = 0,       /* the walking clock advances every frame */
    RUN_STOP = 1,       /* the clock stands still: the pose of the current phase is held */
    RUN_TORQUE_OFF = 2, /* no pulses at all: every compare output disconnected, lines low */
};

/* plan flags */
#define PLAN_SATURATED 0x01u     /* some servo's angle or pulse was clipped */
#define PLAN_GAMMA_CLAMPED 0x02u /* eq (45) summed below -1 on some leg */

typedef struct {
    uint32_t frame;          /* the frame this plan is for (0 = first after reset) */
    int32_t phase_acc;       /* phi_Trunk of this frame (gait.h: 2^32 counts = 2 pi) */
    int32_t next_phase_acc;  /* phi_Trunk of the next frame: the walking clock step */
    float angle[GAIT_NUM_JOINTS];            /* joint angles, rad, eqs (2)-(9) */
    uint16_t servo_ocr[ARTRO_NUM_SERVOS];    /* OCR of each servo's pulse */
    uint16_t ocr[TDM_CHANNELS][ARTRO_SLOTS_USED]; /* OCR per line and slot */
    uint8_t tccra[TDM_TIMERS][ARTRO_SLOTS_PER_FRAME]; /* TCCR1A, TCCR3A per slot */
    uint16_t saturated;      /* bit i: servo i clipped */
    uint8_t flags;           /* PLAN_* */
    uint8_t state;           /* enum run_state the plan was made for */
} plan_t;

/* Phase at reset: the lateral shift passes through zero, both feet on the ground (-pi/2). */
#define PLAN_START_PHASE_ACC (-GAIT_PHASE_QUARTER)

void plan_init_channel_map(void);
/* Fill `plan` for `frame` at trunk phase `phase_acc` with the current parameters. */
void plan_compute(plan_t *plan, uint32_t frame, int32_t phase_acc, uint8_t state);

#endif /* ARTRO_PLAN_H */
