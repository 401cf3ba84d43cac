/* harness.c -- the ArtRo firmware on simavr's ATmega128 core (or the Mega board's ATmega2560,
 * with the I2C bus of harness_i2c.c: docs/BOARDS.md), as a small C library for Python.
 *
 * Loads the firmware ELF into simavr, records every level change of the six TDM lines
 * (OC1A/B/C = PB5/6/7, OC3A/B/C = PE3/4/5) and the three select lines (PC0..2) with its CPU
 * cycle, and bridges UART0 both ways: bytes the firmware sends are recorded with their cycle,
 * bytes for the firmware are queued and fed following simavr's XON/XOFF flow control (its receive
 * FIFO drops what comes while it is full).
 *
 * Three corrections of simavr's timer models, each can be left out to show what it does:
 *  - FIX_MODE14: simavr maps waveform mode 14 of Timer1/Timer3 to phase-correct PWM on this core,
 *    which ignores OCR writes (upstream issue buserror/simavr#579); the table entry is set to
 *    fast PWM with TOP = ICRn.
 *  - FIX_OCR_HIGH_BYTE: in PWM modes simavr takes a new OCRnx only if the 16-bit value differs
 *    once the low byte is written, comparing with the high byte already stored -- so a change of
 *    the high byte alone is lost. On the chip the high byte waits in TEMP and both bytes change
 *    together; the harness makes simavr see such a write as the change it is.
 *  - FIX_UART_BYTE_TIME: simavr times a UART byte when UBRRnL is written, with the U2Xn bit of
 *    that moment and always a parity bit. The firmware sets U2X0 after the rate, as the
 *    datasheet allows, and sends no parity: 57600 baud became 26 182 (11 bits of 32 us), so a
 *    walk's SENSORS stream lost one frame in three. The byte time is recomputed after every
 *    write to the UART's rate and control registers, as the chip's baud generator has it.
 *
 * The balance sensors (docs/DESIGN.md §15), attached on request:
 *  - an MPU-6050 on simavr's TWI bus: a register file at address 0x68 that acknowledges its
 *    address, takes a register pointer and writes, and answers reads from the pointer on, as
 *    the part does; its 14 data registers from 0x3B hold what Python sets for the frame. Faults
 *    on request: the next transactions not acknowledged (NACK), or a burst ended by a bus error
 *    after k bytes (the harness cancels the TWI's pending status and raises status 0x00).
 *  - the force sensors on simavr's ADC0..ADC7 inputs, in millivolts. simavr scales a
 *    conversion by 1023 / Vref where the chip takes 1024 / Vref: Python feeds the millivolts
 *    that give the chip's count (app/firmware/sensor_feed.py).
 * simavr 1.6 reports the status after SLA+W as a data byte's: corrected (on_twi_status).
 * simavr times a TWI byte at 9 us whatever TWBR says (400 kHz takes 22.5 us): when a read
 * completes differs, what it reads does not; the firmware waits for neither.
 * docs/DESIGN.md §5.
 */
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <simavr/avr_adc.h>
#include <simavr/avr_extint.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_timer.h>
#include <simavr/avr_twi.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#define NUM_LINES 9
#define FIX_MODE14 1
#define FIX_OCR_HIGH_BYTE 2
#define FIX_UART_BYTE_TIME 4
#define NUM_OCR 6
#define PROFILE_PARTS 8 /* marker values 0..7 */
#define PROFILE_ISR 8
#define PROFILE_SLEEP 9
#define PROFILE_BINS 10
#define F_CPU_HZ 16000000u
#define PCA9685_ADDRESS 0x40u

/* harness_i2c.c: the PCA9685 and the bus monitor */
struct i2c_bus;
struct i2c_bus *i2c_bus_new(avr_t *avr, avr_irq_t *input, uint8_t address);
void i2c_bus_free(struct i2c_bus *bus);
void i2c_bus_on_twi(struct avr_irq_t *irq, uint32_t value, void *param);
void i2c_bus_on_reply(struct avr_irq_t *irq, uint32_t value, void *param);

typedef struct {
    uint64_t cycle;
    uint8_t line;
    uint8_t level;
} edge_t;

typedef struct {
    uint64_t cycle;
    uint8_t byte;
} uart_byte_t;

typedef struct harness harness_t;

#define IMU_ADDRESS_BYTE (0x68u << 1) /* SLA+W; SLA+R is | 1 */

typedef struct {
    avr_irq_t *irq; /* TWI_IRQ_INPUT (to the MCU) and TWI_IRQ_OUTPUT (from it) */
    avr_twi_t *twi;
    uint8_t reg[128];
    uint8_t selected, pointer, index; /* index: bytes since the address in this transaction */
    uint32_t nack_left;               /* transactions still to be refused */
    int32_t short_after;              /* end the next burst with a bus error after this many bytes */
    uint32_t transactions, reads, bytes_read, faults;
    int sla_w_sent; /* FIX_TWI_SLA_W: the next status is SLA+W's */
} imu_t;

/* simavr's write handler of an OCRnxL register, wrapped */
typedef struct {
    avr_io_write_t write;
    void *param;
    avr_io_addr_t high;
    uint8_t last_high;
} ocr_wrap_t;

typedef struct {
    harness_t *h;
    uint8_t line;
} line_ref_t;

struct harness {
    avr_t *avr;
    avr_timer_t *timer1, *timer3;
    int64_t timer_start[2]; /* cycle at which Timer1 / Timer3 started counting, -1 before */
    uint8_t level[NUM_LINES];
    line_ref_t refs[NUM_LINES];
    edge_t *edges;
    size_t n_edges, cap_edges;
    uart_byte_t *out;
    size_t n_out, cap_out;
    uint8_t *in;
    size_t in_head, in_tail, cap_in;
    int xoff;
    avr_irq_t *uart_input;
    uint64_t slept_cycles;
    ocr_wrap_t ocr[NUM_OCR];
    imu_t imu;
    int imu_attached, bus_connected;
    int one_timer; /* not the ATmega128: no Timer3 to wait for */
    struct i2c_bus *i2c; /* harness_i2c.c's bus, once attached */
    uint32_t adc_conversions;
    /* profile: cycles by the main loop's part marker (a byte of SRAM), in interrupts, asleep;
     * and the cycle at which a flag byte last went from 0 to non-zero */
    int profiling;
    uint32_t part_addr, flag_addr;
    uint64_t part_cycles[PROFILE_BINS];
    uint64_t flag_rose_cycle;
};

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

/* FIX_UART_BYTE_TIME: a byte is a start bit, the data bits, a parity bit if UPMn1:0 ask for
 * one and the stop bits, each (UBRRn + 1) * 16 cycles, or * 8 with U2Xn. */
static void uart_byte_time(avr_t *avr, avr_uart_t *uart)
{
    static const uint8_t data_bits[8] = {5, 6, 7, 8, 8, 8, 8, 9};
    uint32_t ubrr = avr_regbit_get(avr, uart->ubrrl) | (avr_regbit_get(avr, uart->ubrrh) << 8);
    uint8_t size = avr_regbit_get(avr, uart->ucsz) | (avr_regbit_get(avr, uart->ucsz2) << 2);
    uint8_t parity = (avr->data[uart->r_ucsrc] & 0x30) ? 1 : 0; /* UPMn1:0, bits 5:4 */
    uint8_t stop = 1 + avr_regbit_get(avr, uart->usbs);
    uint32_t per_bit = (ubrr + 1) * (avr_regbit_get(avr, uart->u2x) ? 8u : 16u);
    uart->cycles_per_byte = per_bit * (1u + data_bits[size] + parity + stop);
}

/* after simavr's own handler of the register (which stores the byte) */
static void uart_config_written(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)addr;
    (void)v;
    uart_byte_time(avr, param);
}

/* a register simavr does not watch: the byte stored here, as the core would */
static void uart_config_stored(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    avr_core_watch_write(avr, addr, v);
    uart_byte_time(avr, param);
}

static int fix_uart_byte_time(avr_t *avr)
{
    avr_uart_t *uart = NULL;
    for (avr_io_t *io = avr->io_port; io; io = io->next)
        if (io->kind && strcmp(io->kind, "uart") == 0 && ((avr_uart_t *)io)->name == '0')
            uart = (avr_uart_t *)io; /* avr_io_t is its first member */
    if (!uart)
        return -1;
    const avr_io_addr_t regs[] = {uart->ubrrl.reg, uart->ubrrh.reg, uart->r_ucsra,
                                  uart->r_ucsrb, uart->r_ucsrc};
    for (size_t i = 0; i < sizeof regs / sizeof regs[0]; i++) {
        avr_io_addr_t io = AVR_DATA_TO_IO(regs[i]);
        int watched = avr->io[io].w.c != NULL;
        avr_register_io_write(avr, regs[i], watched ? uart_config_written : uart_config_stored,
                              uart);
    }
    return 0;
}

static void ocr_low_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    ocr_wrap_t *w = param;
    uint8_t high = avr->data[w->high];
    if (avr->data[addr] == v && high != w->last_high)
        avr->data[addr] = (uint8_t)~v; /* let simavr see the 16-bit value change */
    w->last_high = high;
    w->write(avr, addr, v, w->param);
}

static void wrap_ocr_writes(harness_t *h)
{
    avr_timer_t *timers[2] = {h->timer1, h->timer3};
    for (int t = 0; t < 2; t++) {
        for (int c = 0; c < 3; c++) {
            avr_timer_comp_t *comp = &timers[t]->comp[c];
            ocr_wrap_t *w = &h->ocr[3 * t + c];
            avr_io_addr_t io = AVR_DATA_TO_IO(comp->r_ocr);
            w->write = h->avr->io[io].w.c;
            w->param = h->avr->io[io].w.param;
            w->high = comp->r_ocrh;
            w->last_high = h->avr->data[comp->r_ocrh];
            h->avr->io[io].w.c = ocr_low_write;
            h->avr->io[io].w.param = w;
        }
    }
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

/* ---- the MPU-6050 register file on the TWI bus ------------------------------------------- */

/* A bus error now: the TWI's pending status change is cancelled, TWSR reads 0x00 and its
 * interrupt is raised (what the chip shows for an illegal START/STOP on the bus). */
static avr_cycle_count_t bus_error(avr_t *avr, avr_cycle_count_t when, void *param)
{
    (void)when;
    imu_t *imu = param;
    avr_cycle_timer_t pending[8];
    int n = 0;
    for (avr_cycle_timer_slot_p t = avr->cycle_timers.timer; t && n < 8; t = t->next)
        if (t->param == imu->twi)
            pending[n++] = t->timer;
    for (int i = 0; i < n; i++)
        avr_cycle_timer_cancel(avr, pending[i], imu->twi);
    avr_regbit_setto_raw(avr, imu->twi->twsr, 0x00);
    avr_raise_interrupt(avr, &imu->twi->twi);
    imu->faults++;
    return 0;
}

static void on_twi(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    harness_t *h = param;
    imu_t *imu = &h->imu;
    avr_twi_msg_irq_t v;
    v.u.v = value;
    if (v.u.twi.msg & TWI_COND_STOP) {
        imu->selected = 0;
    }
    if (v.u.twi.msg & TWI_COND_START) {
        imu->selected = 0;
        imu->index = 0;
        imu->sla_w_sent = !(v.u.twi.addr & 1u);
        if ((v.u.twi.addr & 0xFEu) != IMU_ADDRESS_BYTE || !h->imu_attached)
            return;
        if (!(v.u.twi.addr & 1u)) { /* SLA+W: a new transaction */
            imu->transactions++;
            if (imu->nack_left) {
                imu->nack_left--;
                imu->faults++;
                return; /* no ACK: the master reads SLA+W NACK */
            }
        }
        imu->selected = v.u.twi.addr;
        avr_raise_irq(imu->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_ACK, imu->selected, 1));
        return;
    }
    if (!imu->selected)
        return;
    if (v.u.twi.msg & TWI_COND_WRITE) {
        avr_raise_irq(imu->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_ACK, imu->selected, 1));
        if (imu->index++ == 0)
            imu->pointer = v.u.twi.data & 0x7Fu;
        else
            imu->reg[imu->pointer++ & 0x7Fu] = v.u.twi.data;
    }
    if (v.u.twi.msg & TWI_COND_READ) {
        if (imu->index == 0)
            imu->reads++;
        if (imu->short_after >= 0 && imu->index >= imu->short_after) {
            imu->short_after = -1;
            imu->selected = 0;
            avr_cycle_timer_register(h->avr, 1, bus_error, imu);
            return;
        }
        imu->index++;
        imu->bytes_read++;
        uint8_t data = imu->reg[imu->pointer++ & 0x7Fu];
        avr_raise_irq(imu->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_READ, imu->selected, data));
    }
}

/* simavr 1.6 reports SLA+W as a data byte: writing SLA+W to TWDR marks its write latch, and the
 * address phase then sets status 0x28/0x30 (data ACK/NACK) where the chip sets 0x18/0x20
 * (fixed upstream after 1.6, "fix for wrong return value of i2c_write"). The harness rewrites
 * the status that follows an SLA+W. */
static void on_twi_status(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    imu_t *imu = param;
    if (!imu->sla_w_sent)
        return;
    imu->sla_w_sent = 0;
    if (value == 0x28u || value == 0x30u)
        avr_regbit_setto_raw(imu->twi->io.avr, imu->twi->twsr, value == 0x28u ? 0x18u : 0x20u);
}

static void on_adc_trigger(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    ((harness_t *)param)->adc_conversions++;
}

/* Connect the harness to the MCU's TWI (once): the SLA+W status fix, then what answers. */
static int bus_connect(harness_t *h)
{
    static const char *names[2] = {"8>imu.out", "32<imu.in"};
    imu_t *imu = &h->imu;
    if (h->bus_connected)
        return 0;
    for (avr_io_t *io = h->avr->io_port; io; io = io->next)
        if (io->kind && strcmp(io->kind, "twi") == 0)
            imu->twi = (avr_twi_t *)io;
    if (!imu->twi)
        return -1;
    imu->irq = avr_alloc_irq(&h->avr->irq_pool, 0, 2, names);
    avr_irq_register_notify(imu->irq + TWI_IRQ_OUTPUT, on_twi, h);
    avr_connect_irq(imu->irq + TWI_IRQ_INPUT, avr_io_getirq(h->avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT));
    avr_connect_irq(avr_io_getirq(h->avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT), imu->irq + TWI_IRQ_OUTPUT);
    avr_irq_register_notify(
        avr_io_getirq(h->avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_STATUS), on_twi_status, imu);
    h->bus_connected = 1;
    return 0;
}

/* Put the MPU-6050 on the TWI bus and connect the ADC inputs; 0 on success. */
int artro_mcu_attach_sensors(harness_t *h)
{
    imu_t *imu = &h->imu;
    if (bus_connect(h) != 0)
        return -1;
    imu->reg[0x75] = 0x68u; /* WHO_AM_I */
    imu->short_after = -1;
    avr_irq_register_notify(
        avr_io_getirq(h->avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_OUT_TRIGGER), on_adc_trigger, h);
    h->imu_attached = 1;
    return 0;
}

/* Put a PCA9685 (address 0x40) and the bus monitor on the TWI bus; the bus (for the
 * artro_pca_* and artro_i2c_* calls of harness_i2c.c), NULL if there is no TWI. */
struct i2c_bus *artro_mcu_attach_pca9685(harness_t *h)
{
    if (h->i2c)
        return h->i2c;
    if (bus_connect(h) != 0)
        return NULL;
    h->i2c = i2c_bus_new(h->avr, h->imu.irq + TWI_IRQ_INPUT, PCA9685_ADDRESS);
    if (!h->i2c)
        return NULL;
    avr_irq_register_notify(h->imu.irq + TWI_IRQ_OUTPUT, i2c_bus_on_twi, h->i2c);
    avr_irq_register_notify(h->imu.irq + TWI_IRQ_INPUT, i2c_bus_on_reply, h->i2c);
    return h->i2c;
}

/* The IMU's 14 data registers from 0x3B (accel x, y, z, temperature, gyro x, y, z; big-endian). */
void artro_mcu_set_imu_data(harness_t *h, const uint8_t *data14)
{
    memcpy(&h->imu.reg[0x3B], data14, 14);
}

uint8_t artro_mcu_imu_register(harness_t *h, uint8_t reg)
{
    return h->imu.reg[reg & 0x7Fu];
}

/* Refuse the next `nack` transactions; end the next burst after `short_after` bytes (-1: no). */
void artro_mcu_imu_fault(harness_t *h, uint32_t nack, int32_t short_after)
{
    h->imu.nack_left = nack;
    h->imu.short_after = short_after;
}

/* ADC0..ADC7 inputs, millivolts. */
void artro_mcu_set_adc_mv(harness_t *h, const uint16_t *mv)
{
    for (int i = 0; i < 8; i++)
        avr_raise_irq(avr_io_getirq(h->avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + i), mv[i]);
}

/* Counters since the start: TWI transactions begun with our address, burst reads, bytes read,
 * faults delivered, ADC conversions. */
void artro_mcu_sensor_counts(harness_t *h, uint32_t *out5)
{
    out5[0] = h->imu.transactions;
    out5[1] = h->imu.reads;
    out5[2] = h->imu.bytes_read;
    out5[3] = h->imu.faults;
    out5[4] = h->adc_conversions;
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
    if (fixes & FIX_MODE14) {
        /* mode 14 = WGMn3:0 1110: fast PWM, TOP = ICRn, OCRnx taken at the period end */
        const avr_timer_wgm_t fast_pwm_icr = AVR_TIMER_WGM_ICFASTPWM();
        h->timer1->wgm_op[14] = fast_pwm_icr;
        h->timer3->wgm_op[14] = fast_pwm_icr;
    }
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
