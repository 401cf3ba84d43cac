/* sensors.h -- the balance sensors on the MCU's own buses (docs/DESIGN.md §15):
 *
 *   - an MPU-6050 IMU on the TWI bus at 400 kHz: a burst of its 14 data bytes from ACCEL_XOUT_H
 *     (0x3B), interrupt-driven, at ±250 °/s and ±2 g; its gyro offsets calibrated at rest at boot;
 *   - four force sensors (FSR) under each sole on ADC0..ADC7 (left fl, fr, bl, br, then right),
 *     single conversions at prescaler 128 (125 kHz), AVCC reference, through a voltage divider.
 *
 * The TDM guard starts a read in slot SENSE_SLOT; the main loop takes the sample when it plans
 * the next frame. A read that fails (NACK, a burst cut short, not done in time) leaves the last
 * good sample in place and is counted and flagged.
 */
#ifndef ARTRO_SENSORS_H
#define ARTRO_SENSORS_H

#include <stdint.h>

#define IMU_TWI_ADDRESS 0x68u /* AD0 low */
#define FSR_CHANNELS 8u

/* sensor status bits (the SENSORS message) */
#define SENSE_IMU_PRESENT 0x01u /* the IMU answered at boot and was calibrated */
#define SENSE_IMU_STALE 0x02u   /* this frame's IMU read failed: the last good sample is used */
#define SENSE_IMU_NACK 0x04u    /* ... because the IMU did not acknowledge */
#define SENSE_IMU_SHORT 0x08u   /* ... because the burst ended early or the bus misbehaved */
#define SENSE_FSR_STALE 0x10u   /* this frame's ADC sweep did not finish */

typedef struct {
    int16_t accel[3];         /* raw counts, the part's axes (x forward, y left, z up) */
    int16_t gyro[3];          /* raw counts, before the calibrated offset */
    uint16_t adc[FSR_CHANNELS];
} sensor_raw_t;

typedef struct {
    float gyro_rad_s[3];      /* (raw - offset) * scale */
    float accel_m_s2[3];
    float fsr_n[2][4];        /* left foot first */
} sensor_reading_t;

extern sensor_raw_t g_sensor_raw;       /* the last good sample (main loop) */
extern int16_t g_gyro_offset[3];        /* the boot calibration's result */
extern uint8_t g_sensor_status;         /* SENSE_* of the last sample taken */
extern uint8_t g_imu_failures;          /* failed IMU reads since boot (saturates at 255) */

/* Set up the TWI and the ADC, wake and configure the IMU and calibrate its gyro at rest
 * (CALIBRATION_SAMPLES reads, CALIBRATION_SPACING_MS apart). Interrupts must be on. */
void sensors_boot(void);
/* Start this frame's IMU burst and ADC sweep (from the TDM guard interrupt). */
void sensors_start(void);
/* Take the sample started last (main loop): updates g_sensor_raw with what arrived, sets
 * g_sensor_status, and fills `out` in SI units (float32). */
void sensors_take(sensor_reading_t *out);

#endif /* ARTRO_SENSORS_H */
