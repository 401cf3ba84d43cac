/* harness_sensors.c -- the simavr harness's balance sensors: the MPU-6050 register file on
 * simavr's TWI bus, the force sensors on the ADC, and the TWI's connection that the PCA9685 of
 * harness_i2c.c shares (the harness_t of harness.h). docs/DESIGN.md §5.
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
 */
#include <stdint.h>
#include <string.h>

#include <simavr/avr_adc.h>
#include <simavr/avr_twi.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#include "harness.h"

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
