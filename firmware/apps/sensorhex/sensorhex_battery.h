/*
 * SensoRHex battery manager node (sensorhex.urbs `node BatteryManager`): three Li-Po packs.
 *
 *   outbox 1 BatteryStatus  every update (100 Hz): per pack voltage, current, charge, presence,
 *                           temperature; low (a present pack under its cut-off), charging
 *
 * The state of charge is estimated from the pack voltage (linear between empty_mv and full_mv,
 * compensated by the internal resistance times the current): coarse, but needs no state that a
 * reset would lose. Hardware through sensorhex_battery_io_t.
 */
#ifndef SENSORHEX_BATTERY_H
#define SENSORHEX_BATTERY_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_node.h"

#define SENSORHEX_BATTERY_PACKS 3u
/** Storage block for the battery node's mailboxes. */
#define SENSORHEX_BATTERY_STORAGE URB_NODE_STORAGE_BYTES(19u)

/** Battery hardware. All members required; `pack` is 0..2. */
typedef struct {
    void *ctx;
    bool (*present)(void *ctx, uint8_t pack);        /**< pack connected */
    uint16_t (*voltage_mv)(void *ctx, uint8_t pack); /**< pack voltage, mV */
    int16_t (*current_ma)(void *ctx, uint8_t pack);  /**< pack current, mA, positive discharging */
    int8_t (*temp_c)(void *ctx, uint8_t pack);       /**< pack temperature, degC */
    bool (*charger)(void *ctx);                      /**< a charger is connected */
} sensorhex_battery_io_t;

typedef struct {
    uint8_t index;           /**< node index */
    uint16_t empty_mv;       /**< 0 % (3S: 3 x 3.3 V) */
    uint16_t full_mv;        /**< 100 % (3S: 3 x 4.2 V) */
    uint16_t cutoff_mv;      /**< `low` below this (3S: 3 x 3.5 V) */
    uint16_t resistance_mohm; /**< pack internal resistance, for the charge estimate */
} sensorhex_battery_config_t;

typedef struct {
    const sensorhex_battery_io_t *io;
    sensorhex_battery_config_t cfg;
    uint16_t faults;
} sensorhex_battery_t;

extern const urb_node_hooks_t sensorhex_battery_hooks;

/** Default settings for 3S Li-Po packs. */
void sensorhex_battery_defaults(sensorhex_battery_config_t *cfg, uint8_t index);
/** Prepares *app. */
void sensorhex_battery_setup(sensorhex_battery_t *app, const sensorhex_battery_io_t *io,
                             const sensorhex_battery_config_t *cfg);
/** Node configuration for this app: 100 Hz updates on a 1 kHz heartbeat. */
void sensorhex_battery_node_config(urb_node_config_t *cfg);
/** State of charge in percent (0..100) for a pack at voltage_mv drawing current_ma. */
uint8_t sensorhex_battery_charge(const sensorhex_battery_config_t *cfg, uint16_t voltage_mv, int16_t current_ma);

#endif /* SENSORHEX_BATTERY_H */
