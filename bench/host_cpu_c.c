/*
 * The SensoRHex load through the native host library (host/c), for bench/host_cpu_c.py: two USB
 * bridges with three motor drivers each, every motor read (MotorFeedback) and commanded
 * (MotorCommand) every millisecond, and three sensors (BatteryManager, Imu, IrDistance) read at
 * 100 Hz over RS232: 12.3 requests per millisecond. The loop is embedded in the program's one thread,
 * as a robot's control thread would run it, in one of three ways:
 *   (default) urb_loop_run_once waits until input, the library's deadline or the program's next 1-ms
 *             tick (one wait per wake-up: the tick, every IN transfer, every RS232 response);
 *   `poll`    the program ppolls the library's descriptor until the earlier of its tick and
 *             urb_loop_next_deadline, then calls urb_loop_run_once(0), as a program with descriptors of
 *             its own would (two waits per wake-up);
 *   `cyclic`  the cyclic pattern (urb_loop.h): urb_sleep_until the 1-ms tick, then urb_loop_service
 *             (everything that came during the period, without waiting), then the submissions: one
 *             wake-up per tick.
 *
 *     host_cpu_c USB_FD0 USB_FD1 RS232_PORT SECONDS [slow] [poll|cyclic]
 *     host_cpu_c floor SECONDS PERIOD_NS [cyclic]
 *                                            the loop with no bridge, woken every PERIOD_NS: the
 *                                            cost of the wake-ups alone (by urb_loop_run_once's
 *                                            timeout, or with `cyclic` by urb_sleep_until, then
 *                                            urb_loop_service)
 *
 * Prints one JSON object: the measured window's wall and CPU time (getrusage of this process: the
 * library, its system calls and the loop; the bridges run in other processes), requests per kind and
 * outcome, late ticks, wake-ups, the mean and largest latency (submission to callback) of the
 * requests that succeeded. SECONDS 0 stops after discovery (callgrind runs subtract that start-up). `slow`
 * (for runs under valgrind, ~50 times slower) multiplies the timeouts, lifetimes and silences by 40.
 */
#define _GNU_SOURCE /* ppoll: a timeout in ns */
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "urb_loop.h"
#include "urb_sensorhex.h"

#define MOTORS 6
#define SENSORS 3
#define POOL 64

typedef struct {
    urb_node_t node;
    urb_transfer_t pool[POOL];
    bool busy[POOL];
} axis_t;

static urb_loop_t loop;
static axis_t motors[MOTORS];
static axis_t sensors[SENSORS];
static uint64_t done_ok;
static uint64_t done_failed;
static uint64_t not_submitted;
static urb_ns_t latency_sum[2]; /* of the requests that succeeded: [0] USB, [1] RS232 */
static uint64_t latency_count[2];
static urb_ns_t latency_max[2];

static void on_done(urb_transfer_t *t, void *user)
{
    bool *busy = user;
    *busy = false;
    if (urb_transfer_ok(t)) {
        done_ok++;
        urb_ns_t const latency = urb_transfer_latency_ns(t); /* submission to callback */
        uintptr_t const at = (uintptr_t)busy;
        size_t const rs232 = ((at >= (uintptr_t)&sensors[0]) && (at < (uintptr_t)&sensors[SENSORS])) ? 1u : 0u;
        latency_sum[rs232] += latency;
        latency_count[rs232]++;
        latency_max[rs232] = (latency > latency_max[rs232]) ? latency : latency_max[rs232];
    } else {
        done_failed++;
    }
}

/* A free transfer of the axis' pool, or NULL. */
static urb_transfer_t *take(axis_t *a, bool **busy)
{
    for (size_t i = 0u; i < POOL; i++) {
        if (!a->busy[i]) {
            a->busy[i] = true;
            *busy = &a->busy[i];
            return &a->pool[i];
        }
    }
    return NULL;
}

static void submit_read(axis_t *a, uint8_t mailbox)
{
    bool *busy;
    urb_transfer_t *t = take(a, &busy);
    if ((t == NULL) || (urb_transfer_read(t, 0u, mailbox, urb_node_mailbox_size(&a->node, true, mailbox)) != 0) ||
        (urb_transfer_set_callback(t, on_done, busy) != 0) || (urb_node_submit(&a->node, t) != 0)) {
        not_submitted++;
        if (t != NULL) {
            *busy = false;
        }
    }
}

static void submit_command(axis_t *a, int16_t millivolts)
{
    bool *busy;
    urb_transfer_t *t = take(a, &busy);
    urb_motor_command_t cmd = {millivolts};
    uint8_t bytes[URB_MOTOR_COMMAND_SIZE];
    if ((t == NULL) || (urb_motor_command_encode(&cmd, bytes, sizeof bytes) <= 0) ||
        (urb_transfer_write(t, 0u, URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_COMMAND, bytes, sizeof bytes) != 0) ||
        (urb_transfer_set_callback(t, on_done, busy) != 0) || (urb_node_submit(&a->node, t) != 0)) {
        not_submitted++;
        if (t != NULL) {
            *busy = false;
        }
    }
}

static double cpu_seconds(void)
{
    struct rusage ru;
    (void)getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_utime.tv_sec + (double)ru.ru_utime.tv_usec * 1e-6 + (double)ru.ru_stime.tv_sec +
           (double)ru.ru_stime.tv_usec * 1e-6;
}

/* Voluntary context switches: how often the program slept and was woken (the wake-ups of the load). */
static long sleeps(void)
{
    struct rusage ru;
    (void)getrusage(RUSAGE_SELF, &ru);
    return ru.ru_nvcsw;
}

static double sys_seconds(void)
{
    struct rusage ru;
    (void)getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_stime.tv_sec + (double)ru.ru_stime.tv_usec * 1e-6;
}

static int fail(const char *what, const char *err)
{
    (void)fprintf(stderr, "host_cpu_c: %s: %s\n", what, err);
    return 1;
}

/* The floor: the library's loop with no bridge, woken every `period` by its own timeout (`cyclic`:
 * urb_sleep_until, then urb_loop_service) and doing nothing else, for `seconds`; prints its CPU per
 * wake-up. What any program waking that often pays on this machine (the kernel's sleep and wake-up,
 * the timer), whatever it does when awake. */
static int floor_run(double seconds, urb_ns_t period, bool cyclic)
{
    if ((urb_loop_init(&loop, NULL) != URB_HOST_OK) || (period <= 0)) {
        return fail("floor", "cannot create the loop");
    }
    uint64_t const wakes = (uint64_t)(seconds * 1e9 / (double)period + 0.5);
    urb_ns_t next = (urb_now_ns() / period + 1) * period;
    urb_ns_t const start = next;
    double const cpu0 = cpu_seconds();
    long const sleeps0 = sleeps();
    for (uint64_t i = 0u; i < wakes;) {
        urb_ns_t const now = urb_now_ns();
        if (cyclic) {
            urb_sleep_until(next);
            (void)urb_loop_service(&loop);
        } else {
            (void)urb_loop_run_once(&loop, (next > now) ? next - now : 0);
        }
        if (urb_now_ns() >= next) {
            i++;
            next += period;
        }
    }
    double const cpu = cpu_seconds() - cpu0;
    (void)printf("{\"wakes\": %llu, \"wall_s\": %.6f, \"cpu_s\": %.6f, \"sleeps\": %ld}\n", (unsigned long long)wakes,
                 (double)(urb_now_ns() - start) * 1e-9, cpu, sleeps() - sleeps0);
    urb_loop_destroy(&loop);
    return 0;
}

int main(int argc, char **argv)
{
    if (((argc == 4) || ((argc == 5) && (strcmp(argv[4], "cyclic") == 0))) && (strcmp(argv[1], "floor") == 0)) {
        return floor_run(atof(argv[2]), (urb_ns_t)atoll(argv[3]), argc == 5);
    }
    bool slow = false;
    bool poll_fd = false;
    bool cyclic = false;
    for (int i = 5; i < argc; i++) {
        slow = slow || (strcmp(argv[i], "slow") == 0);
        poll_fd = poll_fd || (strcmp(argv[i], "poll") == 0);
        cyclic = cyclic || (strcmp(argv[i], "cyclic") == 0);
    }
    if ((argc < 5) || (argc > 7) || ((size_t)(argc - 5) != (size_t)slow + (size_t)poll_fd + (size_t)cyclic) ||
        (poll_fd && cyclic)) {
        (void)fprintf(stderr, "usage: host_cpu_c USB_FD0 USB_FD1 RS232_PORT SECONDS [slow] [poll|cyclic]\n");
        return 2;
    }
    urb_core_config_t usb_cfg;
    urb_core_config_t rs_cfg;
    urb_core_default_config(&usb_cfg, URB_LINK_USB);
    urb_core_default_config(&rs_cfg, URB_LINK_RS232);
    if (slow) {
        urb_core_config_t *const cfgs[2] = {&usb_cfg, &rs_cfg};
        for (size_t i = 0u; i < 2u; i++) {
            cfgs[i]->timeout_ns *= 40;
            cfgs[i]->placeholder_ns *= 40;
            cfgs[i]->lost_after_ns *= 40;
        }
    }
    double const seconds = atof(argv[4]);
    char err[1024];
    if (urb_loop_init(&loop, NULL) != URB_HOST_OK) {
        return fail("loop", "cannot create it");
    }
    urb_manager_t *usb[2];
    urb_manager_t *rs232;
    for (int b = 0; b < 2; b++) {
        char name[32];
        (void)snprintf(name, sizeof name, "usb-bridge-%d", b);
        if (urb_loop_add_usb_fd(&loop, atoi(argv[1 + b]), name, &usb_cfg, &usb[b]) != URB_HOST_OK) {
            return fail(name, "cannot add it");
        }
        if (urb_loop_discover(&loop, usb[b], true, 60 * URB_NS_PER_S, err, sizeof err) != URB_HOST_OK) {
            return fail(name, err);
        }
    }
    if ((urb_loop_add_rs232(&loop, argv[3], 115200u, &rs_cfg, &rs232, err, sizeof err) != URB_HOST_OK) ||
        (urb_loop_discover(&loop, rs232, true, 60 * URB_NS_PER_S, err, sizeof err) != URB_HOST_OK)) {
        return fail(argv[3], err);
    }
    for (uint8_t i = 0u; i < MOTORS; i++) {
        if (urb_loop_find_node(&loop, URB_NODE_MOTOR_DRIVER_CLASS, i, &motors[i].node, err, sizeof err) != 0) {
            return fail("motor", err);
        }
    }
    uint8_t const classes[SENSORS] = {URB_NODE_BATTERY_MANAGER_CLASS, URB_NODE_IMU_CLASS, URB_NODE_IR_DISTANCE_CLASS};
    for (size_t i = 0u; i < SENSORS; i++) {
        if (urb_loop_find_node(&loop, classes[i], 0u, &sensors[i].node, err, sizeof err) != 0) {
            return fail("sensor", err);
        }
    }
    urb_ns_t const period = URB_NS_PER_MS;
    uint64_t const ticks = (uint64_t)(seconds * 1000.0 + 0.5);
    uint64_t late = 0u;
    uint64_t submitted = 0u;
    urb_ns_t next = (urb_now_ns() / period + 1) * period;
    urb_ns_t const start = next;
    double const cpu0 = cpu_seconds();
    double const sys0 = sys_seconds();
    long const sleeps0 = sleeps();
    struct pollfd p = {urb_loop_fd(&loop), POLLIN, 0};
    for (uint64_t tick = 0u; tick < ticks;) {
        urb_ns_t const now = urb_now_ns();
        if (cyclic) { /* one wake-up per tick: the responses of the period are read at the tick */
            urb_sleep_until(next);
            (void)urb_loop_service(&loop);
        } else if (poll_fd) { /* an application waiting on descriptors of its own too */
            urb_ns_t deadline = urb_loop_next_deadline(&loop);
            deadline = (next < deadline) ? next : deadline;
            if (deadline > now) {
                struct timespec ts = {(time_t)((deadline - now) / URB_NS_PER_S),
                                      (long)((deadline - now) % URB_NS_PER_S)};
                (void)ppoll(&p, 1, &ts, NULL);
            }
            (void)urb_loop_run_once(&loop, 0);
        } else { /* the loop's descriptor is all it waits on: the loop's wait, until our tick at the latest */
            (void)urb_loop_run_once(&loop, (next > now) ? next - now : 0);
        }
        urb_ns_t const t = urb_now_ns();
        if (t < next) {
            continue;
        }
        late += (t - next > period / 2) ? 1u : 0u;
        for (size_t i = 0u; i < MOTORS; i++) {
            submit_read(&motors[i], URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_FEEDBACK);
            submit_command(&motors[i], (int16_t)(1000 + (int16_t)(tick % 100u)));
            submitted += 2u;
        }
        if (tick % 10u == 0u) {
            for (size_t i = 0u; i < SENSORS; i++) {
                submit_read(&sensors[i], 1u);
                submitted++;
            }
        }
        tick++;
        next += period;
        if (next <= t) {
            next = (t / period + 1) * period;
        }
    }
    long const tick_sleeps = sleeps() - sleeps0; /* the wake-ups of the ticks alone, without the settling */
    double const tick_wall = (double)(urb_now_ns() - start) * 1e-9;
    urb_ns_t const settle = urb_now_ns() + 300 * URB_NS_PER_MS; /* the last callbacks */
    while ((done_ok + done_failed + not_submitted < submitted) && (urb_now_ns() < settle)) {
        (void)urb_loop_run_once(&loop, 5 * URB_NS_PER_MS);
    }
    double const cpu = cpu_seconds() - cpu0;
    double const sys = sys_seconds() - sys0;
    long const slept = sleeps() - sleeps0;
    double const wall = (double)(urb_now_ns() - start) * 1e-9;
    (void)printf("{\"ticks\": %llu, \"submitted\": %llu, \"ok\": %llu, \"failed\": %llu, \"not_submitted\": %llu, "
                 "\"late_ticks\": %llu, \"wall_s\": %.6f, \"cpu_s\": %.6f, \"sys_s\": %.6f, \"sleeps\": %ld, "
                 "\"tick_sleeps\": %ld, \"tick_wall_s\": %.6f, "
                 "\"usb_latency_mean_us\": %.1f, \"usb_latency_max_us\": %.1f, \"rs232_latency_mean_us\": %.1f, "
                 "\"rs232_latency_max_us\": %.1f}\n",
                 (unsigned long long)ticks, (unsigned long long)submitted, (unsigned long long)done_ok,
                 (unsigned long long)done_failed, (unsigned long long)not_submitted, (unsigned long long)late, wall, cpu,
                 sys, slept, tick_sleeps, tick_wall, (double)latency_sum[0] / 1e3 / (double)((latency_count[0] > 0u) ? latency_count[0] : 1u),
                 (double)latency_max[0] / 1e3,
                 (double)latency_sum[1] / 1e3 / (double)((latency_count[1] > 0u) ? latency_count[1] : 1u),
                 (double)latency_max[1] / 1e3);
    for (int b = 0; b < 2; b++) {
        (void)urb_loop_close_manager(&loop, usb[b], true);
    }
    urb_loop_destroy(&loop);
    return 0;
}
