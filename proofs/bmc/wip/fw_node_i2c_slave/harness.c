/*
 * Proof: the node's I2C slave downlink (urb_node_i2c_event, firmware/node/urb_i2c.c), the byte
 * state machine over the mailboxes (spec/schema/README.md "Frames").
 *
 * Node: outbox 0 (25 bytes) and inbox 0 (6 bytes) in the node, application outbox FW_OUT and inbox
 * FW_IN in one storage block with guard bytes after them, every other mailbox not set up. Mailbox
 * contents, front buffers and new flags are arbitrary.
 *
 Frames with arbitrary contents (mailbox sizes FW_B_MIN..FW_B_MAX: 13..14 puts the
 * covered length on both sides of the CRC-8 / CRC-16 boundary), every event within
 * FW_I2C_EVENT_BUDGET cycles (the PLL update a SYNC's counter byte triggers is fw_node_pll_update's):
 *   read        select outbox FW_OUT, read size + check + 1 bytes while the application publishes a
 *               new version: the bytes are the version latched at the address, its check, 0xFF
 *   SYNC        a general call with the magic then a counter calls the PLL once with the captured
 *               tick and the counter; any other first byte is NACKed and calls nothing
 *
 * NOT YET PROVED HERE (ESBMC 8.4 ran out of memory even for a 1-byte write; see the report in the
 * git log): arbitrary event sequences and the write path (commit only of a complete, checked write
 * at STOP / repeated START; NACK and faults). tests/firmware/node/test_i2c.c and the simulation's
 * TLC trace check (sim/tla/TraceInbox.tla) cover them by testing.
 *
 * The harness includes the prepared urb_node.c (urb_isr_fault is the real one); urb_pll_sync is a
 * stub recording its call (fw_node_pll_update proves it); the CRC byte steps are an order-sensitive
 * stand-in (stubs/fw_node_crc_stub.c: the state machine only carries the check).
 */
#include "urb_verify.h"

#include "urb_node.c"

#include "urb_runtime.h"

#include "../../stubs/fw_budgets.h"

#include "../../stubs/fw_node_crc_stub.c"

#define FW_COST_BUDGET FW_I2C_EVENT_BUDGET

#ifndef FW_B_MIN
#define FW_B_MIN 13u /* smallest mailbox size (13: CRC-8 at 14 covered bytes) */
#endif
#ifndef FW_B_MAX
#define FW_B_MAX 14u /* largest mailbox size (14: CRC-16 at 15 covered bytes) */
#endif
#define FW_IN 3u  /* the application inbox */
#define FW_OUT 5u /* the application outbox */
#define FW_GUARD 2u
#define FW_BOX_MAX FW_B_MAX
#define FW_STORAGE (4u * FW_BOX_MAX + FW_GUARD)

URB_PROOF_COST_STORAGE;

static urb_node_t node;
static urb_node_hal_t hal;
static uint8_t storage[FW_STORAGE];
static uint8_t storage0[FW_STORAGE]; /* the storage as set up */
static uint8_t in_size;
static uint8_t out_size;
static uint32_t capture_tick;
static uint8_t pll_calls;
static uint32_t pll_t_d;
static uint8_t pll_counter;

/* ----- stubs ----- */

void urb_pll_sync(urb_node_t *n, uint32_t t_d, uint8_t counter)
{
    URB_ASSERT(n == &node, "PLL: the node");
    pll_calls++;
    pll_t_d = t_d;
    pll_counter = counter;
}

static uint32_t hal_now(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    return capture_tick;
}

static uint32_t hal_capture(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    return capture_tick;
}

static void hal_mark(void *ctx, urb_node_mark_t mark)
{
    (void)ctx;
    URB_ASSERT(mark == URB_NODE_MARK_SYNC, "the I2C interrupt marks SYNC only");
    URB_COST(FW_HAL_CALL_CYCLES);
}

/* ----- set-up ----- */

static void setup_node(uint8_t so, uint8_t si)
{
    hal.now = hal_now;
    hal.sync_capture = URB_NONDET_BOOL() ? hal_capture : NULL;
    hal.mark = URB_NONDET_BOOL() ? hal_mark : NULL;
    node.hal = &hal;
    node.started = 1u;
    node.storage = storage;
    node.storage_len = (uint16_t)sizeof storage;
    /* urb_mailbox_reset, written field by field (see stubs/fw_node_stubs.c) */
    for (uint8_t n = 0u; n < URB_NODE_MAILBOXES; n++) {
        node.outbox[n].isr_idx = URB_NONE;
        node.outbox[n].held = URB_NONE;
        node.inbox[n].isr_idx = URB_NONE;
        node.inbox[n].app_idx = URB_NONE;
    }
    node.outbox[0].size = URB_NODE_OUTBOX0_SIZE;
    node.inbox[0].offset = 2u * URB_NODE_OUTBOX0_SIZE;
    node.inbox[0].size = URB_NODE_INBOX0_SIZE;
    out_size = so;
    in_size = si;
    node.outbox[FW_OUT].size = so;
    node.outbox[FW_OUT].offset = 0u;
    node.inbox[FW_IN].size = si;
    node.inbox[FW_IN].offset = (uint16_t)(2u * so);
    node.storage_used = (uint16_t)(2u * (so + si));
    /* arbitrary history: fronts, new flags, the application holding an inbox buffer */
    node.outbox[FW_OUT].front = URB_NONDET_BOOL() ? 1u : 0u;
    node.outbox[0].front = URB_NONDET_BOOL() ? 1u : 0u;
    node.inbox[FW_IN].front = URB_NONDET_BOOL() ? 1u : 0u;
    node.inbox[FW_IN].fresh[0] = URB_NONDET_BOOL() ? 1u : 0u;
    node.inbox[FW_IN].fresh[1] = URB_NONDET_BOOL() ? 1u : 0u;
    uint8_t const app = URB_NONDET_U8();
    URB_ASSUME(app <= URB_NONE);
    node.inbox[FW_IN].app_idx = app;
    node.i2c.state = URB_I2C_ST_IDLE;
    node.i2c.selected = 0u;
    capture_tick = URB_NONDET_U32();
    for (uint8_t k = 0u; k < FW_STORAGE; k++) {
        storage[k] = URB_NONDET_U8();
        storage0[k] = storage[k];
    }
}

static uint16_t event(urb_i2c_event_t e, uint8_t byte)
{
    URB_COST_BEGIN();
    uint16_t const r = urb_node_i2c_event(&node, e, byte);
    URB_COST_END(FW_COST_BUDGET);
    return r;
}

static uint8_t *out_buf(uint8_t b)
{
    return &storage[(b != 0u) ? out_size : 0u];
}

/* link_check over the select byte then `len` bytes of data, as the master computes it: the tier
 * rule and the byte steps (here the stub's, see stubs/fw_node_crc_stub.c); a loop with a constant
 * bound, so the unwinding does not follow the symbolic length. */
static uint32_t reference_check(uint8_t select, const uint8_t *data, uint8_t len)
{
    if ((1u + (unsigned)len) <= URB_CRC8_LINK_CHECK_MAX_COVERED) {
        uint8_t crc = urb_crc8_link_check_byte(URB_CRC8_LINK_CHECK_INIT, select);
        for (uint8_t k = 0u; k < FW_BOX_MAX; k++) {
            if (k < len) {
                crc = urb_crc8_link_check_byte(crc, data[k]);
            }
        }
        return urb_crc8_link_check_final(crc);
    }
    uint16_t crc = urb_crc16_link_check_byte(URB_CRC16_LINK_CHECK_INIT, select);
    for (uint8_t k = 0u; k < FW_BOX_MAX; k++) {
        if (k < len) {
            crc = urb_crc16_link_check_byte(crc, data[k]);
        }
    }
    return urb_crc16_link_check_final(crc);
}

/* Check bytes of a frame covering the select byte and `size` bytes (the two tiers). */
static uint8_t check_len_of(uint8_t size)
{
    return ((1u + (unsigned)size) <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u;
}

/* ----- part 2: frames ----- */

static void part_read(void)
{
    urb_node_outbox_t *ob = &node.outbox[FW_OUT];
    uint8_t const cl = check_len_of(out_size);
    URB_ASSERT(event(URB_I2C_ADDR_WRITE, 0u) == URB_I2C_ACK, "address: ACK");
    URB_ASSERT(event(URB_I2C_RX_BYTE, (uint8_t)(0x80u | FW_OUT)) == URB_I2C_ACK, "read select of a set-up outbox: ACK");
    URB_ASSERT(event(URB_I2C_STOP, 0u) == URB_I2C_ACK, "STOP");
    uint8_t const latched = ob->front;
    uint32_t const want = reference_check((uint8_t)(0x80u | FW_OUT), out_buf(latched), out_size);
    URB_ASSERT(event(URB_I2C_ADDR_READ, 0u) == URB_I2C_ACK, "read address: ACK");
    /* the application publishes the other buffer meanwhile (its lock succeeds: not being read) */
    uint8_t *w = NULL;
    bool const publish = URB_NONDET_BOOL();
    if (publish) {
        URB_ASSERT(urb_lock_outbox_any(&node, FW_OUT, &w) == URB_NODE_OK, "the buffer not being read is free");
        URB_ASSERT(w == out_buf((uint8_t)(1u - latched)), "the lock hands out the other buffer");
        URB_ASSERT(urb_release_outbox_any(&node, FW_OUT) == URB_NODE_OK, "release");
    }
    for (uint8_t k = 0u; k < (uint8_t)(FW_B_MAX + 3u); k++) {
        if (k < (uint8_t)(out_size + cl + 1u)) {
            uint16_t const r = event(URB_I2C_TX_BYTE, 0u);
            uint8_t expect = 0xFFu;
            if (k < out_size) {
                expect = out_buf(latched)[k];
            } else if (k < (uint8_t)(out_size + cl)) {
                expect = (uint8_t)(want >> (8u * (uint8_t)(k - out_size)));
            }
            URB_ASSERT(r == expect, "read: the latched version, its check, then 0xFF");
        }
    }
    URB_ASSERT(event(URB_I2C_TX_NACK, 0u) == URB_I2C_ACK, "end of the read");
    URB_ASSERT(ob->isr_idx == URB_NONE, "the read is closed");
    for (uint8_t k = 0u; k < FW_STORAGE; k++) {
        URB_ASSERT(storage[k] == storage0[k], "a read writes no mailbox or guard byte");
    }
}

static void part_sync(void)
{
    uint8_t const magic = URB_NONDET_U8();
    uint8_t const counter = URB_NONDET_U8();
    URB_ASSERT(event(URB_I2C_GENERAL_CALL, 0u) == URB_I2C_ACK, "general call: ACK");
    uint16_t const r = event(URB_I2C_RX_BYTE, magic);
    URB_ASSERT((r == URB_I2C_ACK) == (magic == URB_SYNC_MAGIC), "SYNC magic: ACK exactly for 0xA5");
    if (magic == URB_SYNC_MAGIC) {
        URB_ASSERT(event(URB_I2C_RX_BYTE, counter) == URB_I2C_ACK, "SYNC counter: ACK");
        URB_ASSERT((pll_calls == 1u) && (pll_t_d == capture_tick) && (pll_counter == counter),
                   "SYNC: one PLL update with the captured tick and the counter");
    }
    URB_ASSERT(event(URB_I2C_RX_BYTE, URB_NONDET_U8()) == URB_I2C_NACK, "a SYNC has two bytes");
    URB_ASSERT(event(URB_I2C_STOP, 0u) == URB_I2C_ACK, "STOP");
    URB_ASSERT(pll_calls == ((magic == URB_SYNC_MAGIC) ? 1u : 0u), "the PLL runs for a SYNC only");
}

void harness(void)
{
    uint8_t const size = URB_NONDET_U8();
    URB_ASSUME((size >= FW_B_MIN) && (size <= FW_B_MAX));
    setup_node(size, size);
    if (URB_NONDET_BOOL()) {
        part_read();
    } else {
        part_sync();
    }
}
