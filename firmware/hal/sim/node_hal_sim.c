/* node_hal_sim.c: the node library on a simulated MCU and I2C bus. See node_hal_sim.h. */
#include "node_hal_sim.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "sim_node_faults.h"

/* Event kinds, in bits 0..7 of the event argument; the node's power generation above. */
enum { EV_TIMER_IRQ, EV_TIMER_ISR, EV_POLL, EV_ACQ_DONE, EV_SCL_TIMEOUT, EV_SCL_TIMEOUT_ISR };
#define NODE_ARG(n, kind, gen) ((uint64_t)(kind) | ((gen) << 8))

static void node_event(void *ctx, uint64_t arg, urbsim_ns_t now);
static void scl_timeout(sim_node_t *n, urbsim_ns_t now, bool isr);

/* ---------------------------------------------------------------- HAL functions */

static uint32_t hal_now(void *ctx)
{
    sim_node_t *n = ctx;
    return (uint32_t)urbsim_clock_ticks(&n->mcu.clk, n->k->now);
}

static void hal_set_compare(void *ctx, uint32_t at)
{
    sim_node_t *n = ctx;
    uint64_t cur = urbsim_clock_ticks(&n->mcu.clk, n->k->now);
    int32_t delta = (int32_t)(at - (uint32_t)cur);
    uint64_t target = delta > 0 ? cur + (uint64_t)delta : cur + 1u; /* a past compare fires at once */
    urbsim_ns_t t = urbsim_clock_virtual_at_tick(&n->mcu.clk, target);
    n->compare_gen++; /* replaces any pending compare, withdrawn through its handle when still far */
    urbsim_kernel_at_handle(n->k, t, node_event, n,
                            NODE_ARG(n, EV_TIMER_IRQ, (n->gen << 24) | (n->compare_gen & 0xFFFFFFu)), &n->compare_ev);
}

static uint32_t hal_sync_capture(void *ctx)
{
    sim_node_t *n = ctx;
    return (uint32_t)urbsim_clock_ticks(&n->mcu.clk, n->gc_hw);
}

static void hal_set_address(void *ctx, uint8_t address)
{
    sim_node_t *n = ctx;
    n->slave.address = address;
    n->slave.general_call = true;
    urbsim_i2c_power(n->bus, &n->slave, true); /* interrupts on: the node is on the bus */
}

static void hal_mark(void *ctx, urb_node_mark_t mark)
{
    sim_node_t *n = ctx;
    sim_log_put(&n->log, n->k->now, (uint32_t)mark, (uint32_t)urbsim_clock_ticks(&n->mcu.clk, n->k->now));
    if (urbsim_trace_on(n->tr, URBSIM_TR_SYNC)) {
        static const char *names[] = {"beat", "acq_end", "sync"};
        urbsim_trace(n->tr, URBSIM_TR_SYNC, n->k->now, n->name, mark < 3 ? names[mark] : "mark", "%s", "");
    }
}

/* ---------------------------------------------------------------- main loop */

/* An update is due: the library's timer interrupt counted a heartbeat the main loop has not run. */
static bool update_due(const sim_node_t *n)
{
    return urb_node_update_due(&n->node);
}

/* The main loop wakes (after an interrupt returned at t): run a poll as soon as the CPU is free. */
static void want_poll(sim_node_t *n, urbsim_ns_t t)
{
    if (!n->powered || n->acquiring) {
        return; /* the pending acquisition's poll will do all pending work */
    }
    t += urbsim_clock_cycles_ns(&n->mcu.clk, t, n->cfg.wake_cycles);
    if (t < n->mcu.thread_until) {
        t = n->mcu.thread_until;
    }
    if (n->poll_pending && n->poll_at <= t) {
        return;
    }
    n->poll_pending = true;
    n->poll_at = t;
    n->poll_gen++; /* a later iteration brought forward is withdrawn through the handle */
    urbsim_kernel_at_handle(n->k, t, node_event, n, NODE_ARG(n, EV_POLL, (n->gen << 24) | (n->poll_gen & 0xFFFFFFu)),
                            &n->poll_ev);
}

/* A main-loop iteration due at `now` while a handler runs waits for it: true when it was put off. */
static bool poll_waits_for_isr(sim_node_t *n, uint64_t arg, urbsim_ns_t now)
{
    urbsim_ns_t free_at = urbsim_mcu_thread_free(&n->mcu, now);
    if (free_at == now) {
        return false;
    }
    if ((arg & 0xFFu) == EV_POLL) {
        n->poll_at = free_at; /* still pending: a poll wanted before free_at is not scheduled again */
        urbsim_kernel_at_handle(n->k, free_at, node_event, n, arg, &n->poll_ev);
    } else {
        urbsim_kernel_at(n->k, free_at, node_event, n, arg);
    }
    return true;
}

static void run_poll(sim_node_t *n, urbsim_ns_t now)
{
    n->polls++;
    uint8_t done = urb_node_poll(&n->node);
    if (done & URB_NODE_POLL_UPDATE) {
        n->updates++;
    }
    urbsim_mcu_thread_busy(&n->mcu, now, urbsim_clock_cycles_ns(&n->mcu.clk, now, n->cfg.poll_cycles));
    if (update_due(n)) {
        want_poll(n, now); /* a heartbeat came during this iteration */
    }
}

static void node_event(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    sim_node_t *n = ctx;
    uint64_t g = arg >> 8;
    if ((g >> 24) != (n->gen & 0xFFFFFFFFFFull) || !n->powered) {
        return; /* scheduled before a power loss */
    }
    uint64_t sub = g & 0xFFFFFFu;
    switch ((int)(arg & 0xFFu)) {
    case EV_TIMER_IRQ: {
        if (sub != (n->compare_gen & 0xFFFFFFu)) {
            return; /* replaced by a later set_compare */
        }
        urbsim_ns_t end;
        urbsim_ns_t start = urbsim_mcu_isr(&n->mcu, now, n->cfg.timer_isr_cycles, &end);
        urbsim_kernel_at(n->k, start, node_event, n, NODE_ARG(n, EV_TIMER_ISR, (n->gen << 24) | (end & 0xFFFFFFu)));
        break;
    }
    case EV_TIMER_ISR: {
        urb_node_timer_event(&n->node);
        urbsim_ns_t end = now + urbsim_clock_cycles_ns(&n->mcu.clk, now, n->cfg.timer_isr_cycles);
        if (update_due(n)) {
            want_poll(n, end);
        }
        break;
    }
    case EV_POLL:
        if (sub != (n->poll_gen & 0xFFFFFFu) || poll_waits_for_isr(n, arg, now)) {
            return;
        }
        n->poll_pending = false;
        if (update_due(n)) {
            /* This iteration runs app_update: it first spends the acquisition time. */
            double extra = (double)urbsim_rng_below(&n->rng, (uint64_t)n->cfg.acq_jitter_cycles + 1u);
            n->acquiring = true;
            n->acq_start = now;
            urbsim_ns_t until = urbsim_mcu_thread_busy(
                &n->mcu, now, (urbsim_ns_t)n->cfg.acq_ns + urbsim_clock_cycles_ns(&n->mcu.clk, now, extra));
            urbsim_kernel_at(n->k, until, node_event, n, NODE_ARG(n, EV_ACQ_DONE, n->gen << 24));
            return;
        }
        run_poll(n, now);
        break;
    case EV_SCL_TIMEOUT:
    case EV_SCL_TIMEOUT_ISR:
        scl_timeout(n, now, (arg & 0xFFu) == EV_SCL_TIMEOUT_ISR);
        break;
    default: /* EV_ACQ_DONE */
        if (now < n->mcu.thread_until) {
            /* interrupts preempted the acquisition: it ends later */
            urbsim_kernel_at(n->k, n->mcu.thread_until, node_event, n, arg);
            return;
        }
        if (poll_waits_for_isr(n, arg, now)) {
            return; /* a handler raised before the acquisition began runs at its end */
        }
        n->acquiring = false;
        run_poll(n, now);
        break;
    }
}

/* ---------------------------------------------------------------- mailbox observer
 * Trace category "mailbox" (sim/tla/TraceOutbox.tla): for outbox 1, the application's releases
 * and the interrupt's read of it (begin, each data byte, end), as the MailboxOutbox actions the
 * library cites. The library's downlink view (urb_node_downlink) gives the outbox being read and
 * the index of each byte sent. */

static void probe_released(void *ctx, uint32_t counter)
{
    sim_node_t *n = ctx;
    urbsim_trace(n->tr, URBSIM_TR_MAILBOX, n->k->now, n->name, "release", ",\"box\":1,\"counter\":%u",
                 (unsigned)counter);
}

/* Trace category "mailbox", inbox 1 (sim/tla/TraceInbox.tla): the interrupt's side of every bus
 * write (wbegin with the buffer it fills or wnack, each data byte stored, commit or abort) and the
 * application's side (lock with the buffer it owns, each byte it reads, release), as the
 * MailboxInbox actions the library cites. The interrupt's side is read off the inbox's buffer
 * indices (urb_node_inbox_buffers) before and after each downlink event. */

static void inbox_event(sim_node_t *n, const char *ev, const char *fmt, unsigned a, unsigned b)
{
    char fields[64];
    (void)snprintf(fields, sizeof fields, fmt, a, b);
    urbsim_trace(n->tr, URBSIM_TR_MAILBOX, n->k->now, n->name, ev, ",\"box\":1%s", fields);
}

/* urb_node_i2c_event, with inbox 1's transitions logged when the mailbox trace is on. */
static uint16_t node_i2c(sim_node_t *n, urb_i2c_event_t ev, uint8_t byte)
{
    urb_node_buffers_t before;
    if (!urbsim_trace_on(n->tr, URBSIM_TR_MAILBOX) || !urb_node_inbox_buffers(&n->node, 1u, &before)) {
        return urb_node_i2c_event(&n->node, ev, byte);
    }
    urb_node_downlink_t dl;
    urb_node_downlink(&n->node, &dl);
    bool const data = ev == URB_I2C_RX_BYTE && dl.phase == URB_NODE_DL_WRITE && dl.mailbox == 1u;
    uint8_t const k = dl.count;
    uint16_t const r = urb_node_i2c_event(&n->node, ev, byte);
    urb_node_buffers_t after = before; /* inbox 1 stays set up: the call below always copies */
    (void)urb_node_inbox_buffers(&n->node, 1u, &after);
    if (before.isr != URB_NODE_NO_BUFFER && after.isr == URB_NODE_NO_BUFFER) {
        inbox_event(n, after.front != before.front ? "commit" : "abort", "", 0u, 0u);
    }
    if (data && k == 0u) {
        if (after.isr == URB_NODE_NO_BUFFER) {
            inbox_event(n, "wnack", "", 0u, 0u);
        } else {
            inbox_event(n, "wbegin", ",\"buf\":%u", after.isr, 0u);
        }
    }
    if (data && after.isr != URB_NODE_NO_BUFFER) {
        inbox_event(n, "wbyte", ",\"index\":%u,\"value\":%u", k, byte);
    }
    return r;
}

static void probe_inbox_locked(void *ctx, int rc, const uint8_t *data, uint8_t len)
{
    sim_node_t *n = ctx;
    if (!urbsim_trace_on(n->tr, URBSIM_TR_MAILBOX)) {
        return;
    }
    if (rc < 0) {
        /* only BUSY is a MailboxInbox outcome; another error (a misused API) cannot match the spec */
        inbox_event(n, rc == URB_NODE_ERR_BUSY ? "busy" : "lock_error", ",\"err\":%u", (unsigned)-rc, 0u);
        return;
    }
    urb_node_buffers_t bufs = {URB_NODE_NO_BUFFER, URB_NODE_NO_BUFFER, URB_NODE_NO_BUFFER};
    (void)urb_node_inbox_buffers(&n->node, 1u, &bufs);
    inbox_event(n, "lock", ",\"buf\":%u,\"new\":%u", bufs.app, rc == URB_NODE_NEW);
    for (uint8_t i = 0u; i < len; i++) {
        inbox_event(n, "rbyte", ",\"index\":%u,\"value\":%u", i, data[i]);
    }
}

static void probe_inbox_released(void *ctx)
{
    sim_node_t *n = ctx;
    if (urbsim_trace_on(n->tr, URBSIM_TR_MAILBOX)) {
        inbox_event(n, "in_release", "", 0u, 0u);
    }
}

/* ---------------------------------------------------------------- faults
 * Every application's fault hook passes through the port, which logs it (trace category "fault",
 * "app_fault") and counts it per code (stats "fault_checksum" .. "fault_stuck_bus") before calling
 * the application's own hook. */

static const char *const FAULT_NAME[URB_NODE_FAULT_CODES + 1u] = {"none", "checksum", "overrun", "lost_sync",
                                                                  "stuck_bus"};

static void port_fault(urb_node_t *node, void *user, urb_node_fault_t code)
{
    sim_node_t *n = (sim_node_t *)(void *)((char *)node - offsetof(sim_node_t, node));
    unsigned const c = (unsigned)code <= URB_NODE_FAULT_CODES ? (unsigned)code : 0u;
    n->faults[c]++;
    urbsim_trace(n->tr, URBSIM_TR_FAULT, n->k->now, n->name, "app_fault", ",\"code\":%u,\"fault\":\"%s\"", c,
                 FAULT_NAME[c]);
    if (n->app_hooks->fault != NULL) {
        n->app_hooks->fault(node, user, code);
    }
}

/* The port's SMBus-style SCL low timeout (as on the SAMD21 SERCOM or STM32 I2C slaves): SCL held
 * low since `from` for the whole timeout raises the peripheral's error interrupt, whose handler
 * reports URB_I2C_STUCK to the library (abort the transaction in progress, STUCK_BUS fault). */
void sim_node_scl_low(sim_node_t *n, urbsim_ns_t timeout_ns)
{
    if (!n->powered) {
        return;
    }
    n->scl_low_from = n->k->now;
    urbsim_kernel_at(n->k, n->k->now + timeout_ns, node_event, n, NODE_ARG(n, EV_SCL_TIMEOUT, n->gen << 24));
}

static void scl_timeout(sim_node_t *n, urbsim_ns_t now, bool isr)
{
    if (!isr) {
        /* SCL released (or released and stuck again) in the meantime: the counter restarted */
        if ((urbsim_i2c_lines(n->bus) & URBSIM_I2C_SCL) != 0u || n->bus->scl_from != n->scl_low_from) {
            return;
        }
        urbsim_ns_t end;
        urbsim_ns_t start = urbsim_mcu_isr(&n->mcu, now, n->cfg.i2c_isr_cycles, &end);
        urbsim_kernel_at(n->k, start, node_event, n, NODE_ARG(n, EV_SCL_TIMEOUT_ISR, n->gen << 24));
        return;
    }
    static const char *const STATE[] = {"idle", "select", "write", "write_check", "write_done", "selected", "read",
                                        "sync", "ignore"};
    urb_node_downlink_t dl;
    urb_node_downlink(&n->node, &dl);
    unsigned const st = (unsigned)dl.phase;
    urbsim_trace(n->tr, URBSIM_TR_FAULT, now, n->name, "scl_timeout", ",\"aborted\":\"%s\"",
                 st < sizeof STATE / sizeof STATE[0] ? STATE[st] : "?");
    (void)node_i2c(n, URB_I2C_STUCK, 0u);
    n->stuck_reports++;
    want_poll(n, now + urbsim_clock_cycles_ns(&n->mcu.clk, now, n->cfg.i2c_isr_cycles));
}

/* ---------------------------------------------------------------- I2C slave port */

static urbsim_ns_t slave_window(void *ctx, urbsim_ns_t t_irq, urbsim_ns_t *end)
{
    sim_node_t *n = ctx;
    return urbsim_mcu_isr(&n->mcu, t_irq, n->cfg.i2c_isr_cycles, end);
}

static bool slave_address(void *ctx, bool read, bool gc, urbsim_ns_t t_hw)
{
    sim_node_t *n = ctx;
    urb_i2c_event_t ev = gc ? URB_I2C_GENERAL_CALL : (read ? URB_I2C_ADDR_READ : URB_I2C_ADDR_WRITE);
    if (gc) {
        n->gc_hw = t_hw;
    }
    if (read) {
        sim_log_put(&n->log, t_hw, SIM_MARK_READ, 0);
    }
    bool ack = node_i2c(n, ev, 0) == URB_I2C_ACK;
    urb_node_downlink_t dl;
    urb_node_downlink(&n->node, &dl);
    n->reading_mb1 = read && ack && dl.mailbox == 1u;
    if (n->reading_mb1) {
        urbsim_trace(n->tr, URBSIM_TR_MAILBOX, n->k->now, n->name, "begin", ",\"box\":1");
    }
    return ack;
}

static bool slave_rx(void *ctx, uint8_t byte, urbsim_ns_t t_hw)
{
    sim_node_t *n = ctx;
    (void)t_hw;
    return node_i2c(n, URB_I2C_RX_BYTE, byte) == URB_I2C_ACK;
}

static uint8_t slave_tx(void *ctx, urbsim_ns_t t_hw)
{
    sim_node_t *n = ctx;
    (void)t_hw;
    urb_node_downlink_t dl;
    urb_node_downlink(&n->node, &dl);
    uint8_t index = dl.count;
    uint8_t byte = (uint8_t)node_i2c(n, URB_I2C_TX_BYTE, 0);
    if (n->reading_mb1 && index < urb_node_outbox_size(&n->node, 1u)) {
        urbsim_trace(n->tr, URBSIM_TR_MAILBOX, n->k->now, n->name, "byte", ",\"box\":1,\"index\":%u,\"value\":%u",
                     index, byte);
    }
    return byte;
}

static void slave_tx_nack(void *ctx, urbsim_ns_t t_hw)
{
    sim_node_t *n = ctx;
    (void)t_hw;
    (void)node_i2c(n, URB_I2C_TX_NACK, 0);
}

static void slave_stop(void *ctx, bool repeated, urbsim_ns_t t_hw)
{
    sim_node_t *n = ctx;
    (void)t_hw;
    if (repeated) {
        return; /* the library sees a repeated START as the next ADDR_* event */
    }
    (void)node_i2c(n, URB_I2C_STOP, 0);
    if (n->reading_mb1) {
        n->reading_mb1 = false;
        urbsim_trace(n->tr, URBSIM_TR_MAILBOX, n->k->now, n->name, "end", ",\"box\":1");
    }
    want_poll(n, n->mcu.isr_free_at);
}

/* ---------------------------------------------------------------- lifecycle */

sim_node_t *sim_node_new(const char *name, urbsim_kernel_t *k, urbsim_trace_t *tr, urbsim_i2c_bus_t *bus,
                         const sim_node_cfg_t *cfg, const sim_app_cfg_t *app, const urbsim_rng_t *rng)
{
    sim_node_t *n = calloc(1, sizeof *n);
    if (n == NULL) {
        return NULL;
    }
    urb_node_config_default(&n->ncfg);
    urbsim_rng_t app_rng = *rng;
    urbsim_rng_seed(&app_rng, urbsim_rng_u64(&app_rng) ^ 0xA99u);
    if (app->app == SIM_APP_PROBE) {
        n->app_state.probe.class_id = app->class_id;
        n->app_state.probe.index = app->index;
        n->app_state.probe.fingerprint = app->fingerprint;
        n->app_state.probe.out_size = app->out_size;
        n->app_state.probe.in_size = app->in_size;
        n->app_state.probe.fill_counter = app->fill_counter;
        n->app_state.probe.on_release = probe_released;
        n->app_state.probe.on_inbox_locked = probe_inbox_locked;
        n->app_state.probe.on_inbox_released = probe_inbox_released;
        n->app_state.probe.hook_ctx = n;
        sim_app_binding_t b;
        (void)sim_app_bind(&n->app_state, SIM_APP_PROBE, app->index, &n->ncfg, &b);
        n->hooks = b.hooks;
        n->app = b.app;
        n->storage_len = b.storage_len;
    } else if (!sim_sensorhex_bind(n, app->app, app->index, &app->motor, &app_rng, &n->ncfg)) {
        free(n);
        return NULL;
    }
    n->app_hooks = n->hooks;
    n->port_hooks = *n->hooks;
    n->port_hooks.fault = port_fault;
    n->hooks = &n->port_hooks;
    strncpy(n->name, name, sizeof n->name - 1u);
    n->k = k;
    n->tr = tr;
    n->bus = bus;
    n->cfg = *cfg;
    n->cfg.clock.timer_hz = (double)cfg->ticks_per_us * 1e6;
    n->ncfg.i2c_address = cfg->address;
    n->ncfg.ticks_per_us = cfg->ticks_per_us;
    n->ncfg.heartbeat_us = cfg->heartbeat_us;
    n->ncfg.sync_enabled = cfg->sync_enabled ? 1u : 0u;
    n->ncfg.lead_us = cfg->lead_us;
    n->ncfg.kd_q8 = cfg->kd_q8;
    n->ncfg.kn_q8 = cfg->kn_q8;
    n->ncfg.outlier_ns = cfg->outlier_ns;
    n->ncfg.max_outliers = cfg->max_outliers;
    n->ncfg.acq_window = cfg->acq_window;
    n->ncfg.acq_guard_us = cfg->acq_guard_us;
    if (n->storage_len > sizeof n->storage) {
        n->storage_len = (uint16_t)sizeof n->storage;
    }
    urbsim_rng_t clock_rng = *rng;
    urbsim_mcu_init(&n->mcu, &n->cfg.clock, &clock_rng);
    urbsim_rng_seed(&n->rng, urbsim_rng_u64(&clock_rng) ^ 0xAC0u);
    n->hal.ctx = n;
    n->hal.now = hal_now;
    n->hal.set_compare = hal_set_compare;
    n->hal.sync_capture = cfg->sync_capture ? hal_sync_capture : NULL;
    n->hal.set_address = hal_set_address;
    n->hal.mark = hal_mark;
    n->hal.identify = NULL;
    n->slave.ctx = n;
    n->slave.address = cfg->address;
    n->slave.powered = false;
    n->slave.isr_window = slave_window;
    n->slave.on_address = slave_address;
    n->slave.on_rx = slave_rx;
    n->slave.on_tx = slave_tx;
    n->slave.on_tx_nack = slave_tx_nack;
    n->slave.on_stop = slave_stop;
    if (!urbsim_i2c_attach(bus, &n->slave)) {
        free(n);
        return NULL;
    }
    return n;
}

void sim_node_free(sim_node_t *n)
{
    free(n);
}

sim_log_t *sim_node_log(sim_node_t *n)
{
    return &n->log;
}

void sim_node_status(const sim_node_t *n, int64_t *out)
{
    urb_node_sync_status_t s;
    urb_node_sync_status(&n->node, &s);
    out[0] = (int64_t)s.state;
    out[1] = (int64_t)s.period_q8;
    out[2] = (int64_t)s.phase_q8;
    out[3] = (int64_t)s.lead_ticks;
    out[4] = (int64_t)s.acq_ticks;
    out[5] = (int64_t)s.syncs;
    out[6] = (int64_t)s.rejected;
    out[7] = urb_node_synced(&n->node) ? 1 : 0;
    out[8] = n->init_result;
}

int sim_node_plant(sim_node_t *n, double *out)
{
    if (!n->has_plant) {
        return -1;
    }
    urbsim_motor_t *m = &n->plant;
    urbsim_motor_advance(m, n->k->now);
    out[0] = m->theta;
    out[1] = m->w;
    out[2] = m->i;
    out[3] = m->v;
    out[4] = m->theta / m->p.N;
    out[5] = m->temp;
    return 0;
}

double sim_node_stat(const sim_node_t *n, const char *s)
{
    if (!strcmp(s, "ppm")) return n->mcu.clk.cfg.ppm0;
    if (!strcmp(s, "polls")) return (double)n->polls;
    if (!strcmp(s, "updates")) return (double)n->updates;
    if (!strcmp(s, "boots")) return (double)n->boots;
    if (!strcmp(s, "irqs")) return (double)n->mcu.irqs;
    if (!strcmp(s, "isr_ns")) return (double)n->mcu.isr_ns;
    if (!strcmp(s, "marks_lost")) return (double)n->log.lost;
    if (!strcmp(s, "stuck_reports")) return (double)n->stuck_reports;
    for (unsigned c = 1u; c <= URB_NODE_FAULT_CODES; c++) {
        if (!strncmp(s, "fault_", 6) && !strcmp(s + 6, FAULT_NAME[c])) return (double)n->faults[c];
    }
    return NAN;
}

void sim_node_power_on(sim_node_t *n)
{
    urbsim_ns_t now = n->k->now;
    n->powered = true;
    n->boots++;
    n->acquiring = false;
    n->poll_pending = false;
    urbsim_mcu_reset(&n->mcu, now);
    sim_log_put(&n->log, now, SIM_MARK_BOOT, (uint32_t)n->boots);
    urbsim_trace(n->tr, URBSIM_TR_FAULT, now, n->name, "power_on", ",\"boot\":%llu", (unsigned long long)n->boots);
    n->init_result = urb_node_init(&n->node, &n->hal, n->hooks, n->app, &n->ncfg, n->storage, n->storage_len);
    want_poll(n, now);
}

void sim_node_power_off(sim_node_t *n)
{
    n->powered = false;
    n->gen++; /* every pending event is stale now: withdraw those that can be */
    urbsim_kernel_cancel(n->k, &n->compare_ev);
    urbsim_kernel_cancel(n->k, &n->poll_ev);
    urbsim_i2c_power(n->bus, &n->slave, false);
    urbsim_trace(n->tr, URBSIM_TR_FAULT, n->k->now, n->name, "power_off", "%s", "");
}
