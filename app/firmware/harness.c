/* harness.c -- the ArtRo firmware on simavr's ATmega128 core (or the Mega board's ATmega2560,
 * with the I2C bus of harness_i2c.c: docs/BOARDS.md), as a small C library for Python.
 *
 * Loads the firmware ELF into simavr, records every level change of the six TDM lines
 * (OC1A/B/C = PB5/6/7, OC3A/B/C = PE3/4/5) and the three select lines (PC0..2) with its CPU
 * cycle, and bridges UART0 both ways: bytes the firmware sends are recorded with their cycle,
 * bytes for the firmware are queued and fed following simavr's XON/XOFF flow control (its receive
 * FIFO drops what comes while it is full).
 *
 * The core of the harness: loading, running, the edges, the UART bridge, the profile and the
 * artro_mcu_* calls of all that. The corrections of simavr it applies are in harness_fixes.c,
 * the balance sensors in harness_sensors.c, what they share in harness.h. docs/DESIGN.md §5.
 */
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <simavr/avr_extint.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_timer.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#include "harness.h"

static const struct {
    char port;
    uint8_t pin;
} LINE_PINS[NUM_LINES] = {
    {'B', 5}, {'B', 6}, {'B', 7}, {'E', 3}, {'E', 4}, {'E', 5}, {'C', 0}, {'C', 1}, {'C', 2},
};

static int grow(void **buf, size_t *cap, size_t need, size_t item)
{
    if (need <= *cap)
        return 0;
    size_t cap2 = *cap ? *cap * 2 : 4096;
    while (cap2 < need)
        cap2 *= 2;
    void *p = realloc(*buf, cap2 * item);
    if (!p)
        return -1;
    *buf = p;
    *cap = cap2;
    return 0;
}

static void on_line(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    line_ref_t *ref = param;
    harness_t *h = ref->h;
    uint8_t level = value ? 1 : 0;
    if (level == h->level[ref->line])
        return;
    h->level[ref->line] = level;
    if (grow((void **)&h->edges, &h->cap_edges, h->n_edges + 1, sizeof(edge_t)))
        return;
    h->edges[h->n_edges++] = (edge_t){h->avr->cycle, ref->line, level};
}

static void pump(harness_t *h)
{
    while (!h->xoff && h->in_head != h->in_tail) {
        uint8_t byte = h->in[h->in_tail++];
        avr_raise_irq(h->uart_input, byte); /* may raise XOFF, re-entrantly */
    }
    if (h->in_head == h->in_tail)
        h->in_head = h->in_tail = 0;
}

static void on_uart_out(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    harness_t *h = param;
    if (grow((void **)&h->out, &h->cap_out, h->n_out + 1, sizeof(uart_byte_t)))
        return;
    h->out[h->n_out++] = (uart_byte_t){h->avr->cycle, (uint8_t)value};
}

static void on_xon(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    harness_t *h = param;
    h->xoff = 0;
    pump(h);
}

static void on_xoff(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    ((harness_t *)param)->xoff = 1;
}

static harness_t *harness_of(avr_t *avr)
{
    return avr->custom.data;
}

/* simavr's sleep hook: no real-time pacing (run as fast as the host can), but count the cycles
 * slept -- the core then adds 1 + how_long to the cycle counter. */
static void no_sleep(avr_t *avr, avr_cycle_count_t how_long)
{
    harness_of(avr)->slept_cycles += 1 + how_long;
}

/* Timer1 and Timer3: the avr_timer_t instances registered with the core. */
static void find_timers(harness_t *h)
{
    for (avr_io_t *io = h->avr->io_port; io; io = io->next) {
        if (!io->kind || strcmp(io->kind, "timer") != 0)
            continue;
        avr_timer_t *timer = (avr_timer_t *)io; /* avr_io_t is its first member */
        if (timer->name == '1')
            h->timer1 = timer;
        else if (timer->name == '3')
            h->timer3 = timer;
    }
}

/* simavr's own logger prints the ELF loader's debug lines ("Loaded ... .text") on stdout, which
 * would corrupt what a program writes there (`artro firmware run --json`): errors go to stderr,
 * the rest nowhere. */
static void quiet_logger(avr_t *avr, const int level, const char *format, va_list ap)
{
    if (level <= LOG_ERROR && (!avr || avr->log >= level))
        vfprintf(stderr, format, ap);
}

harness_t *artro_mcu_new(const char *elf_path, const char *mcu, int fixes, char *error,
                         int error_len)
{
    avr_global_logger_set(quiet_logger);
    elf_firmware_t firmware;
    memset(&firmware, 0, sizeof firmware);
    if (elf_read_firmware(elf_path, &firmware) != 0) {
        snprintf(error, error_len, "cannot read firmware ELF %s", elf_path);
        return NULL;
    }
    harness_t *h = calloc(1, sizeof *h);
    if (!h)
        return NULL;
    h->avr = avr_make_mcu_by_name(mcu);
    if (!h->avr) {
        snprintf(error, error_len, "simavr has no %s core", mcu);
        free(h);
        return NULL;
    }
    h->avr->custom.data = h; /* for the sleep hook */
    h->one_timer = strcmp(mcu, "atmega128") != 0;
    avr_init(h->avr);
    h->avr->log = LOG_ERROR;
    h->avr->sleep = no_sleep;
    firmware.frequency = F_CPU_HZ;
    avr_load_firmware(h->avr, &firmware);
    h->avr->frequency = F_CPU_HZ;
    h->avr->vcc = h->avr->avcc = h->avr->aref = 5000; /* millivolts: the ADC's references */

    find_timers(h);
    if (!h->timer1 || !h->timer3) {
        snprintf(error, error_len, "Timer1/Timer3 not found in the simavr core");
        avr_terminate(h->avr);
        free(h);
        return NULL;
    }
    if (fixes & FIX_OCR_HIGH_BYTE)
        wrap_ocr_writes(h);
    if ((fixes & FIX_UART_BYTE_TIME) && fix_uart_byte_time(h->avr) != 0) {
        snprintf(error, error_len, "UART0 not found in the simavr core");
        avr_terminate(h->avr);
        free(h);
        return NULL;
    }
    if (fixes & FIX_MODE14)
        fix_mode14(h);
    h->timer_start[0] = h->timer_start[1] = -1;
    /* Speed, not behaviour: simavr polls a pin every cycle while it is low if the pin is an
     * external interrupt in its default low-level mode, enabled or not. OC3B/OC3C are INT4/INT5
     * (PE4/PE5) and low most of the frame, which made the emulator ~4x slower. The firmware
     * enables no external interrupt, so a level that is not polled changes nothing it sees. */
    for (uint8_t i = 0; i < EXTINT_COUNT; i++)
        avr_extint_set_strict_lvl_trig(h->avr, i, 0);

    for (uint8_t i = 0; i < NUM_LINES; i++) {
        h->refs[i] = (line_ref_t){h, i};
        avr_irq_t *irq =
            avr_io_getirq(h->avr, AVR_IOCTL_IOPORT_GETIRQ(LINE_PINS[i].port), LINE_PINS[i].pin);
        avr_irq_register_notify(irq, on_line, &h->refs[i]);
    }

    uint32_t flags = 0; /* no console echo of UART bytes, no polling sleeps */
    avr_ioctl(h->avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    h->uart_input = avr_io_getirq(h->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(
        avr_io_getirq(h->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), on_uart_out, h);
    avr_irq_register_notify(
        avr_io_getirq(h->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), on_xon, h);
    avr_irq_register_notify(
        avr_io_getirq(h->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), on_xoff, h);
    h->xoff = 1; /* until the firmware enables its receiver */
    return h;
}

void artro_mcu_free(harness_t *h)
{
    if (!h)
        return;
    avr_terminate(h->avr);
    i2c_bus_free(h->i2c);
    free(h->edges);
    free(h->out);
    free(h->in);
    free(h);
}

static void note_timer_start(harness_t *h)
{
    avr_timer_t *timers[2] = {h->timer1, h->timer3};
    for (int i = 0; i < 2; i++)
        if (h->timer_start[i] < 0 && timers[i]->tov_cycles)
            h->timer_start[i] = (int64_t)timers[i]->tov_base;
    if (h->one_timer && h->timer_start[0] >= 0) /* the Mega's frame clock: Timer1 alone */
        h->timer_start[1] = h->timer_start[0];
}

/* Run until the cycle counter reaches `cycle`. Returns simavr's CPU state (cpu_Done and
 * cpu_Crashed end the run). */
static int run_profiled(harness_t *h)
{
    avr_t *avr = h->avr;
    const uint64_t before = avr->cycle, slept = h->slept_cycles;
    const uint8_t part = avr->data[h->part_addr];
    const int in_isr = !avr->sreg[S_I];
    const uint8_t flag = avr->data[h->flag_addr];
    int state = avr_run(avr); /* one instruction, and a sleep it starts or ends in */
    const uint64_t asleep = h->slept_cycles - slept;
    int bin = in_isr ? PROFILE_ISR : (part < PROFILE_PARTS ? part : 0);
    h->part_cycles[bin] += avr->cycle - before - asleep;
    h->part_cycles[PROFILE_SLEEP] += asleep;
    if (!flag && avr->data[h->flag_addr])
        h->flag_rose_cycle = avr->cycle;
    return state;
}

/* Count cycles by the byte at `part_addr` (the firmware's main-loop part marker) from now on,
 * and note when the byte at `flag_addr` rises; part_addr 0 stops. */
void artro_mcu_profile(harness_t *h, uint32_t part_addr, uint32_t flag_addr)
{
    h->profiling = part_addr != 0;
    h->part_addr = part_addr;
    h->flag_addr = flag_addr;
}

/* Cycles per bin (PROFILE_BINS: parts 0..7, in interrupts, asleep) and the flag's last rise. */
uint64_t artro_mcu_profile_take(harness_t *h, uint64_t *bins)
{
    memcpy(bins, h->part_cycles, sizeof h->part_cycles);
    memset(h->part_cycles, 0, sizeof h->part_cycles);
    return h->flag_rose_cycle;
}

int artro_mcu_run_until(harness_t *h, uint64_t cycle)
{
    avr_t *avr = h->avr;
    int state = avr->state;
    while (avr->cycle < cycle) {
        state = h->profiling ? run_profiled(h) : avr_run(avr);
        if (h->timer_start[1] < 0)
            note_timer_start(h);
        if (state == cpu_Done || state == cpu_Crashed)
            break;
    }
    return state;
}

uint64_t artro_mcu_cycle(harness_t *h)
{
    return h->avr->cycle;
}

/* Cycles the CPU spent executing (not sleeping) since the start. */
uint64_t artro_mcu_busy_cycles(harness_t *h)
{
    return h->avr->cycle - h->slept_cycles;
}

int64_t artro_mcu_timer_start(harness_t *h, int which)
{
    return h->timer_start[which == 3 ? 1 : 0];
}

/* Move up to `max` recorded edges out (oldest first); returns how many. */
size_t artro_mcu_take_edges(harness_t *h, uint64_t *cycles, uint8_t *lines, uint8_t *levels,
                            size_t max)
{
    size_t n = h->n_edges < max ? h->n_edges : max;
    for (size_t i = 0; i < n; i++) {
        cycles[i] = h->edges[i].cycle;
        lines[i] = h->edges[i].line;
        levels[i] = h->edges[i].level;
    }
    memmove(h->edges, h->edges + n, (h->n_edges - n) * sizeof(edge_t));
    h->n_edges -= n;
    return n;
}

size_t artro_mcu_take_uart(harness_t *h, uint64_t *cycles, uint8_t *bytes, size_t max)
{
    size_t n = h->n_out < max ? h->n_out : max;
    for (size_t i = 0; i < n; i++) {
        cycles[i] = h->out[i].cycle;
        bytes[i] = h->out[i].byte;
    }
    memmove(h->out, h->out + n, (h->n_out - n) * sizeof(uart_byte_t));
    h->n_out -= n;
    return n;
}

/* Queue bytes for the firmware's receiver; they go in as its FIFO makes room. */
int artro_mcu_uart_send(harness_t *h, const uint8_t *bytes, size_t n)
{
    if (grow((void **)&h->in, &h->cap_in, h->in_head + n, 1))
        return -1;
    memcpy(h->in + h->in_head, bytes, n);
    h->in_head += n;
    pump(h);
    return 0;
}

size_t artro_mcu_uart_queued(harness_t *h)
{
    return h->in_head - h->in_tail;
}

/* Copy n bytes of data memory (SRAM and registers) from `addr` (data space, 0 = r0). */
int artro_mcu_read(harness_t *h, uint32_t addr, uint8_t *out, uint32_t n)
{
    if ((uint64_t)addr + n > (uint64_t)h->avr->ramend + 1)
        return -1;
    memcpy(out, h->avr->data + addr, n);
    return 0;
}
