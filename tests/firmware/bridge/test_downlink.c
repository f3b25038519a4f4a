/*
 * I2C downlink through the bridge: NACK at every position, check failures, the selection cache
 * and node resets, timeouts, stuck bus and bus clear, long (CRC-16) mailboxes.
 */
#include <stdlib.h>
#include <string.h>

#include "support.h"
#include "urb_node.h" /* with the bridge headers: urb_i2c_event_t is defined once (urb_i2c_event.h) */

#define NODE 0x20u

static int setup(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    *state = r;
    return 0;
}

static int teardown(void **state)
{
    rig_free(*state);
    return 0;
}

static urb_fake_node_t *node(urb_hosted_rig_t *r)
{
    return &r->bus.nodes[0];
}

static void request(urb_hosted_rig_t *r, bool read, uint8_t mailbox, uint8_t seq, uint8_t len)
{
    uint8_t f[40];
    uint8_t payload[32];
    for (uint8_t i = 0u; i < 32u; i++) {
        payload[i] = (uint8_t)(0xA0u + i);
    }
    size_t n = read ? enc_read(f, NODE, mailbox, seq, len) : enc_write(f, NODE, mailbox, seq, len, payload);
    send_frame(r, f, n);
    assert_true(urb_hosted_rig_settle(r, 50000u));
}

/* Write to a present node of known layout NACKed once at each position (a corrupted byte or
 * acknowledge): address (the probe finds the node: TIMEOUT), select and data bytes (admission
 * checked them: CHECKSUM), first data byte (NODE_BUSY), check. Bridge.tla: Serve allows nothing
 * else for a present node; nothing was stored. */
/* lobster-trace: urb.ERR_002 */
static void write_nack_positions(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t const expected[] = {URB_STATUS_TIMEOUT,  URB_STATUS_CHECKSUM, URB_STATUS_NODE_BUSY, URB_STATUS_CHECKSUM,
                                URB_STATUS_CHECKSUM, URB_STATUS_CHECKSUM, URB_STATUS_CHECKSUM};
    /* inbox 1 holds 4 bytes: positions 0 address, 1 select, 2..5 data, 6 check */
    for (uint8_t pos = 0u; pos < 7u; pos++) {
        node(r)->nack_at = pos;
        node(r)->nack_once = true;
        request(r, false, 1u, pos, 4u);
    }
    request(r, false, 1u, 7u, 4u); /* and without a NACK */
    stream_t s = rs232_stream(r);
    for (uint8_t pos = 0u; pos < 7u; pos++) {
        expect_response(&s, pos, expected[pos], 0u, NULL);
    }
    expect_response(&s, 7u, URB_STATUS_OK, 0u, NULL);
    expect_end(&s);
    assert_int_equal(node(r)->writes[1], 1u); /* only the last write was stored */
    assert_true(urb_bridge_present(&r->bridge, NODE));
}

/* A node whose both inbox buffers are taken refuses the first data byte: NODE_BUSY. */
/* lobster-trace: urb.MBX_009 */
static void inbox_busy_is_node_busy(void **state)
{
    urb_hosted_rig_t *r = *state;
    node(r)->inbox_busy = true;
    request(r, false, 1u, 1u, 4u);
    node(r)->inbox_busy = false;
    request(r, false, 1u, 2u, 4u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_NODE_BUSY, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_OK, 0u, NULL);
    expect_end(&s);
}

/* Read of a present node NACKed once at the address (probe: TIMEOUT), at the select (CHECKSUM);
 * a corrupted read fails its check. */
/* lobster-trace: urb.ERR_001 */
static void read_failures(void **state)
{
    urb_hosted_rig_t *r = *state;
    node(r)->nack_at = 0;
    node(r)->nack_once = true;
    request(r, true, 1u, 1u, 4u);
    node(r)->nack_at = 1;
    node(r)->nack_once = true;
    request(r, true, 1u, 2u, 4u);
    node(r)->corrupt_read = true;
    request(r, true, 1u, 3u, 4u);
    node(r)->corrupt_read = false;
    request(r, true, 1u, 4u, 4u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_TIMEOUT, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_CHECKSUM, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_CHECKSUM, 0u, NULL);
    expect_response(&s, 4u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* A present node that stops acknowledging: the probe after the NACKed address finds it gone, the
 * request gets NO_NODE at once (Discovery.tla: HostRequest) and the node counts as absent, so the
 * next request gets NO_NODE without a probe. Back on the bus, its first answer makes it present
 * again, and a corrupted address is a TIMEOUT once more. */
static void vanished_node_is_probed(void **state)
{
    urb_hosted_rig_t *r = *state;
    node(r)->present = false;
    uint32_t const s0 = r->bus.starts;
    request(r, true, 1u, 1u, 4u);
    assert_int_equal(r->bus.starts, s0 + 2u); /* the select's address NACKed, then the probe */
    assert_false(urb_bridge_present(&r->bridge, NODE));
    request(r, false, 1u, 2u, 4u);
    assert_int_equal(r->bus.starts, s0 + 3u); /* absent: no probe */
    node(r)->present = true;
    request(r, true, 1u, 3u, 4u);
    assert_true(urb_bridge_present(&r->bridge, NODE));
    node(r)->nack_at = 0;
    node(r)->nack_once = true;
    request(r, false, 1u, 4u, 4u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_NO_NODE, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_NO_NODE, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_OK, 4u, NULL);
    expect_response(&s, 4u, URB_STATUS_TIMEOUT, 0u, NULL);
    expect_end(&s);
    assert_int_equal(node(r)->writes[1], 0u);
}

/* A node the scan did not find (hot-plugged) is identified before its first request goes to the
 * bus: one read of its outbox 0, and its sizes are learnt. A length that differs from its mailbox
 * then gets SIZE_MISMATCH without bus traffic, as for a scanned node: an unused outbox, and a write
 * shorter than its inbox, which the node acknowledges to the end and drops at the STOP (answered
 * OK before: Bridge.tla WriteStatusTruthful). Its silence is NO_NODE. */
/* lobster-trace: urb.ERR_003 */
static void unknown_node_identified_first(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[40];
    uint8_t const payload[4] = {1u, 2u, 3u, 4u};
    urb_fake_node_t *late = add_node(r, 0x21u, 0x43u, 0u, 4u, 4u); /* after the scan */
    send_frame(r, f, enc_write(f, 0x21u, 1u, 1u, 2u, payload)); /* inbox 1 holds 4 bytes */
    send_frame(r, f, enc_read(f, 0x21u, 3u, 2u, 2u));           /* outbox 3 unused */
    send_frame(r, f, enc_write(f, 0x21u, 1u, 3u, 4u, payload));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    assert_int_equal(late->reads, 1u); /* its identification, once: then only the 4-byte write */
    assert_int_equal(late->selects, 1u);
    assert_int_equal(late->writes[1], 1u);
    assert_int_equal(late->aborted_writes, 0u);
    late->present = false;
    send_frame(r, f, enc_read(f, 0x21u, 1u, 4u, 4u));
    send_frame(r, f, enc_read(f, 0x22u, 1u, 5u, 4u)); /* nobody there: the identification is not acknowledged */
    assert_true(urb_hosted_rig_settle(r, 50000u));
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_OK, 0u, NULL);
    expect_response(&s, 4u, URB_STATUS_NO_NODE, 0u, NULL);
    expect_response(&s, 5u, URB_STATUS_NO_NODE, 0u, NULL);
    expect_end(&s);
}

/* The select byte goes out only when the cached selection differs. */
static void selection_cache(void **state)
{
    urb_hosted_rig_t *r = *state;
    node(r)->out_size[2] = 3u;
    urb_fake_node_identify(node(r));
    request(r, true, 0u, 0u, 25u); /* the host re-reads the identification: sizes learnt again */
    uint32_t const s0 = node(r)->selects;
    request(r, true, 1u, 1u, 4u);
    request(r, true, 1u, 2u, 4u);
    request(r, true, 1u, 3u, 4u);
    assert_int_equal(node(r)->selects, s0 + 1u);
    request(r, false, 1u, 4u, 4u); /* a write keeps the read selection */
    request(r, true, 1u, 5u, 4u);
    assert_int_equal(node(r)->selects, s0 + 1u);
    request(r, true, 2u, 6u, 3u);
    request(r, true, 1u, 7u, 4u);
    assert_int_equal(node(r)->selects, s0 + 3u);
    assert_int_equal(urb_i2c_master_selection(&r->master, NODE), 1u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 0u, URB_STATUS_OK, 25u, NULL);
    for (uint8_t i = 1u; i <= 3u; i++) {
        expect_response(&s, i, URB_STATUS_OK, 4u, NULL);
    }
    expect_response(&s, 4u, URB_STATUS_OK, 0u, NULL);
    expect_response(&s, 5u, URB_STATUS_OK, 4u, NULL);
    expect_response(&s, 6u, URB_STATUS_OK, 3u, NULL);
    expect_response(&s, 7u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* A node that resets between two reads answers from outbox 0 under the cached selection: the
 * check (covering the implicit select byte) fails, the bridge forgets the selection, and the next
 * read selects again and succeeds. */
/* lobster-trace: urb.CRC_003 */
static void node_reset_between_reads(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t data[32];
    request(r, true, 1u, 1u, 4u);
    urb_fake_node_reset(node(r));
    request(r, true, 1u, 2u, 4u);
    assert_int_equal(urb_i2c_master_selection(&r->master, NODE), URB_I2C_NO_SELECTION);
    request(r, true, 1u, 3u, 4u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_OK, 4u, NULL);
    expect_response(&s, 2u, URB_STATUS_CHECKSUM, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_OK, 4u, data);
    expect_end(&s);
    assert_int_equal(data[0], NODE);
}

/* A node that resets in the middle of a read transaction (after the select, before the data). */
static void node_reset_mid_transaction(void **state)
{
    urb_hosted_rig_t *r = *state;
    node(r)->reset_after_select = true;
    request(r, true, 1u, 1u, 4u);
    request(r, true, 1u, 2u, 4u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_CHECKSUM, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* A node that stretches the clock past the timeout: TIMEOUT, and the bridge goes on. */
/* lobster-trace: urb.FLT_002 */
static void timeout_then_recovery(void **state)
{
    urb_hosted_rig_t *r = *state;
    node(r)->stretch_us = 5000u;
    request(r, true, 1u, 1u, 4u);
    node(r)->stretch_us = 0u;
    node(r)->mute = true; /* events lost, lines free */
    request(r, false, 1u, 2u, 4u);
    node(r)->mute = false;
    request(r, true, 1u, 3u, 4u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_TIMEOUT, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_TIMEOUT, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
    assert_int_equal(urb_i2c_master_timeouts(&r->master), 2u);
    assert_int_equal(urb_i2c_master_bus_clears(&r->master), 0u);
}

/* SDA held low before a request: nine clock pulses and a STOP, BUS_STUCK (not executed), then the
 * freed bus works. */
/* lobster-trace: urb.FLT_001 */
static void stuck_sda_cleared(void **state)
{
    urb_hosted_rig_t *r = *state;
    node(r)->hold_sda = 3u; /* lets go after 3 clocks */
    uint32_t const starts = r->bus.starts;
    request(r, false, 1u, 1u, 4u);
    assert_int_equal(r->bus.scl_pulses, 9u);
    assert_int_equal(r->bus.bitbang_stops, 1u);
    assert_int_equal(r->bus.starts, starts); /* the request never started */
    assert_int_equal(node(r)->writes[1], 0u);
    request(r, false, 1u, 2u, 4u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_BUS_STUCK, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_OK, 0u, NULL);
    expect_end(&s);
    assert_int_equal(urb_i2c_master_bus_clears(&r->master), 1u);
}

/* A bus that stays stuck: every request is answered BUS_STUCK (never wedged, never dropped). */
/* lobster-trace: urb.FLT_001 */
static void permanently_stuck(void **state)
{
    urb_hosted_rig_t *r = *state;
    node(r)->hold_scl = true;
    for (uint8_t i = 0u; i < 3u; i++) {
        request(r, true, 1u, i, 4u);
    }
    node(r)->hold_scl = false;
    node(r)->hold_sda = URB_FAKE_HOLD_FOREVER;
    request(r, true, 1u, 3u, 4u);
    node(r)->hold_sda = 0u;
    request(r, true, 1u, 4u, 4u);
    stream_t s = rs232_stream(r);
    for (uint8_t i = 0u; i < 4u; i++) {
        expect_response(&s, i, URB_STATUS_BUS_STUCK, 0u, NULL);
    }
    expect_response(&s, 4u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* The bus gets stuck in the middle of a transaction: the timeout finds a line low, clears the bus,
 * BUS_STUCK; the selection cache is forgotten (the node may be anywhere in its frame). */
/* lobster-trace: urb.FLT_001 */
static void stuck_during_transaction(void **state)
{
    urb_hosted_rig_t *r = *state;
    request(r, true, 1u, 1u, 4u);
    assert_int_equal(urb_i2c_master_selection(&r->master, NODE), 1u);
    uint8_t f[8];
    enc_read(f, NODE, 1u, 2u, 4u);
    urb_hosted_rig_uart_send(r, f, 4u, BYTE_US);
    urb_hosted_rig_run(r, 30u); /* the read has started */
    assert_true(r->bus.starts > 0u);
    node(r)->mute = true;
    r->bus.lost = true;
    node(r)->hold_sda = 5u;
    assert_true(urb_hosted_rig_settle(r, 50000u));
    node(r)->mute = false;
    request(r, true, 1u, 3u, 4u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_OK, 4u, NULL);
    expect_response(&s, 2u, URB_STATUS_BUS_STUCK, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
    assert_int_equal(r->bus.scl_pulses, 9u);
}

/* BridgeCommand BUS_CLEAR: nine pulses and a STOP on request; OK when the bus is free after. */
static void bus_clear_command(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t const cmd[3] = {URB_BRIDGE_OPCODE_BUS_CLEAR, 0u, 0u};
    uint8_t f[16];
    send_frame(r, f, enc_write(f, 0u, 0u, 1u, 3u, cmd));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    node(r)->hold_scl = true;
    send_frame(r, f, enc_write(f, 0u, 0u, 2u, 3u, cmd));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_OK, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_BUS_STUCK, 0u, NULL);
    expect_end(&s);
    assert_int_equal(r->bus.scl_pulses, 9u); /* the second clear could not clock SCL */
    assert_int_equal(urb_i2c_master_bus_clears(&r->master), 2u);
}

/* 32-byte mailboxes use the CRC-16 check in both directions; 13 bytes is the last CRC-8 size. */
static void long_mailboxes(void **state)
{
    urb_hosted_rig_t *r = *state;
    urb_fake_node_t *n = node(r);
    n->in_size[2] = 32u;
    n->out_size[2] = 32u;
    n->in_size[3] = 13u;
    n->out_size[3] = 13u;
    n->in_size[4] = 14u;
    n->out_size[4] = 14u;
    urb_fake_node_identify(n);
    request(r, true, 0u, 0u, 25u); /* relearn the sizes */
    uint8_t const sizes[3] = {32u, 13u, 14u};
    uint8_t data[32];
    for (uint8_t k = 0u; k < 3u; k++) {
        request(r, false, (uint8_t)(2u + k), (uint8_t)(1u + 2u * k), sizes[k]);
        request(r, true, (uint8_t)(2u + k), (uint8_t)(2u + 2u * k), sizes[k]);
        n->nack_at = (int16_t)(2 + sizes[k] + (sizes[k] >= 14u ? 1 : 0)); /* the last check byte */
        n->nack_once = true;
        request(r, false, (uint8_t)(2u + k), 9u, sizes[k]);
    }
    stream_t s = rs232_stream(r);
    expect_response(&s, 0u, URB_STATUS_OK, 25u, NULL);
    for (uint8_t k = 0u; k < 3u; k++) {
        expect_response(&s, (uint8_t)(1u + 2u * k), URB_STATUS_OK, 0u, NULL);
        expect_response(&s, (uint8_t)(2u + 2u * k), URB_STATUS_OK, sizes[k], data);
        for (uint8_t i = 0u; i < sizes[k]; i++) {
            assert_int_equal(data[i], 0xA0u + i);
        }
        expect_response(&s, 9u, URB_STATUS_CHECKSUM, 0u, NULL);
    }
    expect_end(&s);
}

/* The timeout follows the bit rate (review F4): at 100 kb/s a byte with its ACK takes 90 us, so the
 * 30-byte identification read of the start-up scan and a 32-byte write (36 bytes) take about 3 ms,
 * more than the 2 ms of 400 kb/s. Set up as hosted_main.c does for --i2c-khz 100: the node is
 * found, a 32-byte write is committed, a 32-byte read comes back, nothing times out. */
/* lobster-trace: urb.FLT_002 */
static void standard_mode_timeout_follows_bitrate(void **state)
{
    (void)state;
    assert_int_equal(urb_i2c_master_timeout_us(400u), 2000u); /* unchanged at 400 kb/s */
    assert_int_equal(urb_i2c_master_timeout_us(5000u), URB_I2C_MIN_TIMEOUT_US);
    assert_int_equal(urb_i2c_master_timeout_us(336u), 2000u);
    assert_int_equal(urb_i2c_master_timeout_us(335u), 2006u);
    assert_int_equal(urb_i2c_master_timeout_us(100u), 6720u);
    assert_int_equal(urb_i2c_master_timeout_us(10u), 67200u);
    assert_int_equal(urb_i2c_master_timeout_us(0u), URB_I2C_MIN_TIMEOUT_US);
    assert_int_equal(urb_i2c_master_timeout_us(0xFFFFFFFFu), URB_I2C_MIN_TIMEOUT_US);
    urb_i2c_master_config_t dcfg;
    urb_i2c_master_default_config(&dcfg);
    assert_int_equal(dcfg.timeout_us, urb_i2c_master_timeout_us(dcfg.bitrate_kbps));

    uint32_t const rates[2] = {100u, 10u};
    for (unsigned k = 0u; k < 2u; k++) {
        uint32_t const khz = rates[k];
        urb_hosted_rig_t *r = calloc(1u, sizeof *r);
        assert_non_null(r);
        urb_bridge_config_t cfg;
        urb_bridge_default_config(&cfg);
        cfg.heartbeat_us = 0u;
        urb_i2c_master_config_t mcfg;
        urb_i2c_master_default_config(&mcfg);
        mcfg.bitrate_kbps = (uint16_t)khz;
        mcfg.timeout_us = urb_i2c_master_timeout_us(khz);
        assert_int_equal(urb_hosted_rig_init(r, &cfg, &mcfg), URB_OK);
        r->bus.byte_us = (9000u + khz - 1u) / khz; /* as hosted_main.c */
        r->bus.start_us = (1000u + khz - 1u) / khz;
        urb_fake_node_t *n = add_node(r, NODE, 0x42u, 0u, 32u, 32u);
        rig_start(r);
        assert_true(urb_hosted_rig_settle(r, 1000000u));
        assert_true(urb_bridge_present(&r->bridge, NODE));
        uint8_t data[32];
        for (uint8_t i = 0u; i < 32u; i++) {
            data[i] = (uint8_t)(0x40u + i);
        }
        uint8_t f[40];
        send_frame(r, f, enc_write(f, NODE, 1u, 1u, 32u, data));
        assert_true(urb_hosted_rig_settle(r, 1000000u));
        send_frame(r, f, enc_read(f, NODE, 1u, 2u, 32u));
        assert_true(urb_hosted_rig_settle(r, 1000000u));
        send_frame(r, f, enc_read(f, NODE, 1u, 3u, 8u)); /* wrong length: refused at admission (sizes known) */
        assert_true(urb_hosted_rig_settle(r, 1000000u));
        stream_t s = rs232_stream(r);
        expect_response(&s, 1u, URB_STATUS_OK, 0u, NULL);
        expect_response(&s, 2u, URB_STATUS_OK, 32u, NULL);
        expect_response(&s, 3u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
        expect_end(&s);
        assert_int_equal(n->writes[1], 1u);
        assert_int_equal(urb_i2c_master_timeouts(&r->master), 0u);
        free(r);
    }
}

/* A master HAL that accepts every operation and reports nothing: the test delivers the events. */
static void hal_op(void *ctx) { (void)ctx; }
static void hal_byte(void *ctx, uint8_t byte) { (void)ctx; (void)byte; }
static void hal_read(void *ctx, bool ack) { (void)ctx; (void)ack; }
static uint8_t hal_lines(void *ctx) { (void)ctx; return (uint8_t)(URB_I2C_SCL | URB_I2C_SDA); }

/* Slave and master events share one type with disjoint values: a slave event reaching the master
 * (a miswired port) is refused like a bus error, not taken for a completion. */
static void slave_event_refused_by_master(void **state)
{
    (void)state;
    urb_i2c_hal_t const hal = {NULL, hal_op, hal_byte, hal_read, hal_op, hal_op, hal_lines, hal_byte, hal_op};
    urb_i2c_master_config_t cfg;
    urb_i2c_master_default_config(&cfg);
    urb_i2c_master_t m;
    urb_i2c_master_init(&m, &hal, &cfg);
    urb_downlink_t dl;
    urb_i2c_master_downlink(&m, &dl);
    uint8_t buf[4];
    urb_downlink_txn_t const t = {URB_DL_READ, NODE, 1u, 4u, 0u, false, buf};
    assert_true(dl.begin(dl.ctx, &t, 0u));
    urb_i2c_master_event(&m, URB_I2C_ADDR_WRITE, 0u); /* not URB_I2C_EV_START */
    assert_int_equal(dl.poll(dl.ctx, 1u), URB_STATUS_TIMEOUT);
    assert_int_equal(dl.poll(dl.ctx, 2u), URB_DOWNLINK_IDLE);
    /* the same transaction with the master's own events completes */
    uint32_t deadline = 0u;
    assert_false(urb_i2c_master_busy(&m));
    assert_false(urb_i2c_master_deadline(&m, &deadline));
    assert_true(dl.begin(dl.ctx, &t, 3u));
    assert_true(urb_i2c_master_busy(&m));
    assert_true(urb_i2c_master_deadline(&m, &deadline));
    assert_int_equal(deadline, 3u + cfg.timeout_us + 1u);
    urb_i2c_master_event(&m, URB_I2C_EV_START, 0u);
    assert_int_equal(dl.poll(dl.ctx, 4u), URB_DOWNLINK_BUSY);
    assert_int_equal(dl.poll(dl.ctx, deadline - 1u), URB_DOWNLINK_BUSY); /* the deadline is the first late poll */
    assert_int_equal(urb_i2c_master_timeouts(&m), 0u);
    assert_int_equal(dl.poll(dl.ctx, deadline), URB_STATUS_TIMEOUT);
    assert_int_equal(urb_i2c_master_timeouts(&m), 1u);
    assert_int_equal(urb_i2c_master_bus_clears(&m), 0u);
    assert_false(urb_i2c_master_busy(&m));
}

int run_downlink_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(write_nack_positions, setup, teardown),
        cmocka_unit_test_setup_teardown(inbox_busy_is_node_busy, setup, teardown),
        cmocka_unit_test_setup_teardown(read_failures, setup, teardown),
        cmocka_unit_test_setup_teardown(vanished_node_is_probed, setup, teardown),
        cmocka_unit_test_setup_teardown(unknown_node_identified_first, setup, teardown),
        cmocka_unit_test_setup_teardown(selection_cache, setup, teardown),
        cmocka_unit_test_setup_teardown(node_reset_between_reads, setup, teardown),
        cmocka_unit_test_setup_teardown(node_reset_mid_transaction, setup, teardown),
        cmocka_unit_test_setup_teardown(timeout_then_recovery, setup, teardown),
        cmocka_unit_test_setup_teardown(stuck_sda_cleared, setup, teardown),
        cmocka_unit_test_setup_teardown(permanently_stuck, setup, teardown),
        cmocka_unit_test_setup_teardown(stuck_during_transaction, setup, teardown),
        cmocka_unit_test_setup_teardown(bus_clear_command, setup, teardown),
        cmocka_unit_test_setup_teardown(long_mailboxes, setup, teardown),
        cmocka_unit_test(standard_mode_timeout_follows_bitrate),
        cmocka_unit_test(slave_event_refused_by_master),
    };
    return cmocka_run_group_tests_name("bridge_downlink", tests, NULL, NULL);
}
