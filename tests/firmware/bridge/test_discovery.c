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
/* lobster-trace: urb.DSC_004, urb.DSC_005 */
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
/* lobster-trace: urb.DSC_006 */
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
 * unknown: its next request reads the identification again first. */
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
    /* still unreadable: the request is answered CHECKSUM and does not reach the node */
    uint32_t const reads = n->reads;
    send_frame(r, f, enc_read(f, 0x40u, 1u, 3u, 4u));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    assert_int_equal(n->reads, reads + 1u);
    /* readable again: the identification is read before the request, which is checked against it */
    n->corrupt_read = false;
    send_frame(r, f, enc_read(f, 0x40u, 1u, 4u, 5u));
    send_frame(r, f, enc_read(f, 0x40u, 1u, 5u, 4u));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    assert_int_equal(n->reads, reads + 3u); /* its identification, then the 4-byte read */
    stream_t s = rs232_stream(r);
    uint8_t data[32];
    expect_response(&s, 1u, URB_STATUS_OK, 0u, NULL);
    expect_response(&s, 2u, URB_STATUS_OK, 16u, data);
    expect_response(&s, 3u, URB_STATUS_CHECKSUM, 0u, NULL);
    expect_response(&s, 4u, URB_STATUS_SIZE_MISMATCH, 0u, NULL); /* 5 bytes asked of a 4-byte outbox */
    expect_response(&s, 5u, URB_STATUS_OK, 4u, NULL);
    expect_end(&s);
    urb_bridge_scan_t scan;
    assert_int_equal(urb_bridge_scan_decode(&scan, data, 16u), 16);
    assert_true(scan.present[0x40]);
}

/* A scan with no node at all terminates (DiscoveryCompletes) and reports an empty map. */
/* lobster-trace: urb.DSC_004 */
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

/* The node table is bounded (URB_BRIDGE_MAX_NODES entries, filled in scan order); the fake bus holds
 * more nodes than that. */
#if URB_FAKE_MAX_NODES <= URB_BRIDGE_MAX_NODES
#error "more_nodes_than_table needs a fake bus with more nodes than the bridge's node table"
#endif
#define TABLE_NODES ((uint8_t)URB_BRIDGE_MAX_NODES)
#define ALL_NODES ((uint8_t)URB_FAKE_MAX_NODES)

/* Outbox 1 and inbox 1 of the i-th node (address 0x10 + i): every node in the table has a size of
 * its own (1..32), and no extra node has the size of the first one (1), so an extra node whose
 * sizes landed in another node's entry shows. */
static uint8_t box_size(uint8_t i)
{
    return (i < TABLE_NODES) ? (uint8_t)(1u + (i % 32u)) : (uint8_t)(2u + 3u * ((i - TABLE_NODES) % 10u));
}

/* One read of outbox 1, answered alone: its status, for an OK read the node's data (add_node fills
 * outbox 1 with address + i), and whether it went to the bus or was answered by the bridge itself. */
static void read_alone(urb_hosted_rig_t *r, uint8_t address, uint8_t length, uint8_t seq, uint8_t status, bool on_bus)
{
    uint8_t f[8];
    uint8_t data[32];
    size_t const before = r->hal.tx_len;
    uint32_t const starts = r->bus.starts;
    send_frame(r, f, enc_read(f, address, 1u, seq, length));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    if (on_bus != (r->bus.starts != starts)) {
        print_error("read of %u bytes at 0x%02x: %s the bus\n", length, address, on_bus ? "did not reach" : "reached");
    }
    assert_int_equal(r->bus.starts != starts, on_bus);
    stream_t s = rs232_stream(r);
    s.pos = before;
    bool const ok = status == URB_STATUS_OK;
    expect_response(&s, seq, status, ok ? length : 0u, data);
    expect_end(&s);
    for (uint8_t i = 0u; ok && (i < length); i++) {
        assert_int_equal(data[i], (uint8_t)(address + i));
    }
}

/* A length that differs from the i-th node's outbox 1. */
static uint8_t wrong_length(uint8_t i)
{
    return (box_size(i) < 32u) ? (uint8_t)(box_size(i) + 1u) : (uint8_t)(box_size(i) - 1u);
}

/* More nodes than URB_BRIDGE_MAX_NODES: all of them are in the map and served. The first
 * URB_BRIDGE_MAX_NODES the scan finds keep their own sizes (a wrong length is refused by the bridge,
 * no downlink traffic); the extra ones have no sizes remembered: each of their requests reads the
 * node's identification first (downlink traffic) and is checked against it, a write shorter than
 * the inbox included, and they take no remembered node's entry. A node forgotten by a rescan frees
 * its entry for an extra one. */
static void more_nodes_than_table(void **state)
{
    urb_hosted_rig_t *r = rig_new(16u, 0u);
    *state = r;
    urb_fake_node_t *node[ALL_NODES];
    for (uint8_t i = 0u; i < ALL_NODES; i++) {
        node[i] = add_node(r, (uint8_t)(0x10u + i), 0x42u, i, box_size(i), box_size(i));
    }
    rig_start(r);
    urb_bridge_scan_t scan;
    read_scan_map(r, 0u, &scan);
    for (uint8_t a = 0u; a < 128u; a++) {
        bool const expected = (a >= 0x10u) && (a < 0x10u + ALL_NODES);
        assert_int_equal(scan.present[a], expected);
        assert_int_equal(urb_bridge_present(&r->bridge, a), expected);
    }
    uint8_t seq = 1u;
    for (uint8_t i = 0u; i < ALL_NODES; i++) {
        uint8_t const a = (uint8_t)(0x10u + i);
        bool const remembered = i < TABLE_NODES;
        read_alone(r, a, box_size(i), (seq++) & 0x0Fu, URB_STATUS_OK, true);
        read_alone(r, a, wrong_length(i), (seq++) & 0x0Fu, URB_STATUS_SIZE_MISMATCH, !remembered);
    }
    /* a write shorter than an extra node's inbox is refused, not acknowledged and dropped */
    uint8_t const extra = TABLE_NODES;
    uint8_t payload[32];
    for (uint8_t i = 0u; i < 32u; i++) {
        payload[i] = (uint8_t)(0x10u + extra + i); /* what its outbox 1 holds: the echo changes nothing */
    }
    uint8_t f[40];
    size_t const before = r->hal.tx_len;
    send_frame(r, f, enc_write(f, (uint8_t)(0x10u + extra), 1u, (seq++) & 0x0Fu, (uint8_t)(box_size(extra) - 1u),
                               payload));
    send_frame(r, f, enc_write(f, (uint8_t)(0x10u + extra), 1u, (seq++) & 0x0Fu, box_size(extra), payload));
    assert_true(urb_hosted_rig_settle(r, 50000u));
    stream_t s = rs232_stream(r);
    s.pos = before;
    expect_response(&s, (uint8_t)((seq - 2u) & 0x0Fu), URB_STATUS_SIZE_MISMATCH, 0u, NULL);
    expect_response(&s, (uint8_t)((seq - 1u) & 0x0Fu), URB_STATUS_OK, 0u, NULL);
    expect_end(&s);
    assert_int_equal(node[extra]->writes[1], 1u);
    assert_int_equal(node[extra]->aborted_writes, 0u);
    /* after the extra nodes were seen (again) by a rescan, the first node's entry still holds its sizes */
    scan_command(r, (seq++) & 0x0Fu);
    read_alone(r, 0x10u, box_size(0u), (seq++) & 0x0Fu, URB_STATUS_OK, true);
    read_alone(r, 0x10u, 2u, (seq++) & 0x0Fu, URB_STATUS_SIZE_MISMATCH, false);
    read_alone(r, (uint8_t)(0x10u + TABLE_NODES), box_size(0u), (seq++) & 0x0Fu, URB_STATUS_SIZE_MISMATCH, true);
    /* the first node vanishes: the next scan forgets it, and the first extra node takes its entry */
    node[0]->present = false;
    scan_command(r, (seq++) & 0x0Fu);
    read_scan_map(r, (seq++) & 0x0Fu, &scan);
    assert_false(scan.present[0x10]);
    assert_true(scan.present[0x10u + TABLE_NODES]);
    read_alone(r, 0x10u, box_size(0u), (seq++) & 0x0Fu, URB_STATUS_NO_NODE, true);
    read_alone(r, (uint8_t)(0x10u + TABLE_NODES), wrong_length(TABLE_NODES), (seq++) & 0x0Fu,
               URB_STATUS_SIZE_MISMATCH, false);
    read_alone(r, (uint8_t)(0x10u + TABLE_NODES), box_size(TABLE_NODES), (seq++) & 0x0Fu, URB_STATUS_OK, true);
    read_alone(r, (uint8_t)(0x11u + TABLE_NODES), wrong_length(TABLE_NODES + 1u), (seq++) & 0x0Fu,
               URB_STATUS_SIZE_MISMATCH, true);
    read_alone(r, 0x11u, wrong_length(1u), (seq++) & 0x0Fu, URB_STATUS_SIZE_MISMATCH, false);
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
