/*
 * The Linux port: the hand-over record (names, format, caps, an unwritable directory), opening
 * serial ports (every refusal with its message), and the event loop over a SOCK_SEQPACKET pair
 * (USB) and a pseudo-terminal (RS232) to the bridge firmware running on a thread: discovery,
 * requests, refusals, a draining close, submissions after it, a bridge that goes away, the loop
 * on its own thread, a blocking call inside a callback.
 */
#include "host_test.h"

#include <errno.h>
#include <fcntl.h>
#include <pty.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include "urb_sensorhex.h"

static char dir[256];
static urb_loop_t loop;
static bridge_thread_t bridge;
static pool_t pool;

static int setup_dir(void **state)
{
    (void)state;
    (void)snprintf(dir, sizeof dir, "/tmp/urb-host-c-test-%ld", (long)getpid());
    (void)mkdir(dir, 0700);
    return 0;
}

static int teardown_dir(void **state)
{
    (void)state;
    char cmd[300];
    (void)snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void test_record_names_follow_handover_py(void **state)
{
    (void)state;
    urb_handover_t h;
    assert_int_equal(urb_handover_init(&h, "/dev/ttyUSB0", "/state"), URB_HOST_OK);
    assert_string_equal(h.path, "/state/dev_ttyUSB0.handover");
    assert_int_equal(urb_handover_init(&h, "//tmp/./a/../urb0/", "/s"), URB_HOST_OK);
    assert_string_equal(h.path, "/s/tmp_urb0.handover");
    assert_int_equal(urb_handover_init(NULL, "/x", NULL), URB_HOST_EINVAL);
    (void)setenv("URB_STATE_DIR", "/from/env", 1);
    assert_int_equal(urb_handover_init(&h, "/dev/ttyS0", NULL), URB_HOST_OK);
    assert_string_equal(h.path, "/from/env/dev_ttyS0.handover");
    (void)unsetenv("URB_STATE_DIR");
    (void)setenv("XDG_RUNTIME_DIR", "/run/user/7", 1);
    assert_int_equal(urb_handover_init(&h, "/dev/ttyS0", NULL), URB_HOST_OK);
    assert_string_equal(h.path, "/run/user/7/urb/dev_ttyS0.handover");
    (void)unsetenv("XDG_RUNTIME_DIR");
}

static void test_record_cover_settle_and_read_back(void **state)
{
    (void)state;
    urb_handover_t h;
    char sub[300];
    (void)snprintf(sub, sizeof sub, "%s/new/dir", dir); /* made on first use */
    assert_int_equal(urb_handover_init(&h, "/dev/ttyS9", sub), URB_HOST_OK);
    urb_ns_t const now = urb_now_ns();
    assert_int_equal(urb_handover_predecessor_until(&h, now), URB_NO_TIME);
    assert_int_equal(urb_handover_cover(&h, now + 300 * MS, now), URB_HOST_OK);
    urb_ns_t const until = urb_handover_predecessor_until(&h, urb_now_ns());
    urb_ns_t const want = now + 300 * MS + URB_HANDOVER_AHEAD_NS; /* written ahead by a second */
    assert_true((until > want - 50 * MS) && (until < want + 50 * MS));
    FILE *f = fopen(h.path, "r");
    assert_non_null(f);
    char text[64] = {0};
    assert_non_null(fgets(text, sizeof text, f));
    (void)fclose(f);
    assert_true(strlen(text) > 10u && text[strlen(text) - 1u] == '\n'); /* wall-clock ns, then a newline */
    assert_int_equal(urb_handover_settle(&h, now + 100 * MS, now), URB_HOST_OK); /* the exact instant */
    urb_ns_t const exact = urb_handover_predecessor_until(&h, urb_now_ns());
    assert_true((exact > now + 50 * MS) && (exact < now + 150 * MS));
    assert_int_equal(urb_handover_settle(&h, URB_NO_TIME, now), URB_HOST_OK); /* a drained close */
    assert_int_equal(urb_handover_predecessor_until(&h, now), URB_NO_TIME);
    f = fopen(h.path, "w");
    assert_non_null(f);
    (void)fputs("not a number\n", f);
    (void)fclose(f);
    assert_int_equal(urb_handover_predecessor_until(&h, 5), 5 + URB_PLACEHOLDER_NS); /* unreadable */
    f = fopen(h.path, "w");
    (void)fputs("99999999999999999999999\n", f); /* a clock set back, a damaged file: at most 10 s */
    (void)fclose(f);
    assert_int_equal(urb_handover_predecessor_until(&h, 5), 5 + URB_HANDOVER_MAX_WAIT_NS);
}

static void test_an_unwritable_directory_is_said_once(void **state)
{
    (void)state;
    /* a file in the way of the directory: fails for root too */
    char blocker[300];
    (void)snprintf(blocker, sizeof blocker, "%s/plainfile", dir);
    FILE *f = fopen(blocker, "w");
    assert_non_null(f);
    (void)fclose(f);
    char sub[320];
    (void)snprintf(sub, sizeof sub, "%s/sub", blocker);
    urb_handover_t h;
    assert_int_equal(urb_handover_init(&h, "/dev/ttyS1", sub), URB_HOST_OK);
    assert_int_equal(urb_handover_cover(&h, 1, 0), URB_HOST_EIO);
    assert_true(h.warned);
    assert_non_null(strstr(h.error, "Set URB_STATE_DIR to a writable directory."));
    char first[sizeof h.error];
    (void)snprintf(first, sizeof first, "%s", h.error);
    assert_int_equal(urb_handover_cover(&h, 2 * URB_NS_PER_S, 0), URB_HOST_EIO);
    assert_string_equal(h.error, first);
}

static void test_serial_open_says_what_is_wrong(void **state)
{
    (void)state;
    int fd = -1;
    char err[600];
    assert_int_equal(urb_serial_open("/dev/no-such-port", 115200u, &fd, NULL, err, sizeof err), URB_HOST_EIO);
    assert_non_null(strstr(err, "/dev/no-such-port: no such port. Check the path and the cable"));
    assert_int_equal(urb_serial_open(dir, 115200u, &fd, NULL, err, sizeof err), URB_HOST_EIO);
    assert_non_null(strstr(err, "is a directory, not a serial port"));
    char file[300];
    (void)snprintf(file, sizeof file, "%s/regular", dir);
    FILE *f = fopen(file, "w");
    (void)fclose(f);
    assert_int_equal(urb_serial_open(file, 115200u, &fd, NULL, err, sizeof err), URB_HOST_EIO);
    assert_non_null(strstr(err, "not a serial port (a regular file)"));
    assert_int_equal(urb_serial_open(file, 12345u, &fd, NULL, err, sizeof err), URB_HOST_EINVAL);
    assert_non_null(strstr(err, "invalid serial setting"));
    int master = -1;
    int slave = -1;
    char name[128];
    assert_int_equal(openpty(&master, &slave, name, NULL, NULL), 0);
    bool low = true;
    assert_int_equal(urb_serial_open(name, 115200u, &fd, &low, err, sizeof err), URB_HOST_OK);
    assert_false(low); /* a pty has no ASYNC_LOW_LATENCY: not an error */
    int other = -1;
    assert_int_equal(urb_serial_open(name, 115200u, &other, NULL, err, sizeof err), URB_HOST_EIO);
    assert_non_null(strstr(err, "the port is in use by another program"));
    urb_serial_close(fd);
    assert_int_equal(urb_serial_open(name, 115200u, &fd, NULL, err, sizeof err), URB_HOST_OK); /* the lock went */
    urb_serial_close(fd);
    (void)close(slave);
    (void)close(master);
    assert_int_equal(urb_usbdev_open("/dev/no-such-urb", &fd, err, sizeof err), URB_HOST_EIO);
    assert_non_null(strstr(err, "cannot open the USB bridge device"));
}

/* ----- the loop ------------------------------------------------------------------------------------- */

static int lost_calls;
static size_t completed_at_lost;

static void on_lost(urb_manager_t *m, const char *reason, void *user)
{
    (void)m;
    (void)user;
    assert_non_null(reason);
    lost_calls++;
    completed_at_lost = pool.count;
}

static void run_until(size_t count, urb_ns_t max_ns)
{
    urb_ns_t const end = urb_now_ns() + max_ns;
    while ((pool.count < count) && (urb_now_ns() < end)) {
        assert_true(urb_loop_run_once(&loop, 5 * MS) >= 0);
    }
}

static void test_loop_over_usb_to_the_firmware(void **state)
{
    (void)state;
    pool_init(&pool);
    int sv[2];
    assert_int_equal(socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0, sv), 0);
    bridge_thread_start(&bridge, sv[1], true);
    assert_int_equal(urb_loop_init(&loop, NULL), URB_HOST_OK);
    urb_loop_set_lost_callback(&loop, on_lost, NULL);
    urb_manager_t *m = NULL;
    assert_int_equal(urb_loop_add_usb_fd(&loop, sv[0], "usb-pair", NULL, &m), URB_HOST_OK);
    char err[600] = "";
    int32_t const rc = urb_loop_discover(&loop, m, true, 5 * URB_NS_PER_S, err, sizeof err);
    if (rc != URB_HOST_OK) {
        print_error("discover: %s\n", err);
    }
    assert_int_equal(rc, URB_HOST_OK);
    urb_node_t motor;
    assert_int_equal(urb_loop_find_node(&loop, URB_NODE_MOTOR_DRIVER_CLASS, 1u, &motor, err, sizeof err), URB_HOST_OK);
    assert_int_equal(urb_node_row(&motor)->address, 0x21u);
    for (size_t i = 0u; i < 20u; i++) {
        assert_int_equal(urb_transfer_read(&pool.t[i], 0u, 1u, 6u), URB_HOST_OK);
        assert_int_equal(urb_transfer_set_callback(&pool.t[i], pool_record, &pool), URB_HOST_OK);
        assert_int_equal(urb_node_submit(&motor, &pool.t[i]), URB_HOST_OK);
    }
    assert_int_equal(urb_transfer_read(&pool.t[20], 0u, 1u, 4u), URB_HOST_OK); /* the schema says 6 */
    assert_int_equal(urb_transfer_set_callback(&pool.t[20], pool_record, &pool), URB_HOST_OK);
    assert_int_equal(urb_node_submit(&motor, &pool.t[20]), URB_HOST_OK);
    assert_int_equal(pool.count, 0u); /* never inside submit while the loop runs */
    assert_true(urb_loop_next_deadline(&loop) <= urb_now_ns()); /* a refusal waits for its callback */
    run_until(21u, 3 * URB_NS_PER_S);
    pool_all_once(&pool, 21u);
    assert_int_equal(pool.t[20].flags, URB_FLAG_HOST_SIZE_MISMATCH);
    assert_int_equal(pool.t[20].sent_ns, URB_NO_TIME);
    for (size_t i = 0u; i < 20u; i++) {
        assert_true(urb_transfer_ok(&pool.t[i]));
        assert_true(urb_transfer_latency_ns(&pool.t[i]) > 0);
    }
    assert_int_equal(urb_loop_close_manager(&loop, m, true), URB_HOST_OK);
    assert_int_equal(urb_transfer_read(&pool.t[21], 0u, 1u, 6u), URB_HOST_OK);
    assert_int_equal(urb_transfer_set_callback(&pool.t[21], pool_record, &pool), URB_HOST_OK);
    assert_int_equal(urb_node_submit(&motor, &pool.t[21]), URB_HOST_OK);
    assert_int_equal(pool.count, 22u); /* closed: no dispatcher, its callback ran inside the call */
    assert_string_equal(pool.t[21].lost_reason, "closed by the application");
    assert_int_equal(lost_calls, 0); /* a close is no loss */
    urb_loop_destroy(&loop);
    bridge_thread_stop(&bridge);
    (void)close(sv[0]);
    (void)close(sv[1]);
}

static void test_loop_over_a_pty_and_a_bridge_that_goes_away(void **state)
{
    (void)state;
    pool_init(&pool);
    lost_calls = 0;
    int master = -1;
    int slave = -1;
    char name[128];
    assert_int_equal(openpty(&master, &slave, name, NULL, NULL), 0);
    (void)close(slave);
    assert_int_equal(fcntl(master, F_SETFL, O_NONBLOCK), 0);
    bridge_thread_start(&bridge, master, false);
    (void)setenv("URB_STATE_DIR", dir, 1);
    assert_int_equal(urb_loop_init(&loop, NULL), URB_HOST_OK);
    urb_loop_set_lost_callback(&loop, on_lost, NULL);
    urb_manager_t *m = NULL;
    char err[600];
    assert_int_equal(urb_loop_add_rs232(&loop, name, 115200u, NULL, &m, err, sizeof err), URB_HOST_OK);
    assert_int_equal(urb_loop_discover(&loop, m, false, 5 * URB_NS_PER_S, err, sizeof err), URB_HOST_OK);
    urb_node_t motor;
    assert_int_equal(urb_loop_find_node(&loop, URB_NODE_MOTOR_DRIVER_CLASS, 0u, &motor, err, sizeof err), URB_HOST_OK);
    assert_int_equal(urb_loop_start_thread(&loop), URB_HOST_OK);
    assert_int_equal(urb_loop_run_once(&loop, 0), URB_HOST_ESTATE); /* only its thread runs it now */
    for (size_t i = 0u; i < 10u; i++) {
        assert_int_equal(urb_transfer_read(&pool.t[i], 0u, 1u, 6u), URB_HOST_OK);
        assert_int_equal(urb_transfer_set_callback(&pool.t[i], pool_record, &pool), URB_HOST_OK);
        assert_int_equal(urb_node_submit(&motor, &pool.t[i]), URB_HOST_OK);
    }
    urb_ns_t const end = urb_now_ns() + 3 * URB_NS_PER_S;
    while ((pool.count < 10u) && (urb_now_ns() < end)) {
        (void)usleep(1000);
    }
    assert_int_equal(urb_loop_stop_thread(&loop), URB_HOST_OK);
    pool_all_once(&pool, 10u);
    bridge_thread_stop(&bridge);
    (void)close(master); /* the bridge process ended: the pty's slave side reads EIO */
    for (size_t i = 10u; i < 14u; i++) {
        assert_int_equal(urb_transfer_read(&pool.t[i], 0u, 1u, 6u), URB_HOST_OK);
        assert_int_equal(urb_transfer_set_callback(&pool.t[i], pool_record, &pool), URB_HOST_OK);
        assert_int_equal(urb_node_submit(&motor, &pool.t[i]), URB_HOST_OK);
    }
    run_until(14u, 3 * URB_NS_PER_S);
    pool_all_once(&pool, 14u);
    assert_int_equal(lost_calls, 1);
    assert_true(completed_at_lost < 14u); /* told before the callbacks of the requests it failed */
    assert_non_null(strstr(urb_manager_lost_reason(m), "I/O error: the device was unplugged, or the bridge process ended"));
    assert_int_equal(pool.t[13].flags, URB_FLAG_BRIDGE_LOST);
    assert_int_equal(urb_loop_reconnect(&loop, m, err, sizeof err), URB_HOST_EIO); /* the pty is gone with it */
    assert_non_null(strstr(err, "call urb_loop_reconnect again"));
    assert_non_null(strstr(urb_manager_lost_reason(m), "reconnect failed: "));
    urb_loop_destroy(&loop);
    (void)unsetenv("URB_STATE_DIR");
}

static urb_loop_t *cb_loop;
static int32_t blocking_rc;
static void blocking_inside(urb_transfer_t *t, void *user)
{
    (void)t;
    (void)user;
    char err[200];
    blocking_rc = urb_loop_discover(cb_loop, &cb_loop->managers[0], false, MS, err, sizeof err);
}

static void test_a_blocking_call_inside_a_callback_is_refused(void **state)
{
    (void)state;
    int sv[2];
    assert_int_equal(socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0, sv), 0);
    bridge_thread_start(&bridge, sv[1], true);
    assert_int_equal(urb_loop_init(&loop, NULL), URB_HOST_OK);
    cb_loop = &loop;
    urb_manager_t *m = NULL;
    assert_int_equal(urb_loop_add_usb_fd(&loop, sv[0], "usb-pair", NULL, &m), URB_HOST_OK);
    urb_transfer_t t;
    assert_int_equal(urb_transfer_read(&t, 0x20u, 1u, 6u), URB_HOST_OK);
    assert_int_equal(urb_transfer_set_callback(&t, blocking_inside, NULL), URB_HOST_OK);
    assert_int_equal(urb_loop_submit(&loop, m, &t), URB_HOST_OK);
    blocking_rc = 1;
    urb_ns_t const end = urb_now_ns() + 2 * URB_NS_PER_S;
    while ((blocking_rc == 1) && (urb_now_ns() < end)) {
        (void)urb_loop_run_once(&loop, 5 * MS);
    }
    assert_int_equal(blocking_rc, URB_HOST_ESTATE);
    urb_loop_destroy(&loop);
    bridge_thread_stop(&bridge);
    (void)close(sv[0]);
    (void)close(sv[1]);
}

int run_port_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_record_names_follow_handover_py),
        cmocka_unit_test(test_record_cover_settle_and_read_back),
        cmocka_unit_test(test_an_unwritable_directory_is_said_once),
        cmocka_unit_test(test_serial_open_says_what_is_wrong),
        cmocka_unit_test(test_loop_over_usb_to_the_firmware),
        cmocka_unit_test(test_loop_over_a_pty_and_a_bridge_that_goes_away),
        cmocka_unit_test(test_a_blocking_call_inside_a_callback_is_refused),
    };
    return cmocka_run_group_tests_name("host_c_port", tests, setup_dir, teardown_dir);
}
