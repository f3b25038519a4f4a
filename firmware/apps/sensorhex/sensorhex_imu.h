/*
 * SensoRHex inertial measurement node (sensorhex.urbs `node Imu`).
 *
 *   outbox 1 ImuSample  every update (100 Hz): acceleration, angular rate, temperature, counter
 *
 * The node filters on board, as the paper suggests for the slow nodes: app_idle reads the sensor
 * as often as the main loop allows (at most `oversample` readings per update) and app_update
 * publishes their mean, so the 100 Hz sample carries less noise than one reading.
 */
#ifndef SENSORHEX_IMU_H
#define SENSORHEX_IMU_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_node.h"

#define SENSORHEX_IMU_STORAGE URB_NODE_STORAGE_BYTES(14u)

/** One reading in the schema's units: accel in mm/s^2, gyro in mrad/s, temp in degC. */
typedef struct {
    int16_t accel[3];
    int16_t gyro[3];
    int8_t temp;
} sensorhex_imu_reading_t;

/** IMU hardware. */
typedef struct {
    void *ctx;
    bool (*read)(void *ctx, sensorhex_imu_reading_t *out); /**< false: no new reading */
} sensorhex_imu_io_t;

typedef struct {
    uint8_t index;      /**< node index */
    uint8_t oversample; /**< readings averaged per update, 1..16 (1: read once in the update) */
} sensorhex_imu_config_t;

typedef struct {
    const sensorhex_imu_io_t *io;
    sensorhex_imu_config_t cfg;
    int32_t sum[7];     /* accel x3, gyro x3, temp */
    uint8_t count;      /* readings in sum */
    uint8_t sample;     /* ImuSample.sample */
    uint16_t faults;
} sensorhex_imu_t;

extern const urb_node_hooks_t sensorhex_imu_hooks;

/** Default settings: oversample 8. */
void sensorhex_imu_defaults(sensorhex_imu_config_t *cfg, uint8_t index);
/** Prepares *app. */
void sensorhex_imu_setup(sensorhex_imu_t *app, const sensorhex_imu_io_t *io, const sensorhex_imu_config_t *cfg);
/** Node configuration for this app: 100 Hz updates on a 1 kHz heartbeat. */
void sensorhex_imu_node_config(urb_node_config_t *cfg);

#endif /* SENSORHEX_IMU_H */
