/*
 * The RS232 protocol core on every path: matching, hunting, timeouts, placeholders, the lost-bridge
 * rules, drain, hand-over, bad arguments. Each test checks that every request completes exactly
 * once (pool_take) and says which flag it gets.
 */
#include "host_test.h"

#include <string.h>

#include "urb_core.h"

static urb_core_t core;
static pool_t pool;

static int setup_rs232(void **state)
{
    (void)state;
    pool_init(&pool);
    return urb_core_init(&core, URB_LINK_RS232, NULL);
}

static void feed(const uint8_t *b, size_t n, urb_ns_t now)
{
    assert_int_equal(urb_core_receive(&core, b, n, now), URB_HOST_OK);
}

static void answer(const urb_transfer_t *t, uint8_t status, uint8_t fill, urb_ns_t now)
{
    uint8_t buf[URB_RESPONSE_MAX];
    feed(buf, response(buf, t, status, fill), now);
}

static void test_window_and_sequence_numbers(void **state)
{
    (void)state;
    urb_core_config_t cfg;
    urb_core_default_config(&cfg, URB_LINK_RS232);
    cfg.window = 3u;
    assert_int_equal(urb_core_init(&core, URB_LINK_RS232, &cfg), URB_HOST_OK);
    for (size_t i = 0u; i < 5u; i++) {
        submit_read(&pool, i, &core, 6u, 0);
    }
    uint8_t frame[URB_REQUEST_MAX];
    assert_int_equal(urb_core_next_frame(&core, 0, frame, sizeof frame), 4);
    urb_uplink_read_request_t r;
    assert_int_equal(urb_uplink_read_request_decode(&r, frame, 4u), 4);
    assert_int_equal(r.seq, 1); /* the first request of a core carries 1 (Bridge.tla SeqOf) */
    assert_int_equal(r.address, 8);
    assert_int_equal(r.length, 6);
    assert_int_equal(send_all(&core, 0), 2u); /* the window holds 3 */
    assert_int_equal(urb_core_in_flight(&core), 3u);
    assert_true(urb_core_busy(&core));
    assert_false(urb_core_has_queued(&core));
    answer(&pool.t[0], 0u, 0xAB, 10);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_true(urb_transfer_ok(&pool.t[0]));
    assert_int_equal(pool.t[0].response_len, 6);
    assert_int_equal(pool.t[0].response[5], 0xAB);
    assert_int_equal(pool.t[0].completed_ns, 10);
    assert_int_equal(send_all(&core, 10), 1u);
    assert_int_equal(pool.t[3].seq, 4);
}

static void test_response_split_anywhere_and_two_in_one_chunk(void **state)
{
    (void)state;
    urb_transfer_t *a = submit_read(&pool, 0, &core, 6u, 0);
    urb_transfer_t *b = submit_read(&pool, 1, &core, 25u, 0);
    send_all(&core, 0);
    uint8_t stream[80];
    size_t n = response(stream, a, 0u, 1u);
    n += response(stream + n, b, 0u, 2u);
    assert_int_equal(n, 8u + 28u); /* 25 data bytes take a CRC-16 */
    for (size_t i = 0u; i < n; i++) {
        feed(stream + i, 1u, (urb_ns_t)i);
    }
    assert_int_equal(pool_take(&pool, &core), 2u);
    assert_int_equal(pool_nth(&pool, 0)->response[0], 1);
    assert_int_equal(pool_nth(&pool, 1)->response_len, 25);
    assert_int_equal(pool_nth(&pool, 1)->completed_ns, (urb_ns_t)(n - 1u));
}

static void test_every_bridge_status_is_its_flag_and_carries_no_data(void **state)
{
    (void)state;
    for (uint8_t s = 1u; s <= 8u; s++) {
        urb_transfer_t *t = submit_read(&pool, s, &core, 6u, 0);
        send_all(&core, 0);
        answer(t, s, 0u, 1);
        assert_int_equal(pool_take(&pool, &core), 1u);
        assert_int_equal(t->flags, 1u << (s - 1u));
        assert_int_equal(t->status, s);
        assert_int_equal(t->response_len, 0u);
    }
    assert_int_equal(urb_flags_from_status(7u), URB_FLAG_BUS_STUCK); /* a stuck bus, cleared */
}

static void test_hunting_skips_a_corrupt_response_and_a_later_one_proves_it_lost(void **state)
{
    (void)state;
    urb_transfer_t *a = submit_read(&pool, 0, &core, 6u, 0);
    urb_transfer_t *b = submit_read(&pool, 1, &core, 6u, 0);
    urb_transfer_t *c = submit_read(&pool, 2, &core, 6u, 0);
    send_all(&core, 0);
    uint8_t stream[32];
    size_t n = response(stream, a, 0u, 0u);
    stream[3] ^= 0x40u; /* one flipped bit: the CRC-8 sees it */
    n += response(stream + n, b, 0u, 0x42u);
    feed(stream, n, 1);
    assert_int_equal(pool_take(&pool, &core), 2u);
    assert_ptr_equal(pool_nth(&pool, 0), a);
    assert_int_equal(a->flags, URB_FLAG_UPLINK_CHECKSUM); /* corrupt bytes stood in its place */
    assert_ptr_equal(pool_nth(&pool, 1), b);
    assert_true(urb_transfer_ok(b));
    assert_int_equal(b->response[0], 0x42);
    assert_true(core.m.stray_bytes > 0u);
    (void)urb_core_poll(&core, 100 * MS); /* c's request was lost on the way: its timeout */
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_int_equal(c->flags, URB_FLAG_UPLINK_TIMEOUT);
    pool_all_once(&pool, 3u);
}

static void test_every_single_bit_flip_of_a_response_is_caught(void **state)
{
    (void)state;
    uint8_t good[URB_RESPONSE_MAX];
    for (size_t bit = 0u; bit < 8u * 8u; bit++) {
        setup_rs232(NULL);
        urb_transfer_t *a = submit_read(&pool, 0, &core, 6u, 0);
        urb_transfer_t *b = submit_read(&pool, 1, &core, 6u, 0);
        send_all(&core, 0);
        size_t const n = response(good, a, 0u, 0x5Au);
        assert_int_equal(n, 8u);
        good[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
        feed(good, n, 1);
        answer(b, 0u, 0x33u, 2);
        assert_int_equal(pool_take(&pool, &core), 2u);
        assert_int_equal(a->flags, URB_FLAG_UPLINK_CHECKSUM); /* never someone else's data */
        assert_true(urb_transfer_ok(b));
        assert_int_equal(b->response[0], 0x33);
    }
}

static void test_malformed_headers_and_wrong_sizes_are_stray(void **state)
{
    (void)state;
    urb_transfer_t *a = submit_read(&pool, 0, &core, 6u, 0);
    send_all(&core, 0);
    uint8_t const bad_status = (uint8_t)(0x90u | 1u); /* status 9 does not exist */
    feed(&bad_status, 1u, 1);
    uint8_t const other_seq = 0x05u;                  /* no request carries 5 */
    feed(&other_seq, 1u, 2);
    uint8_t wrong_size[URB_RESPONSE_MAX];             /* a 4-byte read's answer to a 6-byte read */
    urb_transfer_t four;
    assert_int_equal(urb_transfer_read(&four, 8u, 1u, 4u), URB_HOST_OK);
    four.seq = a->seq;
    feed(wrong_size, response(wrong_size, &four, 0u, 0u), 3);
    assert_int_equal(pool_take(&pool, &core), 0u);
    assert_true(core.m.stray_bytes >= 2u);
    answer(a, 0u, 7u, 4);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_true(urb_transfer_ok(a)); /* the garbage before it did not cost it its answer */
    assert_int_equal(a->response[0], 7);
}

static void test_bytes_with_nothing_pending_are_counted_and_dropped(void **state)
{
    (void)state;
    uint8_t const junk[5] = {1, 2, 3, 4, 5};
    feed(junk, sizeof junk, 0);
    assert_int_equal(core.m.stray_bytes, 5u);
    assert_int_equal(core.m.rx_len, 0u);
    assert_int_equal(urb_core_next_deadline(&core), URB_NEVER);
}

static void test_timeout_keeps_a_placeholder_until_its_late_response(void **state)
{
    (void)state;
    urb_transfer_t *a = submit_read(&pool, 0, &core, 6u, 0);
    send_all(&core, 0);
    assert_int_equal(urb_core_next_deadline(&core), 100 * MS);
    (void)urb_core_poll(&core, 100 * MS);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_int_equal(a->flags, URB_FLAG_UPLINK_TIMEOUT);
    assert_int_equal(urb_core_placeholders(&core), 1u); /* Bridge.tla HostTimeout: the number stays reserved */
    int8_t const seq = a->seq;
    /* the late response is discarded and counted, never given to another request */
    urb_transfer_t late;
    assert_int_equal(urb_transfer_read(&late, 8u, 1u, 6u), URB_HOST_OK);
    late.seq = seq;
    uint8_t buf[URB_RESPONSE_MAX];
    urb_transfer_t *b = submit_read(&pool, 1, &core, 6u, 150 * MS);
    send_all(&core, 150 * MS);
    feed(buf, response(buf, &late, 0u, 9u), 160 * MS);
    assert_int_equal(core.m.late_responses, 1u);
    assert_int_equal(pool_take(&pool, &core), 0u);
    assert_int_equal(urb_core_placeholders(&core), 0u);
    answer(b, 0u, 1u, 170 * MS);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_true(urb_transfer_ok(b));
}

static void test_placeholder_expires_after_its_lifetime(void **state)
{
    (void)state;
    submit_read(&pool, 0, &core, 6u, 0);
    send_all(&core, 0);
    (void)urb_core_poll(&core, 100 * MS);
    pool_take(&pool, &core);
    assert_int_equal(urb_core_next_deadline(&core), URB_PLACEHOLDER_NS); /* Bridge.tla HostExpire */
    (void)urb_core_poll(&core, URB_PLACEHOLDER_NS - 1);
    assert_int_equal(urb_core_placeholders(&core), 1u);
    (void)urb_core_poll(&core, URB_PLACEHOLDER_NS);
    assert_int_equal(urb_core_in_flight(&core), 0u);
    assert_int_equal(core.m.released_placeholders, 1u);
}

/* The matcher's slots form a ring: with the requests in flight straddling its end, a timeout in its
 * first slot is found as one in its last (the core's check before urb_matcher_time_out walks the ring). */
static void test_a_timeout_across_the_end_of_the_ring(void **state)
{
    (void)state;
    for (size_t i = 0u; i < URB_MATCHER_SLOTS - 1u; i++) { /* answered one by one: the head moves to the last slot */
        urb_transfer_t *t = submit_read(&pool, i, &core, 6u, 0);
        send_all(&core, 0);
        answer(t, 0u, 1u, 0);
    }
    assert_int_equal(pool_take(&pool, &core), URB_MATCHER_SLOTS - 1u);
    assert_int_equal(core.m.head, URB_MATCHER_SLOTS - 1u);
    urb_transfer_t *a = submit_read(&pool, 20, &core, 6u, 0); /* the ring's last slot */
    send_all(&core, 0);
    urb_transfer_t *b = submit_read(&pool, 21, &core, 6u, 10 * MS); /* its first */
    send_all(&core, 10 * MS);
    (void)urb_core_poll(&core, 100 * MS); /* a times out and stays a placeholder */
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_int_equal(a->flags, URB_FLAG_UPLINK_TIMEOUT);
    (void)urb_core_poll(&core, 110 * MS); /* b's timeout, behind a placeholder that is not due */
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_int_equal(b->flags, URB_FLAG_UPLINK_TIMEOUT);
    assert_int_equal(urb_core_placeholders(&core), 2u);
}

static void test_a_full_window_of_placeholders_holds_new_requests_back(void **state)
{
    (void)state;
    for (size_t i = 0u; i < 4u; i++) {
        submit_read(&pool, i, &core, 6u, 0);
    }
    send_all(&core, 0);
    (void)urb_core_poll(&core, 100 * MS);
    assert_int_equal(pool_take(&pool, &core), 4u);
    submit_read(&pool, 4, &core, 6u, 101 * MS);
    assert_int_equal(send_all(&core, 101 * MS), 0u); /* the bridge may still answer all four */
    assert_int_equal(send_all(&core, URB_PLACEHOLDER_NS), 1u);
    assert_int_equal(pool.t[4].seq, 5); /* numbering goes on */
}

static void test_idle_gap_drops_the_first_byte_of_a_stalled_candidate(void **state)
{
    (void)state;
    urb_transfer_t *a = submit_read(&pool, 0, &core, 32u, 0);
    urb_transfer_t *b = submit_read(&pool, 1, &core, 6u, 0);
    send_all(&core, 0);
    uint8_t ra[URB_RESPONSE_MAX];
    uint8_t rb[URB_RESPONSE_MAX];
    response(ra, a, 0u, 1u);
    size_t const nb = response(rb, b, 0u, 2u);
    feed(ra, 1u, MS); /* only the first byte of a's 35-byte answer came ... */
    feed(rb, nb, 2 * MS); /* ... then b's whole answer, which the 35-byte candidate swallows */
    assert_true(core.partial);
    assert_int_equal(pool_take(&pool, &core), 0u);
    assert_int_equal(urb_core_next_deadline(&core), 2 * MS + 20 * MS);
    (void)urb_core_poll(&core, 22 * MS); /* the gap: the stalled candidate loses its first byte, b is found */
    assert_int_equal(pool_take(&pool, &core), 2u);
    assert_int_equal(a->flags, URB_FLAG_UPLINK_CHECKSUM);
    assert_true(urb_transfer_ok(b));
    assert_int_equal(b->response[0], 2);
}

static void test_silence_with_requests_outstanding_loses_the_bridge(void **state)
{
    (void)state;
    submit_read(&pool, 0, &core, 6u, 0);
    send_all(&core, 0);
    for (size_t i = 1u; i < 6u; i++) {
        submit_read(&pool, i, &core, 6u, 0);
    }
    (void)urb_core_poll(&core, 100 * MS);
    assert_null(urb_core_lost_reason(&core));
    (void)urb_core_poll(&core, 500 * MS); /* rule 2: 500 ms of silence, requests outstanding all along */
    assert_string_equal(urb_core_lost_reason(&core), "the bridge sent nothing for 500 ms with requests outstanding");
    pool_take(&pool, &core);
    pool_all_once(&pool, 6u);
    for (size_t i = 1u; i < 6u; i++) { /* queued ones fail with the reason, never sent */
        assert_int_equal(pool.t[i].flags, URB_FLAG_BRIDGE_LOST);
        assert_string_equal(pool.t[i].lost_reason, urb_core_lost_reason(&core));
        assert_int_equal(pool.t[i].sent_ns, URB_NO_TIME);
    }
    urb_transfer_t *later = submit_read(&pool, 6, &core, 6u, 600 * MS);
    assert_int_equal(pool_take(&pool, &core), 1u); /* at once, until a reset */
    assert_int_equal(later->flags, URB_FLAG_BRIDGE_LOST);
    uint8_t const junk = 0x11u;
    feed(&junk, 1u, 601 * MS);
    assert_int_equal(core.m.stray_bytes, 1u);
}

static void test_sparse_timeouts_in_a_row_lose_it_a_glitch_does_not(void **state)
{
    (void)state;
    /* a glitch: a whole window lost within 3 ms times out together; the bridge answers the next one */
    for (size_t i = 0u; i < 4u; i++) {
        submit_read(&pool, i, &core, 6u, 0);
    }
    send_all(&core, 0);
    (void)urb_core_poll(&core, 100 * MS);
    assert_null(urb_core_lost_reason(&core));
    urb_transfer_t *next = submit_read(&pool, 4, &core, 6u, 300 * MS);
    assert_int_equal(send_all(&core, 300 * MS), 1u); /* once the glitch's placeholders expired */
    answer(next, 0u, 1u, 301 * MS);
    assert_true(urb_transfer_ok(next));
    /* sparse traffic: one read a second, every one lost: lost at the 8th in a row, not before */
    urb_ns_t t = URB_NS_PER_S;
    for (size_t i = 5u; i < 13u; i++) {
        assert_null(urb_core_lost_reason(&core));
        submit_read(&pool, i, &core, 6u, t);
        send_all(&core, t);
        (void)urb_core_poll(&core, t + 100 * MS);
        (void)urb_core_poll(&core, t + URB_PLACEHOLDER_NS);
        t += URB_NS_PER_S;
    }
    assert_string_equal(urb_core_lost_reason(&core),
                        "8 requests in a row got no response and the bridge sent nothing for 7799 ms");
    pool_take(&pool, &core);
    pool_all_once(&pool, 13u);
}

static void test_io_error_fails_everything_and_reset_keeps_placeholders(void **state)
{
    (void)state;
    urb_transfer_t *a = submit_read(&pool, 0, &core, 6u, 0);
    send_all(&core, 0);
    submit_read(&pool, 1, &core, 6u, 0);
    urb_core_link_lost(&core, MS, "/dev/ttyS0: I/O error: the device was unplugged, or the bridge process ended");
    assert_int_equal(pool_take(&pool, &core), 0u + 2u);
    assert_int_equal(a->flags, URB_FLAG_BRIDGE_LOST);
    assert_int_equal(urb_core_placeholders(&core), 1u); /* Bridge.tla HostLinkLost */
    urb_core_link_lost(&core, 2 * MS, "again"); /* once per loss */
    assert_string_equal(urb_core_lost_reason(&core),
                        "/dev/ttyS0: I/O error: the device was unplugged, or the bridge process ended");
    urb_core_reset(&core, 3 * MS); /* Bridge.tla HostReopen */
    assert_null(urb_core_lost_reason(&core));
    assert_int_equal(urb_core_placeholders(&core), 1u);
    urb_transfer_t *b = submit_read(&pool, 2, &core, 6u, 4 * MS);
    send_all(&core, 4 * MS);
    assert_int_equal(b->seq, 2); /* numbering goes on after a reconnect */
    answer(b, 0u, 3u, 5 * MS);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_int_equal(core.m.released_placeholders, 1u); /* a later response passed it */
}

static void test_a_long_reason_is_cut_and_terminated(void **state)
{
    (void)state;
    char text[400];
    memset(text, 'x', sizeof text - 1u);
    text[sizeof text - 1u] = '\0';
    submit_read(&pool, 0, &core, 6u, 0);
    urb_core_link_lost(&core, 0, text);
    pool_take(&pool, &core);
    assert_int_equal(strlen(pool.t[0].lost_reason), URB_REASON_MAX - 1u);
}

static void test_drain_fails_the_queue_and_waits_for_what_is_in_flight(void **state)
{
    (void)state;
    urb_transfer_t *a = submit_read(&pool, 0, &core, 6u, 0);
    send_all(&core, 0);
    submit_read(&pool, 1, &core, 6u, 0);
    assert_int_equal(urb_core_start_drain(&core, MS), URB_PLACEHOLDER_NS);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_string_equal(pool.t[1].lost_reason, "closed by the application");
    submit_read(&pool, 2, &core, 6u, 2 * MS);
    assert_int_equal(pool_take(&pool, &core), 1u); /* closing: at once */
    assert_int_equal(send_all(&core, 2 * MS), 0u);
    assert_false(urb_core_drained(&core));
    answer(a, 0u, 1u, 3 * MS);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_true(urb_transfer_ok(a));
    assert_true(urb_core_drained(&core));
    assert_int_equal(urb_core_start_drain(&core, 4 * MS), URB_NO_TIME);
}

static void test_hand_over_sends_nothing_before_the_previous_process_is_over(void **state)
{
    (void)state;
    urb_core_hand_over(&core, 50 * MS);
    urb_transfer_t *a = submit_read(&pool, 0, &core, 6u, 0);
    assert_int_equal(send_all(&core, 0), 0u);
    assert_int_equal(urb_core_next_deadline(&core), 50 * MS);
    urb_transfer_t old;
    assert_int_equal(urb_transfer_read(&old, 8u, 1u, 6u), URB_HOST_OK);
    old.seq = 1; /* the previous process's late answer echoing the number our first request will carry */
    uint8_t buf[URB_RESPONSE_MAX];
    feed(buf, response(buf, &old, 0u, 0xEEu), 10 * MS);
    assert_int_equal(core.m.stray_bytes, 8u); /* discarded: nothing of ours is in flight */
    (void)urb_core_poll(&core, 49 * MS);
    assert_null(urb_core_lost_reason(&core)); /* the wait is no silence */
    assert_int_equal(send_all(&core, 50 * MS), 1u);
    assert_int_equal(a->sent_ns, 50 * MS);
    answer(a, 0u, 1u, 51 * MS);
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_int_equal(a->response[0], 1);
}

static void test_a_long_answer_holds_the_clocks_of_what_follows(void **state)
{
    (void)state;
    urb_transfer_t *scan = &pool.t[0];
    uint8_t const cmd[3] = {1u, 0u, 0u};
    assert_int_equal(urb_transfer_write(scan, 0u, 0u, cmd, 3u), URB_HOST_OK);
    assert_int_equal(urb_transfer_set_answer_within(scan, URB_SCAN_ANSWER_NS), URB_HOST_OK);
    assert_int_equal(urb_core_submit(&core, scan, 0), URB_HOST_OK);
    urb_transfer_t *map = submit_read(&pool, 1, &core, 16u, 0);
    send_all(&core, 0);
    (void)urb_core_poll(&core, 1400 * MS); /* no timeout, no loss while the scan runs */
    assert_int_equal(pool_take(&pool, &core), 0u);
    assert_null(urb_core_lost_reason(&core));
    answer(scan, 0u, 0u, 1450 * MS);
    (void)urb_core_poll(&core, URB_SCAN_ANSWER_NS + 99 * MS);
    assert_int_equal(pool_take(&pool, &core), 1u);
    (void)urb_core_poll(&core, URB_SCAN_ANSWER_NS + 100 * MS); /* its clock started after the scan's */
    assert_int_equal(pool_take(&pool, &core), 1u);
    assert_int_equal(map->flags, URB_FLAG_UPLINK_TIMEOUT);
}

static void test_bad_arguments_change_nothing(void **state)
{
    (void)state;
    urb_transfer_t t;
    uint8_t buf[URB_REQUEST_MAX];
    urb_core_config_t cfg;
    assert_int_equal(urb_core_init(NULL, URB_LINK_RS232, NULL), URB_HOST_EINVAL);
    assert_int_equal(urb_core_init(&core, (urb_link_kind_t)7, NULL), URB_HOST_EINVAL);
    urb_core_default_config(&cfg, URB_LINK_RS232);
    cfg.window = 16u; /* would alias the 4-bit number */
    assert_int_equal(urb_core_init(&core, URB_LINK_RS232, &cfg), URB_HOST_EINVAL);
    urb_core_default_config(&cfg, URB_LINK_RS232);
    cfg.timeout_ns = 0;
    assert_int_equal(urb_core_init(&core, URB_LINK_RS232, &cfg), URB_HOST_EINVAL);
    assert_int_equal(urb_core_init(&core, URB_LINK_RS232, NULL), URB_HOST_OK);
    assert_int_equal(urb_transfer_read(&t, 128u, 1u, 6u), URB_HOST_EINVAL);
    assert_int_equal(urb_transfer_read(&t, 8u, 8u, 6u), URB_HOST_EINVAL);
    assert_int_equal(urb_transfer_read(&t, 8u, 1u, 0u), URB_HOST_EINVAL);
    assert_int_equal(urb_transfer_read(&t, 8u, 1u, 33u), URB_HOST_EINVAL);
    assert_int_equal(urb_transfer_write(&t, 8u, 1u, NULL, 2u), URB_HOST_EINVAL);
    assert_int_equal(urb_core_submit(&core, NULL, 0), URB_HOST_EINVAL);
    memset(&t, 0, sizeof t);
    t.length = 40u; /* a hand-built transfer out of range */
    assert_int_equal(urb_core_submit(&core, &t, 0), URB_HOST_EINVAL);
    assert_int_equal(urb_transfer_read(&t, 8u, 1u, 6u), URB_HOST_OK);
    assert_int_equal(urb_core_submit(&core, &t, 0), URB_HOST_OK);
    assert_int_equal(urb_core_submit(&core, &t, 0), URB_HOST_EBUSY); /* submitted once */
    assert_true(urb_transfer_owned(&t)); /* the core owns it */
    assert_int_equal(urb_transfer_set_callback(&t, NULL, NULL), URB_HOST_EBUSY);
    assert_int_equal(urb_core_next_frame(&core, 0, buf, 10u), URB_HOST_ENOSPC);
    assert_int_equal(urb_core_frame_out(&core, 0, buf, sizeof buf), URB_HOST_EINVAL); /* not USB */
    assert_int_equal(urb_core_receive_batch(&core, buf, 4u, 0), URB_HOST_EINVAL);
    assert_int_equal(urb_core_receive(&core, NULL, 3u, 0), URB_HOST_EINVAL);
    assert_int_equal(urb_core_set_window(&core, 0u), URB_HOST_EINVAL);
    assert_int_equal(urb_core_in_flight(&core), 0u);
    assert_int_equal(core.queued, 1u); /* only the one good submission */
    assert_int_equal(urb_core_poll(NULL, 0), URB_HOST_EINVAL);
    assert_null(urb_core_take_completed(NULL));
    assert_int_equal(urb_core_next_deadline(NULL), URB_NEVER);
}

static void test_flag_names_and_hints(void **state)
{
    (void)state;
    char text[64];
    assert_int_equal(urb_flags_describe(0u, text, sizeof text), 2);
    assert_string_equal(text, "OK");
    assert_true(urb_flags_describe(URB_FLAG_NO_NODE | URB_FLAG_BRIDGE_LOST, text, sizeof text) > 0);
    assert_string_equal(text, "NO_NODE|BRIDGE_LOST");
    assert_int_equal(urb_flags_describe(URB_FLAG_ALL, text, 8u), URB_HOST_ENOSPC);
    assert_int_equal(urb_flags_describe(1u, NULL, 4u), URB_HOST_EINVAL);
    assert_string_equal(urb_flag_name(URB_FLAG_FINGERPRINT_MISMATCH), "FINGERPRINT_MISMATCH");
    assert_null(urb_flag_name(3u));
    assert_string_equal(urb_flags_hint(URB_FLAG_BUSY), "the bridge FIFO was full; submit fewer requests at once");
    assert_string_equal(urb_flags_hint(0u), "the request succeeded");
    assert_string_equal(urb_flags_hint(1u << 20), "unknown error");
    assert_int_equal(urb_flags_from_status(9u), URB_FLAG_ALL + 1u);
    assert_string_equal(urb_host_error_name(URB_HOST_EBUSY), "EBUSY");
}

int run_core_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_window_and_sequence_numbers, setup_rs232),
        cmocka_unit_test_setup(test_response_split_anywhere_and_two_in_one_chunk, setup_rs232),
        cmocka_unit_test_setup(test_every_bridge_status_is_its_flag_and_carries_no_data, setup_rs232),
        cmocka_unit_test_setup(test_hunting_skips_a_corrupt_response_and_a_later_one_proves_it_lost, setup_rs232),
        cmocka_unit_test_setup(test_every_single_bit_flip_of_a_response_is_caught, setup_rs232),
        cmocka_unit_test_setup(test_malformed_headers_and_wrong_sizes_are_stray, setup_rs232),
        cmocka_unit_test_setup(test_bytes_with_nothing_pending_are_counted_and_dropped, setup_rs232),
        cmocka_unit_test_setup(test_timeout_keeps_a_placeholder_until_its_late_response, setup_rs232),
        cmocka_unit_test_setup(test_placeholder_expires_after_its_lifetime, setup_rs232),
        cmocka_unit_test_setup(test_a_timeout_across_the_end_of_the_ring, setup_rs232),
        cmocka_unit_test_setup(test_a_full_window_of_placeholders_holds_new_requests_back, setup_rs232),
        cmocka_unit_test_setup(test_idle_gap_drops_the_first_byte_of_a_stalled_candidate, setup_rs232),
        cmocka_unit_test_setup(test_silence_with_requests_outstanding_loses_the_bridge, setup_rs232),
        cmocka_unit_test_setup(test_sparse_timeouts_in_a_row_lose_it_a_glitch_does_not, setup_rs232),
        cmocka_unit_test_setup(test_io_error_fails_everything_and_reset_keeps_placeholders, setup_rs232),
        cmocka_unit_test_setup(test_a_long_reason_is_cut_and_terminated, setup_rs232),
        cmocka_unit_test_setup(test_drain_fails_the_queue_and_waits_for_what_is_in_flight, setup_rs232),
        cmocka_unit_test_setup(test_hand_over_sends_nothing_before_the_previous_process_is_over, setup_rs232),
        cmocka_unit_test_setup(test_a_long_answer_holds_the_clocks_of_what_follows, setup_rs232),
        cmocka_unit_test_setup(test_bad_arguments_change_nothing, setup_rs232),
        cmocka_unit_test(test_flag_names_and_hints),
    };
    return cmocka_run_group_tests_name("host_c_core_rs232", tests, NULL, NULL);
}
