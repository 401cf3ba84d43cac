/* harness.h -- what the simavr harness's files share: the harness_t struct and its parts, the
 * fixes' bits, and the calls between harness.c (the core), harness_fixes.c (the corrections of
 * simavr's timers and UART), harness_sensors.c (the MPU-6050 and the ADC) and harness_i2c.c.
 * docs/DESIGN.md §5.
 */
#ifndef ARTRO_HARNESS_H
#define ARTRO_HARNESS_H

#include <stddef.h>
#include <stdint.h>

#include <simavr/avr_timer.h>
#include <simavr/avr_twi.h>
#include <simavr/sim_avr.h>
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

/* calls between the harness's own files: not exported from the library */
#define HARNESS_INTERNAL __attribute__((visibility("hidden")))

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

/* harness_fixes.c: the corrections, applied by artro_mcu_new as `fixes` asks */
HARNESS_INTERNAL int fix_uart_byte_time(avr_t *avr);
HARNESS_INTERNAL void wrap_ocr_writes(harness_t *h);
HARNESS_INTERNAL void fix_mode14(harness_t *h);

#endif
