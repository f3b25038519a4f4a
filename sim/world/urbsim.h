/*
 * urbsim.h: the simulation as Python sees it (through ctypes, sim/urb_sim/native.py).
 *
 * A world is one simulated system: bridges (RS232 or USB uplink, each with its I2C downlink),
 * nodes on those downlinks running the real firmware, the USB host controller they share and the
 * host CPU's timing. Build it (new, set parameters, add bridges and nodes), start it, then advance
 * virtual time with urbsim_run while the Python side plays the host CPU:
 *
 *   - urbsim_run stops early when a host thread blocked on I/O wakes up (RS232 bytes or a USB IN
 *     transfer arrived and the read thread's wake-up latency passed); urbsim_host_take then hands
 *     over what arrived, bridge by bridge, in order;
 *   - urbsim_host_timer says when a thread sleeping until a given CPU-clock time really runs (the
 *     next 1-kHz OS tick plus scheduling jitter);
 *   - urbsim_host_send puts a request frame on an RS232 line, or hands one batch to the USB driver.
 *
 * Every function returns a negative value (or NULL) on a bad argument; nothing aborts the process.
 * Times are virtual ns unless named "local" (a device's own clock).
 */
#ifndef URBSIM_H
#define URBSIM_H

#include <stdint.h>

typedef struct urbsim_world urbsim_world_t;

enum { URBSIM_UPLINK_RS232 = 0, URBSIM_UPLINK_USB = 1 };
enum { URBSIM_APP_PROBE = 0, URBSIM_APP_MOTOR = 1, URBSIM_APP_BATTERY = 2, URBSIM_APP_IMU = 3,
       URBSIM_APP_IR = 4 };

/* ---- construction ---- */
urbsim_world_t *urbsim_new(uint64_t seed);
void urbsim_free(urbsim_world_t *w);
/** Set parameter `name` (see params.h); applies to devices added afterwards. 0, or -1 unknown. */
int urbsim_set(urbsim_world_t *w, const char *name, double value);
/** Current value of a parameter (NaN when unknown). */
double urbsim_get(const urbsim_world_t *w, const char *name);
/** Parameter table: count, and name/default/doc of entry i. */
int urbsim_param_count(void);
const char *urbsim_param_name(int i);
double urbsim_param_default(int i);
const char *urbsim_param_doc(int i);
/** Add a bridge; returns its id (0, 1, ...) or -1. */
int urbsim_add_bridge(urbsim_world_t *w, int uplink);
/** Add a node running `app` at I2C `address` on `bridge`; returns its id or -1. */
int urbsim_add_node(urbsim_world_t *w, int bridge, int app, int address, int index);
/** Write the trace to `path` (NULL: hash only) for the categories in `mask` (trace.h). */
int urbsim_trace_open(urbsim_world_t *w, const char *path, uint32_t mask);
/** Power everything on: nodes spread over node.boot_spread_ms, bridges at bridge.boot_ms. */
int urbsim_start(urbsim_world_t *w);

/* ---- running ---- */
/** Run until virtual time `limit` or until a host I/O wake-up; returns 1 for a wake-up, 0 at limit. */
int urbsim_run(urbsim_world_t *w, uint64_t limit);
uint64_t urbsim_now(const urbsim_world_t *w);
/** Events executed so far. */
uint64_t urbsim_events(const urbsim_world_t *w);
uint64_t urbsim_trace_hash(const urbsim_world_t *w);
uint64_t urbsim_trace_lines(const urbsim_world_t *w);
/** Flush the trace file. */
void urbsim_trace_flush(urbsim_world_t *w);

/* ---- host CPU ---- */
/** The host CPU clock (CLOCK_MONOTONIC of the simulated computer) now, ns. */
int64_t urbsim_host_local(urbsim_world_t *w);
/** Virtual time at which a thread sleeping until CPU-clock time `local_ns` runs. */
uint64_t urbsim_host_timer(urbsim_world_t *w, int64_t local_ns);
/** Send bytes (RS232: one write(); USB: one bulk-OUT batch). Returns bytes accepted or -1. */
int urbsim_host_send(urbsim_world_t *w, int bridge, const uint8_t *data, uint32_t n);
/** Take the next delivered item: returns its length (>= 0) with its bridge in *bridge, or -1. */
int urbsim_host_take(urbsim_world_t *w, int *bridge, uint8_t *buf, uint32_t cap);
/** urbsim_host_take, and the items still ready after this one in *more (so that the caller knows
 *  without another call whether to take again). */
int urbsim_host_take_more(urbsim_world_t *w, int *bridge, uint32_t *more, uint8_t *buf, uint32_t cap);
#define URBSIM_RUN_LIMIT (-1) /**< urbsim_run_take: `limit` reached, no host wake-up */
#define URBSIM_RUN_ERROR (-2) /**< urbsim_run_take: no world, not started, or a NULL argument */
/** urbsim_run and, on a host wake-up, urbsim_host_take_more in one call (one crossing from Python
 *  per wake-up instead of three): returns the first ready item's length (>= 0), its bridge in
 *  *bridge (-1: woken with nothing ready) and the items still ready in *more; URBSIM_RUN_LIMIT when
 *  `limit` was reached; URBSIM_RUN_ERROR on a bad call. */
int urbsim_run_take(urbsim_world_t *w, uint64_t limit, int *bridge, uint32_t *more, uint8_t *buf, uint32_t cap);

/* ---- measurements ---- */
/** Drain a device's mark log (node marks: 0 beat, 1 acq_end, 2 sync, 3 read, 4 boot; bridge marks
 *  8 serve, 9 sync, 10 emit, value = level). kind << 24 | value in v. Returns entries. */
uint32_t urbsim_node_marks(urbsim_world_t *w, int node, uint64_t *t, uint32_t *v, uint32_t cap);
uint32_t urbsim_bridge_marks(urbsim_world_t *w, int bridge, uint64_t *t, uint32_t *v, uint32_t cap);
/** Node heartbeat status: out[0..8] = state, period_q8, phase_q8, lead_ticks, acq_ticks, syncs,
 *  rejected, synced, init_result. Returns 0 or -1. */
int urbsim_node_status(urbsim_world_t *w, int node, int64_t *out);
/** Motor driver node: true motor/leg state now, out[0..5] = motor angle (rad), speed (rad/s),
 *  current (A), applied voltage (V), leg angle (rad), case temperature (degC). 0, or -1. */
int urbsim_node_plant(urbsim_world_t *w, int node, double *out);
/** A named statistic of device `id` (see world.c stat()); NaN when unknown. */
double urbsim_stat(urbsim_world_t *w, const char *name, int id);

/* ---- faults (take effect now) ---- */
int urbsim_fault_i2c_ber(urbsim_world_t *w, int bridge, double ber);
/** Hold a downlink line low: line 0 SDA, 1 SCL; for `duration_ns` (0: until released by a bus
 *  clear for SDA with pulses > 0, else forever). */
int urbsim_fault_i2c_stuck(urbsim_world_t *w, int bridge, int line, uint64_t duration_ns, uint32_t pulses);
/** RS232 faults: dir 0 host->bridge, 1 bridge->host; bit error rate and byte loss probability. */
int urbsim_fault_uart(urbsim_world_t *w, int bridge, int dir, double ber, double loss);
/** USB: probability that an IN transfer is lost on its way to the read thread. */
int urbsim_fault_usb_loss(urbsim_world_t *w, int bridge, double loss);
int urbsim_node_power(urbsim_world_t *w, int node, int on);
int urbsim_bridge_power(urbsim_world_t *w, int bridge, int on);
/** A babbling node: attach a device at `address` on `bridge` that acknowledges its address and
 *  also answers every read on the bus with random bytes from now on (rate: probability per
 *  transaction). Returns 0. */
int urbsim_fault_babble(urbsim_world_t *w, int bridge, int address, double rate);

/* ---- native host (speed: benchmarks and sweeps without Python in the loop) ----
 * A traffic model. The C host library itself (host/c/core) drives a world through this API in
 * sim_host_c.h (urbsim_chost_*: the experiments' PD loops and readers, no Python in the loop). */
/** Drive `bridge` from the native host model (native_host.c) instead of Python: every
 *  `period_ticks` OS ticks it sends its periodic requests. Before urbsim_start. 0, or -1. */
int urbsim_native_host(urbsim_world_t *w, int bridge, int period_ticks);
/** Add a periodic request (every `every` loop cycles) to a natively driven bridge. 0, or -1. */
int urbsim_native_request(urbsim_world_t *w, int bridge, int address, int mailbox, int read, int length, int every);
/** Native host counters: sent, ok, failed, timeouts, skipped, resyncs, pending, lat_mean_ns,
 *  lat_max_ns, lat_min_ns; NaN when unknown. */
double urbsim_native_stat(urbsim_world_t *w, int bridge, const char *name);

#endif /* URBSIM_H */
