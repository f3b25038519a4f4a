/*
 * A bridge on a scripted downlink and HAL stubs (scripted_rig.h), for test_fifo_model.c.
 */
#include "scripted_rig.h"

#include <string.h>

/* ===== A node layout per downlink address ====================================================== */

/* Node `a`'s mailbox sizes: inbox 0 and outbox 0 as on every node, then sizes that differ from
 * node to node (a SIZE_MISMATCH on one is a match on another). */
void srig_node_sizes(uint8_t a, uint8_t in[8], uint8_t out[8])
{
    memset(in, 0, 8u);
    memset(out, 0, 8u);
    in[0] = URB_COMMAND_SIZE;
    out[0] = URB_IDENTIFICATION_SIZE;
    in[1] = 4u;
    out[1] = 4u;
    in[2] = (uint8_t)(13u + (a & 1u));
    out[2] = 32u;
    in[3] = 1u;
    out[3] = (uint8_t)(a - 7u);
}

void srig_node_identification(uint8_t a, uint8_t *buf)
{
    urb_identification_t id;
    memset(&id, 0, sizeof id);
    id.class_id = 0x42u;
    id.index = a;
    srig_node_sizes(a, id.inbox_sizes, id.outbox_sizes);
    assert_int_equal(urb_identification_encode(&id, buf, URB_IDENTIFICATION_SIZE), (int32_t)URB_IDENTIFICATION_SIZE);
}

/* Present at the start (the initial scan finds them); the others answer the scan NO_NODE. */
bool srig_present_at_start(uint8_t a)
{
    return (a == 8u) || (a == 10u) || (a == 11u) || (a == 15u);
}

/* ===== The scripted bridge ====================================================================== */


static uint32_t hal_now(void *ctx)
{
    return ((srig_t *)ctx)->now;
}

static void hal_period(void *ctx, uint32_t period_us)
{
    ((srig_t *)ctx)->period = period_us;
}

void srig_drain_uart(srig_t *r)
{
    uint8_t byte;
    while (urb_bridge_uart_tx_pop(&r->b, &byte)) {
        assert_true(r->tx_len < sizeof r->tx);
        r->tx[r->tx_len++] = byte;
    }
}

static void hal_kick(void *ctx)
{
    srig_t *r = ctx;
    if (!r->tx_stall) {
        srig_drain_uart(r);
    }
}

static bool dl_begin(void *ctx, const urb_downlink_txn_t *t, uint32_t now_us)
{
    srig_t *r = ctx;
    (void)now_us;
    if (r->refuse || r->busy) {
        return false;
    }
    r->txn = *t;
    r->busy = true;
    r->done = false;
    r->lose = false;
    r->begins++;
    return true;
}

static int8_t dl_poll(void *ctx, uint32_t now_us)
{
    srig_t *r = ctx;
    (void)now_us;
    if (!r->busy) {
        return URB_DOWNLINK_IDLE;
    }
    if (r->lose) {
        r->busy = false;
        return URB_DOWNLINK_IDLE;
    }
    if (!r->done) {
        return URB_DOWNLINK_BUSY;
    }
    r->busy = false;
    return (int8_t)r->outcome;
}

/* Ends the running transaction with `status`; a read gets `data` (its length), or scribbles when
 * it failed (the bridge must not send them). */
void srig_finish(srig_t *r, uint8_t status, const uint8_t *data)
{
    assert_true(r->busy && !r->done);
    if ((r->txn.op == URB_DL_READ) && (r->txn.data != NULL)) {
        for (uint8_t i = 0u; i < r->txn.length; i++) {
            r->txn.data[i] = (status == URB_STATUS_OK) ? data[i] : (uint8_t)(0xA0u + i);
        }
    }
    r->outcome = status;
    r->done = true;
}

void srig_init(srig_t *r, uint8_t depth, uint16_t heartbeat_us)
{
    memset(r, 0, sizeof *r);
    r->hal.ctx = r;
    r->hal.now_us = hal_now;
    r->hal.heartbeat_period = hal_period;
    r->hal.uart_tx_kick = hal_kick;
    r->hal.mark = NULL;
    r->dl.ctx = r;
    r->dl.kind = 0u;
    r->dl.bitrate_kbps = 400u;
    r->dl.first_address = SRIG_FIRST;
    r->dl.last_address = SRIG_LAST;
    r->dl.begin = dl_begin;
    r->dl.poll = dl_poll;
    urb_bridge_config_t cfg;
    urb_bridge_default_config(&cfg);
    cfg.fifo_depth = depth;
    cfg.heartbeat_us = heartbeat_us;
    cfg.scan_at_start = true;
    assert_int_equal(urb_bridge_init(&r->b, &cfg, &r->hal, &r->dl), URB_OK);
    /* the initial scan: every address once, identification reads answered by the layout above */
    for (unsigned polls = 0u; r->b.scanning || r->busy; polls++) {
        assert_true(polls < 100u);
        urb_bridge_poll(&r->b);
        if (r->busy && !r->done) {
            assert_int_equal(r->txn.op, URB_DL_READ);
            uint8_t id[URB_IDENTIFICATION_SIZE];
            srig_node_identification(r->txn.address, id);
            srig_finish(r, srig_present_at_start(r->txn.address) ? URB_STATUS_OK : URB_STATUS_NO_NODE, id);
        }
    }
    assert_int_equal(urb_bridge_stats(&r->b)->scans, 1u);
    assert_int_equal(r->begins, SRIG_LAST - SRIG_FIRST + 1u);
}
