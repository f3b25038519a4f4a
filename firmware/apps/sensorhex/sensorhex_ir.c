/*
 * SensoRHex infrared distance node (see sensorhex_ir.h).
 */
#include "sensorhex_ir.h"

#include <stddef.h>

#include "urb_sensorhex.h"

void sensorhex_ir_defaults(sensorhex_ir_config_t *cfg, uint8_t index)
{
    cfg->index = index;
    cfg->min_mm = 100u;
    cfg->max_mm = 1500u;
    cfg->min_strength = 20u;
}

void sensorhex_ir_setup(sensorhex_ir_t *app, const sensorhex_ir_io_t *io, const sensorhex_ir_config_t *cfg)
{
    app->io = io;
    app->cfg = *cfg;
    app->filled = 0u;
    app->hist[0] = 0u;
    app->hist[1] = 0u;
    app->hist[2] = 0u;
    app->faults = 0u;
}

void sensorhex_ir_node_config(urb_node_config_t *cfg)
{
    cfg->update_divider = 10u;
    cfg->fw_major = 1u;
    cfg->fw_minor = 0u;
    cfg->fw_patch = 0u;
}

uint16_t sensorhex_ir_median3(uint16_t a, uint16_t b, uint16_t c)
{
    uint16_t const lo = (a > b) ? b : a;
    uint16_t const hi = (a > b) ? a : b;
    if (c <= lo) {
        return lo;
    }
    return (c >= hi) ? hi : c;
}

static void ir_bootup(urb_node_t *node, void *user)
{
    sensorhex_ir_t const *app = user;
    (void)urb_node_set_class(node, URB_NODE_IR_DISTANCE_CLASS);
    (void)urb_node_set_index(node, app->cfg.index);
    (void)urb_node_set_fingerprint(node, URB_NODE_IR_DISTANCE_FINGERPRINT);
    (void)urb_node_setup_outbox(node, URB_NODE_IR_DISTANCE_OUTBOX_IR_RANGE, URB_NODE_IR_DISTANCE_OUTBOX1_SIZE);
}

static void ir_update(urb_node_t *node, void *user)
{
    sensorhex_ir_t *app = user;
    sensorhex_ir_io_t const *io = app->io;
    app->hist[2] = app->hist[1];
    app->hist[1] = app->hist[0];
    app->hist[0] = io->distance_mm(io->ctx);
    uint8_t const strength = io->strength(io->ctx);
    if (app->filled < 3u) {
        app->filled++;
    }
    /* until three readings exist, the latest one stands alone */
    uint16_t const d = (app->filled < 3u) ? app->hist[0] : sensorhex_ir_median3(app->hist[0], app->hist[1], app->hist[2]);
    urb_ir_range_t const r = {d, strength,
                              (d >= app->cfg.min_mm) && (d <= app->cfg.max_mm) && (strength >= app->cfg.min_strength)};
    uint8_t *out = NULL;
    if (urb_node_lock_outbox(node, URB_NODE_IR_DISTANCE_OUTBOX_IR_RANGE, &out) == URB_NODE_OK) {
        (void)urb_ir_range_encode(&r, out, URB_IR_RANGE_SIZE);
        (void)urb_node_release_outbox(node, URB_NODE_IR_DISTANCE_OUTBOX_IR_RANGE);
    }
}

static void ir_reset(urb_node_t *node, void *user)
{
    (void)node;
    ((sensorhex_ir_t *)user)->filled = 0u;
}

static void ir_fault(urb_node_t *node, void *user, urb_node_fault_t fault)
{
    (void)node;
    (void)fault;
    ((sensorhex_ir_t *)user)->faults++;
}

const urb_node_hooks_t sensorhex_ir_hooks = {ir_bootup, NULL, ir_reset, NULL, ir_update, NULL, ir_fault};
