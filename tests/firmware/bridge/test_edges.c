/*
 * The bridge's argument checks and the paths the traffic tests do not take: every way
 * urb_bridge_init refuses its arguments, the USB entry points on NULL, the I2C master fed events its
 * phase does not expect (on a recording HAL, event by event), local requests with a broken downlink
 * description, a HAL without timing marks, the NOP command, a heartbeat tick while SYNC is off, and a
 * node whose identification does not decode.
 */
#include <stdlib.h>
#include <string.h>

#include "support.h"
#include "urb_runtime.h"

#define NODE 0x20u

static int teardown(void **state)
{
    rig_free(*state);
    return 0;
}

/* ===== urb_bridge_init ========================================================================== */

/* Each argument rule on its own (MC/DC of the check): the valid set is accepted, and changing any one
 * of them alone makes init refuse with URB_ERR_ARGUMENT. */
static void init_refuses_each_bad_argument(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    urb_bridge_t *b = &r->bridge;
    urb_bridge_config_t cfg;
    urb_bridge_default_config(&cfg);
    urb_bridge_hal_t const hal = r->hal.hal;
    urb_downlink_t const dl = r->dl;
    assert_int_equal(urb_bridge_init(b, &cfg, &hal, &dl), URB_OK);
    assert_int_equal(urb_bridge_init(NULL, &cfg, &hal, &dl), URB_ERR_ARGUMENT);
    assert_int_equal(urb_bridge_init(b, NULL, &hal, &dl), URB_ERR_ARGUMENT);
    assert_int_equal(urb_bridge_init(b, &cfg, NULL, &dl), URB_ERR_ARGUMENT);
    assert_int_equal(urb_bridge_init(b, &cfg, &hal, NULL), URB_ERR_ARGUMENT);
    urb_bridge_hal_t h = hal;
    h.now_us = NULL;
    assert_int_equal(urb_bridge_init(b, &cfg, &h, &dl), URB_ERR_ARGUMENT);
    h = hal;
    h.heartbeat_period = NULL;
    assert_int_equal(urb_bridge_init(b, &cfg, &h, &dl), URB_ERR_ARGUMENT);
    h = hal;
    h.uart_tx_kick = NULL;
    assert_int_equal(urb_bridge_init(b, &cfg, &h, &dl), URB_ERR_ARGUMENT);
    urb_downlink_t d = dl;
    d.begin = NULL;
    assert_int_equal(urb_bridge_init(b, &cfg, &hal, &d), URB_ERR_ARGUMENT);
    d = dl;
    d.poll = NULL;
    assert_int_equal(urb_bridge_init(b, &cfg, &hal, &d), URB_ERR_ARGUMENT);
    d = dl;
    d.first_address = 0u;
    assert_int_equal(urb_bridge_init(b, &cfg, &hal, &d), URB_ERR_ARGUMENT);
    d = dl;
    d.first_address = (uint8_t)(dl.last_address + 1u);
    assert_int_equal(urb_bridge_init(b, &cfg, &hal, &d), URB_ERR_ARGUMENT);
    d = dl;
    d.last_address = 0x80u;
    assert_int_equal(urb_bridge_init(b, &cfg, &hal, &d), URB_ERR_ARGUMENT);
    urb_bridge_config_t c = cfg;
    c.fifo_depth = 0u;
    assert_int_equal(urb_bridge_init(b, &c, &hal, &dl), URB_ERR_ARGUMENT);
    c = cfg;
    c.fifo_depth = URB_BRIDGE_FIFO_MAX + 1u;
    assert_int_equal(urb_bridge_init(b, &c, &hal, &dl), URB_ERR_ARGUMENT);
    c = cfg;
    c.baud = 0u;
    assert_int_equal(urb_bridge_init(b, &c, &hal, &dl), URB_ERR_ARGUMENT);
    /* an idle gap of 0 means "two byte times at the configured rate", another value is kept; no scan
     * when not asked */
    c = cfg;
    c.idle_gap_us = 0u;
    c.scan_at_start = false;
    assert_int_equal(urb_bridge_init(b, &c, &hal, &dl), URB_OK);
    assert_int_equal(b->cfg.idle_gap_us, (20000000u + c.baud - 1u) / c.baud);
    assert_false(b->scanning);
    c.idle_gap_us = 500u;
    assert_int_equal(urb_bridge_init(b, &c, &hal, &dl), URB_OK);
    assert_int_equal(b->cfg.idle_gap_us, 500u);
}

/* ===== USB entry points ========================================================================= */

static void usb_entry_points_refuse_null(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    rig_start(r);
    uint32_t const bad = urb_bridge_stats(&r->bridge)->usb_bad_batches;
    assert_false(urb_bridge_usb_out(&r->bridge, NULL, 16u));
    assert_int_equal(urb_bridge_stats(&r->bridge)->usb_bad_batches, bad + 1u);
    /* a response batch ready for the IN transfer: a NULL buffer takes nothing, and it is still there */
    urb_bridge_usb_sof(&r->bridge);
    uint8_t f[4];
    const uint8_t *ptrs[1] = {f};
    size_t lens[1] = {enc_read(f, URB_BRIDGE_ADDRESS, URB_NODE_BRIDGE_OUTBOX_BRIDGE_INFO, 1u, URB_BRIDGE_INFO_SIZE)};
    uint8_t batch[32];
    assert_true(urb_bridge_usb_out(&r->bridge, batch, usb_batch(batch, 1u, ptrs, lens, 1u)));
    urb_hosted_rig_run(r, 1000u);
    urb_bridge_usb_sof(&r->bridge);
    uint8_t in[512];
    assert_int_equal(urb_bridge_usb_in(&r->bridge, NULL, sizeof in), 0u);
    assert_true(urb_bridge_usb_in(&r->bridge, in, sizeof in) > 0u);
}

/* ===== I2C master on a recording HAL ============================================================ */

typedef struct {
    unsigned starts, writes, reads, stops, aborts;
    uint8_t lines;
} rec_t;

static void rec_start(void *c) { ((rec_t *)c)->starts++; }
static void rec_write(void *c, uint8_t byte) { (void)byte; ((rec_t *)c)->writes++; }
static void rec_read(void *c, bool ack) { (void)ack; ((rec_t *)c)->reads++; }
static void rec_stop(void *c) { ((rec_t *)c)->stops++; }
static void rec_abort(void *c) { ((rec_t *)c)->aborts++; }
static uint8_t rec_lines(void *c) { return ((rec_t *)c)->lines; }
static void rec_drive(void *c, uint8_t lines) { (void)c; (void)lines; }
static void rec_release(void *c) { (void)c; }

typedef struct {
    rec_t rec;
    urb_i2c_hal_t hal;
    urb_i2c_master_t m;
    urb_downlink_t dl;
    uint8_t data[32];
} master_rig_t;

static void master_new(master_rig_t *mr)
{
    memset(mr, 0, sizeof *mr);
    mr->rec.lines = URB_I2C_SCL | URB_I2C_SDA;
    mr->hal = (urb_i2c_hal_t){&mr->rec, rec_start, rec_write, rec_read, rec_stop, rec_abort, rec_lines, rec_drive,
                              rec_release};
    urb_i2c_master_config_t cfg;
    urb_i2c_master_default_config(&cfg);
    urb_i2c_master_init(&mr->m, &mr->hal, &cfg);
    urb_i2c_master_downlink(&mr->m, &mr->dl);
}

static bool master_begin(master_rig_t *mr, uint8_t op, bool reselect)
{
    urb_downlink_txn_t const t = {op, NODE, 1u, 4u, 7u, reselect, mr->data};
    return mr->dl.begin(mr->dl.ctx, &t, 0u);
}

/* Polls until the outcome is reported (a bus clear, if any, runs to its end). */
static int8_t master_outcome(master_rig_t *mr)
{
    for (uint32_t t = 1u; t < 100000u; t += 10u) {
        int8_t const r = mr->dl.poll(mr->dl.ctx, t);
        if (r != URB_DOWNLINK_BUSY) {
            return r;
        }
    }
    fail_msg("the master never reported an outcome");
    return URB_DOWNLINK_BUSY;
}

/* Events outside a transaction are late events of an aborted one: ignored. A begin while a
 * transaction runs is refused. busy() holds from START to the last byte only. */
static void master_late_events_and_busy(void **state)
{
    (void)state;
    master_rig_t mr;
    master_new(&mr);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u); /* idle */
    assert_int_equal(mr.rec.starts + mr.rec.writes + mr.rec.stops, 0u);
    assert_int_equal(mr.dl.poll(mr.dl.ctx, 0u), URB_DOWNLINK_IDLE);
    assert_true(master_begin(&mr, URB_DL_WRITE, false));
    assert_true(urb_i2c_master_busy(&mr.m));
    assert_false(master_begin(&mr, URB_DL_WRITE, false)); /* one transaction at a time */
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    assert_int_equal(mr.rec.writes, 1u); /* the address */
    urb_i2c_master_event(&mr.m, URB_I2C_EV_NACK, 0u); /* nobody there: STOP, NO_NODE */
    assert_false(urb_i2c_master_busy(&mr.m));        /* finished, outcome not yet polled */
    unsigned const stops = mr.rec.stops;
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u); /* late: ignored */
    assert_int_equal(mr.rec.stops, stops);
    assert_int_equal(master_outcome(&mr), URB_STATUS_NO_NODE);
}

/* A bus error reported by the controller, and every event a phase does not expect, end the
 * transaction as a fault: with free lines, a TIMEOUT (the request was not executed). */
static void master_unexpected_events_are_faults(void **state)
{
    (void)state;
    master_rig_t mr;
    /* controller error during the header */
    master_new(&mr);
    assert_true(master_begin(&mr, URB_DL_WRITE, false));
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ERROR, 0u);
    assert_int_equal(master_outcome(&mr), URB_STATUS_TIMEOUT);
    /* a byte where START was expected */
    master_new(&mr);
    assert_true(master_begin(&mr, URB_DL_WRITE, false));
    urb_i2c_master_event(&mr.m, URB_I2C_EV_BYTE, 0u);
    assert_int_equal(master_outcome(&mr), URB_STATUS_TIMEOUT);
    /* a START where an ACK of a written byte was expected */
    master_new(&mr);
    assert_true(master_begin(&mr, URB_DL_WRITE, false));
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    assert_int_equal(master_outcome(&mr), URB_STATUS_TIMEOUT);
    /* a read: a START where the read address's ACK was expected, then where a byte was expected */
    master_new(&mr);
    assert_true(master_begin(&mr, URB_DL_READ, false));
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    for (int i = 0; i < 2; i++) { /* address + W, select: ACKed */
        urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u);
    }
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u); /* the repeated START: address + R written */
    urb_i2c_master_event(&mr.m, URB_I2C_EV_BYTE, 0u);
    assert_int_equal(master_outcome(&mr), URB_STATUS_TIMEOUT);
    master_new(&mr);
    assert_true(master_begin(&mr, URB_DL_READ, false));
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u); /* address + R ACKed: reading */
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u); /* an ACK where a byte was expected */
    assert_int_equal(master_outcome(&mr), URB_STATUS_TIMEOUT);
    assert_int_equal(urb_i2c_master_selection(&mr.m, NODE), URB_I2C_NO_SELECTION);
}

/* A SYNC nobody acknowledges is no error (OK), and a SYNC that faults forgets no node's selection. */
static void master_sync_nack_and_fault(void **state)
{
    (void)state;
    master_rig_t mr;
    master_new(&mr);
    assert_true(master_begin(&mr, URB_DL_SYNC, false));
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_NACK, 0u); /* the general call, unacknowledged */
    assert_int_equal(master_outcome(&mr), URB_STATUS_OK);
    /* a good read of outbox 1 caches the node's selection; a faulting SYNC keeps it */
    assert_true(master_begin(&mr, URB_DL_READ, false));
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u); /* address + W */
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u); /* select */
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ACK, 0u); /* address + R */
    uint8_t const sel = (uint8_t)(0x80u | 1u);
    uint8_t const good[4] = {1u, 2u, 3u, 4u};
    uint32_t const check = urb_link_check(&sel, 1u, good, 4u);
    for (int i = 0; i < 4; i++) {
        urb_i2c_master_event(&mr.m, URB_I2C_EV_BYTE, good[i]);
    }
    urb_i2c_master_event(&mr.m, URB_I2C_EV_BYTE, (uint8_t)check);
    assert_int_equal(master_outcome(&mr), URB_STATUS_OK);
    assert_memory_equal(mr.data, good, 4u);
    assert_int_equal(urb_i2c_master_selection(&mr.m, NODE), 1u);
    assert_true(master_begin(&mr, URB_DL_SYNC, false));
    urb_i2c_master_event(&mr.m, URB_I2C_EV_START, 0u);
    urb_i2c_master_event(&mr.m, URB_I2C_EV_ERROR, 0u);
    assert_int_equal(master_outcome(&mr), URB_STATUS_TIMEOUT);
    assert_int_equal(urb_i2c_master_selection(&mr.m, NODE), 1u);
}

/* ===== The bridge on a rig ======================================================================= */

static void request(urb_hosted_rig_t *r, bool read, uint8_t address, uint8_t mailbox, uint8_t seq, uint8_t len,
                    const uint8_t *data)
{
    uint8_t f[40];
    size_t const n = read ? enc_read(f, address, mailbox, seq, len) : enc_write(f, address, mailbox, seq, len, data);
    send_frame(r, f, n);
    assert_true(urb_hosted_rig_settle(r, 100000u));
}

/* BridgeInfo of a downlink that reports a kind outside DownlinkKind cannot be encoded: the read is
 * answered BAD_REQUEST rather than with a malformed frame. The NOP command is answered OK. */
static void local_requests_edge_cases(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    rig_start(r);
    r->bridge.dl.kind = 0xFFu;
    request(r, true, URB_BRIDGE_ADDRESS, URB_NODE_BRIDGE_OUTBOX_BRIDGE_INFO, 1u, URB_BRIDGE_INFO_SIZE, NULL);
    uint8_t const nop[URB_BRIDGE_COMMAND_SIZE] = {URB_BRIDGE_OPCODE_NOP, 0u, 0u};
    request(r, false, URB_BRIDGE_ADDRESS, URB_NODE_BRIDGE_INBOX_BRIDGE_COMMAND, 2u, sizeof nop, nop);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_BAD_REQUEST, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_OK, 0u, NULL);
    expect_end(&s);
}

/* A HAL without timing marks (mark == NULL, allowed by urb_bridge_hal.h) serves like one with them. */
static void hal_without_marks(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    r->hal.hal.mark = NULL;
    rig_start(r);
    request(r, true, NODE, 1u, 3u, 4u, NULL);
    stream_t s = rs232_stream(r);
    uint8_t data[4];
    expect_response(&s, 3u, URB_STATUS_OK, 4u, data);
    assert_int_equal(data[0], NODE);
    expect_end(&s);
    assert_int_equal(r->hal.mark_rises[URB_MARK_SERVE], 0u);
}

/* A heartbeat tick that arrives while SYNC is off (set to 0 by SET_HEARTBEAT, or a HAL tick that
 * raced the change) starts no SYNC and is consumed. */
static void heartbeat_tick_while_sync_off(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    urb_fake_node_t *n = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    urb_bridge_heartbeat(&r->bridge);
    assert_true(urb_hosted_rig_settle(r, 10000u));
    assert_int_equal(n->syncs, 0u);
    assert_int_equal(urb_bridge_stats(&r->bridge)->syncs, 0u);
    assert_true(urb_bridge_idle(&r->bridge));
}

/* A node whose outbox 0 holds no valid Identification: the host reads it (OK, the bytes as they
 * are), and the bridge, which learns mailbox sizes from identification reads, forgets that node's
 * sizes instead of learning garbage: a request of any length then goes to the node. */
static void undecodable_identification_forgets_sizes(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    urb_fake_node_t *n = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    assert_int_not_equal(r->bridge.node_of[NODE], 0u); /* the scan learnt its sizes */
    memset(n->outbox[0], 0xFF, sizeof n->outbox[0]);
    request(r, true, NODE, 0u, 1u, URB_IDENTIFICATION_SIZE, NULL);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_OK, URB_IDENTIFICATION_SIZE, NULL);
    assert_int_equal(r->bridge.node_of[NODE], 0u);
    /* the next request to it needs its sizes: the identification read before it does not decode
     * (CHECKSUM), then a bus held low during that read (BUS_STUCK); neither request reached the node */
    uint32_t const reads = n->reads;
    request(r, true, NODE, 1u, 2u, 4u, NULL);
    n->hold_scl = true;
    request(r, true, NODE, 1u, 3u, 4u, NULL);
    n->hold_scl = false;
    /* a Command to inbox 0 needs no identification (inbox 0 has one size on every node); refused at
     * its select byte by a node whose sizes the bridge does not hold, it stays BAD_REQUEST (with
     * known sizes, a refused select is a corrupted byte: CHECKSUM) */
    n->nack_at = 1;
    n->nack_once = true;
    uint8_t const cmd[URB_COMMAND_SIZE] = {0u};
    request(r, false, NODE, 0u, 4u, URB_COMMAND_SIZE, cmd);
    s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_OK, URB_IDENTIFICATION_SIZE, NULL);
    expect_response(&s, 2u, URB_STATUS_CHECKSUM, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_BUS_STUCK, 0u, NULL);
    expect_response(&s, 4u, URB_STATUS_BAD_REQUEST, 0u, NULL);
    expect_end(&s);
    assert_int_equal(n->outbox[1][0], NODE); /* outbox 1 untouched; only identification reads ran */
    assert_true(n->reads >= reads + 1u);
}

/* A present node that does not acknowledge a request's address is probed; a probe that itself
 * faults (the bus is held low meanwhile) answers the request with that fault (BUS_STUCK), and the node
 * stays present: nothing says it left. */
static void probe_that_faults(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    urb_fake_node_t *n = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    n->nack_at = 0;
    n->nack_once = true;
    uint8_t f[4];
    urb_hosted_rig_uart_send(r, f, enc_read(f, NODE, 1u, 1u, 4u), BYTE_US);
    for (uint32_t t = 0u; (t < 50000u) && !urb_i2c_master_busy(&r->master); t++) {
        urb_hosted_rig_run(r, 1u);
    }
    assert_true(urb_i2c_master_busy(&r->master)); /* the request is on the bus (its address will be NACKed) */
    n->hold_sda = 3u; /* SDA gets stuck low now: the probe that follows the NACK finds the bus stuck */
    assert_true(urb_hosted_rig_settle(r, 200000u));
    assert_false(r->bridge.probing);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_BUS_STUCK, 0u, NULL);
    expect_end(&s);
    assert_true(urb_bridge_present(&r->bridge, NODE));
}

/* A node past the bridge's node table is identified before each request (its sizes cannot be kept);
 * when it then refuses the select byte, the bridge knows the request matched the node's layout (the
 * identification checked it), so the refusal is a corrupted byte: CHECKSUM, as for a node in the table. */
static void refused_select_after_identification(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    urb_fake_node_t *last = NULL;
    for (uint8_t i = 0u; i <= URB_BRIDGE_MAX_NODES; i++) {
        last = add_node(r, (uint8_t)(0x10u + i), 0x42u, i, 4u, 4u);
    }
    rig_start(r);
    uint8_t const a = (uint8_t)(0x10u + URB_BRIDGE_MAX_NODES);
    assert_int_equal(r->bridge.node_of[a], 0u); /* the table is full */
    uint8_t const data[4] = {1u, 2u, 3u, 4u};
    uint8_t f[16];
    urb_hosted_rig_uart_send(r, f, enc_write(f, a, 1u, 5u, 4u, data), BYTE_US);
    for (uint32_t t = 0u; (t < 50000u) && !r->bridge.size_checked; t++) {
        urb_hosted_rig_run(r, 1u);
    }
    assert_true(r->bridge.size_checked); /* identified; now the write goes to the bus */
    last->nack_at = 1;
    last->nack_once = true;
    assert_true(urb_hosted_rig_settle(r, 50000u));
    assert_int_equal(r->bridge.node_of[a], 0u); /* still past the table */
    stream_t s = rs232_stream(r);
    expect_response(&s, 5u, URB_STATUS_CHECKSUM, 0u, NULL);
    expect_end(&s);
}

/* A full FIFO of requests to the bridge itself is served in one poll (the serving loop ends at its
 * bound, URB_BRIDGE_FIFO_MAX, not at an empty FIFO). */
static void fifo_of_local_requests_in_one_poll(void **state)
{
    urb_hosted_rig_t *r = rig_new(URB_BRIDGE_FIFO_MAX, 0u);
    *state = r;
    rig_start(r);
    uint8_t frames[URB_BRIDGE_FIFO_MAX][4];
    const uint8_t *ptrs[URB_BRIDGE_FIFO_MAX];
    size_t lens[URB_BRIDGE_FIFO_MAX];
    for (uint8_t k = 0u; k < URB_BRIDGE_FIFO_MAX; k++) {
        lens[k] = enc_read(frames[k], URB_BRIDGE_ADDRESS, URB_NODE_BRIDGE_OUTBOX_BRIDGE_INFO, k, URB_BRIDGE_INFO_SIZE);
        ptrs[k] = frames[k];
    }
    uint8_t batch[128];
    urb_bridge_usb_sof(&r->bridge);
    assert_true(urb_bridge_usb_out(&r->bridge, batch, usb_batch(batch, 1u, ptrs, lens, URB_BRIDGE_FIFO_MAX)));
    urb_bridge_poll(&r->bridge);
    assert_int_equal(urb_bridge_stats(&r->bridge)->responses, URB_BRIDGE_FIFO_MAX);
    assert_int_equal(urb_bridge_stats(&r->bridge)->busy, 0u);
}

/* Responses that the RS232 uplink cannot take yet (its transmit ring is full: nobody drains it) keep
 * the bridge from being idle; once the ring drains, the next poll sends them and the bridge is idle. */
static void idle_waits_for_a_full_uart(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    rig_start(r);
    urb_bridge_t *b = &r->bridge;
    for (uint8_t k = 0u; k < 8u; k++) { /* 8 BridgeScan responses: more than the 128-byte ring holds */
        uint8_t f[4];
        size_t const n = enc_read(f, URB_BRIDGE_ADDRESS, URB_NODE_BRIDGE_OUTBOX_BRIDGE_SCAN, k, URB_BRIDGE_SCAN_SIZE);
        for (size_t i = 0u; i < n; i++) {
            urb_bridge_uart_rx(b, f[i], r->hal.now);
            r->hal.now += BYTE_US;
        }
    }
    r->hal.now += 2000u; /* the line goes idle */
    for (int i = 0; i < 8; i++) {
        urb_bridge_poll(b);
    }
    assert_true(urb_bridge_stats(b)->responses < 8u);
    assert_false(urb_bridge_idle(b)); /* nothing to serve, but responses wait for the uplink */
    uint8_t byte;
    for (int i = 0; i < 8; i++) {
        while (urb_bridge_uart_tx_pop(b, &byte)) {
        }
        urb_bridge_poll(b);
    }
    while (urb_bridge_uart_tx_pop(b, &byte)) {
    }
    assert_int_equal(urb_bridge_stats(b)->responses, 8u);
    assert_true(urb_bridge_idle(b));
}

int run_edges_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(init_refuses_each_bad_argument, teardown),
        cmocka_unit_test_teardown(usb_entry_points_refuse_null, teardown),
        cmocka_unit_test(master_late_events_and_busy),
        cmocka_unit_test(master_unexpected_events_are_faults),
        cmocka_unit_test(master_sync_nack_and_fault),
        cmocka_unit_test_teardown(local_requests_edge_cases, teardown),
        cmocka_unit_test_teardown(hal_without_marks, teardown),
        cmocka_unit_test_teardown(heartbeat_tick_while_sync_off, teardown),
        cmocka_unit_test_teardown(undecodable_identification_forgets_sizes, teardown),
        cmocka_unit_test_teardown(probe_that_faults, teardown),
        cmocka_unit_test_teardown(refused_select_after_identification, teardown),
        cmocka_unit_test_teardown(fifo_of_local_requests_in_one_poll, teardown),
        cmocka_unit_test_teardown(idle_waits_for_a_full_uart, teardown),
    };
    return cmocka_run_group_tests_name("bridge_edges", tests, NULL, NULL);
}
