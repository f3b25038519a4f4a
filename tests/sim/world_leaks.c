/*
 * world_leaks.c: every allocating path of the simulation's C API (sim/world/urbsim.h), for
 * LeakSanitizer. tools/sim_sanitized.py links it against the sanitized library and runs it: at exit
 * LeakSanitizer reports any block the worlds did not give back. The Python runs cannot do this:
 * the interpreter's own blocks at exit would drown the report.
 *
 *   world_leaks TRACE_PATH
 *
 * Exit status 0 when every call answered as expected; 1 (with the call that did not) otherwise.
 */
#include <stdio.h>
#include <stdlib.h>

#include "sim_host_c.h"
#include "urbsim.h"

#define MS 1000000ull

static int failures;

static void expect(int got, int want, const char *what)
{
    if (got != want) {
        fprintf(stderr, "world_leaks: %s returned %d, expected %d\n", what, got, want);
        failures++;
    }
}

static void expect_ok(int got, const char *what)
{
    if (got < 0) {
        fprintf(stderr, "world_leaks: %s failed (%d)\n", what, got);
        failures++;
    }
}

/* Run to `limit`, handing whatever the host would read to nobody (the native host drives the
 * buses; the Python side is not here). */
static void run_until(urbsim_world_t *w, uint64_t limit)
{
    uint8_t buf[512];
    int bridge;
    while (urbsim_run(w, limit) == 1) {
        while (urbsim_host_take(w, &bridge, buf, sizeof buf) >= 0) {
        }
    }
}

/* The SensoRHex topology (Fig. 14) with native host traffic, every trace category written to
 * `trace`, and every fault injected once: power loss and reboot of a node and a bridge, stuck lines,
 * bit errors, a babbling node (created, then reconfigured), lossy uplinks. */
static void sensorhex(uint64_t seed, const char *trace)
{
    urbsim_world_t *w = urbsim_new(seed);
    if (!w) {
        expect_ok(-1, "urbsim_new");
        return;
    }
    int usb0 = urbsim_add_bridge(w, URBSIM_UPLINK_USB);
    int usb1 = urbsim_add_bridge(w, URBSIM_UPLINK_USB);
    int rs = urbsim_add_bridge(w, URBSIM_UPLINK_RS232);
    expect_ok(usb0 | usb1 | rs, "urbsim_add_bridge");
    for (int i = 0; i < 3; i++) {
        expect_ok(urbsim_add_node(w, usb0, URBSIM_APP_MOTOR, 0x20 + i, i), "urbsim_add_node (motor)");
        expect_ok(urbsim_add_node(w, usb1, URBSIM_APP_MOTOR, 0x20 + i, 3 + i), "urbsim_add_node (motor)");
    }
    expect_ok(urbsim_add_node(w, rs, URBSIM_APP_BATTERY, 0x30, 0), "urbsim_add_node (battery)");
    expect_ok(urbsim_add_node(w, rs, URBSIM_APP_IMU, 0x31, 0), "urbsim_add_node (imu)");
    expect_ok(urbsim_add_node(w, rs, URBSIM_APP_IR, 0x32, 0), "urbsim_add_node (ir)");
    expect_ok(urbsim_add_node(w, rs, URBSIM_APP_PROBE, 0x33, 0), "urbsim_add_node (probe)");
    /* Opening a trace twice closes the first file. */
    expect(urbsim_trace_open(w, trace, 0xFFFFFFFFu), 0, "urbsim_trace_open");
    expect(urbsim_trace_open(w, trace, 0xFFFFFFFFu), 0, "urbsim_trace_open (again)");
    const int usb[2] = {usb0, usb1};
    for (int b = 0; b < 2; b++) {
        expect(urbsim_native_host(w, usb[b], 1), 0, "urbsim_native_host");
        expect(urbsim_native_host(w, usb[b], 2), 0, "urbsim_native_host (again)");
        for (int i = 0; i < 3; i++) {
            expect(urbsim_native_request(w, usb[b], 0x20 + i, 1, 1, 6, 1), 0, "urbsim_native_request");
            expect(urbsim_native_request(w, usb[b], 0x20 + i, 1, 0, 2, 1), 0, "urbsim_native_request");
        }
    }
    expect(urbsim_native_host(w, rs, 10), 0, "urbsim_native_host (rs232)");
    for (int i = 0; i < 4; i++) {
        expect(urbsim_native_request(w, rs, 0x30 + i, 1, 1, 4, 1), 0, "urbsim_native_request (rs232)");
    }
    expect(urbsim_start(w), 0, "urbsim_start");
    run_until(w, 300 * MS);

    expect(urbsim_fault_i2c_ber(w, usb0, 1e-3), 0, "urbsim_fault_i2c_ber");
    expect(urbsim_fault_babble(w, usb1, 0x20, 0.2), 0, "urbsim_fault_babble");
    expect(urbsim_fault_babble(w, usb1, 0x21, 0.5), 0, "urbsim_fault_babble (again)");
    expect(urbsim_fault_uart(w, rs, 0, 1e-4, 0.01), 0, "urbsim_fault_uart");
    expect(urbsim_fault_usb_loss(w, usb0, 0.01), 0, "urbsim_fault_usb_loss");
    expect(urbsim_node_power(w, 0, 0), 0, "urbsim_node_power (off)");
    run_until(w, 350 * MS);
    expect(urbsim_node_power(w, 0, 1), 0, "urbsim_node_power (on)");
    expect(urbsim_fault_i2c_stuck(w, rs, 0, 0, 5), 0, "urbsim_fault_i2c_stuck (SDA)");
    expect(urbsim_bridge_power(w, usb1, 0), 0, "urbsim_bridge_power (off)");
    run_until(w, 400 * MS);
    expect(urbsim_bridge_power(w, usb1, 1), 0, "urbsim_bridge_power (on)");
    expect(urbsim_fault_i2c_stuck(w, usb0, 1, 2 * MS, 0), 0, "urbsim_fault_i2c_stuck (SCL)");
    run_until(w, 600 * MS);
    urbsim_trace_flush(w);
    urbsim_free(w);
}

/* More nodes than a downlink takes (the failed one is given back), so many that the event queues
 * grow, and a world freed before it started. */
static void crowded(uint64_t seed)
{
    urbsim_world_t *w = urbsim_new(seed);
    if (!w) {
        expect_ok(-1, "urbsim_new");
        return;
    }
    int b = urbsim_add_bridge(w, URBSIM_UPLINK_USB);
    expect_ok(b, "urbsim_add_bridge");
    for (int i = 0; i < 64; i++) {
        expect_ok(urbsim_add_node(w, b, URBSIM_APP_PROBE, 0x08 + i, i), "urbsim_add_node (probe)");
    }
    expect(urbsim_add_node(w, b, URBSIM_APP_PROBE, 0x50, 0), -1, "urbsim_add_node (a 65th slave)");
    expect(urbsim_start(w), 0, "urbsim_start");
    run_until(w, 200 * MS);
    urbsim_free(w);

    urbsim_world_t *unstarted = urbsim_new(seed);
    if (unstarted) {
        expect_ok(urbsim_add_bridge(unstarted, URBSIM_UPLINK_RS232), "urbsim_add_bridge");
        expect_ok(urbsim_add_node(unstarted, 0, URBSIM_APP_MOTOR, 0x20, 0), "urbsim_add_node (motor)");
    }
    urbsim_free(unstarted);
    urbsim_free(NULL);
}

/* The C host library driving a world (sim/world/sim_host_c.h): its transfer blocks, event heap,
 * records and logs grown by a loop that outruns its links (six motors at 1 kHz), freed with
 * requests still in flight; a host refused for a world not started. */
static void c_host(uint64_t seed)
{
    urbsim_world_t *w = urbsim_new(seed);
    if (!w) {
        expect_ok(-1, "urbsim_new");
        return;
    }
    expect(urbsim_chost_new(w) == NULL, 1, "urbsim_chost_new (world not started)");
    int usb = urbsim_add_bridge(w, URBSIM_UPLINK_USB), rs = urbsim_add_bridge(w, URBSIM_UPLINK_RS232);
    int motors[6];
    for (int i = 0; i < 6; i++) {
        motors[i] = urbsim_add_node(w, usb, URBSIM_APP_MOTOR, 0x20 + i, i);
        expect_ok(motors[i], "urbsim_add_node (motor)");
    }
    expect_ok(urbsim_add_node(w, rs, URBSIM_APP_IMU, 0x31, 0), "urbsim_add_node (imu)");
    expect(urbsim_start(w), 0, "urbsim_start");
    run_until(w, 80 * MS);
    urbsim_chost_t *h = urbsim_chost_new(w);
    if (!h) {
        expect_ok(-1, "urbsim_chost_new");
        urbsim_free(w);
        return;
    }
    expect(urbsim_chost_bridge(h, usb, 1, 15, 1, 1), 0, "urbsim_chost_bridge (usb)");
    expect(urbsim_chost_bridge(h, rs, 0, 4, 1, 1), 0, "urbsim_chost_bridge (rs232)");
    expect(urbsim_chost_bridge(h, rs, 0, 4, 1, 1), -1, "urbsim_chost_bridge (twice)");
    expect(urbsim_chost_bridge(h, 5, 0, 4, 1, 1), -1, "urbsim_chost_bridge (no such bridge)");
    for (int i = 0; i < 6; i++) {
        expect_ok(urbsim_chost_axis(h, usb, motors[i], 0x20 + i, 5.0, 0.02, 12.0, 1.0, 3.0, i % 2 ? i : -1),
                  "urbsim_chost_axis");
    }
    expect_ok(urbsim_chost_read(h, rs, 0x31, 1, 12, 10), "urbsim_chost_read");
    expect(urbsim_chost_loop(h, (int64_t)MS, 300u, 0), 0, "urbsim_chost_loop");
    expect(urbsim_chost_advance_to(h, urbsim_now(w) + 250 * MS), 0, "urbsim_chost_advance_to");
    expect(urbsim_chost_stat(h, "submitted") > 1000.0, 1, "urbsim_chost_stat (submitted)");
    urbsim_chost_free(h);
    urbsim_chost_free(urbsim_chost_new(w)); /* one that never drove anything */
    urbsim_free(w);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: world_leaks TRACE_PATH\n");
        return 2;
    }
    for (uint64_t seed = 1; seed <= 2; seed++) {
        sensorhex(seed, argv[1]);
        crowded(seed);
        c_host(seed);
    }
    if (failures) {
        fprintf(stderr, "world_leaks: %d call(s) did not answer as expected\n", failures);
        return 1;
    }
    printf("world_leaks: every world built, ran and was freed\n");
    return 0;
}
