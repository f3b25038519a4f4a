/*
 * SYNC heartbeat on the downlink: period, counter, precedence over requests, skipped ticks,
 * SET_HEARTBEAT.
 */
#include <string.h>

#include "support.h"

#define NODE 0x20u

static int teardown(void **state)
{
    rig_free(*state);
    return 0;
}

/* Every 1 ms a SYNC with the next counter, each within a few microseconds of its tick. */
/* lobster-trace: urb.SYN_007 */
static void sync_every_period(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 1000u);
    *state = r;
    urb_fake_node_t *n = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r); /* the scan runs with SYNCs interleaved */
    uint32_t const s0 = n->syncs;
    uint8_t const c0 = n->last_sync;
    assert_true(s0 >= 3u);
    for (uint32_t k = 1u; k <= 10u; k++) {
        uint32_t const tick = r->hal.hb_next;
        urb_hosted_rig_run(r, tick - r->hal.now + 100u);
        assert_int_equal(n->syncs, s0 + k);
        assert_int_equal(n->last_sync, (uint8_t)(c0 + k));
        /* START + address + 0xA5 + counter at 400 kb/s: the SYNC's last byte lands ~72 us after the tick */
        assert_true(n->last_sync_us - tick <= 3u * 23u + 3u + 2u);
    }
    assert_int_equal(urb_bridge_stats(&r->bridge)->syncs_missed, 0u);
}

/* A SYNC due while a request is on the downlink waits for it, then goes before the next request. */
static void sync_after_current_before_next(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 1000u);
    *state = r;
    urb_fake_node_t *n = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    n->stretch_us = 200u; /* a read takes about 1.25 ms */
    uint8_t f[8];
    enc_read(f, NODE, 1u, 1u, 4u);
    enc_read(f + 4, NODE, 1u, 2u, 4u);
    uint32_t tick = r->hal.hb_next;
    if (tick - r->hal.now < 900u) {
        tick += 1000u;
    }
    urb_hosted_rig_run(r, tick - r->hal.now - 900u);
    uint32_t const s0 = n->syncs;
    uint32_t const reads0 = n->reads;
    uint8_t batch[32];
    const uint8_t *ptrs[2] = {f, f + 4};
    size_t lens[2] = {4u, 4u};
    assert_true(urb_bridge_usb_out(&r->bridge, batch, usb_batch(batch, 1u, ptrs, lens, 2u)));
    urb_hosted_rig_run(r, 1000u); /* the tick passes during the first read */
    assert_int_equal(n->syncs, s0); /* the SYNC does not cut into the read... */
    for (int i = 0; (i < 2000) && (n->syncs == s0); i++) {
        urb_hosted_rig_run(r, 1u);
    }
    assert_int_equal(n->syncs, s0 + 1u);
    assert_int_equal(n->reads, reads0 + 1u); /* ...and goes out before the second read */
    assert_true(n->last_sync_us - tick < 600u);
    urb_hosted_rig_run(r, 3000u);
    assert_int_equal(n->reads, reads0 + 2u);
}

/* A transaction longer than two periods: the ticks in between do not queue up SYNCs; the counter
 * skips so nodes can tell. */
/* lobster-trace: urb.SYN_007 */
static void missed_ticks_skip_the_counter(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 500u);
    *state = r;
    urb_fake_node_t *n = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    r->master.cfg.timeout_us = 10000u;
    n->stretch_us = 400u; /* ~2.5 ms read: five ticks */
    uint8_t f[8];
    uint8_t const c0 = n->last_sync;
    uint32_t const s0 = n->syncs;
    send_frame(r, f, enc_read(f, NODE, 1u, 1u, 4u));
    urb_hosted_rig_run(r, 3000u);
    n->stretch_us = 0u;
    urb_hosted_rig_run(r, 2000u);
    uint32_t const sent = n->syncs - s0;
    uint8_t const advanced = (uint8_t)(n->last_sync - c0);
    assert_true(advanced > sent);
    assert_true(urb_bridge_stats(&r->bridge)->syncs_missed >= 3u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* SET_HEARTBEAT changes the period (BridgeInfo reports it); 0 stops SYNC. */
static void set_heartbeat(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 1000u);
    *state = r;
    urb_fake_node_t *n = add_node(r, NODE, 0x42u, 1u, 4u, 4u);
    rig_start(r);
    uint8_t f[16];
    uint8_t cmd[3] = {URB_BRIDGE_OPCODE_SET_HEARTBEAT, 0xF4u, 0x01u}; /* 500 us */
    send_frame(r, f, enc_write(f, 0u, 0u, 1u, 3u, cmd));
    assert_int_equal(r->hal.hb_period, 500u);
    uint32_t s0 = n->syncs;
    urb_hosted_rig_run(r, 5000u);
    assert_true(n->syncs - s0 >= 9u && n->syncs - s0 <= 11u);
    send_frame(r, f, enc_read(f, 0u, 0u, 2u, 10u));
    cmd[1] = 0u;
    cmd[2] = 0u;
    send_frame(r, f, enc_write(f, 0u, 0u, 3u, 3u, cmd));
    s0 = n->syncs;
    urb_hosted_rig_run(r, 5000u);
    assert_int_equal(n->syncs, s0);
    stream_t s = rs232_stream(r);
    uint8_t data[32];
    expect_response(&s, 1u, URB_STATUS_OK, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_OK, 10u, data);
    expect_response(&s, 3u, URB_STATUS_OK, 0u, NULL);
    expect_end(&s);
    urb_bridge_info_t info;
    assert_int_equal(urb_bridge_info_decode(&info, data, 10u), 10);
    assert_int_equal(info.heartbeat_us, 500u);
}

int run_sync_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(sync_every_period, teardown),
        cmocka_unit_test_teardown(sync_after_current_before_next, teardown),
        cmocka_unit_test_teardown(missed_ticks_skip_the_counter, teardown),
        cmocka_unit_test_teardown(set_heartbeat, teardown),
    };
    return cmocka_run_group_tests_name("bridge_sync", tests, NULL, NULL);
}
