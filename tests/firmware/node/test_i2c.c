/*
 * Downlink (I2C slave) state machine: every rule of the contract in spec/schema/README.md and
 * firmware/node/urb_i2c.c, every error path, the read path with its implicit-select check, SYNC
 * framing, and resets in the middle of a transaction.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "node_fixture.h"
#include "urb_core.h"
#include "urb_runtime.h"

static int setup(void **state)
{
    static fixture_t fx;
    fx_defaults(&fx);
    assert_int_equal(fx_start(&fx), URB_NODE_OK);
    *state = &fx;
    return 0;
}

static urb_node_t *N(void **state)
{
    return &((fixture_t *)*state)->node;
}

static fixture_t *F(void **state)
{
    return (fixture_t *)*state;
}

/* Locks inbox n, copies it out, releases; returns the lock result. */
static int take_inbox(urb_node_t *node, uint8_t n, uint8_t *out)
{
    const uint8_t *data = NULL;
    int const rc = urb_node_lock_inbox(node, n, &data);
    if (rc >= 0) {
        memcpy(out, data, urb_node_inbox_size(node, n));
        assert_int_equal(urb_node_release_inbox(node, n), URB_NODE_OK);
    }
    return rc;
}

static void publish(urb_node_t *node, uint8_t n, uint8_t fill)
{
    uint8_t *buf = NULL;
    assert_int_equal(urb_node_lock_outbox(node, n, &buf), URB_NODE_OK);
    memset(buf, fill, urb_node_outbox_size(node, n));
    assert_int_equal(urb_node_release_outbox(node, n), URB_NODE_OK);
}

static void write_crc8_tier(void **state)
{
    uint8_t const data[2] = {0x12u, 0x34u};
    uint8_t got[2] = {0};
    assert_int_equal(fx_write(N(state), 1u, data, 2u), FX_ALL_ACKED);
    assert_int_equal(take_inbox(N(state), 1u, got), URB_NODE_NEW);
    assert_memory_equal(got, data, 2u);
    /* the same message again is not new */
    assert_int_equal(take_inbox(N(state), 1u, got), URB_NODE_OK);
    assert_memory_equal(got, data, 2u);
}

static void write_crc16_tier(void **state)
{
    uint8_t data[20];
    uint8_t got[20];
    for (uint8_t i = 0u; i < 20u; i++) {
        data[i] = (uint8_t)(0xA0u + i);
    }
    uint8_t frame[40];
    size_t const n = fx_frame(frame, 2u, data, 20u, 0u);
    assert_int_equal(n, 1u + 20u + 2u); /* covered 21 > 14: CRC-16, two bytes */
    assert_int_equal(fx_write_raw(N(state), frame, n, true), FX_ALL_ACKED);
    assert_int_equal(take_inbox(N(state), 2u, got), URB_NODE_NEW);
    assert_memory_equal(got, data, 20u);
}

static void select_refused(void **state)
{
    uint8_t const data[2] = {1u, 2u};
    uint8_t frame[8];
    /* inbox 3 is not set up: NACK the select byte (bridge: BAD_REQUEST) */
    size_t n = fx_frame(frame, 3u, data, 2u, 0u);
    assert_int_equal(fx_write_raw(N(state), frame, n, true), 0);
    /* reserved bits set */
    uint8_t const bad = 0x09u;
    assert_int_equal(fx_write_raw(N(state), &bad, 1u, true), 0);
    uint8_t const bad_read = 0x88u;
    assert_int_equal(fx_write_raw(N(state), &bad_read, 1u, true), 0);
    /* outbox 5 is not set up: NACK the read select, the selection stays */
    assert_false(fx_select(N(state), 5u));
    assert_int_equal(N(state)->i2c.selected, 0u);
    /* a read select has one byte: a second one is NACKed */
    uint8_t const two[2] = {0x81u, 0x00u};
    assert_int_equal(fx_write_raw(N(state), two, 2u, true), 1);
    assert_int_equal(N(state)->i2c.selected, 1u);
    /* nothing reached the application */
    uint8_t got[2];
    assert_int_equal(take_inbox(N(state), 1u, got), URB_NODE_OK);
}

static void short_writes_abort(void **state)
{
    uint8_t const data[2] = {7u, 8u};
    uint8_t frame[8];
    size_t const n = fx_frame(frame, 1u, data, 2u, 0u);
    uint8_t got[2];
    /* stop after the select, after one data byte, after both data bytes (check missing) */
    for (size_t cut = 1u; cut < n; cut++) {
        assert_int_equal(fx_write_raw(N(state), frame, cut, true), FX_ALL_ACKED);
        assert_int_equal(take_inbox(N(state), 1u, got), URB_NODE_OK);
        assert_int_equal(got[0], 0u);
        assert_int_equal(N(state)->inbox[1].isr_idx, URB_NONE);
    }
    /* CRC-16 tier: stop after the first of the two check bytes */
    uint8_t big[20] = {0};
    uint8_t frame16[40];
    size_t const n16 = fx_frame(frame16, 2u, big, 20u, 0u);
    big[0] = 1u;
    (void)fx_frame(frame16, 2u, big, 20u, 0u);
    assert_int_equal(fx_write_raw(N(state), frame16, n16 - 1u, true), FX_ALL_ACKED);
    uint8_t got20[20];
    assert_int_equal(take_inbox(N(state), 2u, got20), URB_NODE_OK);
    assert_int_equal(got20[0], 0u);
    assert_int_equal(F(state)->faults[URB_NODE_FAULT_CHECKSUM], 0u);
}

static void long_write_nacked(void **state)
{
    uint8_t const data[2] = {7u, 8u};
    uint8_t frame[8];
    size_t const n = fx_frame(frame, 1u, data, 2u, 0u);
    frame[n] = 0x55u;
    /* the byte after size + check is NACKed (bridge: SIZE_MISMATCH), nothing is committed */
    assert_int_equal(fx_write_raw(N(state), frame, n + 1u, true), (int)n);
    uint8_t got[2];
    assert_int_equal(take_inbox(N(state), 1u, got), URB_NODE_OK);
    assert_int_equal(got[0], 0u);
    (void)urb_node_poll(N(state));
    assert_int_equal(F(state)->faults[URB_NODE_FAULT_CHECKSUM], 0u); /* a good check, then extra: no fault */
    /* a 3-byte payload for a 2-byte inbox (a bridge that does not know the layout): the node cannot
     * tell the third data byte from a wrong check byte, so it NACKs it as a failed check and counts
     * CHECKSUM (Identification.fault); the bridge, knowing the length it sent, reports the NACK at
     * that position as SIZE_MISMATCH (urb_i2c.c, firmware/node/README.md "Downlink", review F8) */
    uint8_t const three[3] = {1u, 2u, 3u};
    uint8_t f3[8];
    size_t const n3 = fx_frame(f3, 1u, three, 3u, 0u);
    assert_int_equal(fx_write_raw(N(state), f3, n3, true), 3);
    assert_int_equal(take_inbox(N(state), 1u, got), URB_NODE_OK);
    assert_int_equal(got[0], 0u);
    (void)urb_node_poll(N(state));
    assert_int_equal(F(state)->faults[URB_NODE_FAULT_CHECKSUM], 1u);
    assert_int_equal(F(state)->faults[URB_NODE_FAULT_OVERRUN], 0u);
    /* unless the third data byte happens to equal the check: then the real check byte is the one
     * beyond size + check, NACKed without a fault; nothing is stored either way */
    uint8_t const sel = 0x01u;
    uint8_t two_plus[3] = {4u, 5u, 0u};
    two_plus[2] = (uint8_t)urb_link_check(&sel, 1u, two_plus, 2u);
    size_t const n4 = fx_frame(f3, 1u, two_plus, 3u, 0u);
    assert_int_equal(fx_write_raw(N(state), f3, n4, true), 4);
    assert_int_equal(take_inbox(N(state), 1u, got), URB_NODE_OK);
    assert_int_equal(got[0], 0u);
    (void)urb_node_poll(N(state));
    assert_int_equal(F(state)->faults[URB_NODE_FAULT_CHECKSUM], 1u);
}

/* lobster-trace: urb.CRC_004 */
static void bad_check_nacked(void **state)
{
    uint8_t const data[2] = {7u, 8u};
    uint8_t frame[8];
    size_t const n = fx_frame(frame, 1u, data, 2u, 0x01u);
    assert_int_equal(fx_write_raw(N(state), frame, n, true), (int)n - 1); /* NACK the check byte */
    uint8_t got[2];
    assert_int_equal(take_inbox(N(state), 1u, got), URB_NODE_OK);
    assert_int_equal(got[0], 0u);
    (void)urb_node_poll(N(state));
    assert_int_equal(F(state)->faults[URB_NODE_FAULT_CHECKSUM], 1u);
    /* CRC-16: a bad FIRST check byte is still ACKed; the last one is NACKed */
    uint8_t big[20];
    memset(big, 3, sizeof big);
    uint8_t f16[40];
    size_t const n16 = fx_frame(f16, 2u, big, 20u, 0u);
    f16[n16 - 2u] ^= 0x80u;
    assert_int_equal(fx_write_raw(N(state), f16, n16, true), (int)n16 - 1);
    uint8_t got20[20];
    assert_int_equal(take_inbox(N(state), 2u, got20), URB_NODE_OK);
    assert_int_equal(got20[0], 0u);
    (void)urb_node_poll(N(state));
    assert_int_equal(F(state)->faults[URB_NODE_FAULT_CHECKSUM], 2u);
    assert_int_equal(F(state)->last_fault, URB_NODE_FAULT_CHECKSUM);
}

/* lobster-trace: urb.MBX_009 */
static void write_refused_when_both_buffers_busy(void **state)
{
    urb_node_t *node = N(state);
    uint8_t const a[2] = {1u, 1u};
    uint8_t const b[2] = {2u, 2u};
    uint8_t const c[2] = {3u, 3u};
    assert_int_equal(fx_write(node, 1u, a, 2u), FX_ALL_ACKED);
    const uint8_t *held = NULL;
    assert_int_equal(urb_node_lock_inbox(node, 1u, &held), URB_NODE_NEW);
    /* one more write lands in the other buffer */
    assert_int_equal(fx_write(node, 1u, b, 2u), FX_ALL_ACKED);
    /* the next would need the held buffer: NACK on the first data byte (bridge: NODE_BUSY) */
    assert_int_equal(fx_write(node, 1u, c, 2u), 1);
    assert_memory_equal(held, a, 2u); /* the held message is intact */
    assert_int_equal(urb_node_release_inbox(node, 1u), URB_NODE_OK);
    (void)urb_node_poll(node);
    assert_int_equal(F(state)->faults[URB_NODE_FAULT_OVERRUN], 1u);
    uint8_t got[2];
    assert_int_equal(take_inbox(node, 1u, got), URB_NODE_NEW);
    assert_memory_equal(got, b, 2u); /* the latest committed one */
    assert_int_equal(fx_write(node, 1u, c, 2u), FX_ALL_ACKED);
    assert_int_equal(take_inbox(node, 1u, got), URB_NODE_NEW);
    assert_memory_equal(got, c, 2u);
}

static void read_outbox_with_check(void **state)
{
    urb_node_t *node = N(state);
    uint8_t data[20];
    publish(node, 1u, 0x5Au);
    assert_true(fx_read_checked(node, 1u, 6u, data));
    assert_int_equal(data[0], 0x5Au);
    assert_int_equal(data[5], 0x5Au);
    publish(node, 2u, 0x33u); /* CRC-16 tier */
    assert_true(fx_read_checked(node, 2u, 20u, data));
    assert_int_equal(data[19], 0x33u);
    /* the selection is kept: a plain read returns outbox 2 again; extra clocks read 0xFF */
    uint8_t raw[24];
    fx_read(node, raw, 24u);
    assert_int_equal(raw[0], 0x33u);
    assert_int_equal(raw[22], 0xFFu);
    assert_int_equal(raw[23], 0xFFu);
    assert_int_equal(node->outbox[2].isr_idx, URB_NONE);
}

/* lobster-trace: urb.CRC_003 */
static void read_check_covers_select(void **state)
{
    urb_node_t *node = N(state);
    publish(node, 1u, 0x11u);
    assert_true(fx_select(node, 1u));
    uint8_t raw[7];
    fx_read(node, raw, 7u);
    /* the same bytes with another implicit select would not check: a lost selection is caught */
    uint8_t const sel_ok = 0x81u;
    uint8_t const sel_other = 0x82u;
    assert_int_equal(urb_link_check(&sel_ok, 1u, raw, 6u), raw[6]);
    assert_int_not_equal(urb_link_check(&sel_other, 1u, raw, 6u), raw[6]);
    /* and the generated decoder agrees */
    urb_downlink_read_response_t resp;
    memset(&resp, 0, sizeof resp);
    resp.select.mailbox = 1u;
    resp.select.read = true;
    assert_int_equal(urb_downlink_read_response_decode(&resp, raw, 7u), 7);
}

static void default_selection_is_outbox0(void **state)
{
    urb_node_t *node = N(state);
    uint8_t raw[27];
    fx_read(node, raw, 27u); /* no select since reset: outbox 0, Identification */
    urb_downlink_read_response_t resp;
    memset(&resp, 0, sizeof resp);
    resp.select.mailbox = 0u;
    resp.select.read = true;
    assert_int_equal(urb_downlink_read_response_decode(&resp, raw, 27u), 27);
    urb_identification_t id;
    assert_int_equal(urb_identification_decode(&id, resp.data, 25u), 25);
    assert_int_equal(id.class_id, 0x42u);
    assert_int_equal(id.index, 5u);
    assert_int_equal(id.fingerprint, 0xDEADBEEFu);
    assert_int_equal(id.fw_major, 1u);
    assert_int_equal(id.fw_minor, 2u);
    assert_int_equal(id.fw_patch, 3u);
    assert_int_equal(id.inbox_sizes[0], 6u);
    assert_int_equal(id.inbox_sizes[1], 2u);
    assert_int_equal(id.inbox_sizes[2], 20u);
    assert_int_equal(id.inbox_sizes[3], 0u);
    assert_int_equal(id.outbox_sizes[0], 25u);
    assert_int_equal(id.outbox_sizes[1], 6u);
    assert_int_equal(id.outbox_sizes[2], 20u);
    assert_false(id.synced);
    assert_false(id.fault);
}

static void read_during_release(void **state)
{
    urb_node_t *node = N(state);
    publish(node, 1u, 0xAAu);
    assert_true(fx_select(node, 1u));
    /* the bridge starts reading (latches buffer "AA") and takes two bytes */
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
    uint8_t raw[7];
    raw[0] = (uint8_t)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    raw[1] = (uint8_t)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    /* meanwhile the application publishes "BB" into the other buffer: allowed */
    publish(node, 1u, 0xBBu);
    /* and cannot lock again: the next buffer is the one being read (AppLockCheck: BUSY) */
    uint8_t *buf = NULL;
    assert_int_equal(urb_node_lock_outbox(node, 1u, &buf), URB_NODE_ERR_BUSY);
    for (size_t i = 2u; i < 7u; i++) {
        raw[i] = (uint8_t)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    }
    (void)urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    /* the read was not torn: all "AA", valid check */
    for (size_t i = 0u; i < 6u; i++) {
        assert_int_equal(raw[i], 0xAAu);
    }
    uint8_t const sel = 0x81u;
    assert_int_equal(urb_link_check(&sel, 1u, raw, 6u), raw[6]);
    /* the next read returns the fresh message; the lock works again */
    fx_read(node, raw, 7u);
    assert_int_equal(raw[0], 0xBBu);
    assert_int_equal(urb_node_lock_outbox(node, 1u, &buf), URB_NODE_OK);
    assert_int_equal(urb_node_release_outbox(node, 1u), URB_NODE_OK);
}

/* A byte received while the node transmits (a port that lost the direction: tests/fuzz/README.md,
 * Findings) is refused and ends the read: the outbox is no longer latched, so the application can
 * publish twice in a row. */
static void byte_received_during_read_ends_it(void **state)
{
    urb_node_t *node = N(state);
    publish(node, 1u, 0xAAu);
    assert_true(fx_select(node, 1u));
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u), URB_I2C_ACK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xAAu);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x55u), URB_I2C_NACK);
    urb_node_downlink_t dl;
    urb_node_downlink(node, &dl);
    assert_int_equal(dl.phase, URB_NODE_DL_IGNORE);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xFFu); /* nothing more is sent */
    publish(node, 1u, 0xBBu);
    publish(node, 1u, 0xCCu); /* BUSY here if the read still held buffer "AA" */
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    uint8_t raw[7];
    fx_read(node, raw, 7u);
    assert_int_equal(raw[0], 0xCCu);
}

static void repeated_start_commits(void **state)
{
    urb_node_t *node = N(state);
    uint8_t const data[2] = {9u, 9u};
    uint8_t frame[8];
    size_t const n = fx_frame(frame, 1u, data, 2u, 0u);
    assert_int_equal(fx_write_raw(node, frame, n, false), FX_ALL_ACKED);
    /* repeated START into a read: the write is complete and committed */
    uint8_t raw[27];
    fx_read(node, raw, 27u);
    uint8_t got[2];
    assert_int_equal(take_inbox(node, 1u, got), URB_NODE_NEW);
    assert_memory_equal(got, data, 2u);
    /* a repeated START in the middle of a write aborts it */
    uint8_t const d2[2] = {4u, 4u};
    assert_int_equal(fx_frame(frame, 1u, d2, 2u, 0u), n);
    assert_int_equal(fx_write_raw(node, frame, 2u, false), FX_ALL_ACKED);
    assert_int_equal(fx_write(node, 2u, (const uint8_t[20]){0}, 20u), FX_ALL_ACKED);
    assert_int_equal(take_inbox(node, 1u, got), URB_NODE_OK);
    assert_memory_equal(got, data, 2u);
}

static void bus_error_and_stuck_abort(void **state)
{
    urb_node_t *node = N(state);
    uint8_t const data[2] = {5u, 6u};
    uint8_t frame[8];
    size_t const n = fx_frame(frame, 1u, data, 2u, 0u);
    /* complete and checked, but the transaction ends in a bus error: no commit */
    assert_int_equal(fx_write_raw(node, frame, n, false), FX_ALL_ACKED);
    (void)urb_node_i2c_event(node, URB_I2C_BUS_ERROR, 0u);
    uint8_t got[2];
    assert_int_equal(take_inbox(node, 1u, got), URB_NODE_OK);
    assert_int_equal(got[0], 0u);
    /* stuck bus in the middle of a write: abort + STUCK_BUS */
    assert_int_equal(fx_write_raw(node, frame, 2u, false), FX_ALL_ACKED);
    (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u);
    assert_int_equal(node->inbox[1].isr_idx, URB_NONE);
    /* stuck in the middle of a read: the read ends */
    publish(node, 1u, 1u);
    assert_true(fx_select(node, 1u));
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    assert_int_not_equal(node->outbox[1].isr_idx, URB_NONE);
    (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u);
    assert_int_equal(node->outbox[1].isr_idx, URB_NONE);
    (void)urb_node_poll(node);
    assert_int_equal(F(state)->faults[URB_NODE_FAULT_STUCK_BUS], 1u); /* once per poll */
}

static void idle_bus_events(void **state)
{
    urb_node_t *node = N(state);
    /* bytes without an address: NACK; a read byte outside a read: 0xFF */
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0u), URB_I2C_NACK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xFFu);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u), URB_I2C_ACK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_STOP, 0u), URB_I2C_ACK);
    assert_int_equal(urb_node_i2c_event(node, (urb_i2c_event_t)99, 0u), URB_I2C_NACK);
    /* a bridge master's completion is not a slave event (disjoint values in urb_i2c_event.h) */
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_EV_START, 0u), URB_I2C_NACK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_EV_ACK, 0u), URB_I2C_NACK);
    /* address then STOP: nothing */
    assert_int_equal(fx_write_raw(node, NULL, 0u, true), FX_ALL_ACKED);
    assert_int_equal(urb_node_i2c_event(NULL, URB_I2C_ADDR_WRITE, 0u), URB_I2C_NACK);
    assert_int_equal(urb_node_i2c_event(NULL, URB_I2C_TX_BYTE, 0u), 0xFFu);
}

static void not_started_ignores_bus(void **state)
{
    (void)state;
    fixture_t fx;
    fx_defaults(&fx);
    fx.in_sizes[3] = 40u; /* setup fails: the node stays off the bus */
    assert_int_equal(fx_start(&fx), URB_NODE_ERR_ARG);
    assert_int_equal(fx.port.address, 0u);
    assert_int_equal(urb_node_i2c_event(&fx.node, URB_I2C_ADDR_WRITE, 0u), URB_I2C_NACK);
    assert_int_equal(urb_node_i2c_event(&fx.node, URB_I2C_TX_BYTE, 0u), 0xFFu);
    urb_node_timer_event(&fx.node); /* ignored */
    assert_int_equal(urb_node_poll(&fx.node), 0u);
}

static void reset_in_the_middle(void **state)
{
    urb_node_t *node = N(state);
    fixture_t *fx = F(state);
    uint8_t const data[20] = {1u};
    uint8_t frame[40];
    size_t const n = fx_frame(frame, 2u, data, 20u, 0u);
    /* a write is half way when the node restarts (power glitch, watchdog) */
    assert_int_equal(fx_write_raw(node, frame, 10u, false), FX_ALL_ACKED);
    assert_int_equal(fx_start(fx), URB_NODE_OK);
    /* the rest of the transaction is refused until the next START */
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, frame[10]), URB_I2C_NACK);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    uint8_t got[20];
    assert_int_equal(take_inbox(node, 2u, got), URB_NODE_OK);
    assert_int_equal(got[0], 0u);
    /* a read half way: after the restart the selection is back to outbox 0 and reads start clean */
    publish(node, 1u, 0x77u);
    assert_true(fx_select(node, 1u));
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    assert_int_equal(fx_start(fx), URB_NODE_OK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xFFu);
    assert_int_equal(node->i2c.selected, 0u);
    for (uint8_t m = 0u; m < URB_NODE_MAILBOXES; m++) {
        assert_int_equal(node->outbox[m].isr_idx, URB_NONE);
        assert_int_equal(node->inbox[m].isr_idx, URB_NONE);
    }
    /* and the full frame now works */
    assert_int_equal(fx_write_raw(node, frame, n, true), FX_ALL_ACKED);
    assert_int_equal(take_inbox(node, 2u, got), URB_NODE_NEW);
}

/* lobster-trace: urb.SYN_007 */
static void sync_framing(void **state)
{
    urb_node_t *node = N(state);
    fixture_t *fx = F(state);
    fx->port.capture = 777u;
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_GENERAL_CALL, 0u), URB_I2C_ACK);
    assert_int_equal(node->i2c.sync_t, 777u); /* t_d from the hardware capture */
    assert_int_equal(fx->port.mark_count[URB_NODE_MARK_SYNC], 1u);
    /* another general-call command is not ours */
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x06u), URB_I2C_NACK);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    /* magic, counter, then nothing more */
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_GENERAL_CALL, 0u), URB_I2C_ACK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, URB_SYNC_MAGIC), URB_I2C_ACK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, 1u), URB_I2C_ACK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, 2u), URB_I2C_NACK);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    assert_int_equal(node->pll.syncs, 1u);
    /* without a hardware capture the library reads the timer at the address match */
    fixture_t f2;
    fx_defaults(&f2);
    urb_hal_hosted_init(&f2.port, 5000u, false);
    assert_int_equal(fx_start(&f2), URB_NODE_OK);
    f2.port.now = 6000u;
    (void)urb_node_i2c_event(&f2.node, URB_I2C_GENERAL_CALL, 0u);
    assert_int_equal(f2.node.i2c.sync_t, 6000u);
}

/* The public views of a transaction in progress (what the simulation's trace observers read). */
static void observation_views(void **state)
{
    urb_node_t *node = N(state);
    urb_node_downlink_t dl;
    urb_node_buffers_t bufs;
    urb_node_downlink(node, &dl);
    assert_int_equal(dl.phase, URB_NODE_DL_IDLE);
    assert_false(urb_node_inbox_buffers(node, 3u, &bufs)); /* not set up */
    assert_false(urb_node_inbox_buffers(node, 8u, &bufs));
    assert_true(urb_node_inbox_buffers(node, 1u, &bufs));
    uint8_t const front = bufs.front;
    assert_int_equal(bufs.isr, URB_NODE_NO_BUFFER);
    assert_int_equal(bufs.app, URB_NODE_NO_BUFFER);
    /* a write of inbox 1 (2 bytes, CRC-8): phase, mailbox, byte count and the buffer being filled */
    uint8_t frame[8];
    uint8_t const data[2] = {0x12u, 0x34u};
    size_t const n = fx_frame(frame, 1u, data, 2u, 0u);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_ADDR_WRITE, 0u), URB_I2C_ACK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, frame[0]), URB_I2C_ACK);
    urb_node_downlink(node, &dl);
    assert_int_equal(dl.phase, URB_NODE_DL_WRITE);
    assert_int_equal(dl.mailbox, 1u);
    assert_int_equal(dl.count, 0u);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, frame[1]), URB_I2C_ACK);
    urb_node_downlink(node, &dl);
    assert_int_equal(dl.count, 1u);
    assert_true(urb_node_inbox_buffers(node, 1u, &bufs));
    assert_int_equal(bufs.isr, (uint8_t)(1u - front));
    for (size_t k = 2u; k < n; k++) {
        assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, frame[k]), URB_I2C_ACK);
    }
    urb_node_downlink(node, &dl);
    assert_int_equal(dl.phase, URB_NODE_DL_WRITE_DONE);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_STOP, 0u), URB_I2C_ACK);
    assert_true(urb_node_inbox_buffers(node, 1u, &bufs));
    assert_int_equal(bufs.front, (uint8_t)(1u - front));
    assert_int_equal(bufs.isr, URB_NODE_NO_BUFFER);
    /* a read of outbox 1: the index of the next byte sent */
    assert_true(fx_select(node, 1u));
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u), URB_I2C_ACK);
    urb_node_downlink(node, &dl);
    assert_int_equal(dl.phase, URB_NODE_DL_READ);
    assert_int_equal(dl.mailbox, 1u);
    assert_int_equal(dl.count, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    urb_node_downlink(node, &dl);
    assert_int_equal(dl.count, 1u);
    (void)urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    urb_node_downlink(node, &dl);
    assert_int_equal(dl.phase, URB_NODE_DL_IDLE);
    urb_node_downlink(NULL, &dl); /* harmless */
    urb_node_downlink(node, NULL);
    assert_false(urb_node_inbox_buffers(NULL, 1u, &bufs));
}

static void identification_fault_flag(void **state)
{
    urb_node_t *node = N(state);
    uint8_t raw[27];
    urb_identification_t id;
    /* a checksum fault sets Identification.fault */
    uint8_t const data[2] = {1u, 2u};
    uint8_t frame[8];
    size_t const n = fx_frame(frame, 1u, data, 2u, 0x10u);
    (void)fx_write_raw(node, frame, n, true);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_IDENT) != 0u);
    /* a read cut short does not clear it */
    assert_true(fx_select(node, 0u));
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_IDENT, 0u);
    /* a complete read returns it ... */
    fx_read(node, raw, 27u);
    assert_int_equal(urb_identification_decode(&id, raw, 25u), 25);
    assert_true(id.fault);
    /* ... and since that read began after the publication, the flag clears at the next poll */
    assert_true((urb_node_poll(node) & URB_NODE_POLL_IDENT) != 0u);
    fx_read(node, raw, 27u);
    assert_int_equal(urb_identification_decode(&id, raw, 25u), 25);
    assert_false(id.fault);
}

/* Mutation score (tests/mutation/README.md): seeded bugs the tests above let through. */

/* The check tier switches exactly after 14 covered bytes (select + 13 data: CRC-8, one byte;
 * select + 14 data: CRC-16, two), on the node's side too. */
static void write_at_the_crc8_tier_boundary(void **state)
{
    fixture_t *f = F(state);
    fx_defaults(f);
    f->in_sizes[3] = 13u;
    f->in_sizes[4] = 14u;
    assert_int_equal(fx_start(f), URB_NODE_OK);
    for (uint8_t m = 3u; m <= 4u; m++) {
        uint8_t const size = f->in_sizes[m];
        uint8_t data[14];
        uint8_t got[14];
        for (uint8_t i = 0u; i < size; i++) {
            data[i] = (uint8_t)(0x50u + i + m);
        }
        uint8_t frame[40];
        size_t const n = fx_frame(frame, m, data, size, 0u);
        assert_int_equal(n, 1u + size + ((size == 13u) ? 1u : 2u));
        assert_int_equal(fx_write_raw(N(state), frame, n, true), FX_ALL_ACKED);
        assert_int_equal(take_inbox(N(state), m, got), URB_NODE_NEW);
        assert_memory_equal(got, data, size);
    }
}

/* A write cut short by STOP after a wrong first check byte (CRC-16: the verdict waits for the
 * second) leaves no write open in the inbox: the interrupt gave its buffer up. */
static void write_cut_after_a_wrong_check_byte_is_aborted(void **state)
{
    uint8_t data[20] = {0};
    uint8_t frame[40];
    size_t const n = fx_frame(frame, 2u, data, 20u, 0u);
    frame[n - 2u] ^= 0x5Au; /* the first check byte */
    assert_int_equal(fx_write_raw(N(state), frame, n - 1u, true), FX_ALL_ACKED);
    urb_node_buffers_t bufs;
    assert_true(urb_node_inbox_buffers(N(state), 2u, &bufs));
    assert_int_equal(bufs.isr, URB_NODE_NO_BUFFER);
}

/* Events a node must not act on while a write is in progress: TX_BYTE outside a read (answered
 * 0xFF, SDA released) and every value beyond URB_I2C_STUCK (not a slave event: NACK), sent after
 * each byte of a CRC-16 write; the write keeps its phase and count and commits intact. */
static void foreign_events_leave_a_write_intact(void **state)
{
    urb_node_t *node = N(state);
    uint8_t data[20];
    for (uint8_t i = 0u; i < 20u; i++) {
        data[i] = (uint8_t)(0x31u * i + 7u);
    }
    uint8_t frame[40];
    size_t const n = fx_frame(frame, 2u, data, 20u, 0u);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_ADDR_WRITE, 0u), URB_I2C_ACK);
    for (size_t k = 0u; k <= n; k++) {
        urb_node_downlink_t before;
        urb_node_downlink_t after;
        urb_node_downlink(node, &before);
        assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xFFu);
        for (unsigned ev = (unsigned)URB_I2C_STUCK + 1u; ev <= (unsigned)URB_I2C_EV_ERROR; ev++) {
            assert_int_equal(urb_node_i2c_event(node, (urb_i2c_event_t)ev, 0x5Au), URB_I2C_NACK);
        }
        urb_node_downlink(node, &after);
        assert_int_equal(after.phase, before.phase);
        assert_int_equal(after.mailbox, before.mailbox);
        assert_int_equal(after.count, before.count);
        if (k < n) {
            assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, frame[k]), URB_I2C_ACK);
        }
    }
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    uint8_t got[20];
    assert_int_equal(take_inbox(node, 2u, got), URB_NODE_NEW);
    assert_memory_equal(got, data, 20u);
    /* after the write, outside any transaction: still 0xFF */
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xFFu);
    /* a write cut after its first check byte leaves the byte count inside the check: 0xFF too */
    assert_int_equal(fx_write_raw(node, frame, n - 1u, true), FX_ALL_ACKED);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xFFu);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xFFu);
}

/* A write that fails (a wrong check on a CRC-8 or CRC-16 inbox) or that a bus error or a stuck bus
 * ends after its good check leaves no write open: the interrupt gave its buffer up
 * (MailboxInbox.tla IsrWriteAbort), as the trace observers' view shows. */
static void failed_writes_leave_no_write_open(void **state)
{
    urb_node_t *node = N(state);
    uint8_t data[20] = {0x11u, 0x22u};
    uint8_t frame[40];
    urb_node_buffers_t bufs;
    for (uint8_t m = 1u; m <= 2u; m++) {
        uint8_t const size = urb_node_inbox_size(node, m);
        size_t const n = fx_frame(frame, m, data, size, 0x04u);
        assert_int_equal(fx_write_raw(node, frame, n, false), (int)n - 1); /* the last check byte NACKed */
        assert_true(urb_node_inbox_buffers(node, m, &bufs));
        assert_int_equal(bufs.isr, URB_NODE_NO_BUFFER);
        (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
        static const urb_i2c_event_t ends[] = {URB_I2C_BUS_ERROR, URB_I2C_STUCK};
        for (size_t e = 0u; e < 2u; e++) {
            (void)fx_frame(frame, m, data, size, 0u);
            assert_int_equal(fx_write_raw(node, frame, n, false), FX_ALL_ACKED);
            urb_node_downlink_t dl;
            urb_node_downlink(node, &dl);
            assert_int_equal(dl.phase, URB_NODE_DL_WRITE_DONE);
            (void)urb_node_i2c_event(node, ends[e], 0u);
            assert_true(urb_node_inbox_buffers(node, m, &bufs));
            assert_int_equal(bufs.isr, URB_NODE_NO_BUFFER);
            (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
        }
        uint8_t got[20];
        assert_int_equal(take_inbox(node, m, got), URB_NODE_OK); /* nothing committed */
    }
}

/* Identification.fault clears only after a COMPLETE identification read (25 data + 2 check bytes)
 * that began after the fault was published: a read one check byte short keeps it. */
static void identification_read_one_byte_short_keeps_the_fault(void **state)
{
    urb_node_t *node = N(state);
    uint8_t raw[27];
    (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_IDENT) != 0u); /* fault published */
    for (size_t len = 3u; len <= 26u; len += 23u) {
        fx_read(node, raw, len);
        assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_IDENT, 0u); /* still set */
    }
    fx_read(node, raw, 27u);
    urb_identification_t id;
    assert_int_equal(urb_identification_decode(&id, raw, 25u), 25);
    assert_true(id.fault);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_IDENT) != 0u); /* cleared and republished */
    fx_read(node, raw, 27u);
    assert_int_equal(urb_identification_decode(&id, raw, 25u), 25);
    assert_false(id.fault);
}

/* The master's NACK of a read byte ends the read at once, before its STOP: the outbox is no longer
 * latched (the application publishes twice), further clocks read 0xFF, and a complete
 * identification read counts at the NACK. */
static void master_nack_ends_the_read_at_once(void **state)
{
    urb_node_t *node = N(state);
    fixture_t *fx = F(state);
    publish(node, 1u, 0xA1u);
    assert_true(fx_select(node, 1u));
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u), URB_I2C_ACK);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xA1u);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xA1u);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u), URB_I2C_ACK);
    urb_node_downlink_t dl;
    urb_node_downlink(node, &dl);
    assert_int_equal(dl.phase, URB_NODE_DL_IDLE);
    assert_int_equal(urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u), 0xFFu);
    publish(node, 1u, 0xB2u);
    publish(node, 1u, 0xC3u); /* BUSY here if the read still held buffer "A1" */
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    /* outbox 0: a fault, then a complete identification read ended by the NACK alone */
    (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_IDENT) != 0u);
    assert_true(fx_select(node, 0u));
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
    for (unsigned i = 0u; i < 27u; i++) {
        (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    }
    (void)urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_IDENT) != 0u); /* the fault flag cleared */
    assert_int_equal(fx->faults[URB_NODE_FAULT_STUCK_BUS], 1u);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(write_crc8_tier, setup),
        cmocka_unit_test_setup(write_crc16_tier, setup),
        cmocka_unit_test_setup(select_refused, setup),
        cmocka_unit_test_setup(short_writes_abort, setup),
        cmocka_unit_test_setup(long_write_nacked, setup),
        cmocka_unit_test_setup(bad_check_nacked, setup),
        cmocka_unit_test_setup(write_refused_when_both_buffers_busy, setup),
        cmocka_unit_test_setup(read_outbox_with_check, setup),
        cmocka_unit_test_setup(read_check_covers_select, setup),
        cmocka_unit_test_setup(default_selection_is_outbox0, setup),
        cmocka_unit_test_setup(read_during_release, setup),
        cmocka_unit_test_setup(byte_received_during_read_ends_it, setup),
        cmocka_unit_test_setup(repeated_start_commits, setup),
        cmocka_unit_test_setup(bus_error_and_stuck_abort, setup),
        cmocka_unit_test_setup(idle_bus_events, setup),
        cmocka_unit_test_setup(not_started_ignores_bus, setup),
        cmocka_unit_test_setup(reset_in_the_middle, setup),
        cmocka_unit_test_setup(sync_framing, setup),
        cmocka_unit_test_setup(identification_fault_flag, setup),
        cmocka_unit_test_setup(observation_views, setup),
        cmocka_unit_test_setup(write_at_the_crc8_tier_boundary, setup),
        cmocka_unit_test_setup(write_cut_after_a_wrong_check_byte_is_aborted, setup),
        cmocka_unit_test_setup(foreign_events_leave_a_write_intact, setup),
        cmocka_unit_test_setup(failed_writes_leave_no_write_open, setup),
        cmocka_unit_test_setup(identification_read_one_byte_short_keeps_the_fault, setup),
        cmocka_unit_test_setup(master_nack_ends_the_read_at_once, setup),
    };
    return cmocka_run_group_tests_name("node_i2c", tests, NULL, NULL);
}
