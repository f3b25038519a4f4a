/*
 * Discovery (Discovery.tla): the scan visits every address (gaps never end it), reports exactly the
 * nodes that answered, learns their sizes, never merges duplicates; nodes appear and vanish.
 */
#include <string.h>

#include "support.h"

static int teardown(void **state)
{
    rig_free(*state);
    return 0;
}

static void read_scan_map(urb_hosted_rig_t *r, uint8_t seq, urb_bridge_scan_t *scan)
{
    uint8_t f[8];
    uint8_t data[32];
    size_t const before = r->hal.tx_len;
    send_frame(r, f, enc_read(f, 0u, 1u, seq, 16u));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    stream_t s = rs232_stream(r);
    s.pos = before;
    expect_response(&s, seq, URB_STATUS_OK, 16u, data);
    expect_end(&s);
    assert_int_equal(urb_bridge_scan_decode(scan, data, 16u), 16);
}

static void scan_command(urb_hosted_rig_t *r, uint8_t seq)
{
    uint8_t const cmd[3] = {URB_BRIDGE_OPCODE_SCAN, 0u, 0u};
    uint8_t f[16];
    send_frame(r, f, enc_write(f, 0u, 0u, seq, 3u, cmd));
    assert_true(urb_hosted_rig_settle(r, 200000u));
}

/* Nodes at both ends of the range and in the middle, with gaps between: all found, nothing else;
 * two nodes with the same (class, index) are two entries (duplicates are the host's business). */
static void scan_finds_exactly_the_nodes(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    uint8_t const addrs[] = {0x08u, 0x21u, 0x22u, 0x55u, 0x77u};
    for (uint8_t i = 0u; i < sizeof addrs; i++) {
        add_node(r, addrs[i], 0x42u, (i == 2u) ? 1u : i, 4u, 4u); /* 0x21 and 0x22 are duplicates */
    }
    rig_start(r);
    urb_bridge_scan_t scan;
    read_scan_map(r, 1u, &scan);
    for (uint8_t a = 0u; a < 128u; a++) {
        bool expected = false;
        for (uint8_t i = 0u; i < sizeof addrs; i++) {
            expected = expected || (addrs[i] == a);
        }
        assert_int_equal(scan.present[a], expected);
        assert_int_equal(urb_bridge_present(&r->bridge, a), expected);
    }
    assert_int_equal(urb_bridge_stats(&r->bridge)->scans, 1u);
    /* sizes learnt: a wrong length is refused by the bridge itself, no downlink traffic */
    uint32_t const starts = r->bus.starts;
    uint8_t f[8];
    send_frame(r, f, enc_read(f, 0x77u, 1u, 2u, 5u));
    assert_int_equal(r->bus.starts, starts);
    stream_t s = rs232_stream(r);
    s.pos = 2u + 16u + 1u;
    expect_response(&s, 2u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_end(&s);
}

/* A node vanishes: requests to it get NO_NODE (its sizes are still known); a rescan drops it from
 * the map and forgets its sizes. It comes back: requests work before the next scan (no refusal
 * of an address the scan did not find), and the next scan finds it. */
static void nodes_vanish_and_appear(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    urb_fake_node_t *a = add_node(r, 0x30u, 0x42u, 0u, 4u, 4u);
    urb_fake_node_t *late = add_node(r, 0x31u, 0x43u, 0u, 2u, 2u);
    late->present = false;
    rig_start(r);
    uint8_t f[8];
    a->present = false;
    send_frame(r, f, enc_read(f, 0x30u, 1u, 1u, 4u)); /* NO_NODE (VanishedGetNoNode) */
    send_frame(r, f, enc_read(f, 0x30u, 1u, 2u, 3u)); /* sizes still known */
    late->present = true;
    send_frame(r, f, enc_read(f, 0x31u, 1u, 3u, 2u)); /* appeared after the scan: served */
    assert_true(urb_hosted_rig_settle(r, 50000u));
    scan_command(r, 4u);
    urb_bridge_scan_t scan;
    read_scan_map(r, 5u, &scan);
    assert_false(scan.present[0x30]);
    assert_true(scan.present[0x31]);
    send_frame(r, f, enc_read(f, 0x30u, 1u, 6u, 3u)); /* sizes forgotten: goes to the bus */
    a->present = true;
    send_frame(r, f, enc_read(f, 0x31u, 1u, 7u, 3u)); /* sizes learnt by the scan */
    assert_true(urb_hosted_rig_settle(r, 50000u));
    stream_t s = rs232_stream(r);
    expect_response(&s, 1u, URB_STATUS_NO_NODE, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_response(&s, 3u, URB_STATUS_OK, 2u, NULL);
    expect_response(&s, 4u, URB_STATUS_OK, 0u, NULL);
    expect_response(&s, 5u, URB_STATUS_OK, 16u, NULL);
    expect_response(&s, 6u, URB_STATUS_NO_NODE, 0u, NULL);
    expect_response(&s, 7u, URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_end(&s);
    assert_int_equal(urb_bridge_stats(&r->bridge)->scans, 2u);
}

/* The SCAN command is answered when the scan is over; requests behind it wait and then see the
 * new state. A node that answers its address but not its identification is present, with sizes
 * unknown (its requests go to the node). */
static void scan_command_orders_and_unreadable_identification(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    urb_fake_node_t *n = add_node(r, 0x40u, 0x42u, 0u, 4u, 4u);
    rig_start(r);
    n->corrupt_read = true;
    uint8_t const cmd[3] = {URB_BRIDGE_OPCODE_SCAN, 0u, 0u};
    uint8_t f[32];
    size_t len = enc_write(f, 0u, 0u, 1u, 3u, cmd);
    len += enc_read(f + len, 0u, 1u, 2u, 16u);
    send_frame(r, f, len);
    assert_true(urb_hosted_rig_settle(r, 200000u));
    /* a 5-byte read was refused before: now the bridge does not know the size and asks the node */
    n->corrupt_read = false;
    send_frame(r, f, enc_read(f, 0x40u, 1u, 3u, 5u));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    stream_t s = rs232_stream(r);
    uint8_t data[32];
    expect_response(&s, 1u, URB_STATUS_OK, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_OK, 16u, data);
    expect_response(&s, 3u, URB_STATUS_CHECKSUM, 0u, NULL); /* 5 bytes asked of a 4-byte outbox */
    expect_end(&s);
    urb_bridge_scan_t scan;
    assert_int_equal(urb_bridge_scan_decode(&scan, data, 16u), 16);
    assert_true(scan.present[0x40]);
}

/* A scan with no node at all terminates (DiscoveryCompletes) and reports an empty map. */
static void empty_bus(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    rig_start(r);
    urb_bridge_scan_t scan;
    read_scan_map(r, 1u, &scan);
    for (uint8_t a = 0u; a < 128u; a++) {
        assert_false(scan.present[a]);
    }
}

/* The node table is bounded: more nodes than URB_BRIDGE_MAX_NODES are present in the map; the
 * extra ones just have no sizes remembered. */
static void more_nodes_than_table(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    for (uint8_t i = 0u; i < URB_FAKE_MAX_NODES; i++) {
        add_node(r, (uint8_t)(0x10u + i), 0x42u, i, 4u, 4u);
    }
    rig_start(r);
    for (uint8_t i = 0u; i < URB_FAKE_MAX_NODES; i++) {
        assert_true(urb_bridge_present(&r->bridge, (uint8_t)(0x10u + i)));
    }
}

/* Three bridges in one process (as the simulation runs them): no shared state. Each finds its own
 * nodes, answers its own requests, and keeps its own SYNC counter. */
static void three_bridges_one_process(void **state)
{
    (void)state;
    urb_hosted_rig_t *r[3];
    for (uint8_t k = 0u; k < 3u; k++) {
        r[k] = rig_new((uint8_t)(4u + k), (uint16_t)(500u * (k + 1u)));
        add_node(r[k], (uint8_t)(0x20u + k), 0x42u, k, 4u, 4u);
    }
    uint8_t f[3][8];
    for (uint8_t k = 0u; k < 3u; k++) {
        enc_read(f[k], (uint8_t)(0x20u + k), 1u, k, 4u);
    }
    /* interleave the three rigs, one iteration each per microsecond */
    for (uint32_t t = 0u; t < 30000u; t++) {
        for (uint8_t k = 0u; k < 3u; k++) {
            r[k]->hal.now++;
            if (t >= 10000u && t < 10004u) {
                urb_bridge_uart_rx(&r[k]->bridge, f[k][t - 10000u], r[k]->hal.now);
            }
            urb_hosted_rig_iterate(r[k]);
        }
    }
    for (uint8_t k = 0u; k < 3u; k++) {
        for (uint8_t a = 0x20u; a < 0x23u; a++) {
            assert_int_equal(urb_bridge_present(&r[k]->bridge, a), a == 0x20u + k);
        }
        stream_t s = rs232_stream(r[k]);
        uint8_t data[32];
        expect_response(&s, k, URB_STATUS_OK, 4u, data);
        expect_end(&s);
        assert_int_equal(data[0], 0x20u + k);
        uint32_t const syncs = r[k]->bus.nodes[0].syncs;
        assert_true(syncs >= 60u / (k + 1u) - 2u && syncs <= 60u / (k + 1u));
        rig_free(r[k]);
    }
}

int run_discovery_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(scan_finds_exactly_the_nodes, teardown),
        cmocka_unit_test_teardown(nodes_vanish_and_appear, teardown),
        cmocka_unit_test_teardown(scan_command_orders_and_unreadable_identification, teardown),
        cmocka_unit_test_teardown(empty_bus, teardown),
        cmocka_unit_test_teardown(more_nodes_than_table, teardown),
        cmocka_unit_test(three_bridges_one_process),
    };
    return cmocka_run_group_tests_name("bridge_discovery", tests, NULL, NULL);
}
