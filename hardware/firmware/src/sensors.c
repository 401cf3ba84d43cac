/* sensors.c -- the MPU-6050 on the TWI bus and the foot force sensors on the ADC
 * (docs/DESIGN.md §15). Both run from their interrupts: the TWI interrupt walks one transaction
 * (START, SLA+W, register, repeated START, SLA+R, 14 bytes, STOP), the ADC interrupt one sweep of
 * the eight channels; neither touches a timer, so no TDM edge moves. On a board whose TWI others
 * share (ARTRO_SHARED_TWI: the Mega's PCA9685, docs/BOARDS.md) the bursts go through twi.c, and
 * no other transaction runs between a burst's start (slot SENSE_SLOT) and its take.
 */
#include "sensors.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>
#include <util/delay.h>

#include "artro_schema.h"
#include "config.h"

/* MPU-6050 registers */
#define REG_CONFIG 0x1Au       /* DLPF_CFG */
#define REG_GYRO_CONFIG 0x1Bu  /* FS_SEL 0: ±250 °/s, 131 counts per °/s */
#define REG_ACCEL_CONFIG 0x1Cu /* AFS_SEL 0: ±2 g, 16384 counts per g */
#define REG_ACCEL_XOUT_H 0x3Bu /* the burst: accel x, y, z, temperature, gyro x, y, z */
#define REG_PWR_MGMT_1 0x6Bu
#define IMU_BURST 14u

sensor_raw_t g_sensor_raw;
int16_t g_gyro_offset[3];
uint8_t g_sensor_status;
uint8_t g_imu_failures;

#ifdef ARTRO_SHARED_TWI
#include "twi.h"

static volatile uint8_t s_burst[IMU_BURST];
static uint8_t s_imu_reading; /* the transaction on the bus is this frame's IMU burst */

/* A register write (`write`) or the burst, waited for: the ATmega128's twi_blocking below. */
static uint8_t imu_blocking(uint8_t reg, uint8_t value, uint8_t write)
{
    static uint8_t s_value;
    s_value = value;
    return write ? twi_blocking(IMU_TWI_ADDRESS, reg, &s_value, 1, 0, 0)
                 : twi_blocking(IMU_TWI_ADDRESS, reg, 0, 0, s_burst, IMU_BURST);
}

static void imu_start(void)
{
    s_imu_reading = twi_begin(IMU_TWI_ADDRESS, REG_ACCEL_XOUT_H, 0, 0, s_burst, IMU_BURST)
        == TWI_OK; /* refused while another part's transaction runs: this read fails */
}

/* The burst's result (interrupts off); a burst still running is given up. */
static uint8_t imu_result(void)
{
    uint8_t result = s_imu_reading ? twi_result() : TWI_SHORT;
    if (result == TWI_BUSY)
        twi_finish(TWI_SHORT);
    s_imu_reading = 0;
    return result;
}
#else
/* TWI status codes (TWSR & 0xF8), master modes */
#define TW_START_SENT 0x08u
#define TW_REP_START_SENT 0x10u
#define TW_SLA_W_ACK 0x18u
#define TW_SLA_W_NACK 0x20u
#define TW_DATA_W_ACK 0x28u
#define TW_DATA_W_NACK 0x30u
#define TW_SLA_R_ACK 0x40u
#define TW_SLA_R_NACK 0x48u
#define TW_DATA_R_ACK 0x50u
#define TW_DATA_R_NACK 0x58u

enum { TWI_OK = 0, TWI_NACK = 1, TWI_SHORT = 2, TWI_BUSY = 0xFF };
enum { STEP_START, STEP_SLA_W, STEP_REG, STEP_VALUE, STEP_RESTART, STEP_SLA_R, STEP_DATA };

#define TWCR_GO (_BV(TWINT) | _BV(TWEN) | _BV(TWIE))

static volatile uint8_t s_step, s_result = TWI_OK, s_count;
static uint8_t s_reg, s_value, s_write;
static volatile uint8_t s_burst[IMU_BURST];
#endif
static volatile uint8_t s_adc_channel = FSR_CHANNELS; /* FSR_CHANNELS: the sweep is done */
static volatile uint16_t s_adc[FSR_CHANNELS];
static uint8_t s_imu_present;

#ifndef ARTRO_SHARED_TWI
static void twi_finish(uint8_t result)
{
    TWCR = _BV(TWINT) | _BV(TWSTO) | _BV(TWEN); /* STOP; the interrupt is off until the next */
    s_result = result;
}

ISR(TWI_vect)
{
    const uint8_t status = TWSR & 0xF8u;
    switch (s_step) {
    case STEP_START:
        if (status != TW_START_SENT)
            break;
        TWDR = (uint8_t)(IMU_TWI_ADDRESS << 1);
        s_step = STEP_SLA_W;
        TWCR = TWCR_GO;
        return;
    case STEP_SLA_W:
        if (status != TW_SLA_W_ACK)
            break;
        TWDR = s_reg;
        s_step = STEP_REG;
        TWCR = TWCR_GO;
        return;
    case STEP_REG:
        if (status != TW_DATA_W_ACK)
            break;
        if (s_write) {
            TWDR = s_value;
            s_step = STEP_VALUE;
            TWCR = TWCR_GO;
        } else {
            s_step = STEP_RESTART;
            TWCR = TWCR_GO | _BV(TWSTA);
        }
        return;
    case STEP_VALUE:
        if (status != TW_DATA_W_ACK)
            break;
        twi_finish(TWI_OK);
        return;
    case STEP_RESTART:
        if (status != TW_REP_START_SENT)
            break;
        TWDR = (uint8_t)((IMU_TWI_ADDRESS << 1) | 1u);
        s_step = STEP_SLA_R;
        TWCR = TWCR_GO;
        return;
    case STEP_SLA_R:
        if (status != TW_SLA_R_ACK)
            break;
        s_count = 0;
        s_step = STEP_DATA;
        TWCR = TWCR_GO | _BV(TWEA); /* acknowledge every byte but the last */
        return;
    case STEP_DATA: {
        uint8_t n = s_count;
        if (n < IMU_BURST - 1u ? status != TW_DATA_R_ACK : status != TW_DATA_R_NACK)
            break;
        s_burst[n++] = TWDR;
        s_count = n;
        if (n == IMU_BURST) {
            twi_finish(TWI_OK);
            return;
        }
        TWCR = n < IMU_BURST - 1u ? (uint8_t)(TWCR_GO | _BV(TWEA)) : TWCR_GO;
        return;
    }
    }
    /* anything else: the part did not answer, or the burst ended early (a bus error, a lost
     * arbitration, a NACK where data should come) */
    const uint8_t nack = status == TW_SLA_W_NACK || status == TW_SLA_R_NACK
        || status == TW_DATA_W_NACK;
    twi_finish(nack ? TWI_NACK : TWI_SHORT);
}

static void twi_begin(uint8_t reg, uint8_t value, uint8_t write)
{
    s_reg = reg;
    s_value = value;
    s_write = write;
    s_step = STEP_START;
    s_result = TWI_BUSY;
    TWCR = TWCR_GO | _BV(TWSTA);
}

/* A whole transaction at boot, waited for (about 0.1 ms; given up after 2 ms). */
static uint8_t twi_blocking(uint8_t reg, uint8_t value, uint8_t write)
{
    twi_begin(reg, value, write);
    for (uint8_t i = 0; i < 200u && s_result == TWI_BUSY; i++)
        _delay_us(10);
    if (s_result == TWI_BUSY) {
        twi_finish(TWI_SHORT);
    }
    return s_result;
}

#define imu_blocking twi_blocking

static void imu_start(void)
{
    if (s_result != TWI_BUSY)
        twi_begin(REG_ACCEL_XOUT_H, 0, 0);
}

static uint8_t imu_result(void)
{
    uint8_t result = s_result;
    if (result == TWI_BUSY) /* not done in time: given up, the bus freed for the next */
        twi_finish(TWI_SHORT);
    return result;
}
#endif

ISR(ADC_vect)
{
    uint8_t ch = s_adc_channel;
    s_adc[ch] = ADC;
    if (++ch < FSR_CHANNELS) {
        ADMUX = (uint8_t)(_BV(REFS0) | ch); /* AVCC reference, single-ended channel ch */
        ADCSRA |= _BV(ADSC);
    }
    s_adc_channel = ch;
}

static void decode_burst(sensor_raw_t *raw)
{
    for (uint8_t i = 0; i < 3; i++) {
        raw->accel[i] = (int16_t)((uint16_t)s_burst[2 * i] << 8 | s_burst[2 * i + 1]);
        raw->gyro[i] = (int16_t)((uint16_t)s_burst[8 + 2 * i] << 8 | s_burst[9 + 2 * i]);
    }
}

void sensors_boot(void)
{
#ifdef ARTRO_SHARED_TWI
    twi_init();
#else
    TWSR = 0; /* prescaler 1 */
    TWBR = TWI_TWBR;
    TWCR = _BV(TWEN);
#endif
    ADMUX = _BV(REFS0);
    ADCSRA = _BV(ADEN) | _BV(ADIE) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0); /* clk / 128 */

    s_imu_present = imu_blocking(REG_PWR_MGMT_1, 0x01u, 1) == TWI_OK /* wake, PLL on gyro x */
        && imu_blocking(REG_CONFIG, IMU_DLPF_CFG, 1) == TWI_OK
        && imu_blocking(REG_GYRO_CONFIG, 0x00u, 1) == TWI_OK
        && imu_blocking(REG_ACCEL_CONFIG, 0x00u, 1) == TWI_OK;
    if (!s_imu_present)
        return;
    /* held still: the mean gyro reading is its offset */
    int32_t sum[3] = {0, 0, 0};
    uint8_t good = 0;
    sensor_raw_t raw;
    for (uint8_t k = 0; k < CALIBRATION_SAMPLES; k++) {
        _delay_ms(CALIBRATION_SPACING_MS);
        if (imu_blocking(REG_ACCEL_XOUT_H, 0, 0) != TWI_OK)
            continue;
        decode_burst(&raw);
        for (uint8_t i = 0; i < 3; i++)
            sum[i] += raw.gyro[i];
        good++;
    }
    if (good < CALIBRATION_SAMPLES / 2u) {
        s_imu_present = 0;
        return;
    }
    for (uint8_t i = 0; i < 3; i++) {
        /* rounded to the nearest count, halves away from zero */
        int32_t s = sum[i], half = good / 2;
        g_gyro_offset[i] = (int16_t)(s >= 0 ? (s + half) / good : -((-s + half) / good));
    }
    g_sensor_raw = raw;
}

void sensors_start(void)
{
    if (s_imu_present)
        imu_start();
    if (s_adc_channel >= FSR_CHANNELS) {
        s_adc_channel = 0;
        ADMUX = _BV(REFS0);
        ADCSRA |= _BV(ADSC);
    }
}

void sensors_take(sensor_reading_t *out)
{
    uint8_t status = s_imu_present ? SENSE_IMU_PRESENT : 0u, result, adc_done;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        result = imu_result();
        adc_done = s_adc_channel >= FSR_CHANNELS;
        if (adc_done)
            for (uint8_t i = 0; i < FSR_CHANNELS; i++)
                g_sensor_raw.adc[i] = s_adc[i];
    }
    if (s_imu_present) {
        if (result == TWI_OK) {
            decode_burst(&g_sensor_raw);
        } else {
            status |= SENSE_IMU_STALE;
            status |= result == TWI_NACK ? SENSE_IMU_NACK : SENSE_IMU_SHORT;
            if (g_imu_failures < 255u)
                g_imu_failures++;
        }
    }
    if (!adc_done)
        status |= SENSE_FSR_STALE;
    g_sensor_status = status;

    const sensor_raw_t *raw = &g_sensor_raw;
    for (uint8_t i = 0; i < 3; i++) {
        /* in 32 bits: a reading at its rail less the offset can pass the int16 range (a fast
           fall past 250 deg/s); cast to 16 bits it would read the other way */
        const int32_t counts = (int32_t)raw->gyro[i] - g_gyro_offset[i];
        out->gyro_rad_s[i] = (float)counts * IMU_GYRO_RAD_S_PER_COUNT;
        out->accel_m_s2[i] = (float)raw->accel[i] * IMU_ACCEL_M_S2_PER_COUNT;
    }
    for (uint8_t i = 0; i < FSR_CHANNELS; i++) {
        /* the divider: V / Vcc = adc / 1024 = F / (F + FSR_DIVIDER_N), so F = c adc / (1024 - adc) */
        const float adc = (float)raw->adc[i];
        out->fsr_n[i / 4u][i % 4u] = FSR_DIVIDER_N * adc / (1024.0f - adc);
    }
}
