/*
 * SensoRHex infrared distance node (sensorhex.urbs `node IrDistance`).
 *
 *   outbox 1 IrRange  every update (100 Hz): distance, strength, valid
 *
 * A median of the last three readings removes the single-reading spikes such sensors produce;
 * `valid` holds when the median lies in [min_mm, max_mm] and the return is at least min_strength.
 */
#ifndef SENSORHEX_IR_H
#define SENSORHEX_IR_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_node.h"

#define SENSORHEX_IR_STORAGE URB_NODE_STORAGE_BYTES(4u)

/** IR sensor hardware. */
typedef struct {
    void *ctx;
    uint16_t (*distance_mm)(void *ctx); /**< raw distance, mm */
    uint8_t (*strength)(void *ctx);     /**< return signal strength */
} sensorhex_ir_io_t;

typedef struct {
    uint8_t index;
    uint16_t min_mm;      /**< shortest valid distance */
    uint16_t max_mm;      /**< longest valid distance */
    uint8_t min_strength; /**< weakest valid return */
} sensorhex_ir_config_t;

typedef struct {
    const sensorhex_ir_io_t *io;
    sensorhex_ir_config_t cfg;
    uint16_t hist[3];   /* last three readings */
    uint8_t filled;     /* readings in hist (saturates at 3) */
    uint16_t faults;
} sensorhex_ir_t;

extern const urb_node_hooks_t sensorhex_ir_hooks;

/** Default settings: 100..1500 mm, strength >= 20. */
void sensorhex_ir_defaults(sensorhex_ir_config_t *cfg, uint8_t index);
/** Prepares *app. */
void sensorhex_ir_setup(sensorhex_ir_t *app, const sensorhex_ir_io_t *io, const sensorhex_ir_config_t *cfg);
/** Node configuration for this app: 100 Hz updates on a 1 kHz heartbeat. */
void sensorhex_ir_node_config(urb_node_config_t *cfg);
/** Median of three. */
uint16_t sensorhex_ir_median3(uint16_t a, uint16_t b, uint16_t c);

#endif /* SENSORHEX_IR_H */
