/*
 * Request FIFO (Bridge.tla): arrival order, BUSY exactly when every data slot is taken, admission
 * errors answered in their place, one response per request, bounded memory.
 */
#include <string.h>

#include "support.h"

#define NODE 0x20u

static int teardown(void **state)
{
    rig_free(*state);
    return 0;
}

/* A USB batch delivers many requests at once: with 16 slots, 16 are served and the rest get BUSY,
 * and every response is in request order. */
/* lobster-trace: urb.ORD_001 */
static void overflow_busy_in_order(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    uint8_t frames[20][4];
    const uint8_t *ptrs[20];
    size_t lens[20];
    for (uint8_t i = 0u; i < 20u; i++) {
        lens[i] = enc_read(frames[i], NODE, 1u, (uint8_t)(i & 15u), 4u);
        ptrs[i] = frames[i];
    }
    uint8_t batch[512];
    size_t n = usb_batch(batch, 1u, ptrs, lens, 20u);
    assert_true(urb_bridge_usb_out(&r->bridge, batch, n));
    assert_true(urb_hosted_rig_settle(r, 20000u));
    urb_bridge_usb_sof(&r->bridge);
    uint8_t in[512];
    size_t got = urb_bridge_usb_in(&r->bridge, in, sizeof in);
    assert_true(got > 4u);
    stream_t s = {in + 4, got - 4u, 0u};
    for (uint8_t i = 0u; i < 20u; i++) {
        expect_response(&s, (uint8_t)(i & 15u), (i < 16u) ? URB_STATUS_OK : URB_STATUS_BUSY, 4u, NULL);
    }
    expect_end(&s);
    assert_int_equal(urb_bridge_stats(&r->bridge)->busy, 4u);
}

/* BUSY, BAD_REQUEST and SIZE_MISMATCH are decided at admission but never overtake an earlier
 * request still on the downlink (Bridge.tla ResponsesInRequestOrder, Bridge_BusyOvertakes). */
/* lobster-trace: urb.ORD_003 */
static void admission_errors_keep_their_place(void **state)
{
    urb_hosted_rig_t *r = rig_new(2u, 0u);
    *state = r;
    urb_fake_node_t *slow = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    slow->stretch_us = 300u; /* every byte of its transactions is slow */
    uint8_t f[5][4];
    const uint8_t *ptrs[5] = {f[0], f[1], f[2], f[3], f[4]};
    size_t lens[5];
    lens[0] = enc_read(f[0], NODE, 1u, 0u, 4u);  /* served, slow */
    lens[1] = enc_read(f[1], NODE, 1u, 1u, 4u);  /* second slot */
    lens[2] = enc_read(f[2], NODE, 1u, 2u, 4u);  /* BUSY */
    lens[3] = enc_read(f[3], NODE, 1u, 3u, 9u);  /* SIZE_MISMATCH */
    lens[4] = enc_read(f[4], 0x7Du, 1u, 4u, 4u); /* BAD_REQUEST (reserved address) */
    uint8_t batch[64];
    size_t n = usb_batch(batch, 7u, ptrs, lens, 5u);
    assert_true(urb_bridge_usb_out(&r->bridge, batch, n));
    assert_true(urb_hosted_rig_settle(r, 20000u));
    urb_bridge_usb_sof(&r->bridge);
    uint8_t in[512];
    size_t got = urb_bridge_usb_in(&r->bridge, in, sizeof in);
    stream_t s = {in + 4, got - 4u, 0u};
    expect_response(&s, 0u, URB_STATUS_OK, 4u, NULL);
    expect_response(&s, 1u, URB_STATUS_OK, 4u, NULL);
    expect_response(&s, 2u, URB_STATUS_BUSY, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_response(&s, 4u, URB_STATUS_BAD_REQUEST, 0u, NULL);
    expect_end(&s);
}

/* Admission errors take no data slot: they never cause a BUSY (Bridge.tla BusyOnlyWhenFull). */
static void admission_errors_take_no_slot(void **state)
{
    urb_hosted_rig_t *r = rig_new(2u, 0u);
    *state = r;
    add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    uint8_t f[6][4];
    const uint8_t *ptrs[6] = {f[0], f[1], f[2], f[3], f[4], f[5]};
    size_t lens[6];
    lens[0] = enc_read(f[0], NODE, 1u, 0u, 4u);
    for (uint8_t i = 1u; i < 5u; i++) {
        lens[i] = enc_read(f[i], NODE, 1u, i, 7u); /* SIZE_MISMATCH */
    }
    lens[5] = enc_read(f[5], NODE, 1u, 5u, 4u);
    uint8_t batch[64];
    size_t n = usb_batch(batch, 1u, ptrs, lens, 6u);
    assert_true(urb_bridge_usb_out(&r->bridge, batch, n));
    assert_true(urb_hosted_rig_settle(r, 20000u));
    urb_bridge_usb_sof(&r->bridge);
    uint8_t in[512];
    size_t got = urb_bridge_usb_in(&r->bridge, in, sizeof in);
    stream_t s = {in + 4, got - 4u, 0u};
    expect_response(&s, 0u, URB_STATUS_OK, 4u, NULL);
    for (uint8_t i = 1u; i < 5u; i++) {
        expect_response(&s, i, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    }
    expect_response(&s, 5u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
    assert_int_equal(urb_bridge_stats(&r->bridge)->busy, 0u);
}

/* Over RS232 with a slow node: the FIFO fills, BUSY answers come in order, the queue drains and
 * accepts again; exactly one response per request. */
static void rs232_overflow_then_recovery(void **state)
{
    urb_hosted_rig_t *r = rig_new(4u, 0u);
    *state = r;
    urb_fake_node_t *n = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    r->master.cfg.timeout_us = 20000u;
    n->stretch_us = 1000u; /* about 6 ms per read: all 10 requests arrive during the first one */
    uint8_t f[8];
    for (uint8_t i = 0u; i < 10u; i++) {
        enc_read(f, NODE, 1u, i, 4u);
        urb_hosted_rig_uart_send(r, f, 4u, BYTE_US);
    }
    assert_true(urb_hosted_rig_settle(r, 200000u));
    stream_t s = rs232_stream(r);
    /* a request on the downlink keeps its data slot until its response has left: 4 accepted */
    for (uint8_t i = 0u; i < 10u; i++) {
        expect_response(&s, i, (i < 4u) ? URB_STATUS_OK : URB_STATUS_BUSY, 4u, NULL);
    }
    expect_end(&s);
    n->stretch_us = 0u;
    size_t const before = r->hal.tx_len;
    send_frame(r, f, enc_read(f, NODE, 1u, 11u, 4u));
    assert_true(urb_hosted_rig_settle(r, 20000u));
    s = rs232_stream(r);
    s.pos = before;
    expect_response(&s, 11u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* A host that ignores its window: requests beyond the response slots are counted, not answered,
 * and memory stays bounded (ASan); the bridge works on afterwards. */
/* lobster-trace: urb.RES_003 */
static void window_overflow_is_bounded(void **state)
{
    urb_hosted_rig_t *r = rig_new(4u, 0u);
    *state = r;
    add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    uint8_t batch[512];
    uint8_t f[100][4];
    const uint8_t *ptrs[100];
    size_t lens[100];
    for (uint8_t i = 0u; i < 100u; i++) {
        lens[i] = enc_read(f[i], NODE, 1u, (uint8_t)(i & 15u), 4u);
        ptrs[i] = f[i];
    }
    size_t n = usb_batch(batch, 1u, ptrs, lens, 100u);
    assert_true(n <= sizeof batch);
    assert_true(urb_bridge_usb_out(&r->bridge, batch, n));
    assert_int_equal(urb_bridge_outstanding(&r->bridge), URB_BRIDGE_RING_MAX);
    assert_int_equal(urb_bridge_stats(&r->bridge)->window_overflow, 100u - URB_BRIDGE_RING_MAX);
    /* drain: at most 14 or so responses fit a batch; read several frames */
    unsigned responses = 0u;
    for (int frame = 0; frame < 10; frame++) {
        urb_hosted_rig_run(r, 1000u);
        urb_bridge_usb_sof(&r->bridge);
        uint8_t in[512];
        size_t got = urb_bridge_usb_in(&r->bridge, in, sizeof in);
        assert_true(got >= 4u);
        responses += in[2];
    }
    assert_int_equal(responses, URB_BRIDGE_RING_MAX);
    assert_int_equal(urb_bridge_outstanding(&r->bridge), 0u);
}

int run_fifo_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(overflow_busy_in_order, teardown),
        cmocka_unit_test_teardown(admission_errors_keep_their_place, teardown),
        cmocka_unit_test_teardown(admission_errors_take_no_slot, teardown),
        cmocka_unit_test_teardown(rs232_overflow_then_recovery, teardown),
        cmocka_unit_test_teardown(window_overflow_is_bounded, teardown),
    };
    return cmocka_run_group_tests_name("bridge_fifo", tests, NULL, NULL);
}
