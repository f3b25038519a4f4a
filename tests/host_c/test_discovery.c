/*
 * Discovery and the system table against the real bridge firmware (the hosted rig, in virtual
 * time) over RS232 and USB: identification, the node flags, duplicates across bridges, lookup and
 * refusals, retries, no bridge; and the bridge's statuses end to end (a stuck bus, a vanished
 * node, a wrong size, a busy inbox, a corrupt read, a reserved address).
 */
#include "host_test.h"

#include <string.h>

#include "urb_core.h"
#include "urb_sensorhex.h"

static rig_link_t links[2];
static urb_discovery_t disc[2];
static urb_system_t sys;
static pool_t pool;
static int finished;

static void on_done(urb_discovery_t *d, void *user)
{
    (void)d;
    (void)user;
    finished++;
}

static void discover(size_t i, uint32_t max_us)
{
    urb_discovery_init(&disc[i]);
    assert_int_equal(urb_discovery_start(&disc[i], &links[i].core, NULL, true, on_done, NULL, rig_now(&links[i])),
                     URB_HOST_OK);
    assert_int_equal(urb_discovery_start(&disc[i], &links[i].core, NULL, true, on_done, NULL, 0), URB_HOST_ESTATE);
    for (uint32_t t = 0u; (t < max_us) && !urb_discovery_finished(&disc[i]); t += 1000u) {
        rig_run(&links[i], 1000u);
    }
    assert_true(urb_discovery_finished(&disc[i]));
}

static int setup(void **state)
{
    (void)state;
    finished = 0;
    pool_init(&pool);
    urb_system_init(&sys, NULL);
    return 0;
}

static void sensorhex_nodes(rig_link_t *l)
{
    rig_add(l, 0x20u, URB_NODE_MOTOR_DRIVER_CLASS, 0u);
    rig_add(l, 0x30u, URB_NODE_BATTERY_MANAGER_CLASS, 0u);
    rig_add(l, 0x31u, URB_NODE_IMU_CLASS, 0u);
}

static void check_found(const urb_discovery_t *d)
{
    assert_int_equal(d->outcome, URB_DISCOVERY_DONE);
    assert_true(d->have_info);
    assert_int_equal(d->present_count, 3u);
    assert_int_equal(d->node_count, 3u);
    assert_int_equal(d->nodes[0].address, 0x20u); /* by address */
    assert_int_equal(d->nodes[2].ident.class_id, URB_NODE_IMU_CLASS);
    for (size_t k = 0u; k < 3u; k++) {
        assert_int_equal(d->nodes[k].flags, 0u);
        assert_non_null(d->nodes[k].type);
    }
    assert_int_equal(d->problem_count, 0u);
}

static void test_discovery_over_rs232_and_usb(void **state)
{
    (void)state;
    for (size_t i = 0u; i < 2u; i++) {
        rig_link_init(&links[i], i == 1u, NULL);
        sensorhex_nodes(&links[i]);
        rig_run(&links[i], 20000u); /* the bridge's own scan at start */
        discover(i, 3000000u);
        check_found(&disc[i]);
        assert_int_equal(links[i].core.cfg.window, 15u); /* min(BridgeInfo.fifo_depth, 15) */
    }
    assert_int_equal(finished, 2);
    assert_true(links[1].frames > 0u);
}

static void test_flags_unknown_class_mismatch_and_sizes(void **state)
{
    (void)state;
    rig_link_init(&links[0], false, NULL);
    urb_fake_node_t *generic = rig_add(&links[0], 0x40u, 0x42u, 3u); /* a class the schema does not declare */
    generic->in_size[1] = 8u;
    generic->out_size[1] = 8u;
    urb_fake_node_identify(generic);
    urb_fake_node_t *reflashed = rig_add(&links[0], 0x21u, URB_NODE_MOTOR_DRIVER_CLASS, 1u);
    reflashed->fingerprint ^= 1u; /* built from another schema */
    urb_fake_node_identify(reflashed);
    urb_fake_node_t *resized = rig_add(&links[0], 0x22u, URB_NODE_MOTOR_DRIVER_CLASS, 2u);
    resized->out_size[1] = 7u; /* the right fingerprint, other sizes */
    urb_fake_node_identify(resized);
    rig_run(&links[0], 20000u);
    discover(0, 3000000u);
    urb_discovery_t const *d = &disc[0];
    assert_int_equal(d->node_count, 3u);
    assert_int_equal(d->nodes[0].flags, URB_NODE_MISMATCH);     /* 0x21 */
    assert_int_equal(d->nodes[1].flags, URB_NODE_MISMATCH);     /* 0x22 */
    assert_int_equal(d->nodes[2].flags, URB_NODE_UNKNOWN_CLASS); /* 0x40 */
    assert_null(d->nodes[2].type);
    assert_int_equal(d->problem_count, 1u);
    assert_int_equal(d->problems[0].kind, URB_PROBLEM_SIZES_DIFFER);
    assert_int_equal(d->problems[0].address, 0x22u);

    assert_int_equal(urb_system_merge(&sys, 0u, d), URB_HOST_OK);
    urb_find_t why;
    assert_int_equal(urb_system_find(&sys, URB_NODE_MOTOR_DRIVER_CLASS, 1u, &why), URB_HOST_ENOTFOUND);
    assert_int_equal(why, URB_FIND_MISMATCH);
    char text[600];
    const char *names[1] = {"/dev/ttyS0"};
    assert_true(urb_system_describe_find(&sys, URB_NODE_MOTOR_DRIVER_CLASS, 1u, why, names, 1u, text, sizeof text) > 0);
    assert_non_null(strstr(text, "MotorDriver:1 at /dev/ttyS0 address 33 reports layout fingerprint 0xa81f00fd, but "
                                 "the host's schema spec/schema/sensorhex.urbs gives 0xa81f00fc"));
    assert_int_equal(urb_system_find(&sys, 0x42u, 3u, &why), URB_HOST_ENOTFOUND);
    assert_int_equal(why, URB_FIND_UNKNOWN_CLASS);
    assert_true(urb_system_describe_find(&sys, 0x42u, 3u, why, names, 1u, text, sizeof text) > 0);
    assert_string_equal(text, "class 0x42 is not declared in the host's schema; known: MotorDriver (0x10), "
                              "BatteryManager (0x20), Imu (0x30), IrDistance (0x31)");
    /* node_at reaches them anyway, with their own layout */
    int32_t const row = urb_system_at(&sys, 0u, 0x40u);
    assert_true(row >= 0);
    assert_int_equal(urb_system_refusal(&sys, (uint32_t)row, true, true, 1u, 8u), URB_FLAG_NONE);
    assert_int_equal(urb_system_refusal(&sys, (uint32_t)row, true, true, 2u, 8u), URB_FLAG_HOST_SIZE_MISMATCH);
    int32_t const mm = urb_system_at(&sys, 0u, 0x21u);
    assert_int_equal(urb_system_refusal(&sys, (uint32_t)mm, false, true, 1u, 6u), URB_FLAG_FINGERPRINT_MISMATCH);
    assert_int_equal(urb_system_refusal(&sys, (uint32_t)mm, true, true, 1u, 6u), URB_FLAG_NONE);
    assert_int_equal(urb_system_refusal(&sys, 9999u, false, true, 1u, 6u), URB_FLAG_UNKNOWN_NODE);
}

static void test_duplicates_across_bridges_and_rediscovery(void **state)
{
    (void)state;
    for (size_t i = 0u; i < 2u; i++) {
        rig_link_init(&links[i], i == 1u, NULL);
        rig_add(&links[i], 0x20u, URB_NODE_MOTOR_DRIVER_CLASS, 0u); /* the same class and index twice */
        rig_add(&links[i], (uint8_t)(0x21u + i), URB_NODE_MOTOR_DRIVER_CLASS, (uint8_t)(1u + i));
        rig_run(&links[i], 20000u);
        discover(i, 3000000u);
        assert_int_equal(urb_system_merge(&sys, (uint8_t)i, &disc[i]), URB_HOST_OK);
    }
    for (uint8_t b = 0u; b < 2u; b++) { /* both rows flagged (Discovery.tla Flags), never merged */
        int32_t const r = urb_system_at(&sys, b, 0x20u);
        assert_true(r >= 0);
        assert_int_equal(sys.rows[r].flags, URB_NODE_DUPLICATE);
    }
    urb_find_t why;
    assert_int_equal(urb_system_find(&sys, URB_NODE_MOTOR_DRIVER_CLASS, 0u, &why), URB_HOST_ENOTFOUND);
    assert_int_equal(why, URB_FIND_DUPLICATE);
    char text[600];
    const char *names[2] = {"/dev/ttyS0", "/dev/urb_usb0"};
    assert_true(urb_system_describe_find(&sys, URB_NODE_MOTOR_DRIVER_CLASS, 0u, why, names, 2u, text, sizeof text) > 0);
    assert_string_equal(text, "MotorDriver:0 answers at 2 places (/dev/ttyS0 address 32; /dev/urb_usb0 address 32): "
                              "two nodes have the same class and index. Give each a distinct index (URB_SetIndex) and "
                              "rediscover.");
    int32_t const one = urb_system_find(&sys, URB_NODE_MOTOR_DRIVER_CLASS, 1u, &why);
    assert_true(one >= 0);
    assert_int_equal(urb_system_refusal(&sys, (uint32_t)one, false, true, 1u, 6u), URB_FLAG_NONE);
    assert_int_equal(urb_system_refusal(&sys, (uint32_t)one, false, true, 1u, 5u), URB_FLAG_HOST_SIZE_MISMATCH);
    assert_int_equal(urb_system_refusal(&sys, (uint32_t)one, false, true, 3u, 1u), URB_FLAG_HOST_SIZE_MISMATCH);
    uint32_t rows[8];
    assert_int_equal(urb_system_list(&sys, rows, 8u), 4u);
    /* the node at 0x20 of the USB bridge unplugged; rediscovery of that bridge: its duplicate is gone, the
     * other row keeps its place (accessors stay valid), the vanished one answers UNKNOWN_NODE */
    links[1].rig.bus.nodes[0].present = false;
    discover(1, 3000000u);
    assert_int_equal(urb_system_merge(&sys, 1u, &disc[1]), URB_HOST_OK);
    assert_true(urb_system_find(&sys, URB_NODE_MOTOR_DRIVER_CLASS, 0u, &why) >= 0);
    int32_t const two = urb_system_find(&sys, URB_NODE_MOTOR_DRIVER_CLASS, 2u, &why);
    assert_true(two >= 0);
    assert_int_equal(urb_system_list(&sys, rows, 8u), 3u);
    urb_system_forget(&sys, 1u);
    assert_int_equal(urb_system_refusal(&sys, (uint32_t)two, false, true, 1u, 6u), URB_FLAG_UNKNOWN_NODE);
    assert_int_equal(urb_system_find(&sys, URB_NODE_MOTOR_DRIVER_CLASS, 9u, &why), URB_HOST_ENOTFOUND);
    assert_int_equal(why, URB_FIND_NOT_FOUND);
}

static void test_a_corrupt_identification_is_read_three_times(void **state)
{
    (void)state;
    rig_link_init(&links[0], false, NULL);
    urb_fake_node_t *n = rig_add(&links[0], 0x20u, URB_NODE_MOTOR_DRIVER_CLASS, 0u);
    rig_run(&links[0], 20000u);
    n->corrupt_read = true; /* every read fails its check at the bridge: CHECKSUM */
    uint32_t const before = n->reads;
    discover(0, 3000000u);
    assert_int_equal(disc[0].outcome, URB_DISCOVERY_DONE);
    assert_int_equal(disc[0].node_count, 0u);
    assert_int_equal(disc[0].problem_count, 1u);
    assert_int_equal(disc[0].problems[0].kind, URB_PROBLEM_IDENT_FAILED);
    assert_int_equal(disc[0].problems[0].flags, URB_FLAG_CHECKSUM);
    assert_true(n->reads - before >= 3u + 1u); /* the scan's read, then ours and its two retries */
}

static void test_noise_is_no_bridge(void **state)
{
    (void)state;
    urb_core_t core;
    urb_discovery_t *d = &disc[0];
    assert_int_equal(urb_core_init(&core, URB_LINK_RS232, NULL), URB_HOST_OK);
    urb_discovery_init(d);
    assert_int_equal(urb_discovery_start(d, &core, NULL, true, on_done, NULL, 0), URB_HOST_OK);
    uint8_t frame[URB_REQUEST_MAX];
    assert_int_equal(urb_core_next_frame(&core, 0, frame, sizeof frame), 4);
    uint8_t const noise[7] = {0xF3, 0x00, 0x9C, 0xFF, 0x12, 0xE0, 0x7A};
    assert_int_equal(urb_core_receive(&core, noise, sizeof noise, MS), URB_HOST_OK);
    (void)urb_core_poll(&core, 100 * MS);
    urb_core_dispatch(&core, 100 * MS);
    assert_int_equal(d->outcome, URB_DISCOVERY_NO_BRIDGE);
    char text[600];
    assert_true(urb_discovery_describe(d, "/dev/ttyUSB0", text, sizeof text) > 0);
    assert_string_equal(text, "no URB bridge answered on /dev/ttyUSB0 (7 byte(s) came back, none of them a URB "
                              "bridge's identification: what a wrong baud rate or another device looks like). Check "
                              "that the baud rate matches the bridge firmware's, that /dev/ttyUSB0 is the bridge's "
                              "device, and that the bridge is powered and connected.");
    assert_int_equal(urb_system_merge(&sys, 0u, d), URB_HOST_ESTATE);
    assert_int_equal(urb_discovery_describe(d, "x", text, 10u), URB_HOST_ENOSPC);
}

/* One request through the firmware, its flag. */
static urb_flags_t exchange(rig_link_t *l, urb_transfer_t *t)
{
    assert_int_equal(urb_transfer_set_callback(t, pool_record, &pool), URB_HOST_OK);
    assert_int_equal(urb_core_submit(&l->core, t, rig_now(l)), URB_HOST_OK);
    size_t const before = pool.count;
    for (uint32_t us = 0u; (us < 400000u) && (pool.count == before); us += 500u) {
        rig_run(l, 500u);
    }
    assert_int_equal(pool.count, before + 1u);
    return t->flags;
}

static void test_bridge_statuses_end_to_end(void **state)
{
    (void)state;
    for (size_t i = 0u; i < 2u; i++) {
        pool_init(&pool);
        rig_link_t *l = &links[i];
        rig_link_init(l, i == 1u, NULL);
        urb_fake_node_t *n = rig_add(l, 0x20u, URB_NODE_MOTOR_DRIVER_CLASS, 0u);
        rig_run(l, 20000u);
        urb_transfer_t *t = pool.t;
        assert_int_equal(urb_transfer_read(&t[0], 0x20u, 1u, 6u), URB_HOST_OK);
        assert_int_equal(exchange(l, &t[0]), URB_FLAG_NONE);
        assert_int_equal(t[0].response_len, 6u);
        assert_int_equal(urb_transfer_read(&t[1], 0x20u, 1u, 5u), URB_HOST_OK);
        assert_int_equal(exchange(l, &t[1]), URB_FLAG_SIZE_MISMATCH); /* the bridge knows 6 */
        uint8_t const cmd[2] = {0x10, 0x27};
        n->inbox_busy = true;
        assert_int_equal(urb_transfer_write(&t[2], 0x20u, 1u, cmd, 2u), URB_HOST_OK);
        assert_int_equal(exchange(l, &t[2]), URB_FLAG_NODE_BUSY);
        n->inbox_busy = false;
        n->corrupt_read = true;
        assert_int_equal(urb_transfer_read(&t[3], 0x20u, 1u, 6u), URB_HOST_OK);
        assert_int_equal(exchange(l, &t[3]), URB_FLAG_CHECKSUM);
        n->corrupt_read = false;
        assert_int_equal(urb_transfer_read(&t[4], 0x05u, 1u, 6u), URB_HOST_OK); /* a reserved address */
        assert_int_equal(exchange(l, &t[4]), URB_FLAG_BAD_REQUEST);
        n->hold_scl = true; /* a node holding the clock low: the bus cannot be cleared */
        assert_int_equal(urb_transfer_read(&t[5], 0x20u, 1u, 6u), URB_HOST_OK);
        assert_int_equal(exchange(l, &t[5]), URB_FLAG_BUS_STUCK);
        n->hold_scl = false;
        rig_run(l, 20000u);
        n->present = false; /* unplugged */
        assert_int_equal(urb_transfer_read(&t[6], 0x20u, 1u, 6u), URB_HOST_OK);
        assert_int_equal(exchange(l, &t[6]), URB_FLAG_NO_NODE);
        pool_all_once(&pool, 7u);
        assert_null(urb_core_lost_reason(&l->core));
    }
}

static void test_a_bridge_that_disappears_loses_nothing(void **state)
{
    (void)state;
    for (size_t i = 0u; i < 2u; i++) {
        pool_init(&pool);
        rig_link_t *l = &links[i];
        rig_link_init(l, i == 1u, NULL);
        rig_add(l, 0x20u, URB_NODE_MOTOR_DRIVER_CLASS, 0u);
        rig_run(l, 20000u);
        for (size_t k = 0u; k < 40u; k++) {
            assert_int_equal(urb_transfer_read(&pool.t[k], 0x20u, 1u, 6u), URB_HOST_OK);
            assert_int_equal(urb_transfer_set_callback(&pool.t[k], pool_record, &pool), URB_HOST_OK);
            assert_int_equal(urb_core_submit(&l->core, &pool.t[k], rig_now(l)), URB_HOST_OK);
            if (k == 20u) { /* the bridge goes away: the firmware stops answering */
                l->dead = true;
            }
            rig_run(l, 300u);
        }
        rig_run(l, 600000u);
        pool_all_once(&pool, 40u); /* every request ended, once: timed out, or lost when the window kept
                                      requests outstanding for 500 ms of silence (RS232's window of 4) */
        for (size_t k = 40u; k < 50u; k++) { /* sparse reads: else the first timeout after 500 ms of silence
                                                 and 8 in a row declares it lost (USB's window of 15) */
            assert_int_equal(urb_transfer_read(&pool.t[k], 0x20u, 1u, 6u), URB_HOST_OK);
            assert_int_equal(urb_transfer_set_callback(&pool.t[k], pool_record, &pool), URB_HOST_OK);
            assert_int_equal(urb_core_submit(&l->core, &pool.t[k], rig_now(l)), URB_HOST_OK);
            rig_run(l, 400000u);
        }
        pool_all_once(&pool, 50u);
        assert_non_null(urb_core_lost_reason(&l->core));
        assert_int_equal(pool.t[49].flags, URB_FLAG_BRIDGE_LOST);
    }
}

int run_discovery_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_discovery_over_rs232_and_usb, setup),
        cmocka_unit_test_setup(test_flags_unknown_class_mismatch_and_sizes, setup),
        cmocka_unit_test_setup(test_duplicates_across_bridges_and_rediscovery, setup),
        cmocka_unit_test_setup(test_a_corrupt_identification_is_read_three_times, setup),
        cmocka_unit_test_setup(test_noise_is_no_bridge, setup),
        cmocka_unit_test_setup(test_bridge_statuses_end_to_end, setup),
        cmocka_unit_test_setup(test_a_bridge_that_disappears_loses_nothing, setup),
    };
    return cmocka_run_group_tests_name("host_c_discovery", tests, NULL, NULL);
}
