/* params.h -- every tunable gait value as a run-time parameter in SRAM (docs/DESIGN.md §5).
 *
 * Values are addressed by the ids of the generated artro_schema.h (motion vector, CA, clock and
 * every walking-phase constant); defaults are the exported parameter set (artro_params.h).
 * Writes are validated first and applied whole, so a rejected message changes nothing.
 */
#ifndef ARTRO_PARAMS_RUNTIME_H
#define ARTRO_PARAMS_RUNTIME_H

#include <stdint.h>

#include "artro_schema.h"

/* The parameter store: g_params[id]. Only the main loop reads or writes it. */
extern float g_params[ARTRO_PARAM_COUNT];

/* Shorthand for the gait code: P(SWING_V) is g_params[ARTRO_PID_SWING_V]. */
#define P(name) (g_params[ARTRO_PID_##name])
/* A switch parameter (0 or 1) as a truth value. */
#define SWITCH(name) (g_params[ARTRO_PID_##name] != 0.0f)

enum param_status {
    PARAM_OK = 0,
    PARAM_UNKNOWN_ID = 1,
    PARAM_OUT_OF_RANGE = 2,
};

void params_reset(void);
/* The allowed range of `id` (a switch: 0..1). */
float params_min(uint8_t id);
float params_max(uint8_t id);
/* PARAM_OK if `value` is allowed for `id` (finite, in range, 0/1 for switches). */
uint8_t params_check(uint8_t id, float value);
/* Validate, then store; nothing changes unless PARAM_OK. */
uint8_t params_set(uint8_t id, float value);
/* Validate `count` values for ids first..first+count-1 (all of them), then store them all.
 * On error *bad_id names the first offending id and nothing changes. */
uint8_t params_set_many(uint8_t first, uint8_t count, const float *values, uint8_t *bad_id);

#endif /* ARTRO_PARAMS_RUNTIME_H */
