/* sensors.c -- the MPU-6050 on the TWI bus and the foot force sensors on the ADC
 * (docs/DESIGN.md §15). Both run from their interrupts: the TWI master (twi.c) walks one burst
 * (START, SLA+W, register, repeated START, SLA+R, 14 bytes, STOP), the ADC interrupt one sweep of
 * the eight channels; neither touches a timer, so no TDM edge moves. No other transaction runs
 * between the burst's start (slot SENSE_SLOT) and its take (slot COMPUTE_SLOT).
 */
#include "sensors.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>
#include <util/delay.h>

#include "artro_schema.h"
#include "config.h"
#include "twi.h"

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

static volatile uint8_t s_burst[IMU_BURST];
static volatile uint8_t s_adc_channel = FSR_CHANNELS; /* FSR_CHANNELS: the sweep is done */
static volatile uint16_t s_adc[FSR_CHANNELS];
static uint8_t s_imu_present;
static uint8_t s_imu_reading; /* the transaction on the bus is this IMU burst */

static uint8_t imu_write(uint8_t reg, uint8_t value)
{
    return twi_blocking(IMU_TWI_ADDRESS, reg, &value, 1, 0, 0);
}

static uint8_t imu_read_blocking(void)
{
    return twi_blocking(IMU_TWI_ADDRESS, REG_ACCEL_XOUT_H, 0, 0, s_burst, IMU_BURST);
}

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
    twi_init();
    ADMUX = _BV(REFS0);
    ADCSRA = _BV(ADEN) | _BV(ADIE) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0); /* clk / 128 */

    s_imu_present = imu_write(REG_PWR_MGMT_1, 0x01u) == TWI_OK /* wake, PLL on gyro x */
        && imu_write(REG_CONFIG, IMU_DLPF_CFG) == TWI_OK
        && imu_write(REG_GYRO_CONFIG, 0x00u) == TWI_OK
        && imu_write(REG_ACCEL_CONFIG, 0x00u) == TWI_OK;
    if (!s_imu_present)
        return;
    /* held still: the mean gyro reading is its offset */
    int32_t sum[3] = {0, 0, 0};
    uint8_t good = 0;
    sensor_raw_t raw;
    for (uint8_t k = 0; k < CALIBRATION_SAMPLES; k++) {
        _delay_ms(CALIBRATION_SPACING_MS);
        if (imu_read_blocking() != TWI_OK)
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
        s_imu_reading = twi_begin(IMU_TWI_ADDRESS, REG_ACCEL_XOUT_H, 0, 0, s_burst, IMU_BURST)
            == TWI_OK; /* refused while another part's transaction runs: this read fails */
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
        result = s_imu_reading ? twi_result() : TWI_SHORT;
        if (result == TWI_BUSY) /* not done in time: given up, the bus freed for the next */
            twi_finish(TWI_SHORT);
        s_imu_reading = 0;
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
