/*
 * Eva environment of the node library: a HAL whose every answer is arbitrary (Frama_C_*_interval)
 * and an application that sets up mailboxes 1 and 2 with arbitrary sizes and locks, fills, reads
 * and releases them on every update. Each proofs/framac/eva_node_<entry>/main.c drives one entry point
 * with arbitrary events in an unbounded loop, so Eva's fixpoint covers every sequence of inputs.
 */
#ifndef EVA_NODE_ENV_H
#define EVA_NODE_ENV_H

#include "__fc_builtin.h"
#include "urb_node.h"
#include "urb_node_internal.h"

/* Storage for mailboxes 1 and 2 at their largest (2 x 2 x 32 bytes): a write past the last buffer
 * leaves the array, so Eva reports it. */
#define EVA_NODE_STORAGE 128u

static uint32_t eva_now(void *ctx)
{
    (void)ctx;
    return Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu);
}

static void eva_set_compare(void *ctx, uint32_t at)
{
    (void)ctx;
    (void)at;
}

static void eva_set_address(void *ctx, uint8_t address)
{
    (void)ctx;
    (void)address;
}

static void eva_mark(void *ctx, urb_node_mark_t mark)
{
    (void)ctx;
    (void)mark;
}

static void eva_identify(void *ctx, uint8_t seconds)
{
    (void)ctx;
    (void)seconds;
}

static void eva_bootup(urb_node_t *node, void *user)
{
    (void)user;
    (void)urb_node_set_class(node, Frama_C_unsigned_char_interval(0u, 255u));
    (void)urb_node_set_index(node, Frama_C_unsigned_char_interval(0u, 255u));
    (void)urb_node_setup_inbox(node, 1u, Frama_C_unsigned_char_interval(1u, 32u));
    (void)urb_node_setup_outbox(node, 1u, Frama_C_unsigned_char_interval(1u, 32u));
    (void)urb_node_setup_inbox(node, 2u, Frama_C_unsigned_char_interval(1u, 32u));
    (void)urb_node_setup_outbox(node, 2u, Frama_C_unsigned_char_interval(1u, 32u));
}

/* The application side of mailboxes 1 and 2, as the SensoRHex apps use it. */
static void eva_update(urb_node_t *node, void *user)
{
    (void)user;
    uint8_t const n = Frama_C_unsigned_char_interval(1u, 2u);
    const uint8_t *in = NULL;
    if (urb_node_lock_inbox(node, n, &in) >= 0) {
        uint8_t const size = urb_node_inbox_size(node, n);
        uint8_t sum = 0u;
        for (uint8_t k = 0u; k < size; k++) {
            sum = (uint8_t)(sum + in[k]);
        }
        (void)sum;
        (void)urb_node_release_inbox(node, n);
    }
    uint8_t *out = NULL;
    if (urb_node_lock_outbox(node, n, &out) == URB_NODE_OK) {
        uint8_t const size = urb_node_outbox_size(node, n);
        for (uint8_t k = 0u; k < size; k++) {
            out[k] = Frama_C_unsigned_char_interval(0u, 255u);
        }
        (void)urb_node_release_outbox(node, n);
    }
}

static void eva_signal(urb_node_t *node, void *user, uint8_t signal)
{
    (void)node;
    (void)user;
    (void)signal;
}

static void eva_fault(urb_node_t *node, void *user, urb_node_fault_t fault)
{
    (void)node;
    (void)user;
    (void)fault;
}

/* Brings `node` on the bus with the default configuration at an arbitrary address, an optional
 * capture timer chosen arbitrarily; returns the result of urb_node_init. */
static int eva_node_start(urb_node_t *node, urb_node_hal_t *hal, urb_node_hooks_t *hooks, urb_node_config_t *cfg,
                          uint8_t *storage)
{
    hal->ctx = NULL;
    hal->now = eva_now;
    hal->set_compare = eva_set_compare;
    hal->sync_capture = (Frama_C_nondet(0, 1) != 0) ? eva_now : NULL;
    hal->set_address = eva_set_address;
    hal->mark = eva_mark;
    hal->identify = eva_identify;
    hooks->bootup = eva_bootup;
    hooks->init = NULL;
    hooks->reset = NULL;
    hooks->idle = NULL;
    hooks->update = eva_update;
    hooks->signal = eva_signal;
    hooks->fault = eva_fault;
    urb_node_config_default(cfg);
    cfg->i2c_address = Frama_C_unsigned_char_interval(1u, 127u);
    cfg->sync_enabled = Frama_C_unsigned_char_interval(0u, 1u);
    return urb_node_init(node, hal, hooks, NULL, cfg, storage, (uint16_t)EVA_NODE_STORAGE);
}

#endif /* EVA_NODE_ENV_H */
