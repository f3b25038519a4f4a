/*
 * How the event loop waits (host/c/port/loop.c, urb_loop.h "Embedding"): urb_loop_run_once's own
 * timeout counts in ns; an application polling urb_loop_fd() alone is woken at every deadline by
 * the loop's timer, which urb_loop_run_once(loop, 0) arms and a submission brings forward; a thread
 * already waiting in urb_loop_run_once is woken by a submission that needs an earlier deadline; a
 * USB port is read once per readiness event, and what is still queued is read at the next wait.
 * The USB ports here are SOCK_SEQPACKET pairs with no bridge behind them: nothing answers.
 * On a kernel without epoll_pwait2 (before 5.11) the loop falls back to epoll_wait, whose timeout
 * counts in ms: the test binary is linked with -Wl,--wrap=epoll_pwait2, so a test can make the call
 * fail with ENOSYS as such a kernel does, and see every timeout the loop asked for.
 * The cyclic pattern (urb_loop_service, once per period after urb_sleep_until): it never waits, reads
 * every queued IN transfer, still times requests out and sends a batch per tick, and runs every
 * callback exactly once against the bridge firmware.
 */
#include "host_test.h"

#include <errno.h>
#include <poll.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include "urb_sensorhex.h"

int __real_epoll_pwait2(int epfd, struct epoll_event *events, int maxevents, const struct timespec *timeout,
                        const sigset_t *sigmask);
int __wrap_epoll_pwait2(int epfd, struct epoll_event *events, int maxevents, const struct timespec *timeout,
                        const sigset_t *sigmask);

static bool old_kernel;        /* epoll_pwait2 fails with ENOSYS, as before Linux 5.11 */
static unsigned pwait2_calls;  /* how often the loop called it */
static urb_ns_t longest_wait;  /* the longest timeout it was given (-1: one without a timeout) */

int __wrap_epoll_pwait2(int epfd, struct epoll_event *events, int maxevents, const struct timespec *timeout,
                        const sigset_t *sigmask)
{
    pwait2_calls++;
    urb_ns_t const wait = (timeout == NULL) ? -1 : (urb_ns_t)timeout->tv_sec * URB_NS_PER_S + timeout->tv_nsec;
    if (longest_wait >= 0) {
        longest_wait = ((wait < 0) || (wait > longest_wait)) ? wait : longest_wait;
    }
    if (old_kernel) {
        errno = ENOSYS;
        return -1;
    }
    return __real_epoll_pwait2(epfd, events, maxevents, timeout, sigmask);
}

static urb_loop_t loop;
static pool_t pool;
static int sv[2];

static int open_pair(void **state)
{
    (void)state;
    pool_init(&pool);
    return socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0, sv);
}

static int close_pair(void **state)
{
    (void)state;
    old_kernel = false;
    urb_loop_destroy(&loop);
    (void)close(sv[0]);
    (void)close(sv[1]);
    return 0;
}

/* A USB manager on sv[0] whose requests time out after 20 ms. */
static urb_manager_t *usb_manager(void)
{
    urb_core_config_t cfg;
    urb_core_default_config(&cfg, URB_LINK_USB);
    cfg.timeout_ns = 20 * MS;
    assert_int_equal(urb_loop_init(&loop, NULL), URB_HOST_OK);
    urb_manager_t *m = NULL;
    assert_int_equal(urb_loop_add_usb_fd(&loop, sv[0], "usb-silent", &cfg, &m), URB_HOST_OK);
    return m;
}

static void submit_one(urb_manager_t *m, size_t i)
{
    assert_int_equal(urb_transfer_read(&pool.t[i], 0x20u, 1u, 6u), URB_HOST_OK);
    assert_int_equal(urb_transfer_set_callback(&pool.t[i], pool_record, &pool), URB_HOST_OK);
    assert_int_equal(urb_loop_submit(&loop, m, &pool.t[i]), URB_HOST_OK);
}

static void test_run_once_waits_its_timeout_in_ns(void **state)
{
    (void)state;
    (void)usb_manager(); /* idle: no deadline of its own */
    urb_ns_t const waits[3] = {300 * 1000, 1500 * 1000, 2700 * 1000};
    for (size_t i = 0u; i < 3u; i++) {
        urb_ns_t const start = urb_now_ns();
        assert_int_equal(urb_loop_run_once(&loop, waits[i]), 0);
        assert_true(urb_now_ns() - start >= waits[i]); /* never earlier: only a late scheduler makes it longer */
    }
}

static void test_a_polled_descriptor_wakes_at_every_deadline(void **state)
{
    (void)state;
    urb_manager_t *m = usb_manager();
    assert_int_equal(urb_loop_run_once(&loop, 0), 0); /* the application polls the descriptor from now on */
    submit_one(m, 0u);                                /* frames every ms, then its timeout */
    struct pollfd p = {urb_loop_fd(&loop), POLLIN, 0};
    size_t wakes = 0u;
    urb_ns_t const end = urb_now_ns() + 2 * URB_NS_PER_S;
    while ((pool.count == 0u) && (urb_now_ns() < end)) {
        int const ready = poll(&p, 1, 1000); /* no deadline of ours: only the loop's timer wakes it */
        assert_int_equal(ready, 1);
        wakes++;
        assert_true(urb_loop_run_once(&loop, 0) >= 0);
    }
    pool_all_once(&pool, 1u);
    assert_int_equal(pool.t[0].flags, URB_FLAG_UPLINK_TIMEOUT);
    assert_true(wakes >= 3u); /* the first frame, a later one and the timeout each woke the poll */
}

typedef struct {
    volatile bool returned;
    int32_t ran;
} waiter_t;

static void *wait_forever(void *arg)
{
    waiter_t *w = arg;
    w->ran = urb_loop_run_once(&loop, -1); /* no timeout: only input or the loop's timer ends it */
    w->returned = true;
    return NULL;
}

static void test_a_submission_wakes_a_thread_waiting_in_the_loop(void **state)
{
    (void)state;
    urb_manager_t *m = usb_manager();
    waiter_t w = {false, -1};
    pthread_t thread;
    assert_int_equal(pthread_create(&thread, NULL, wait_forever, &w), 0);
    bool waiting = false;
    urb_ns_t const until = urb_now_ns() + 2 * URB_NS_PER_S;
    while (!waiting && (urb_now_ns() < until)) {
        (void)pthread_mutex_lock(&loop.lock);
        waiting = (loop.waiting_until != 0);
        (void)pthread_mutex_unlock(&loop.lock);
        (void)usleep(1000);
    }
    assert_true(waiting); /* the thread is inside the wait, with no deadline to wake it */
    submit_one(m, 0u);    /* the idle bridge starts ticking: its first frame is due within 1 ms */
    urb_ns_t const end = urb_now_ns() + URB_NS_PER_S; /* its first frame is due within 1 ms */
    while (!w.returned && (urb_now_ns() < end)) {
        (void)usleep(1000);
    }
    bool const woken = w.returned;
    if (!woken) { /* release it, so that the test can fail without hanging */
        uint64_t one = 1u;
        (void)!write(loop.wakefd, &one, sizeof one);
    }
    (void)pthread_join(thread, NULL);
    assert_true(woken);
    assert_int_equal(w.ran, 0);
    urb_ns_t const stop = urb_now_ns() + 2 * URB_NS_PER_S;
    while ((pool.count == 0u) && (urb_now_ns() < stop)) {
        assert_true(urb_loop_run_once(&loop, 5 * MS) >= 0);
    }
    pool_all_once(&pool, 1u);
    uint8_t out[URB_USB_BATCH_MAX];
    assert_true(read(sv[1], out, sizeof out) > 0); /* the request went out in a frame */
    assert_int_equal(urb_loop_close_manager(&loop, m, false), URB_HOST_OK); /* nothing is due any more */
    urb_ns_t const start = urb_now_ns();
    assert_int_equal(urb_loop_run_once(&loop, 3 * MS), 0);
    assert_true(urb_now_ns() - start >= 3 * MS); /* the timer's expiry was reported once: no busy loop */
}

static void test_usb_reads_one_transfer_per_readiness_and_keeps_the_rest(void **state)
{
    (void)state;
    urb_manager_t *m = usb_manager();
    uint8_t const in[2][URB_USB_HEADER_SIZE] = {{1u, 0u, 0u, 0u}, {2u, 0u, 0u, 0u}}; /* two empty IN transfers */
    for (size_t i = 0u; i < 2u; i++) {
        assert_int_equal(write(sv[1], in[i], sizeof in[i]), (ssize_t)sizeof in[i]);
    }
    assert_int_equal(urb_loop_run_once(&loop, 0), 0);
    assert_int_equal(m->core.transfers_in, 1u); /* one read per event: no read ending in EAGAIN */
    assert_int_equal(urb_loop_run_once(&loop, 0), 0);
    assert_int_equal(m->core.transfers_in, 2u); /* the second stayed queued, and the port ready */
    assert_int_equal(urb_loop_run_once(&loop, 0), 0);
    assert_int_equal(m->core.transfers_in, 2u);
}

/* Before Linux 5.11: the first wait finds epoll_pwait2 missing and every later one uses epoll_wait, whose
 * ms are rounded up (a wait shorter than 1 ms rounded down would be no wait: a busy loop); the loop's
 * deadlines still end the requests, each once. */
static void test_without_epoll_pwait2_waits_count_in_whole_ms(void **state)
{
    (void)state;
    urb_manager_t *m = usb_manager();
    old_kernel = true;
    pwait2_calls = 0u;
    for (size_t i = 0u; i < 3u; i++) {
        urb_ns_t const start = urb_now_ns();
        assert_int_equal(urb_loop_run_once(&loop, 300 * 1000), 0);
        assert_true(urb_now_ns() - start >= 300 * 1000); /* never earlier: rounded up to 1 ms */
    }
    assert_true(loop.ms_waits);
    assert_int_equal(pwait2_calls, 1u); /* asked once; the answer is kept */
    submit_one(m, 0u);
    urb_ns_t const end = urb_now_ns() + 2 * URB_NS_PER_S;
    while ((pool.count == 0u) && (urb_now_ns() < end)) {
        assert_true(urb_loop_run_once(&loop, 5 * MS) >= 0);
    }
    pool_all_once(&pool, 1u);
    assert_int_equal(pool.t[0].flags, URB_FLAG_UPLINK_TIMEOUT); /* its deadline fired without epoll_pwait2 */
    uint8_t out[URB_USB_BATCH_MAX];
    assert_true(read(sv[1], out, sizeof out) > 0); /* and its frame went out at the tick */
    assert_int_equal(pwait2_calls, 1u);
}

/* urb_loop_service: a wait of 0 every time (nothing ready is no wait), and every IN transfer queued
 * on a USB port read in one call (the kernel asked again after each), none left behind a first. */
static void test_service_never_waits_and_reads_every_queued_transfer(void **state)
{
    (void)state;
    urb_manager_t *m = usb_manager();
    uint8_t const in[3][URB_USB_HEADER_SIZE] = {{1u, 0u, 0u, 0u}, {2u, 0u, 0u, 0u}, {3u, 0u, 0u, 0u}};
    for (size_t i = 0u; i < 3u; i++) {
        assert_int_equal(write(sv[1], in[i], sizeof in[i]), (ssize_t)sizeof in[i]);
    }
    pwait2_calls = 0u;
    longest_wait = 0;
    assert_int_equal(urb_loop_service(&loop), 0);
    assert_int_equal(m->core.transfers_in, 3u); /* all three in one call */
    assert_int_equal(urb_loop_service(&loop), 0); /* nothing queued: returns without waiting */
    assert_int_equal(m->core.transfers_in, 3u);
    assert_true(pwait2_calls >= 2u);
    assert_int_equal(longest_wait, 0);
}

/* The cyclic pattern on a bridge that never answers: one batch per tick while the request is in
 * flight, then its timeout at the first service after its deadline, its callback run by that service. */
static void test_a_cyclic_program_times_out_and_sends_a_batch_per_tick(void **state)
{
    (void)state;
    urb_manager_t *m = usb_manager();
    urb_ns_t tick = (urb_now_ns() / MS + 1) * MS;
    urb_sleep_until(tick);
    assert_int_equal(urb_loop_service(&loop), 0);
    submit_one(m, 0u);
    int32_t ran = 0;
    size_t services = 0u;
    size_t batches = 0u;
    uint8_t out[URB_USB_BATCH_MAX];
    urb_ns_t const end = urb_now_ns() + 2 * URB_NS_PER_S;
    while ((pool.count == 0u) && (urb_now_ns() < end)) {
        tick += MS;
        urb_sleep_until(tick);
        int32_t const n = urb_loop_service(&loop);
        assert_true(n >= 0);
        ran += n;
        services++;
        while (read(sv[1], out, sizeof out) > 0) {
            batches++;
        }
    }
    pool_all_once(&pool, 1u);
    assert_int_equal(ran, 1); /* its callback ran inside a service */
    assert_int_equal(pool.t[0].flags, URB_FLAG_UPLINK_TIMEOUT);
    assert_true(pool.t[0].completed_ns - pool.t[0].sent_ns >= 20 * MS); /* never before its deadline */
    assert_true(batches >= 2u);        /* the request, then fetches while it was in flight */
    assert_true(batches <= services); /* at most one batch per service */
}

/* The cyclic pattern against the bridge firmware over a SOCK_SEQPACKET pair: two motors read every
 * tick for 40 ticks; every request ends in exactly one callback, all run inside urb_loop_service. */
static void test_a_cyclic_program_against_the_firmware(void **state)
{
    (void)state;
    bridge_thread_t bridge;
    bridge_thread_start(&bridge, sv[1], true);
    assert_int_equal(urb_loop_init(&loop, NULL), URB_HOST_OK);
    urb_manager_t *m = NULL;
    assert_int_equal(urb_loop_add_usb_fd(&loop, sv[0], "usb-cyclic", NULL, &m), URB_HOST_OK);
    char err[600] = "";
    assert_int_equal(urb_loop_discover(&loop, m, true, 5 * URB_NS_PER_S, err, sizeof err), URB_HOST_OK);
    urb_node_t motor[2];
    for (uint8_t k = 0u; k < 2u; k++) {
        assert_int_equal(urb_loop_find_node(&loop, URB_NODE_MOTOR_DRIVER_CLASS, k, &motor[k], err, sizeof err),
                         URB_HOST_OK);
    }
    size_t const ticks = 40u;
    urb_ns_t tick = (urb_now_ns() / MS + 1) * MS;
    int32_t ran = 0;
    for (size_t i = 0u; i < ticks; i++) {
        urb_sleep_until(tick);
        int32_t const n = urb_loop_service(&loop);
        assert_true(n >= 0);
        ran += n;
        for (size_t k = 0u; k < 2u; k++) {
            urb_transfer_t *t = &pool.t[2u * i + k];
            assert_int_equal(urb_transfer_read(t, 0u, 1u, urb_node_mailbox_size(&motor[k], true, 1u)), URB_HOST_OK);
            assert_int_equal(urb_transfer_set_callback(t, pool_record, &pool), URB_HOST_OK);
            assert_int_equal(urb_node_submit(&motor[k], t), URB_HOST_OK);
        }
        tick += MS;
    }
    urb_ns_t const end = urb_now_ns() + 3 * URB_NS_PER_S;
    while ((pool.count < 2u * ticks) && (urb_now_ns() < end)) {
        urb_sleep_until(tick);
        int32_t const n = urb_loop_service(&loop);
        assert_true(n >= 0);
        ran += n;
        tick += MS;
    }
    pool_all_once(&pool, 2u * ticks);
    assert_int_equal(ran, (int32_t)(2u * ticks)); /* every callback ran inside urb_loop_service */
    for (size_t i = 0u; i < 2u * ticks; i++) {
        assert_true(urb_transfer_ok(&pool.t[i]));
    }
    urb_loop_destroy(&loop);
    bridge_thread_stop(&bridge);
}

int run_loop_wait_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_run_once_waits_its_timeout_in_ns, open_pair, close_pair),
        cmocka_unit_test_setup_teardown(test_a_polled_descriptor_wakes_at_every_deadline, open_pair, close_pair),
        cmocka_unit_test_setup_teardown(test_a_submission_wakes_a_thread_waiting_in_the_loop, open_pair, close_pair),
        cmocka_unit_test_setup_teardown(test_usb_reads_one_transfer_per_readiness_and_keeps_the_rest, open_pair,
                                        close_pair),
        cmocka_unit_test_setup_teardown(test_without_epoll_pwait2_waits_count_in_whole_ms, open_pair, close_pair),
        cmocka_unit_test_setup_teardown(test_service_never_waits_and_reads_every_queued_transfer, open_pair,
                                        close_pair),
        cmocka_unit_test_setup_teardown(test_a_cyclic_program_times_out_and_sends_a_batch_per_tick, open_pair,
                                        close_pair),
        cmocka_unit_test_setup_teardown(test_a_cyclic_program_against_the_firmware, open_pair, close_pair),
    };
    return cmocka_run_group_tests_name("host_c_loop_waits", tests, NULL, NULL);
}
