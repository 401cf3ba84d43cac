/* params.c -- the SRAM parameter store with the schema's ranges (docs/DESIGN.md §5). */
#include "params.h"

#include <math.h>

#include "artro_params.h"

#if ARTRO_ENGINE != ARTRO_ENGINE_BEHNKE
#error "artro_params.h names a gait engine this firmware does not run (gait.c is behnke's)"
#endif

float g_params[ARTRO_PARAM_COUNT];

static const float DEFAULTS[ARTRO_PARAM_COUNT] = ARTRO_PARAM_DEFAULTS;
static const float MIN_VALUE[ARTRO_PARAM_COUNT] = ARTRO_PARAM_MIN;
static const float MAX_VALUE[ARTRO_PARAM_COUNT] = ARTRO_PARAM_MAX;
static const uint32_t SWITCH_BITS[] = ARTRO_PARAM_SWITCH_BITS;

void params_reset(void)
{
    for (uint8_t i = 0; i < ARTRO_PARAM_COUNT; i++)
        g_params[i] = DEFAULTS[i];
}

float params_min(uint8_t id)
{
    return MIN_VALUE[id];
}

float params_max(uint8_t id)
{
    return MAX_VALUE[id];
}

static uint8_t is_switch(uint8_t id)
{
    return (SWITCH_BITS[id >> 5] >> (id & 31u)) & 1u;
}

uint8_t params_check(uint8_t id, float value)
{
    if (id >= ARTRO_PARAM_COUNT)
        return PARAM_UNKNOWN_ID;
    if (!isfinite(value))
        return PARAM_OUT_OF_RANGE;
    if (is_switch(id))
        return (value == 0.0f || value == 1.0f) ? PARAM_OK : PARAM_OUT_OF_RANGE;
    /* the ranges are the schema's float64 bounds rounded to float32, so a value that passes
     * the host's check passes here too */
    if (value < MIN_VALUE[id] || value > MAX_VALUE[id])
        return PARAM_OUT_OF_RANGE;
    return PARAM_OK;
}

uint8_t params_set(uint8_t id, float value)
{
    uint8_t status = params_check(id, value);
    if (status == PARAM_OK)
        g_params[id] = value;
    return status;
}

uint8_t params_set_many(uint8_t first, uint8_t count, const float *values, uint8_t *bad_id)
{
    if ((uint16_t)first + count > ARTRO_PARAM_COUNT) {
        /* the first id of the range that does not exist */
        *bad_id = first > ARTRO_PARAM_COUNT ? first : ARTRO_PARAM_COUNT;
        return PARAM_UNKNOWN_ID;
    }
    for (uint8_t i = 0; i < count; i++) {
        uint8_t status = params_check(first + i, values[i]);
        if (status != PARAM_OK) {
            *bad_id = first + i;
            return status;
        }
    }
    for (uint8_t i = 0; i < count; i++)
        g_params[first + i] = values[i];
    return PARAM_OK;
}
