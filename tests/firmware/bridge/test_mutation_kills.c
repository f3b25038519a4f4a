/*
 * Mutation score (tests/mutation/README.md): seeded bugs of tools/c_mutate.py that the other groups
 * let through. The USB IN copy against a buffer one byte short, the master's NACK statuses and read
 * acknowledges seen at the master itself (the bridge turns a known node's SIZE_MISMATCH into
 * CHECKSUM, so the groups above cannot tell them apart), and a bridge initialised over memory a
 * previous run left in any state.
 */
#include <stdlib.h>
#include <string.h>

#include "support.h"
#include "urb_node.h"

#define NODE 0x20u

/* The IN copy never writes past the caller's buffer: every capacity below the batch's length gets
 * 0 and leaves the batch for a later read; the exact capacity gets all of it. Each buffer is a heap
 * block of exactly that size, so a byte too many is an AddressSanitizer error. */
static void usb_in_never_writes_past_its_buffer(void **state)
{
    (void)state;
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    r->bus.byte_us = 2u;
    rig_start(r);
    uint8_t req[8];
    const uint8_t *frames[1] = {req};
    size_t lens[1] = {enc_read(req, NODE, 1u, 3u, 4u)};
    uint8_t batch[64];
    size_t const n = usb_batch(batch, 1u, frames, lens, 1u);
    urb_bridge_usb_sof(&r->bridge);
    assert_true(urb_bridge_usb_out(&r->bridge, batch, n));
    urb_hosted_rig_run(r, 1000u);
    urb_bridge_usb_sof(&r->bridge);
    size_t got = 0u;
    size_t cap = 0u;
    for (; (cap <= 512u) && (got == 0u); cap++) {
        uint8_t *buf = malloc((cap == 0u) ? 1u : cap);
        assert_non_null(buf);
        got = urb_bridge_usb_in(&r->bridge, buf, cap);
        free(buf);
    }
    assert_int_equal(got, cap - 1u); /* the first capacity that gets the batch is its exact length */
    assert_true(got > 4u);           /* the header and the response */
    rig_free(r);
}

/* A master HAL that records what the master asked for; the test delivers the events. */
static bool acks[8];
static unsigned reads;
static void hal_op(void *ctx) { (void)ctx; }
static void hal_byte(void *ctx, uint8_t byte) { (void)ctx; (void)byte; }
static void hal_read(void *ctx, bool ack)
{
    (void)ctx;
    if (reads < 8u) {
        acks[reads] = ack;
    }
    reads++;
}
static uint8_t hal_lines(void *ctx) { (void)ctx; return (uint8_t)(URB_I2C_SCL | URB_I2C_SDA); }
static urb_i2c_hal_t const HAL = {NULL, hal_op, hal_byte, hal_read, hal_op, hal_op, hal_lines, hal_byte, hal_op};

static void master_begin(urb_i2c_master_t *m, urb_downlink_t *dl, const urb_downlink_txn_t *t)
{
    urb_i2c_master_config_t cfg;
    urb_i2c_master_default_config(&cfg);
    urb_i2c_master_init(m, &HAL, &cfg);
    urb_i2c_master_downlink(m, dl);
    assert_true(dl->begin(dl->ctx, t, 0u));
    urb_i2c_master_event(m, URB_I2C_EV_START, 0u);
}

/* A WRITE of 4 bytes to inbox 1 NACKed at each byte, at the master: address (NO_NODE), select
 * (BAD_REQUEST: no such mailbox), first data byte (NODE_BUSY: both buffers taken), later data bytes
 * (SIZE_MISMATCH: more data than the inbox holds), check (CHECKSUM); urb_downlink.h's contract. */
static void master_nack_status_names_the_byte(void **state)
{
    (void)state;
    uint8_t const expected[] = {URB_STATUS_NO_NODE,       URB_STATUS_BAD_REQUEST,   URB_STATUS_NODE_BUSY,
                                URB_STATUS_SIZE_MISMATCH, URB_STATUS_SIZE_MISMATCH, URB_STATUS_SIZE_MISMATCH,
                                URB_STATUS_CHECKSUM};
    uint8_t data[4] = {1u, 2u, 3u, 4u};
    urb_downlink_txn_t const t = {URB_DL_WRITE, NODE, 1u, 4u, 0u, false, data};
    for (uint8_t pos = 0u; pos < sizeof expected; pos++) {
        urb_i2c_master_t m;
        urb_downlink_t dl;
        master_begin(&m, &dl, &t);
        for (uint8_t k = 0u; k < pos; k++) {
            urb_i2c_master_event(&m, URB_I2C_EV_ACK, 0u);
        }
        urb_i2c_master_event(&m, URB_I2C_EV_NACK, 0u);
        assert_int_equal(dl.poll(dl.ctx, 1u), (int8_t)expected[pos]);
    }
}

/* A READ acknowledges every byte but the last one (data and check alike), from the first. */
static void master_acks_all_but_the_last_read_byte(void **state)
{
    (void)state;
    for (uint8_t len = 1u; len <= 3u; len++) {
        uint8_t buf[4];
        urb_downlink_txn_t const t = {URB_DL_READ, NODE, 1u, len, 0u, false, buf};
        urb_i2c_master_t m;
        urb_downlink_t dl;
        reads = 0u;
        master_begin(&m, &dl, &t);
        urb_i2c_master_event(&m, URB_I2C_EV_ACK, 0u);   /* address */
        urb_i2c_master_event(&m, URB_I2C_EV_ACK, 0u);   /* select: then the repeated START */
        urb_i2c_master_event(&m, URB_I2C_EV_START, 0u);
        urb_i2c_master_event(&m, URB_I2C_EV_ACK, 0u);   /* address, read */
        unsigned const n = len + 1u;                    /* data and a CRC-8 check */
        for (unsigned k = 0u; k < n; k++) {
            urb_i2c_master_event(&m, URB_I2C_EV_BYTE, 0u);
        }
        assert_int_equal(reads, n);
        for (unsigned k = 0u; k < n; k++) {
            assert_true(acks[k] == (k + 1u < n));
        }
    }
}

/* A transaction that finished (STOP issued) ignores an event arriving late, as after an abort: its
 * result stands. */
static void master_ignores_a_late_event_after_finishing(void **state)
{
    (void)state;
    uint8_t data[4] = {1u, 2u, 3u, 4u};
    urb_downlink_txn_t const t = {URB_DL_WRITE, NODE, 1u, 4u, 0u, false, data};
    urb_i2c_master_t m;
    urb_downlink_t dl;
    master_begin(&m, &dl, &t);
    for (uint8_t k = 0u; k < 7u; k++) { /* address, select, 4 data, check */
        urb_i2c_master_event(&m, URB_I2C_EV_ACK, 0u);
    }
    urb_i2c_master_event(&m, URB_I2C_EV_ACK, 0u); /* late */
    assert_int_equal(dl.poll(dl.ctx, 1u), (int8_t)URB_STATUS_OK);
}

/* Responses that do not fit in the current USB batch wait for the next one and are counted once,
 * when they leave: stats.responses equals the responses the host received. */
static void responses_counted_once_when_a_batch_is_full(void **state)
{
    (void)state;
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    urb_fake_node_t *n = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    n->out_size[2] = 32u;
    urb_fake_node_identify(n);
    r->bus.byte_us = 2u;
    r->bus.start_us = 1u;
    rig_start(r);
    uint8_t reqs[16][8];
    const uint8_t *frames[16];
    size_t lens[16];
    for (uint8_t k = 0u; k < 16u; k++) {
        lens[k] = enc_read(reqs[k], NODE, 2u, k, 32u);
        frames[k] = reqs[k];
    }
    uint8_t batch[128];
    size_t const len = usb_batch(batch, 1u, frames, lens, 16u);
    urb_bridge_usb_sof(&r->bridge);
    assert_true(urb_bridge_usb_out(&r->bridge, batch, len));
    urb_hosted_rig_run(r, 5000u); /* all 16 served before the next start of frame: 16 x 37 bytes > 512 */
    assert_true(urb_bridge_outstanding(&r->bridge) > 0u);
    unsigned received = 0u;
    uint8_t in[512];
    for (unsigned frame = 0u; (frame < 20u) && (received < 16u); frame++) {
        urb_hosted_rig_run(r, 1000u);
        urb_bridge_usb_sof(&r->bridge);
        size_t const got = urb_bridge_usb_in(&r->bridge, in, sizeof in);
        urb_usb_batch_header_t h;
        assert_int_equal(urb_usb_batch_header_decode(&h, in, 4u), 4);
        assert_true(got >= 4u);
        received += h.count;
    }
    assert_int_equal(received, 16u);
    assert_int_equal(urb_bridge_stats(&r->bridge)->responses, 16u);
    rig_free(r);
}

/* A transmit kick that drains the ring at once, as urb_bridge_hal.h allows (the kick may call
 * urb_bridge_uart_tx_pop): every response byte is queued before the kick, so it all leaves. */
static urb_hosted_rig_t *kicked;
static uint8_t kick_out[256];
static size_t kick_len;

static void kick_drains_at_once(void *ctx)
{
    (void)ctx;
    uint8_t byte;
    while ((kick_len < sizeof kick_out) && urb_bridge_uart_tx_pop(&kicked->bridge, &byte)) {
        kick_out[kick_len++] = byte;
    }
}

static void response_queued_before_a_draining_kick(void **state)
{
    (void)state;
    kicked = rig_new(16u, 0u);
    add_node(kicked, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(kicked);
    kicked->hal.hal.uart_tx_kick = kick_drains_at_once;
    kick_len = 0u;
    uint8_t f[8];
    send_frame(kicked, f, enc_read(f, NODE, 1u, 9u, 4u));
    assert_true(urb_hosted_rig_settle(kicked, 50000u));
    stream_t s = {kick_out, kick_len, 0u};
    expect_response(&s, 9u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
    rig_free(kicked);
}

/* urb_bridge_init over memory in any state (a restart without zeroing): every field it needs is
 * set, so the first requests on RS232 and USB are answered like on zeroed memory. */
static void init_over_garbage_memory(void **state)
{
    (void)state;
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    urb_bridge_config_t cfg;
    urb_bridge_default_config(&cfg);
    cfg.heartbeat_us = 0u;
    memset(&r->bridge, 0xA5, sizeof r->bridge);
    assert_int_equal(urb_bridge_init(&r->bridge, &cfg, &r->hal.hal, &r->dl), URB_OK);
    rig_start(r);
    uint8_t f[8];
    send_frame(r, f, enc_read(f, NODE, 1u, 5u, 4u));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    stream_t s = rs232_stream(r);
    expect_response(&s, 5u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
    const uint8_t *frames[1] = {f};
    size_t lens[1] = {enc_read(f, NODE, 1u, 6u, 4u)};
    uint8_t batch[64];
    size_t const n = usb_batch(batch, 1u, frames, lens, 1u);
    urb_bridge_usb_sof(&r->bridge);
    uint8_t in[512];
    assert_int_equal(urb_bridge_usb_in(&r->bridge, in, sizeof in), 4u); /* the empty batch: a header */
    assert_true(urb_bridge_usb_out(&r->bridge, batch, n));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    urb_bridge_usb_sof(&r->bridge);
    size_t const got = urb_bridge_usb_in(&r->bridge, in, sizeof in);
    assert_true(got > 4u);
    stream_t u = {in + 4, got - 4u, 0u};
    expect_response(&u, 6u, URB_STATUS_OK, 4u, NULL);
    expect_end(&u);
    rig_free(r);
}

int run_mutation_kill_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(usb_in_never_writes_past_its_buffer),
        cmocka_unit_test(master_nack_status_names_the_byte),
        cmocka_unit_test(master_acks_all_but_the_last_read_byte),
        cmocka_unit_test(init_over_garbage_memory),
        cmocka_unit_test(master_ignores_a_late_event_after_finishing),
        cmocka_unit_test(responses_counted_once_when_a_batch_is_full),
        cmocka_unit_test(response_queued_before_a_draining_kick),
    };
    return cmocka_run_group_tests_name("bridge_mutation_kills", tests, NULL, NULL);
}
