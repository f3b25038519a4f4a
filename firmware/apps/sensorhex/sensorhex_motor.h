/*
 * SensoRHex motor driver node (paper Sec. VI-A/VI-D, sensorhex.urbs `node MotorDriver`).
 *
 *   outbox 1 MotorFeedback  every update (1 kHz): encoder, current, voltage
 *   inbox  1 MotorCommand   armature voltage for VOLTAGE mode (the CPU closes the loop)
 *   outbox 2 MotorStatus    every status_divider updates (10 Hz): temperature, mode, flags
 *   inbox  2 MotorConfig    mode, local PD gains and target, voltage limit
 *
 * Each update acquires first (encoder, current, voltage), publishes outbox 1 (its release marks
 * the end of acquisition, so the node's phase lead is exactly this acquisition), then reads the
 * inboxes and drives the motor. Hardware is reached only through sensorhex_motor_io_t, so the
 * simulation plugs in a motor model and the tests a fake.
 *
 * Safety: in VOLTAGE mode the drive is cut after command_timeout updates without a fresh command;
 * every mode is limited to the configured voltage; the drive is cut while the current exceeds
 * twice current_limit_ma or the case is over temp_limit_cdeg (both latched into MotorStatus until
 * the next status publication).
 */
#ifndef SENSORHEX_MOTOR_H
#define SENSORHEX_MOTOR_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_node.h"

/** Storage block for the motor node's mailboxes (urb_node_init). */
#define SENSORHEX_MOTOR_STORAGE URB_NODE_STORAGE_BYTES(6u + 4u + 2u + 11u)

/** The motor hardware, as the application sees it. All members required. */
typedef struct {
    void *ctx;
    uint16_t (*encoder)(void *ctx);           /**< quadrature count, wraps modulo 65536 */
    int16_t (*current_ma)(void *ctx);         /**< armature current, mA */
    int16_t (*voltage_mv)(void *ctx);         /**< measured armature voltage (PWM average), mV */
    int16_t (*case_temp_cdeg)(void *ctx);     /**< motor case temperature, 0.01 degC */
    bool (*hall)(void *ctx);                  /**< the Hall calibration sensor sees the magnet */
    void (*drive_mv)(void *ctx, int16_t mv);  /**< set the armature voltage, mV */
} sensorhex_motor_io_t;

/** Application settings. */
typedef struct {
    uint8_t index;                 /**< node index (leg number) */
    uint16_t update_hz;            /**< app_update rate (for the D term); 1000 */
    int16_t current_limit_ma;      /**< overcurrent flag; the drive is cut beyond twice this */
    int16_t temp_limit_cdeg;       /**< overtemperature: flag and drive cut */
    uint16_t voltage_limit_mv;     /**< limit until MotorConfig sets one */
    uint8_t command_timeout;       /**< VOLTAGE mode: updates without a command before the cut (0: never) */
    uint16_t status_divider;       /**< MotorStatus every N updates */
} sensorhex_motor_config_t;

/** Application state (caller-owned; pass as the `user` pointer of urb_node_init). */
typedef struct {
    const sensorhex_motor_io_t *io;
    sensorhex_motor_config_t cfg;
    int32_t position;      /* unwrapped encoder */
    int32_t prev_position;
    int32_t target;
    uint16_t last_raw;
    uint16_t kp;
    uint16_t kd;
    uint16_t limit_mv;
    int16_t command_mv;
    int16_t applied_mv;    /* last drive value */
    uint16_t status_count;
    uint16_t missed;       /* updates without a fresh command (saturates at 65535, so that a
                              command_timeout of 255 still cuts; MotorStatus reports at most 255) */
    uint8_t mode;          /* urb_motor_mode_t */
    uint8_t have_raw;
    uint8_t overcurrent;
    uint8_t overtemp;
    uint16_t faults;       /* fault hook calls */
} sensorhex_motor_t;

/** The node hooks of the motor driver; user = sensorhex_motor_t *. */
extern const urb_node_hooks_t sensorhex_motor_hooks;

/** Default settings: 1 kHz, 10 A, 80 degC, 12 V, 50-update command timeout, status at 10 Hz. */
void sensorhex_motor_defaults(sensorhex_motor_config_t *cfg, uint8_t index);

/** Prepares *app (state reset, io and settings kept by reference / copied). */
void sensorhex_motor_setup(sensorhex_motor_t *app, const sensorhex_motor_io_t *io, const sensorhex_motor_config_t *cfg);

/** Node configuration for this app: 1 kHz updates. */
void sensorhex_motor_node_config(urb_node_config_t *cfg);

#endif /* SENSORHEX_MOTOR_H */
