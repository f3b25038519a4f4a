/*
 * The USB protocol core: batches (frame counter, max_batch, byte budget, window), empty batches
 * while responses are outstanding, IN transfers matched as one stream (garbage and bad headers),
 * the hand-over flush, the lost-bridge rules with USB's wording.
 */
#include "host_test.h"

#include <string.h>

#include "urb_core.h"

static urb_core_t core;
static pool_t pool;

static int setup_usb(void **state)
{
    (void)state;
    pool_init(&pool);
    return urb_core_init(&core, URB_LINK_USB, NULL);
}

static int32_t out(urb_ns_t now, uint8_t *batch)
{
    return urb_core_frame_out(&core, now, batch, URB_USB_BATCH_MAX);
}

static size_t in_batch(uint8_t *buf, uint16_t frame, const urb_transfer_t *const *ts, size_t n, uint8_t status)
{
    urb_usb_batch_header_t h = {frame, (uint8_t)n};
    assert_int_equal(urb_usb_batch_header_encode(&h, buf, URB_USB_HEADER_SIZE), 4);
    size_t len = URB_USB_HEADER_SIZE;
    for (size_t i = 0u; i < n; i++) {
        len += response(buf + len, ts[i], status, (uint8_t)i);
    }
    return len;
}

static void test_one_batch_per_frame_with_a_header(void **state)
{
    (void)state;
    uint8_t batch[URB_USB_BATCH_MAX];
    assert_int_equal(out(0, batch), 0); /* nothing to send or fetch */
    assert_false(urb_core_wants_frame(&core));
    for (size_t i = 0u; i < 3u; i++) {
        submit_read(&pool, i, &core, 6u, 0);
    }
    assert_true(urb_core_wants_frame(&core));
    int32_t const n = out(MS, batch);
    assert_int_equal(n, 4 + 3 * 4);
    urb_usb_batch_header_t h;
    assert_int_equal(urb_usb_batch_header_decode(&h, batch, 4u), 4);
    assert_int_equal(h.frame, 1);
    assert_int_equal(h.count, 3);
    assert_int_equal(out(2 * MS, batch), 4); /* responses outstanding: an empty batch fetches them */
    assert_int_equal(urb_usb_batch_header_decode(&h, batch, 4u), 4);
    assert_int_equal(h.frame, 2);
    assert_int_equal(h.count, 0);
    const urb_transfer_t *ts[3] = {&pool.t[0], &pool.t[1], &pool.t[2]};
    uint8_t in[URB_USB_BATCH_MAX];
    assert_int_equal(urb_core_receive_batch(&core, in, in_batch(in, 1u, ts, 3u, 0u), 2 * MS), URB_HOST_OK);
    assert_int_equal(pool_take(&pool, &core), 3u);
    pool_all_once(&pool, 3u);
    assert_int_equal(core.transfers_in, 1u);
}

static void test_max_batch_window_and_byte_budget_defer_never_drop(void **state)
{
    (void)state;
    urb_core_config_t cfg;
    urb_core_default_config(&cfg, URB_LINK_USB);
    cfg.max_batch = 2u;
    cfg.window = 3u;
    cfg.batch_bytes = 41u; /* one 32-byte write (37 bytes) at most */
    assert_int_equal(urb_core_init(&core, URB_LINK_USB, &cfg), URB_HOST_OK);
    uint8_t data[32] = {0};
    for (size_t i = 0u; i < 2u; i++) {
        assert_int_equal(urb_transfer_write(&pool.t[i], 8u, 2u, data, 32u), URB_HOST_OK);
        assert_int_equal(urb_core_submit(&core, &pool.t[i], 0), URB_HOST_OK);
    }
    uint8_t batch[URB_USB_BATCH_MAX];
    assert_int_equal(out(MS, batch), 4 + 37); /* the second does not fit this transfer */
    assert_int_equal(out(2 * MS, batch), 4 + 37);
    assert_int_equal(urb_core_init(&core, URB_LINK_USB, &cfg), URB_HOST_OK);
    pool_init(&pool);
    for (size_t i = 0u; i < 5u; i++) {
        submit_read(&pool, i, &core, 6u, 0);
    }
    assert_int_equal(out(MS, batch), 4 + 2 * 4);     /* max_batch */
    assert_int_equal(out(2 * MS, batch), 4 + 1 * 4); /* the window (3) */
    assert_int_equal(out(3 * MS, batch), 4);         /* full: wait */
    assert_int_equal(core.queued, 2u);
}

static void test_garbage_after_responses_and_a_bad_header(void **state)
{
    (void)state;
    uint8_t batch[URB_USB_BATCH_MAX];
    submit_read(&pool, 0, &core, 6u, 0);
    submit_read(&pool, 1, &core, 6u, 0);
    out(MS, batch);
    const urb_transfer_t *ts[1] = {&pool.t[0]};
    uint8_t in[URB_USB_BATCH_MAX];
    size_t n = in_batch(in, 1u, ts, 1u, 0u);
    in[0] ^= 0xFFu; /* a header that fails its check: the responses are matched anyway */
    in[n++] = 0x99u; /* and a byte that answers nothing */
    assert_int_equal(urb_core_receive_batch(&core, in, n, 2 * MS), URB_HOST_OK);
    assert_int_equal(core.bad_headers, 1u);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_true(urb_transfer_ok(&pool.t[0]));
    assert_int_equal(core.m.rx_len, 0u); /* a response never spans two transfers */
    assert_int_equal(core.m.stray_bytes, 1u);
    uint8_t const tiny[2] = {1, 2}; /* shorter than a header */
    assert_int_equal(urb_core_receive_batch(&core, tiny, 2u, 3 * MS), URB_HOST_OK);
    assert_int_equal(core.bad_headers, 2u);
    (void)urb_core_poll(&core, MS + 50 * MS);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_int_equal(pool.t[1].flags, URB_FLAG_UPLINK_CHECKSUM); /* garbage stood where its answer was due */
}

static void test_hand_over_flushes_until_an_empty_transfer(void **state)
{
    (void)state;
    urb_core_hand_over(&core, 10 * MS);
    uint8_t batch[URB_USB_BATCH_MAX];
    urb_transfer_t *a = submit_read(&pool, 0, &core, 6u, 0);
    assert_int_equal(out(MS, batch), 4); /* fetch, send nothing */
    urb_transfer_t old;
    assert_int_equal(urb_transfer_read(&old, 8u, 1u, 6u), URB_HOST_OK);
    old.seq = 1;
    const urb_transfer_t *ts[1] = {&old};
    uint8_t in[URB_USB_BATCH_MAX];
    urb_core_receive_batch(&core, in, in_batch(in, 0u, ts, 1u, 0u), 11 * MS);
    assert_int_equal(core.m.stray_bytes, 8u);
    assert_int_equal(out(11 * MS, batch), 4);
    urb_core_receive_batch(&core, in, in_batch(in, 0u, ts, 0u, 0u), 11 * MS); /* empty, but too early */
    assert_true(core.flushing);
    urb_core_receive_batch(&core, in, in_batch(in, 0u, ts, 0u, 0u), 12 * MS); /* two frames after */
    assert_false(core.flushing);
    assert_int_equal(out(13 * MS, batch), 8);
    assert_int_equal(a->seq, 1);
}

static void test_unplugged_and_silent_bridges(void **state)
{
    (void)state;
    uint8_t batch[URB_USB_BATCH_MAX];
    for (size_t i = 0u; i < 5u; i++) { /* one read every 100 ms, none answered: always something outstanding */
        urb_ns_t const t = (urb_ns_t)i * 100 * MS;
        submit_read(&pool, i, &core, 6u, t);
        assert_int_equal(out(t + MS, batch), 8);
        (void)urb_core_poll(&core, t + 60 * MS);
        assert_null(urb_core_lost_reason(&core));
    }
    (void)urb_core_poll(&core, 500 * MS);
    assert_string_equal(urb_core_lost_reason(&core),
                        "the bridge returned no USB transfer for 500 ms with requests outstanding");
    assert_int_equal(out(502 * MS, batch), 0); /* a lost core sends nothing */
    assert_false(urb_core_wants_frame(&core));
    pool_take(&pool, &core);
    pool_all_once(&pool, 5u);
    for (size_t i = 0u; i < 5u; i++) { /* each timed out on its own first; their placeholders kept it busy */
        assert_int_equal(pool.t[i].flags, URB_FLAG_UPLINK_TIMEOUT);
    }
}

int run_usb_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_one_batch_per_frame_with_a_header, setup_usb),
        cmocka_unit_test_setup(test_max_batch_window_and_byte_budget_defer_never_drop, setup_usb),
        cmocka_unit_test_setup(test_garbage_after_responses_and_a_bad_header, setup_usb),
        cmocka_unit_test_setup(test_hand_over_flushes_until_an_empty_transfer, setup_usb),
        cmocka_unit_test_setup(test_unplugged_and_silent_bridges, setup_usb),
    };
    return cmocka_run_group_tests_name("host_c_core_usb", tests, NULL, NULL);
}
