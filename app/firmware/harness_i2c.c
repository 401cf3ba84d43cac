/* harness_i2c.c -- the I2C bus of the emulated Mega board (docs/BOARDS.md): an NXP PCA9685 part
 * and a monitor of every transaction, on simavr's TWI beside the MPU-6050 of harness_sensors.c.
 *
 * The PCA9685 (datasheet rev. 4): a register file at 0x40 with the register pointer, MODE1's
 * SLEEP and AI (auto-increment), PRE_SCALE (written only while asleep), LEDn_ON/OFF at 0x06 + 4n
 * and ALL_LED. Register changes take effect at the STOP (MODE2 OCH = 0; at each ACK with OCH = 1)
 * and reach the outputs at the end of the period (the datasheet's "end of the LOW cycle"). Its
 * oscillator is its own, 25 MHz, not the AVR's: the 12-bit counter steps every (PRESCALE + 1)
 * / 25 MHz, kept exactly in 1/25 CPU cycles; it starts 500 us after the wake. At each period's
 * start the sixteen outputs' edges of the period are recorded with their CPU cycle
 * (rounded up: the first cycle at which the level holds), and the period's ON/OFF values.
 * SLEEP set again stops the counter at the end of the running period (the firmware sleeps the
 * part only at boot, before any pulse).
 * The monitor logs each transaction: START to STOP, its first address, first register, bytes on
 * the wire (addresses included) and repeated STARTs.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <simavr/avr_twi.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_irq.h>

#define PCA_CHANNELS 16
#define PCA_WAKE_CYCLES 8000u /* 500 us at 16 MHz */
#define PCA_UNITS_PER_OSC 16u /* an oscillator period, 1/25 MHz, is 16/25 CPU cycle */
#define REG_MODE1 0x00u
#define REG_MODE2 0x01u
#define REG_LED0 0x06u
#define REG_ALL_LED 0xFAu
#define REG_PRE_SCALE 0xFEu
#define MODE1_RESTART 0x80u
#define MODE1_AI 0x20u
#define MODE1_SLEEP 0x10u
#define MODE2_OCH 0x08u

typedef struct {
    uint64_t cycle;
    uint8_t line;
    uint8_t level;
} i2c_edge_t;

typedef struct {
    uint64_t start_cycle;
    uint8_t prescale;
    uint16_t on[PCA_CHANNELS], off[PCA_CHANNELS]; /* bit 12: full ON / full OFF */
} pca_period_t;

typedef struct {
    uint64_t start_cycle, stop_cycle;
    uint8_t address, reg, restarts, acked;
    uint16_t bytes;
} i2c_transaction_t;

typedef struct i2c_bus {
    avr_t *avr;
    avr_irq_t *input; /* to the MCU's TWI */
    uint8_t sla;      /* 7-bit address << 1 */
    uint8_t reg[256];
    uint16_t latched_on[PCA_CHANNELS], latched_off[PCA_CHANNELS];
    uint8_t level[PCA_CHANNELS];
    uint8_t selected, pointer;
    uint32_t index; /* bytes written since SLA+W */
    int running;
    uint64_t period_start_units; /* 1/25 CPU cycles */
    i2c_edge_t *edges;
    size_t n_edges, cap_edges;
    pca_period_t *periods;
    size_t n_periods, cap_periods;
    /* the monitor */
    i2c_transaction_t open, *log;
    int in_transaction, expect_register;
    size_t n_log, cap_log;
} i2c_bus_t;

static int grow_buf(void **buf, size_t *cap, size_t need, size_t item)
{
    if (need <= *cap)
        return 0;
    size_t cap2 = *cap ? *cap * 2 : 1024;
    while (cap2 < need)
        cap2 *= 2;
    void *p = realloc(*buf, cap2 * item);
    if (!p)
        return -1;
    *buf = p;
    *cap = cap2;
    return 0;
}

static uint16_t reg16(const i2c_bus_t *b, uint8_t at)
{
    return (uint16_t)(b->reg[at] | (uint16_t)(b->reg[at + 1u] & 0x1Fu) << 8);
}

static void latch(i2c_bus_t *b)
{
    for (int n = 0; n < PCA_CHANNELS; n++) {
        b->latched_on[n] = reg16(b, (uint8_t)(REG_LED0 + 4 * n));
        b->latched_off[n] = reg16(b, (uint8_t)(REG_LED0 + 4 * n + 2));
    }
}

static void edge(i2c_bus_t *b, uint64_t cycle, uint8_t line, uint8_t level)
{
    if (b->level[line] == level)
        return;
    b->level[line] = level;
    if (grow_buf((void **)&b->edges, &b->cap_edges, b->n_edges + 1, sizeof(i2c_edge_t)))
        return;
    b->edges[b->n_edges++] = (i2c_edge_t){cycle, line, level};
}

static uint64_t units_to_cycle(uint64_t units)
{
    return (units + 24u) / 25u; /* the first whole cycle at or after */
}

/* One period of the counter from now: its edges, its values; returns the next start's cycle. */
static avr_cycle_count_t pca_period(avr_t *avr, avr_cycle_count_t when, void *param)
{
    (void)avr;
    (void)when;
    i2c_bus_t *b = param;
    const uint8_t prescale = b->reg[REG_PRE_SCALE];
    const uint64_t step = (uint64_t)(prescale + 1u) * PCA_UNITS_PER_OSC, start = b->period_start_units;
    pca_period_t period = {units_to_cycle(start), prescale, {0}, {0}};
    struct {
        uint16_t count;
        uint8_t line, level;
    } events[3 * PCA_CHANNELS];
    int n_events = 0;
    for (int n = 0; n < PCA_CHANNELS; n++) {
        const uint16_t on = b->latched_on[n], off = b->latched_off[n];
        period.on[n] = on;
        period.off[n] = off;
        const uint16_t on_count = on & 0x0FFFu, off_count = off & 0x0FFFu;
        if (off & 0x1000u || (!(on & 0x1000u) && on_count == off_count)) {
            events[n_events++] = (typeof(events[0])){0, (uint8_t)n, 0};
        } else if (on & 0x1000u) {
            events[n_events++] = (typeof(events[0])){0, (uint8_t)n, 1};
        } else {
            /* high from ON to OFF, through the wrap when OFF < ON */
            events[n_events++] = (typeof(events[0])){0, (uint8_t)n, off_count < on_count || on_count == 0};
            if (on_count)
                events[n_events++] = (typeof(events[0])){on_count, (uint8_t)n, 1};
            events[n_events++] = (typeof(events[0])){off_count, (uint8_t)n, 0};
        }
    }
    for (int i = 1; i < n_events; i++) /* by count, stable: few events */
        for (int j = i; j > 0 && events[j - 1].count > events[j].count; j--) {
            typeof(events[0]) t = events[j];
            events[j] = events[j - 1];
            events[j - 1] = t;
        }
    for (int i = 0; i < n_events; i++)
        edge(b, units_to_cycle(start + events[i].count * step), events[i].line, events[i].level);
    if (!grow_buf((void **)&b->periods, &b->cap_periods, b->n_periods + 1, sizeof(pca_period_t)))
        b->periods[b->n_periods++] = period;
    b->period_start_units = start + 4096u * step;
    if (b->reg[REG_MODE1] & MODE1_SLEEP) { /* asleep: the outputs low from the period's end */
        b->running = 0;
        for (int n = 0; n < PCA_CHANNELS; n++)
            edge(b, units_to_cycle(b->period_start_units), (uint8_t)n, 0);
        return 0;
    }
    return units_to_cycle(b->period_start_units);
}

static void write_register(i2c_bus_t *b, uint8_t at, uint8_t value)
{
    if (at == REG_PRE_SCALE) {
        if (b->reg[REG_MODE1] & MODE1_SLEEP) /* blocked while the oscillator runs */
            b->reg[at] = value < 3u ? 3u : value;
        return;
    }
    if (at == REG_MODE1) {
        const int wake = (b->reg[REG_MODE1] & MODE1_SLEEP) && !(value & MODE1_SLEEP);
        b->reg[at] = (uint8_t)(value & (uint8_t)~MODE1_RESTART); /* RESTART: written 1 clears */
        if (wake && !b->running) {
            b->running = 1;
            const uint64_t start = b->avr->cycle + PCA_WAKE_CYCLES;
            b->period_start_units = start * 25u;
            avr_cycle_timer_register(b->avr, PCA_WAKE_CYCLES, pca_period, b);
        }
        return;
    }
    b->reg[at] = value;
    if (at >= REG_ALL_LED && at < REG_PRE_SCALE) /* ALL_LED_*: every channel's same register */
        for (int n = 0; n < PCA_CHANNELS; n++)
            b->reg[REG_LED0 + 4 * n + (at - REG_ALL_LED)] = value;
}

static void monitor(i2c_bus_t *b, const avr_twi_msg_irq_t *v)
{
    const uint8_t msg = v->u.twi.msg;
    if (msg & TWI_COND_START) {
        if (!b->in_transaction) {
            memset(&b->open, 0, sizeof b->open);
            b->open.start_cycle = b->avr->cycle;
            b->open.address = v->u.twi.addr;
            b->open.reg = 0xFFu;
            b->in_transaction = 1;
        } else {
            b->open.restarts++;
        }
        b->open.bytes++;
        b->expect_register = !(v->u.twi.addr & 1u);
        return;
    }
    if (!b->in_transaction)
        return;
    if (msg & (TWI_COND_WRITE | TWI_COND_READ)) {
        b->open.bytes++;
        if ((msg & TWI_COND_WRITE) && b->expect_register) {
            b->open.reg = v->u.twi.data;
            b->expect_register = 0;
        }
    }
    if (msg & TWI_COND_STOP) {
        b->open.stop_cycle = b->avr->cycle;
        b->in_transaction = 0;
        if (!grow_buf((void **)&b->log, &b->cap_log, b->n_log + 1, sizeof(i2c_transaction_t)))
            b->log[b->n_log++] = b->open;
    }
}

/* What a part answers the MCU: an ACK right after the address marks the transaction acknowledged. */
void i2c_bus_on_reply(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    i2c_bus_t *b = param;
    avr_twi_msg_irq_t v;
    v.u.v = value;
    if (b->in_transaction && (v.u.twi.msg & TWI_COND_ACK) && b->open.bytes == 1u + b->open.restarts)
        b->open.acked = 1;
}

/* Every message the MCU's TWI sends: the monitor's, then the PCA9685's to answer. */
void i2c_bus_on_twi(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    i2c_bus_t *b = param;
    avr_twi_msg_irq_t v;
    v.u.v = value;
    monitor(b, &v);
    const uint8_t msg = v.u.twi.msg;
    if (msg & TWI_COND_STOP) {
        if (b->selected && !(b->reg[REG_MODE2] & MODE2_OCH))
            latch(b); /* outputs change on STOP */
        b->selected = 0;
    }
    if (msg & TWI_COND_START) {
        b->selected = 0;
        b->index = 0;
        if ((v.u.twi.addr & 0xFEu) != b->sla)
            return;
        b->selected = v.u.twi.addr;
        avr_raise_irq(b->input, avr_twi_irq_msg(TWI_COND_ACK, b->selected, 1));
        return;
    }
    if (!b->selected)
        return;
    const uint8_t ai = b->reg[REG_MODE1] & MODE1_AI;
    if (msg & TWI_COND_WRITE) {
        avr_raise_irq(b->input, avr_twi_irq_msg(TWI_COND_ACK, b->selected, 1));
        if (b->index++ == 0) {
            b->pointer = v.u.twi.data;
        } else {
            write_register(b, b->pointer, v.u.twi.data);
            if (b->reg[REG_MODE2] & MODE2_OCH)
                latch(b); /* outputs change on ACK */
            if (ai)
                b->pointer++;
        }
    }
    if (msg & TWI_COND_READ) {
        uint8_t data = b->reg[b->pointer];
        if (ai)
            b->pointer++;
        avr_raise_irq(b->input, avr_twi_irq_msg(TWI_COND_READ, b->selected, data));
    }
}

i2c_bus_t *i2c_bus_new(avr_t *avr, avr_irq_t *input, uint8_t address)
{
    i2c_bus_t *b = calloc(1, sizeof *b);
    if (!b)
        return NULL;
    b->avr = avr;
    b->input = input;
    b->sla = (uint8_t)(address << 1);
    b->reg[REG_MODE1] = 0x11u; /* power-on: SLEEP, ALLCALL */
    b->reg[REG_MODE2] = 0x04u; /* OUTDRV */
    b->reg[REG_PRE_SCALE] = 0x1Eu;
    for (int n = 0; n < PCA_CHANNELS; n++) /* LEDn_OFF_H: full OFF */
        b->reg[REG_LED0 + 4 * n + 3] = 0x10u;
    latch(b);
    return b;
}

void i2c_bus_free(i2c_bus_t *b)
{
    if (!b)
        return;
    free(b->edges);
    free(b->periods);
    free(b->log);
    free(b);
}

/* ---- for Python (ctypes) -------------------------------------------------------------------- */

uint8_t artro_pca_register(i2c_bus_t *b, uint8_t reg)
{
    return b->reg[reg];
}

size_t artro_pca_take_edges(i2c_bus_t *b, uint64_t *cycles, uint8_t *lines, uint8_t *levels,
                            size_t max)
{
    size_t n = b->n_edges < max ? b->n_edges : max;
    for (size_t i = 0; i < n; i++) {
        cycles[i] = b->edges[i].cycle;
        lines[i] = b->edges[i].line;
        levels[i] = b->edges[i].level;
    }
    memmove(b->edges, b->edges + n, (b->n_edges - n) * sizeof(i2c_edge_t));
    b->n_edges -= n;
    return n;
}

/* Periods begun: start cycle, PRESCALE, and per channel ON and OFF (16 each). */
size_t artro_pca_take_periods(i2c_bus_t *b, uint64_t *starts, uint8_t *prescale, uint16_t *on,
                              uint16_t *off, size_t max)
{
    size_t n = b->n_periods < max ? b->n_periods : max;
    for (size_t i = 0; i < n; i++) {
        starts[i] = b->periods[i].start_cycle;
        prescale[i] = b->periods[i].prescale;
        memcpy(on + PCA_CHANNELS * i, b->periods[i].on, sizeof b->periods[i].on);
        memcpy(off + PCA_CHANNELS * i, b->periods[i].off, sizeof b->periods[i].off);
    }
    memmove(b->periods, b->periods + n, (b->n_periods - n) * sizeof(pca_period_t));
    b->n_periods -= n;
    return n;
}

/* Transactions ended: start and stop cycle, address byte (SLA+R/W), first register (0xFF:
 * none), bytes on the wire, repeated STARTs, acknowledged by a part (1/0). */
size_t artro_i2c_take(i2c_bus_t *b, uint64_t *start, uint64_t *stop, uint8_t *address,
                      uint8_t *reg, uint16_t *bytes, uint8_t *restarts, uint8_t *acked, size_t max)
{
    size_t n = b->n_log < max ? b->n_log : max;
    for (size_t i = 0; i < n; i++) {
        const i2c_transaction_t *t = &b->log[i];
        start[i] = t->start_cycle;
        stop[i] = t->stop_cycle;
        address[i] = t->address;
        reg[i] = t->reg;
        bytes[i] = t->bytes;
        restarts[i] = t->restarts;
        acked[i] = t->acked;
    }
    memmove(b->log, b->log + n, (b->n_log - n) * sizeof(i2c_transaction_t));
    b->n_log -= n;
    return n;
}
