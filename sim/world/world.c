/*
 * world.c: one simulated URB system (urbsim.h): assembly of bridges and nodes from the parameter
 * table, the host CPU's timing, the hand-over of uplink data to the Python side, statistics and
 * fault injection.
 *
 * HOST CPU MODEL (documented in sim/README.md):
 *   - its clock is a crystal with error N(cpu.ppm_mean, cpu.ppm_sd);
 *   - the OS tick comes every cpu.tick_us of that clock; a thread sleeping until time T runs at the
 *     first tick at or after T plus cpu.timer_wake_us plus uniform 0..cpu.timer_jitter_us, drawn
 *     once per tick: threads woken by the same tick run back to back in the order they went to
 *     sleep (Linux with HZ=1000: sleeps end on jiffies);
 *   - a thread blocked on I/O (the RS232 read thread, the USB read thread) runs cpu.io_wake_us plus
 *     uniform 0..cpu.io_jitter_us after the interrupt that delivered the data; data arriving
 *     while it is pending is read in the same wake-up.
 */
#ifdef URBSIM_MUTANT_PID_SEED
#define _POSIX_C_SOURCE 200809L /* getpid */
#endif
#include "urbsim.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef URBSIM_MUTANT_PID_SEED
#include <unistd.h>
#endif

#include "native_host.h"
#include "params.h"
#include "sim_devices.h"
#include "sim_node_faults.h"

#define MAX_BRIDGES 8
#define MAX_NODES 128
#define INBOX_ITEMS 256
#define ITEM_BYTES 512

static const char *const PARAM_NAME[] = {
#define X(id, name, def, doc) name,
    URBSIM_PARAMS(X)
#undef X
};
static const double PARAM_DEFAULT[] = {
#define X(id, name, def, doc) def,
    URBSIM_PARAMS(X)
#undef X
};
static const char *const PARAM_DOC[] = {
#define X(id, name, def, doc) doc,
    URBSIM_PARAMS(X)
#undef X
};

typedef struct {
    int bridge;
    uint32_t len;
    int ready;
    uint8_t data[ITEM_BYTES];
} host_item_t;

typedef struct {
    int open_item;        /* RS232: index of the item still collecting bytes, -1 none */
    double usb_loss;
    nh_bridge_t *native;  /* the native host drives this bridge (no Python) */
} host_port_t;

/* A babbling device: answers any address with probability `rate` and sends random bytes. */
typedef struct {
    urbsim_i2c_slave_t slave;
    urbsim_rng_t rng;
    double rate;
    urbsim_mcu_t mcu;
} babbler_t;

struct urbsim_world {
    uint64_t seed;
    urbsim_kernel_t k;
    urbsim_trace_t tr;
    FILE *trace_file;
    double p[P_COUNT];
    bool started;
    /* USB host controller shared by the USB bridges */
    urbsim_clock_t usb_clock;
    urbsim_usb_bus_t usb;
    bool usb_ready;
    /* host CPU */
    urbsim_clock_t cpu;
    urbsim_rng_t host_rng;
    host_port_t port[MAX_BRIDGES];
    host_item_t items[INBOX_ITEMS];
    uint32_t item_head, item_len;
    uint64_t host_wakes;
    /* devices */
    sim_bridge_t *bridges[MAX_BRIDGES];
    int n_bridges;
    sim_node_t *nodes[MAX_NODES];
    int node_bridge[MAX_NODES];
    int n_nodes;
    babbler_t *babblers[MAX_BRIDGES];
    bool native_on;
};

/* ---------------------------------------------------------------- parameters */

static int param_index(const char *name)
{
    for (int i = 0; i < P_COUNT; i++) {
        if (strcmp(PARAM_NAME[i], name) == 0) {
            return i;
        }
    }
    return -1;
}

int urbsim_param_count(void) { return P_COUNT; }
const char *urbsim_param_name(int i) { return (i >= 0 && i < P_COUNT) ? PARAM_NAME[i] : NULL; }
double urbsim_param_default(int i) { return (i >= 0 && i < P_COUNT) ? PARAM_DEFAULT[i] : NAN; }
const char *urbsim_param_doc(int i) { return (i >= 0 && i < P_COUNT) ? PARAM_DOC[i] : NULL; }

int urbsim_set(urbsim_world_t *w, const char *name, double value)
{
    int i = w && name ? param_index(name) : -1;
    if (i < 0) {
        return -1;
    }
    w->p[i] = value;
    return 0;
}

double urbsim_get(const urbsim_world_t *w, const char *name)
{
    int i = w && name ? param_index(name) : -1;
    return i < 0 ? NAN : w->p[i];
}

/* ---------------------------------------------------------------- construction */

urbsim_world_t *urbsim_new(uint64_t seed)
{
    urbsim_world_t *w = calloc(1, sizeof *w);
    if (!w) {
        return NULL;
    }
    w->seed = seed;
#ifdef URBSIM_MUTANT_PID_SEED /* seeded bug (tests/sim/test_determinism.py): the process id salts the seed */
    w->seed ^= (uint64_t)getpid();
#endif
    if (!urbsim_kernel_init(&w->k)) {
        free(w);
        return NULL;
    }
    urbsim_trace_init(&w->tr);
    for (int i = 0; i < P_COUNT; i++) {
        w->p[i] = PARAM_DEFAULT[i];
    }
    for (int i = 0; i < MAX_BRIDGES; i++) {
        w->port[i].open_item = -1;
    }
    return w;
}

void urbsim_free(urbsim_world_t *w)
{
    if (!w) {
        return;
    }
    for (int i = 0; i < w->n_bridges; i++) {
        sim_bridge_free(w->bridges[i]);
#ifndef URBSIM_MUTANT_LEAK_BABBLER /* seeded bug (tools/sim_sanitized.py): a babbling node is never freed */
        free(w->babblers[i]);
#endif
        free(w->port[i].native);
    }
    for (int i = 0; i < w->n_nodes; i++) {
        sim_node_free(w->nodes[i]);
    }
    if (w->trace_file) {
        fclose(w->trace_file);
    }
    urbsim_kernel_free(&w->k);
    free(w);
}

int urbsim_trace_open(urbsim_world_t *w, const char *path, uint32_t mask)
{
    if (!w) {
        return -1;
    }
    if (w->trace_file) {
        fclose(w->trace_file);
        w->trace_file = NULL;
    }
    if (path) {
        w->trace_file = fopen(path, "w");
        if (!w->trace_file) {
            return -1;
        }
    }
    w->tr.file = w->trace_file;
    w->tr.mask = mask;
    return 0;
}

/* A crystal: error drawn from N(mean, sd) on the device's own stream (first draw). */
static urbsim_clock_cfg_t crystal(urbsim_rng_t *r, double hz, double mean, double sd, double wander,
                                  double tau, double ramp, double irq, double jitter)
{
    urbsim_clock_cfg_t c = urbsim_clock_default_cfg();
    c.cpu_hz = hz;
    c.timer_hz = hz;
    c.ppm0 = urbsim_rng_normal(r, mean, sd);
    c.wander_ppm = wander;
    c.wander_tau_s = tau;
    c.ramp_ppm_per_s = ramp;
    c.irq_base_cycles = (uint32_t)irq;
    c.irq_jitter_cycles = (uint32_t)jitter;
    return c;
}

/* A Cortex-M0+ core's flash wait states `ws` and idle path (mcu.h) on its clock: the vector fetch and
 * the handler's first fetch wait 2 ws more, the instruction in flight 0..ws more; mask_cycles come
 * from the code's critical sections, already counted with the wait states (sim/profiles). */
static void core_timing(urbsim_clock_cfg_t *c, double ws, double idle, double mask, double wfi_wake)
{
    c->irq_base_cycles += (uint32_t)(2.0 * ws);
    c->irq_jitter_cycles += (uint32_t)ws;
    c->idle_cycles = idle * (1.0 + 0.5 * ws);
    c->mask_cycles = mask;
    c->wfi_wake_cycles = wfi_wake;
}

/* Code run from flash with `ws` wait states: one per 32-bit fetch of two 16-bit instructions, no
 * cache or prefetch hit (conservative). */
static double from_flash(double cycles, double ws)
{
    return cycles * (1.0 + 0.5 * ws);
}

/* How the nodes on a downlink see its edges, from the bus and node parameters (urbsim_i2c_edges_t). */
static void bus_edges(urbsim_world_t *w, urbsim_i2c_bus_t *bus, int bridge)
{
    urbsim_i2c_edges_t e;
    memset(&e, 0, sizeof e);
    double c_f = w->p[P_I2C_BUS_PF] * 1e-12;
    if (c_f > 0.0 && w->p[P_I2C_SINK_MA] > 0.0) {
        e.fall_ns = c_f * w->p[P_I2C_VDD] / (w->p[P_I2C_SINK_MA] * 1e-3) * 1e9;
    }
    e.rise_tau_ns = w->p[P_I2C_PULLUP] * c_f * 1e9;
    e.vth_min = w->p[P_NODE_VTH_MIN];
    e.vth_max = w->p[P_NODE_VTH_MAX];
    e.filter_min_ns = w->p[P_NODE_FILTER_MIN];
    e.filter_max_ns = w->p[P_NODE_FILTER_MAX];
    if (w->p[P_NODE_I2C_CLK] > 0.0) {
        e.sync_min_ns = w->p[P_NODE_SYNC_MIN] / w->p[P_NODE_I2C_CLK] * 1e9;
        e.sync_max_ns = w->p[P_NODE_SYNC_MAX] / w->p[P_NODE_I2C_CLK] * 1e9;
    }
    urbsim_rng_t r;
    urbsim_rng_derive(&r, w->seed, "i2c/edges", (uint64_t)bridge);
    e.seed = urbsim_rng_u64(&r);
    urbsim_i2c_set_edges(bus, &e);
}

static void host_deliver(void *hctx, int bridge, const uint8_t *data, uint32_t n, urbsim_ns_t t);

static void ensure_usb(urbsim_world_t *w)
{
    if (w->usb_ready) {
        return;
    }
    urbsim_rng_t r;
    urbsim_rng_derive(&r, w->seed, "usb/hc", 0);
    urbsim_clock_cfg_t c = crystal(&r, 12e6, 0.0, w->p[P_USB_PPM_SD], 0.0, 10.0, 0.0, 0.0, 0.0);
    urbsim_clock_init(&w->usb_clock, &c, &r);
    double phase = w->p[P_USB_PHASE_US];
    urbsim_ns_t phase_ns = phase < 0.0 ? urbsim_rng_below(&r, URBSIM_NS_PER_MS) : (urbsim_ns_t)(phase * 1000.0);
    urbsim_usb_init(&w->usb, &w->k, &w->tr, "usb", &w->usb_clock, phase_ns);
    w->usb.bitrate = w->p[P_USB_BITRATE];
    w->usb.hc_irq_ns = (urbsim_ns_t)(w->p[P_USB_HC_IRQ_US] * 1000.0);
    w->usb.nak_next_frame = w->p[P_USB_NAK_NEXT_FRAME] != 0.0;
    w->usb_ready = true;
}

int urbsim_add_bridge(urbsim_world_t *w, int uplink)
{
    if (!w || w->started || w->n_bridges >= MAX_BRIDGES || (uplink != URBSIM_UPLINK_RS232 && uplink != URBSIM_UPLINK_USB)) {
        return -1;
    }
    int id = w->n_bridges;
    urbsim_rng_t r;
    urbsim_rng_derive(&r, w->seed, "bridge", (uint64_t)id);
    sim_bridge_cfg_t cfg;
    cfg.clock = crystal(&r, w->p[P_BRIDGE_CPU_HZ], w->p[P_BRIDGE_PPM_MEAN], w->p[P_BRIDGE_PPM_SD],
                        w->p[P_BRIDGE_WANDER_PPM], 30.0, 0.0, w->p[P_BRIDGE_IRQ_CYCLES], w->p[P_BRIDGE_IRQ_JITTER]);
    double ws = w->p[P_BRIDGE_FLASH_WS];
    core_timing(&cfg.clock, ws, w->p[P_BRIDGE_IDLE_CYCLES], w->p[P_BRIDGE_MASK_CYCLES], w->p[P_BRIDGE_WFI_WAKE]);
    cfg.i2c_isr_cycles = from_flash(w->p[P_BRIDGE_I2C_ISR], ws);
    cfg.uart_isr_cycles = from_flash(w->p[P_BRIDGE_UART_ISR], ws);
    cfg.timer_isr_cycles = from_flash(w->p[P_BRIDGE_TIMER_ISR], ws);
    cfg.usb_isr_cycles = from_flash(w->p[P_BRIDGE_USB_ISR], ws);
    cfg.wake_cycles = from_flash(w->p[P_BRIDGE_WAKE], ws);
    cfg.poll_cycles = from_flash(w->p[P_BRIDGE_POLL], ws);
    cfg.busy_poll_ns = (urbsim_ns_t)(w->p[P_BRIDGE_BUSY_POLL_US] * 1000.0);
    cfg.uart_divider_hz = w->p[P_BRIDGE_DIVIDER];
    cfg.i2c_bitrate = w->p[P_I2C_BITRATE];
    cfg.fifo_depth = (uint8_t)w->p[P_BRIDGE_FIFO];
    cfg.baud = (uint32_t)w->p[P_BRIDGE_BAUD];
    cfg.heartbeat_us = (uint16_t)w->p[P_BRIDGE_HEARTBEAT_US];
    cfg.scan_at_start = w->p[P_BRIDGE_SCAN] != 0.0;
    cfg.usb_read_always = w->p[P_USB_READ_ALWAYS] != 0.0;
    cfg.heartbeat_sof = w->p[P_BRIDGE_HB_SOF] != 0.0;
    char name[32];
    snprintf(name, sizeof name, "%s%d", uplink == URBSIM_UPLINK_USB ? "usb" : "rs232", id);
    if (uplink == URBSIM_UPLINK_USB) {
        ensure_usb(w);
    }
    sim_bridge_t *b = sim_bridge_new(name, id, uplink, &w->k, &w->tr, &cfg,
                                     uplink == URBSIM_UPLINK_USB ? &w->usb : NULL, host_deliver, w, &r);
    if (!b) {
        return -1;
    }
    w->bridges[id] = b;
    w->n_bridges++;
    bus_edges(w, sim_bridge_bus(b), id);
    return id;
}

int urbsim_add_node(urbsim_world_t *w, int bridge, int app, int address, int index)
{
    if (!w || w->started || w->n_nodes >= MAX_NODES || bridge < 0 || bridge >= w->n_bridges || address < 1 ||
        address > 127 || index < 0 || index > 63) {
        return -1;
    }
    int id = w->n_nodes;
    sim_app_cfg_t a;
    a.app = app;
    a.index = (uint8_t)index;
    a.class_id = (uint8_t)w->p[P_PROBE_CLASS];
    a.fingerprint = (uint32_t)w->p[P_PROBE_FINGERPRINT];
    a.out_size = (uint8_t)w->p[P_PROBE_OUT];
    a.in_size = (uint8_t)w->p[P_PROBE_IN];
    a.fill_counter = w->p[P_PROBE_FILL] != 0.0;
    a.motor = urbsim_motor_default_params();
    a.motor.Jleg = w->p[P_MOTOR_JLEG];
    a.motor.mgr = w->p[P_MOTOR_MGR];
    a.motor.N = w->p[P_MOTOR_N];
    a.motor.Vs = w->p[P_MOTOR_VS];
    a.motor.f_pwm = w->p[P_MOTOR_PWM];
    urbsim_rng_t r;
    urbsim_rng_derive(&r, w->seed, "node", (uint64_t)(bridge * 128 + address));
    sim_node_cfg_t cfg;
    cfg.clock = crystal(&r, w->p[P_NODE_CPU_HZ], w->p[P_NODE_PPM_MEAN], w->p[P_NODE_PPM_SD], w->p[P_NODE_WANDER_PPM],
                        w->p[P_NODE_WANDER_TAU], w->p[P_NODE_RAMP], w->p[P_NODE_IRQ_CYCLES], w->p[P_NODE_IRQ_JITTER]);
    cfg.ticks_per_us = (uint16_t)w->p[P_NODE_TICKS_PER_US];
    double ws = w->p[P_NODE_FLASH_WS];
    core_timing(&cfg.clock, ws, w->p[P_NODE_IDLE_CYCLES], w->p[P_NODE_MASK_CYCLES], w->p[P_NODE_WFI_WAKE]);
    cfg.i2c_isr_cycles = from_flash(w->p[P_NODE_I2C_ISR], ws);
    cfg.timer_isr_cycles = from_flash(w->p[P_NODE_TIMER_ISR], ws);
    cfg.wake_cycles = from_flash(w->p[P_NODE_WAKE], ws);
    cfg.poll_cycles = from_flash(w->p[P_NODE_POLL], ws);
    cfg.acq_ns = w->p[P_NODE_ACQ_US] * 1000.0;
    cfg.acq_jitter_cycles = (uint32_t)w->p[P_NODE_ACQ_JITTER];
    cfg.sync_capture = w->p[P_NODE_SYNC_CAPTURE] != 0.0;
    cfg.address = (uint8_t)address;
    cfg.heartbeat_us = (uint16_t)w->p[P_NODE_HEARTBEAT_US];
    cfg.sync_enabled = w->p[P_NODE_SYNC] != 0.0;
    cfg.lead_us = (uint16_t)w->p[P_NODE_LEAD_US];
    cfg.kd_q8 = (uint8_t)w->p[P_NODE_KD_Q8];
    cfg.kn_q8 = (uint8_t)w->p[P_NODE_KN_Q8];
    cfg.outlier_ns = (uint16_t)w->p[P_NODE_OUTLIER_NS];
    cfg.max_outliers = (uint8_t)w->p[P_NODE_MAX_OUTLIERS];
    cfg.acq_window = (uint8_t)w->p[P_NODE_ACQ_WINDOW];
    cfg.acq_guard_us = (uint8_t)w->p[P_NODE_ACQ_GUARD];
    char name[48];
    snprintf(name, sizeof name, "%s/n%d", sim_bridge_name(w->bridges[bridge]), address);
    sim_node_t *n = sim_node_new(name, &w->k, &w->tr, sim_bridge_bus(w->bridges[bridge]), &cfg, &a, &r);
    if (!n) {
        return -1;
    }
    w->nodes[id] = n;
    w->node_bridge[id] = bridge;
    w->n_nodes++;
    return id;
}

/* ---------------------------------------------------------------- start and run */

enum { EV_NODE_ON, EV_HOST_WAKE, EV_BRIDGE_ON, EV_NATIVE_TICK };

static void world_event(void *ctx, uint64_t arg, urbsim_ns_t now);

/* The native host's thread: wakes on every OS tick k (like a thread sleeping on the 1-kHz tick)
 * and sends each natively driven bridge its due requests. */
static void native_tick(urbsim_world_t *w, uint64_t k)
{
    uint8_t buf[URBSIM_USB_MAX_XFER];
    size_t ends[NH_MAX_REQS];
    for (int b = 0; b < w->n_bridges; b++) {
        nh_bridge_t *h = w->port[b].native;
        if (!h) {
            continue;
        }
        nh_timeouts(h, w->k.now, 100 * URBSIM_NS_PER_MS);
        uint32_t frames;
        size_t n = nh_cycle(h, w->k.now, buf, sizeof buf, ends, &frames);
        if (!n) {
            continue;
        }
        sim_bridge_t *br = w->bridges[b];
        if (sim_bridge_uplink(br) == SIM_UPLINK_RS232) {
            size_t from = 0;
            for (uint32_t f = 0; f < frames; f++) { /* one write() per frame */
                sim_bridge_host_send(br, buf + from, (uint32_t)(ends[f] - from));
                from = ends[f];
            }
        } else {
            urbsim_usb_write(&w->usb, (uint32_t)sim_bridge_usb_index(br), buf, (uint32_t)n);
        }
    }
    double tick = w->p[P_CPU_TICK_US] * 1000.0;
    urbsim_kernel_at(&w->k, urbsim_host_timer(w, (int64_t)((double)(k + 1u) * tick)), world_event, w,
                     EV_NATIVE_TICK | ((k + 1u) << 8));
}

static void world_event(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    urbsim_world_t *w = ctx;
    int kind = (int)(arg & 0xFFu);
    int idx = (int)(arg >> 8);
    (void)now;
    if (kind == EV_NODE_ON) {
        sim_node_power_on(w->nodes[idx]);
        return;
    }
    if (kind == EV_BRIDGE_ON) {
        sim_bridge_power_on(w->bridges[idx]);
        return;
    }
    if (kind == EV_NATIVE_TICK) {
        native_tick(w, (uint64_t)idx);
        return;
    }
    /* EV_HOST_WAKE: the read thread of bridge idx runs now and reads everything that arrived. */
    for (uint32_t i = 0; i < w->item_len; i++) {
        host_item_t *it = &w->items[(w->item_head + i) % INBOX_ITEMS];
        if (it->bridge == idx) {
            it->ready = 1;
        }
    }
    w->port[idx].open_item = -1;
    w->host_wakes++;
    urbsim_kernel_stop(&w->k);
}

int urbsim_start(urbsim_world_t *w)
{
    if (!w || w->started) {
        return -1;
    }
    w->started = true;
    urbsim_rng_derive(&w->host_rng, w->seed, "host/cpu", 0);
    urbsim_clock_cfg_t c = crystal(&w->host_rng, 1e9, w->p[P_CPU_PPM_MEAN], w->p[P_CPU_PPM_SD], 0.0, 10.0, 0.0, 0.0, 0.0);
    urbsim_clock_init(&w->cpu, &c, &w->host_rng);
    urbsim_ns_t bridge_on = (urbsim_ns_t)(w->p[P_BRIDGE_BOOT_MS] * 1e6);
    for (int i = 0; i < w->n_bridges; i++) {
        urbsim_kernel_at(&w->k, bridge_on, world_event, w, EV_BRIDGE_ON | ((uint64_t)i << 8));
    }
    if (w->usb_ready) {
        urbsim_usb_run(&w->usb);
    }
    if (w->native_on) {
        /* the native host starts with the first tick after the bridges are up */
        uint64_t k = (uint64_t)(w->p[P_BRIDGE_BOOT_MS] * 1000.0 / w->p[P_CPU_TICK_US]) + 50u;
        urbsim_kernel_at(&w->k, urbsim_host_timer(w, (int64_t)((double)k * w->p[P_CPU_TICK_US] * 1000.0)), world_event,
                         w, EV_NATIVE_TICK | (k << 8));
    }
    for (int i = 0; i < w->n_nodes; i++) {
        urbsim_rng_t r;
        urbsim_rng_derive(&r, w->seed, "node/boot", (uint64_t)i);
        urbsim_ns_t t = (urbsim_ns_t)(urbsim_rng_uniform(&r) * w->p[P_NODE_BOOT_MS] * 1e6);
        urbsim_kernel_at(&w->k, t, world_event, w, EV_NODE_ON | ((uint64_t)i << 8));
    }
    return 0;
}

int urbsim_run(urbsim_world_t *w, uint64_t limit)
{
    if (!w || !w->started) {
        return -1;
    }
    return urbsim_kernel_run_until(&w->k, limit) ? 1 : 0;
}

uint64_t urbsim_now(const urbsim_world_t *w) { return w ? w->k.now : 0u; }
uint64_t urbsim_events(const urbsim_world_t *w) { return w ? w->k.executed : 0u; }
uint64_t urbsim_trace_hash(const urbsim_world_t *w) { return w ? w->tr.hash : 0u; }
uint64_t urbsim_trace_lines(const urbsim_world_t *w) { return w ? w->tr.lines : 0u; }

void urbsim_trace_flush(urbsim_world_t *w)
{
    if (w && w->trace_file) {
        fflush(w->trace_file);
    }
}

/* ---------------------------------------------------------------- host CPU */

int64_t urbsim_host_local(urbsim_world_t *w)
{
    return w && w->started ? (int64_t)floor(urbsim_clock_local_ns(&w->cpu, w->k.now)) : 0;
}

uint64_t urbsim_host_timer(urbsim_world_t *w, int64_t local_ns)
{
    if (!w || !w->started) {
        return 0;
    }
    double tick = w->p[P_CPU_TICK_US] * 1000.0;
    double k = ceil((double)local_ns / tick);
    if (k < 0.0) {
        k = 0.0;
    }
    urbsim_ns_t t = urbsim_clock_virtual_at(&w->cpu, k * tick);
    while (t < w->k.now) {
        k += 1.0; /* that tick has passed: the thread runs at the next one */
        t = urbsim_clock_virtual_at(&w->cpu, k * tick);
    }
    /* Every thread woken by tick k resumes at the same instant (the tick's scheduling delay,
     * drawn once per tick) and they run in the order they went to sleep. */
    urbsim_rng_t tick_rng;
    urbsim_rng_derive(&tick_rng, w->seed, "host/tick", (uint64_t)k);
    double jitter = urbsim_rng_uniform(&tick_rng) * w->p[P_CPU_TIMER_JITTER_US];
    return t + (urbsim_ns_t)((w->p[P_CPU_TIMER_WAKE_US] + jitter) * 1000.0);
}

/* Data reached the host's driver at t (RS232 byte or USB read callback). */
static void host_deliver(void *hctx, int bridge, const uint8_t *data, uint32_t n, urbsim_ns_t t)
{
    urbsim_world_t *w = hctx;
    host_port_t *p = &w->port[bridge];
    bool usb = sim_bridge_uplink(w->bridges[bridge]) == SIM_UPLINK_USB;
    if (p->native) {
        /* the read thread wakes after the usual latency; the model takes the data at once and
         * adds that latency to what it measures */
        double jitter = urbsim_rng_uniform(&w->host_rng) * w->p[P_CPU_IO_JITTER_US];
        nh_receive(p->native, data, n, t + (urbsim_ns_t)((w->p[P_CPU_IO_WAKE_US] + jitter) * 1000.0));
        return;
    }
    if (usb && p->usb_loss > 0.0 && urbsim_rng_uniform(&w->host_rng) < p->usb_loss) {
        urbsim_trace(&w->tr, URBSIM_TR_FAULT, t, sim_bridge_name(w->bridges[bridge]), "usb_in_lost", ",\"len\":%u", n);
        return;
    }
    host_item_t *it = NULL;
    if (!usb && p->open_item >= 0) {
        host_item_t *open = &w->items[p->open_item];
        if (open->len + n <= ITEM_BYTES) {
            it = open;
        }
    }
    bool wake = false;
    if (!it) {
        if (w->item_len >= INBOX_ITEMS) {
            urbsim_trace(&w->tr, URBSIM_TR_FAULT, t, sim_bridge_name(w->bridges[bridge]), "host_overrun", ",\"len\":%u", n);
            return;
        }
        uint32_t slot = (w->item_head + w->item_len) % INBOX_ITEMS;
        it = &w->items[slot];
        it->bridge = bridge;
        it->len = 0;
        it->ready = 0;
        w->item_len++;
        wake = usb || p->open_item < 0;
        if (!usb) {
            p->open_item = (int)slot;
        }
    }
    memcpy(it->data + it->len, data, n);
    it->len += n;
    if (wake) {
        double jitter = urbsim_rng_uniform(&w->host_rng) * w->p[P_CPU_IO_JITTER_US];
        urbsim_ns_t when = t + (urbsim_ns_t)((w->p[P_CPU_IO_WAKE_US] + jitter) * 1000.0);
        urbsim_kernel_at(&w->k, when, world_event, w, EV_HOST_WAKE | ((uint64_t)bridge << 8));
    }
}

int urbsim_host_send(urbsim_world_t *w, int bridge, const uint8_t *data, uint32_t n)
{
    if (!w || !w->started || bridge < 0 || bridge >= w->n_bridges || (!data && n)) {
        return -1;
    }
    sim_bridge_t *b = w->bridges[bridge];
    if (sim_bridge_uplink(b) == SIM_UPLINK_RS232) {
        return (int)sim_bridge_host_send(b, data, n);
    }
    int dev = sim_bridge_usb_index(b);
    if (n > URBSIM_USB_MAX_XFER || dev < 0 || !urbsim_usb_write(&w->usb, (uint32_t)dev, data, n)) {
        return -1;
    }
    return (int)n;
}

/* The first ready item into buf (its bridge in *bridge), removed keeping the order of the others;
 * *more counts the ready items behind it. -1 when none is ready. */
static int host_take_ready(urbsim_world_t *w, int *bridge, uint32_t *more, uint8_t *buf, uint32_t cap)
{
    *more = 0u;
    uint32_t i = 0;
    while (i < w->item_len && !w->items[(w->item_head + i) % INBOX_ITEMS].ready) {
        i++;
    }
    if (i == w->item_len) {
        return -1;
    }
    host_item_t *it = &w->items[(w->item_head + i) % INBOX_ITEMS];
    uint32_t n = it->len < cap ? it->len : cap;
    memcpy(buf, it->data, n);
    *bridge = it->bridge;
    /* remove slot i, keeping the order of the others */
    for (uint32_t j = i; j + 1u < w->item_len; j++) {
        uint32_t a = (w->item_head + j) % INBOX_ITEMS, b = (w->item_head + j + 1u) % INBOX_ITEMS;
        w->items[a] = w->items[b];
        for (int q = 0; q < w->n_bridges; q++) {
            if (w->port[q].open_item == (int)b) {
                w->port[q].open_item = (int)a;
            }
        }
    }
    w->item_len--;
    for (uint32_t j = i; j < w->item_len; j++) {
        *more += w->items[(w->item_head + j) % INBOX_ITEMS].ready ? 1u : 0u;
    }
    return (int)n;
}

int urbsim_host_take(urbsim_world_t *w, int *bridge, uint8_t *buf, uint32_t cap)
{
    uint32_t more;
    return w ? host_take_ready(w, bridge, &more, buf, cap) : -1;
}

int urbsim_host_take_more(urbsim_world_t *w, int *bridge, uint32_t *more, uint8_t *buf, uint32_t cap)
{
    if (!w || !bridge || !more) {
        return -1;
    }
    return host_take_ready(w, bridge, more, buf, cap);
}

int urbsim_run_take(urbsim_world_t *w, uint64_t limit, int *bridge, uint32_t *more, uint8_t *buf, uint32_t cap)
{
    if (!w || !w->started || !bridge || !more) {
        return URBSIM_RUN_ERROR;
    }
    if (!urbsim_kernel_run_until(&w->k, limit)) {
        return URBSIM_RUN_LIMIT;
    }
    int n = host_take_ready(w, bridge, more, buf, cap);
    if (n < 0) {
        *bridge = -1; /* woken with nothing ready (every wake-up has an item: defensive) */
        return 0;
    }
    return n;
}

/* ---------------------------------------------------------------- measurements */

uint32_t urbsim_node_marks(urbsim_world_t *w, int node, uint64_t *t, uint32_t *v, uint32_t cap)
{
    if (!w || node < 0 || node >= w->n_nodes) {
        return 0;
    }
    return sim_log_drain(sim_node_log(w->nodes[node]), t, v, cap);
}

uint32_t urbsim_bridge_marks(urbsim_world_t *w, int bridge, uint64_t *t, uint32_t *v, uint32_t cap)
{
    if (!w || bridge < 0 || bridge >= w->n_bridges) {
        return 0;
    }
    return sim_log_drain(sim_bridge_log(w->bridges[bridge]), t, v, cap);
}

int urbsim_node_status(urbsim_world_t *w, int node, int64_t *out)
{
    if (!w || node < 0 || node >= w->n_nodes) {
        return -1;
    }
    sim_node_status(w->nodes[node], out);
    return 0;
}

int urbsim_node_plant(urbsim_world_t *w, int node, double *out)
{
    if (!w || node < 0 || node >= w->n_nodes) {
        return -1;
    }
    return sim_node_plant(w->nodes[node], out);
}

double urbsim_stat(urbsim_world_t *w, const char *name, int id)
{
    if (!w || !name) {
        return NAN;
    }
    if (strncmp(name, "node.", 5) == 0) {
        return (id < 0 || id >= w->n_nodes) ? NAN : sim_node_stat(w->nodes[id], name + 5);
    }
    if (strncmp(name, "bridge.", 7) == 0 || strncmp(name, "i2c.", 4) == 0 || strncmp(name, "uart.", 5) == 0) {
        return (id < 0 || id >= w->n_bridges) ? NAN : sim_bridge_stat(w->bridges[id], name);
    }
    if (!strcmp(name, "usb.frames")) return (double)w->usb.frames;
    if (!strcmp(name, "usb.busy_bits")) return (double)w->usb.busy_bits;
    if (!strcmp(name, "usb.phase_ns")) return (double)w->usb.phase_ns;
    if (!strcmp(name, "host.wakes")) return (double)w->host_wakes;
    if (!strcmp(name, "kernel.pending")) return (double)urbsim_kernel_pending(&w->k);
    if (!strcmp(name, "kernel.capacity")) return (double)urbsim_kernel_capacity(&w->k);
    if (!strcmp(name, "cpu.ppm")) return w->cpu.cfg.ppm0;
    return NAN;
}

/* ---------------------------------------------------------------- faults */

static bool valid_bridge(const urbsim_world_t *w, int b)
{
    return w && w->started && b >= 0 && b < w->n_bridges;
}

int urbsim_fault_i2c_ber(urbsim_world_t *w, int bridge, double ber)
{
    if (!valid_bridge(w, bridge)) {
        return -1;
    }
    urbsim_i2c_bus_t *bus = sim_bridge_bus(w->bridges[bridge]);
    urbsim_i2c_set_ber(bus, ber);
    urbsim_trace(&w->tr, URBSIM_TR_FAULT, w->k.now, bus->name, "ber", ",\"ber\":%g", ber);
    return 0;
}

int urbsim_fault_i2c_stuck(urbsim_world_t *w, int bridge, int line, uint64_t duration_ns, uint32_t pulses)
{
    if (!valid_bridge(w, bridge) || line < 0 || line > 1) {
        return -1;
    }
    urbsim_i2c_bus_t *bus = sim_bridge_bus(w->bridges[bridge]);
    urbsim_ns_t until = duration_ns ? w->k.now + duration_ns : URBSIM_NEVER;
    if (line == 0) {
        urbsim_i2c_stick_sda(bus, until, pulses);
    } else {
        urbsim_i2c_stick_scl(bus, until);
        for (int i = 0; i < w->n_nodes; i++) {
            if (w->node_bridge[i] == bridge) {
                sim_node_scl_low(w->nodes[i], (urbsim_ns_t)(w->p[P_NODE_SCL_TIMEOUT] * 1e6));
            }
        }
    }
    return 0;
}

int urbsim_fault_uart(urbsim_world_t *w, int bridge, int dir, double ber, double loss)
{
    urbsim_uart_line_t *u = valid_bridge(w, bridge) ? sim_bridge_uart(w->bridges[bridge], dir) : NULL;
    if (!u) {
        return -1;
    }
    urbsim_uart_set_faults(u, ber, loss);
    urbsim_trace(&w->tr, URBSIM_TR_FAULT, w->k.now, u->name, "faults", ",\"ber\":%g,\"loss\":%g", ber, loss);
    return 0;
}

int urbsim_fault_usb_loss(urbsim_world_t *w, int bridge, double loss)
{
    if (!valid_bridge(w, bridge) || sim_bridge_uplink(w->bridges[bridge]) != SIM_UPLINK_USB) {
        return -1;
    }
    w->port[bridge].usb_loss = loss;
    return 0;
}

int urbsim_node_power(urbsim_world_t *w, int node, int on)
{
    if (!w || !w->started || node < 0 || node >= w->n_nodes) {
        return -1;
    }
    if (on) {
        sim_node_power_on(w->nodes[node]);
    } else {
        sim_node_power_off(w->nodes[node]);
    }
    return 0;
}

int urbsim_bridge_power(urbsim_world_t *w, int bridge, int on)
{
    if (!valid_bridge(w, bridge)) {
        return -1;
    }
    if (on) {
        sim_bridge_power_on(w->bridges[bridge]);
    } else {
        sim_bridge_power_off(w->bridges[bridge]);
    }
    return 0;
}

static urbsim_ns_t babble_window(void *ctx, urbsim_ns_t t_irq, urbsim_ns_t *end)
{
    babbler_t *bb = ctx;
    return urbsim_mcu_isr(&bb->mcu, t_irq, 40.0, end);
}
static bool babble_match(void *ctx, uint8_t address)
{
    babbler_t *bb = ctx;
    return address == bb->slave.address || urbsim_rng_uniform(&bb->rng) < bb->rate;
}
static bool babble_addr(void *ctx, bool read, bool gc, urbsim_ns_t t)
{
    (void)ctx, (void)read, (void)gc, (void)t;
    return true;
}
static bool babble_rx(void *ctx, uint8_t byte, urbsim_ns_t t)
{
    (void)ctx, (void)byte, (void)t;
    return true;
}
static uint8_t babble_tx(void *ctx, urbsim_ns_t t)
{
    babbler_t *bb = ctx;
    (void)t;
    return (uint8_t)urbsim_rng_u64(&bb->rng);
}
static void babble_nack(void *ctx, urbsim_ns_t t) { (void)ctx, (void)t; }
static void babble_stop(void *ctx, bool r, urbsim_ns_t t) { (void)ctx, (void)r, (void)t; }

int urbsim_fault_babble(urbsim_world_t *w, int bridge, int address, double rate)
{
    if (!valid_bridge(w, bridge) || address < 1 || address > 127) {
        return -1;
    }
    babbler_t *bb = w->babblers[bridge];
    if (!bb) {
        bb = calloc(1, sizeof *bb);
        if (!bb) {
            return -1;
        }
        urbsim_rng_derive(&bb->rng, w->seed, "babbler", (uint64_t)bridge);
        urbsim_clock_cfg_t c = urbsim_clock_default_cfg();
        urbsim_mcu_init(&bb->mcu, &c, &bb->rng);
        bb->slave.ctx = bb;
        bb->slave.isr_window = babble_window;
        bb->slave.match = babble_match;
        bb->slave.on_address = babble_addr;
        bb->slave.on_rx = babble_rx;
        bb->slave.on_tx = babble_tx;
        bb->slave.on_tx_nack = babble_nack;
        bb->slave.on_stop = babble_stop;
        if (!urbsim_i2c_attach(sim_bridge_bus(w->bridges[bridge]), &bb->slave)) {
            free(bb);
            return -1;
        }
        w->babblers[bridge] = bb;
    }
    bb->slave.address = (uint8_t)address;
    bb->rate = rate;
    urbsim_i2c_power(sim_bridge_bus(w->bridges[bridge]), &bb->slave, rate > 0.0);
    urbsim_trace(&w->tr, URBSIM_TR_FAULT, w->k.now, sim_bridge_bus(w->bridges[bridge])->name, "babble",
                 ",\"address\":%d,\"rate\":%g", address, rate);
    return 0;
}

/* ---------------------------------------------------------------- native host */

int urbsim_native_host(urbsim_world_t *w, int bridge, int period_ticks)
{
    if (!w || w->started || bridge < 0 || bridge >= w->n_bridges || period_ticks < 1) {
        return -1;
    }
    if (!w->port[bridge].native) {
        w->port[bridge].native = calloc(1, sizeof(nh_bridge_t));
        if (!w->port[bridge].native) {
            return -1;
        }
    }
    nh_init(w->port[bridge].native, bridge, sim_bridge_uplink(w->bridges[bridge]) == SIM_UPLINK_USB,
            (uint32_t)period_ticks);
    w->native_on = true;
    return 0;
}

int urbsim_native_request(urbsim_world_t *w, int bridge, int address, int mailbox, int read, int length, int every)
{
    if (!w || bridge < 0 || bridge >= w->n_bridges || !w->port[bridge].native || address < 1 || address > 127) {
        return -1;
    }
    return nh_add(w->port[bridge].native, (uint8_t)address, (uint8_t)mailbox, read != 0, (uint8_t)length,
                  (uint32_t)(every < 1 ? 1 : every));
}

double urbsim_native_stat(urbsim_world_t *w, int bridge, const char *name)
{
    if (!w || !name || bridge < 0 || bridge >= w->n_bridges || !w->port[bridge].native) {
        return NAN;
    }
    const nh_bridge_t *h = w->port[bridge].native;
    if (!strcmp(name, "sent")) return (double)h->sent;
    if (!strcmp(name, "ok")) return (double)h->ok;
    if (!strcmp(name, "failed")) return (double)h->failed;
    if (!strcmp(name, "timeouts")) return (double)h->timeouts;
    if (!strcmp(name, "skipped")) return (double)h->skipped;
    if (!strcmp(name, "resyncs")) return (double)h->resyncs;
    if (!strcmp(name, "pending")) return (double)h->pend_len;
    if (!strcmp(name, "lat_mean_ns")) return h->ok ? (double)h->lat_sum / (double)h->ok : NAN;
    if (!strcmp(name, "lat_max_ns")) return (double)h->lat_max;
    if (!strcmp(name, "lat_min_ns")) return h->ok ? (double)h->lat_min : NAN;
    return NAN;
}
