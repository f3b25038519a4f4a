/*
 * RS232 uplink: framing, resynchronisation (idle gap, hunting), malformed, truncated, oversized
 * and corrupted requests. What is answered, and what is not (spec/schema/README.md).
 */
#include <stdlib.h>
#include <string.h>

#include "support.h"
#include "urb_runtime.h"

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

static void bridge_info_read(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[8];
    uint8_t data[32];
    send_frame(r, f, enc_read(f, 0u, 0u, 5u, 10u));
    stream_t s = rs232_stream(r);
    expect_response(&s, 5u, URB_STATUS_OK, 10u, data);
    expect_end(&s);
    urb_bridge_info_t info;
    assert_int_equal(urb_bridge_info_decode(&info, data, 10u), 10);
    assert_int_equal(info.downlink, URB_DOWNLINK_KIND_I2C);
    assert_int_equal(info.fifo_depth, 16u);
    assert_int_equal(info.bitrate_kbps, 400u);
    assert_int_equal(info.heartbeat_us, 0u);
}

static void write_then_read_node(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[40];
    uint8_t const payload[4] = {1u, 2u, 3u, 4u};
    uint8_t data[32];
    send_frame(r, f, enc_write(f, NODE, 1u, 1u, 4u, payload));
    send_frame(r, f, enc_read(f, NODE, 1u, 2u, 4u));
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_OK, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_OK, 4u, data);
    expect_end(&s);
    assert_memory_equal(data, payload, 4u);
    assert_int_equal(r->bus.nodes[0].writes[1], 1u);
}

/* Two frames in one write() (no gap between them): both answered, in order. */
static void back_to_back_frames(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[8];
    size_t n = enc_read(f, NODE, 1u, 3u, 4u);
    n += enc_read(f + n, 0u, 0u, 4u, 10u);
    send_frame(r, f, n);
    stream_t s = rs232_stream(r);
    expect_response(&s, 3u, URB_STATUS_OK, 4u, NULL);
    expect_response(&s, 4u, URB_STATUS_OK, 10u, NULL);
    expect_end(&s);
}

/* Every single-bit error of a frame is caught by its check: no response; the next frame is fine. */
static void bad_checksums_get_no_response(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[40];
    uint8_t const payload[4] = {9u, 8u, 7u, 6u};
    size_t const n = enc_write(f, NODE, 1u, 7u, 4u, payload);
    for (size_t bit = 0u; bit < 8u * n; bit++) {
        uint8_t g[40];
        memcpy(g, f, n);
        g[bit / 8u] = (uint8_t)(g[bit / 8u] ^ (1u << (bit % 8u)));
        send_frame(r, g, n);
    }
    assert_int_equal(r->hal.tx_len, 0u);
    assert_int_equal(r->bus.nodes[0].writes[1], 0u);
    send_frame(r, f, enc_read(f, NODE, 1u, 8u, 4u));
    stream_t s = rs232_stream(r);
    expect_response(&s, 8u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* A byte inserted before a frame: hunting discards it and finds the frame without a gap. */
static void inserted_byte_is_hunted_away(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[16];
    for (uint8_t junk = 0u; junk < 4u; junk++) {
        f[0] = (uint8_t)(0x55u + junk * 0x31u);
        size_t n = 1u + enc_read(f + 1, NODE, 1u, junk, 4u);
        urb_hosted_rig_uart_send(r, f, n, BYTE_US); /* no idle gap at all */
        urb_hosted_rig_run(r, 120u);               /* less than a gap */
    }
    urb_hosted_rig_run(r, 1000u);
    stream_t s = rs232_stream(r);
    for (uint8_t junk = 0u; junk < 4u; junk++) {
        expect_response(&s, junk, URB_STATUS_OK, 4u, NULL);
    }
    expect_end(&s);
    /* three junk bytes hunted away, one dropped as a partial frame at the final gap */
    assert_true(urb_bridge_stats(&r->bridge)->hunt_discards >= 2u);
}

/* A byte lost inside a frame followed at once by a good frame: the damaged one is not answered,
 * the good one is found by hunting. */
static void lost_byte_then_good_frame(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[64];
    uint8_t const payload[4] = {1u, 1u, 2u, 3u};
    size_t n = enc_write(f, NODE, 1u, 1u, 4u, payload);
    memmove(f + 3, f + 4, n - 4u); /* drop the first data byte */
    n -= 1u;
    n += enc_read(f + n, NODE, 1u, 2u, 4u);
    n += enc_read(f + n, NODE, 1u, 3u, 4u);
    send_frame(r, f, n);
    stream_t s = rs232_stream(r);
    /* the first read's first byte completed the damaged write: only the second read is sure */
    if (s.len > 0u && (s.bytes[0] & 0x0Fu) == 2u) {
        expect_response(&s, 2u, URB_STATUS_OK, 4u, NULL);
    }
    expect_response(&s, 3u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
    assert_int_equal(r->bus.nodes[0].writes[1], 0u);
}

/* A truncated frame, an idle gap, then a good frame: the partial frame is dropped at the gap and
 * does not swallow or delay the next frame (it announced 20 data bytes). */
static void truncated_frame_dropped_at_gap(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[40];
    uint8_t payload[20] = {0};
    size_t n = enc_write(f, NODE, 1u, 1u, 20u, payload);
    (void)n;
    urb_hosted_rig_uart_send(r, f, 6u, BYTE_US);
    urb_hosted_rig_run(r, 400u); /* idle > 2 byte times */
    send_frame(r, f, enc_read(f, NODE, 1u, 2u, 4u));
    stream_t s = rs232_stream(r);
    expect_response(&s, 2u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
    assert_int_equal(urb_bridge_stats(&r->bridge)->gap_drops, 1u);
}

/* An idle gap of exactly two byte times does not split a frame; a longer one does. */
static void gap_threshold(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[8];
    enc_read(f, NODE, 1u, 4u, 4u);
    /* 87 us per byte + 174 us idle = 261 us between byte ends: still one frame */
    urb_hosted_rig_uart_send(r, f, 2u, BYTE_US);
    urb_hosted_rig_uart_send(r, f + 2, 2u, BYTE_US + 174u);
    urb_hosted_rig_run(r, 1000u);
    enc_read(f, NODE, 1u, 5u, 4u);
    urb_hosted_rig_uart_send(r, f, 2u, BYTE_US);
    urb_hosted_rig_uart_send(r, f + 2, 2u, BYTE_US + 176u); /* split: neither half is answered */
    urb_hosted_rig_run(r, 1000u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 4u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* Oversized: a write announcing 40 bytes cannot be a request (hunted away, no response); extra
 * bytes after a good frame do not hurt it. */
static void oversized_requests(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[64];
    uint8_t payload[32] = {0};
    size_t n = enc_write(f, NODE, 1u, 1u, 32u, payload);
    f[2] = 40u;
    send_frame(r, f, n);
    assert_int_equal(r->hal.tx_len, 0u);
    n = enc_read(f, NODE, 1u, 2u, 4u);
    memset(f + n, 0xEE, 5u); /* junk tail in the same burst */
    send_frame(r, f, n + 5u);
    stream_t s = rs232_stream(r);
    expect_response(&s, 2u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* A frame whose check passes but which breaks a schema rule is answered BAD_REQUEST. */
static void malformed_but_checked_is_bad_request(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[8];
    /* read with length 0 */
    f[0] = (uint8_t)(NODE << 1 | 1u);
    f[1] = (uint8_t)(1u | 6u << 4);
    f[2] = 0u;
    f[3] = (uint8_t)urb_link_check(NULL, 0u, f, 3u);
    send_frame(r, f, 4u);
    /* read with length 33 */
    f[1] = (uint8_t)(1u | 7u << 4);
    f[2] = 33u;
    f[3] = (uint8_t)urb_link_check(NULL, 0u, f, 3u);
    send_frame(r, f, 4u);
    /* reserved bit set */
    f[1] = (uint8_t)(1u | 8u | 8u << 4);
    f[2] = 4u;
    f[3] = (uint8_t)urb_link_check(NULL, 0u, f, 3u);
    send_frame(r, f, 4u);
    /* write with length 0 */
    f[0] = (uint8_t)(NODE << 1);
    f[1] = (uint8_t)(1u | 9u << 4);
    f[2] = 0u;
    f[3] = (uint8_t)urb_link_check(NULL, 0u, f, 3u);
    send_frame(r, f, 4u);
    /* reserved I2C addresses */
    send_frame(r, f, enc_read(f, 0x03u, 1u, 10u, 4u));
    send_frame(r, f, enc_read(f, 0x7Cu, 1u, 11u, 4u));
    /* bridge command with an unknown opcode */
    uint8_t const cmd[3] = {0x77u, 0u, 0u};
    uint8_t w[16];
    send_frame(r, w, enc_write(w, 0u, 0u, 12u, 3u, cmd));
    stream_t s = rs232_stream(r);
    for (uint8_t seq = 6u; seq <= 12u; seq++) {
        expect_response(&s, seq, URB_STATUS_BAD_REQUEST, 0u, NULL);
    }
    expect_end(&s);
}

/* Unknown nodes and mailboxes. */
static void unknown_nodes_and_mailboxes(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[40];
    uint8_t const payload[4] = {0};
    send_frame(r, f, enc_read(f, 0x50u, 1u, 1u, 4u));          /* nobody there */
    send_frame(r, f, enc_write(f, 0x51u, 1u, 2u, 4u, payload)); /* nobody there */
    send_frame(r, f, enc_read(f, NODE, 5u, 3u, 4u));            /* outbox 5 unused (size 0) */
    send_frame(r, f, enc_read(f, NODE, 1u, 4u, 5u));            /* wrong length */
    send_frame(r, f, enc_read(f, 0u, 4u, 5u, 4u));              /* bridge outbox 4 does not exist */
    send_frame(r, f, enc_read(f, 0u, 1u, 6u, 15u));             /* BridgeScan is 16 bytes */
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_NO_NODE, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_NO_NODE, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_response(&s, 4u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_response(&s, 5u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_response(&s, 6u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_end(&s);
}

/* Random bytes: never a crash, never an answer that is not a well-formed response; a good frame
 * after a gap is answered. (Deterministic generator; ASan/UBSan watch the memory.) */
static void garbage_stream(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint32_t x = 0x12345u;
    uint8_t buf[64];
    for (int round = 0; round < 40; round++) {
        for (size_t i = 0u; i < sizeof buf; i++) {
            x = x * 1103515245u + 12345u;
            buf[i] = (uint8_t)(x >> 16);
        }
        urb_hosted_rig_uart_send(r, buf, sizeof buf, BYTE_US);
    }
    urb_hosted_rig_run(r, 100000u);
    assert_true(urb_bridge_outstanding(&r->bridge) == 0u);
    size_t const before = r->hal.tx_len;
    uint8_t f[8];
    send_frame(r, f, enc_read(f, NODE, 1u, 9u, 4u));
    stream_t s = rs232_stream(r);
    s.pos = before;
    expect_response(&s, 9u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

/* More bytes than the receive ring holds between two polls: the overrun breaks the frame in
 * progress (no response), later frames are fine. */
static void receive_overrun(void **state)
{
    urb_hosted_rig_t *r = *state;
    uint8_t f[8];
    enc_read(f, NODE, 1u, 1u, 4u);
    for (unsigned i = 0u; i < URB_BRIDGE_RX_RING + 3u; i++) {
        urb_bridge_uart_rx(&r->bridge, f[i % 4u], r->hal.now); /* no poll in between */
    }
    assert_true(urb_bridge_stats(&r->bridge)->rx_overruns >= 3u);
    assert_true(urb_hosted_rig_settle(r, 50000u));
    size_t const before = r->hal.tx_len;
    assert_int_equal(before % 6u, 0u); /* only whole 6-byte read responses came out */
    send_frame(r, f, enc_read(f, NODE, 1u, 2u, 4u));
    stream_t s = rs232_stream(r);
    s.pos = before;
    expect_response(&s, 2u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
}

int run_rs232_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(bridge_info_read, setup, teardown),
        cmocka_unit_test_setup_teardown(write_then_read_node, setup, teardown),
        cmocka_unit_test_setup_teardown(back_to_back_frames, setup, teardown),
        cmocka_unit_test_setup_teardown(bad_checksums_get_no_response, setup, teardown),
        cmocka_unit_test_setup_teardown(inserted_byte_is_hunted_away, setup, teardown),
        cmocka_unit_test_setup_teardown(lost_byte_then_good_frame, setup, teardown),
        cmocka_unit_test_setup_teardown(truncated_frame_dropped_at_gap, setup, teardown),
        cmocka_unit_test_setup_teardown(gap_threshold, setup, teardown),
        cmocka_unit_test_setup_teardown(oversized_requests, setup, teardown),
        cmocka_unit_test_setup_teardown(malformed_but_checked_is_bad_request, setup, teardown),
        cmocka_unit_test_setup_teardown(unknown_nodes_and_mailboxes, setup, teardown),
        cmocka_unit_test_setup_teardown(garbage_stream, setup, teardown),
        cmocka_unit_test_setup_teardown(receive_overrun, setup, teardown),
    };
    return cmocka_run_group_tests_name("bridge_rs232", tests, NULL, NULL);
}
