/* bridge_hal_sim.c: the bridge firmware on a simulated MCU, I2C bus and uplink. See the header. */
#include "bridge_hal_sim.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum {
    EV_POLL,        /* main loop iteration */
    EV_HB_IRQ,      /* heartbeat timer fires */
    EV_HB_ISR,      /* heartbeat handler runs */
    EV_RX_ISR,      /* UART byte handler (byte in bits 32..39) */
    EV_TXE_ISR,     /* UART transmit-register-empty handler */
    EV_I2C_ISR,     /* I2C master completion handler (event bits 32..39, byte 40..47) */
    EV_USB_ISR,     /* USB controller interrupt handler (SOF, OUT received, IN acknowledged) */
};
#define ARG(kind, gen, extra) ((uint64_t)(kind) | (((gen) & 0xFFFFFFull) << 8) | ((uint64_t)(extra) << 32))

static void bridge_event(void *ctx, uint64_t arg, urbsim_ns_t now);
static void obs_usb(sim_bridge_t *b, const uint8_t *d, size_t len, bool out, urbsim_ns_t t);

static void at(sim_bridge_t *b, urbsim_ns_t t, int kind, uint32_t extra)
{
    urbsim_kernel_at(b->k, t, bridge_event, b, ARG(kind, b->gen, extra));
}

/* Raise an interrupt at t_irq with a handler of `cycles`; the handler event runs at its start. */
static void irq(sim_bridge_t *b, urbsim_ns_t t_irq, double cycles, int kind, uint32_t extra)
{
    urbsim_ns_t end;
    urbsim_ns_t start = urbsim_mcu_isr(&b->mcu, t_irq, cycles, &end);
    at(b, start, kind, extra);
}

/* The main loop runs poll as soon as it is awake and free. */
static void want_poll(sim_bridge_t *b, urbsim_ns_t t)
{
    if (!b->powered) {
        return;
    }
    if (t < b->mcu.isr_free_at) {
        t = b->mcu.isr_free_at; /* the main loop runs when no handler does */
    }
    t += urbsim_clock_cycles_ns(&b->mcu.clk, t, b->cfg.wake_cycles);
    if (t < b->mcu.thread_until) {
        t = b->mcu.thread_until;
    }
    if (b->poll_pending && b->poll_at <= t) {
        return;
    }
    b->poll_pending = true;
    b->poll_at = t;
    b->poll_gen++;
    /* A later iteration (a transaction's timeout) brought forward is withdrawn through the handle. */
    urbsim_kernel_at_handle(b->k, t, bridge_event, b, ARG(EV_POLL, b->gen, (uint32_t)(b->poll_gen & 0xFFFFFFFFu)),
                            &b->poll_ev);
}

/* ---------------------------------------------------------------- board HAL */

static uint32_t hal_now_us(void *ctx)
{
    sim_bridge_t *b = ctx;
    return (uint32_t)(uint64_t)(urbsim_clock_local_ns(&b->mcu.clk, b->k->now) / 1000.0);
}

static void hal_heartbeat_period(void *ctx, uint32_t period_us)
{
    sim_bridge_t *b = ctx;
    b->hb_period_us = period_us;
    b->hb_gen++;
    urbsim_kernel_cancel(b->k, &b->hb_ev);
    b->hb_sof_us = 0u;
    if (period_us == 0u || (b->cfg.heartbeat_sof && b->uplink == SIM_UPLINK_USB)) {
        return; /* stopped, or counted from SOF interrupts (usb_sof) */
    }
    b->hb_next_local = urbsim_clock_local_ns(&b->mcu.clk, b->k->now) + (double)period_us * 1000.0;
    urbsim_ns_t t = urbsim_clock_virtual_at(&b->mcu.clk, b->hb_next_local);
    urbsim_kernel_at_handle(b->k, t, bridge_event, b, ARG(EV_HB_IRQ, b->gen, (uint32_t)(b->hb_gen & 0xFFFFFFFFu)),
                            &b->hb_ev);
}

static void hal_uart_tx_kick(void *ctx)
{
    sim_bridge_t *b = ctx;
    if (b->uplink != SIM_UPLINK_RS232 || b->tx_active) {
        return;
    }
    b->tx_active = true;
    irq(b, b->k->now, b->cfg.uart_isr_cycles, EV_TXE_ISR, 0);
}

static void hal_mark(void *ctx, uint8_t id, bool level)
{
    sim_bridge_t *b = ctx;
    sim_log_put(&b->log, b->k->now, SIM_BMARK_SERVE + id, level ? 1u : 0u);
}

/* ---------------------------------------------------------------- I2C master HAL */

static void i2c_start(void *ctx) { urbsim_i2c_start(&((sim_bridge_t *)ctx)->bus); }
static void i2c_write(void *ctx, uint8_t byte) { urbsim_i2c_write(&((sim_bridge_t *)ctx)->bus, byte); }
static void i2c_read(void *ctx, bool ack) { urbsim_i2c_read(&((sim_bridge_t *)ctx)->bus, ack); }
static void i2c_stop(void *ctx) { urbsim_i2c_stop(&((sim_bridge_t *)ctx)->bus); }
static uint8_t i2c_lines(void *ctx) { return urbsim_i2c_lines(&((sim_bridge_t *)ctx)->bus); }
static void i2c_drive(void *ctx, uint8_t lines)
{
    sim_bridge_t *b = ctx;
    if (!b->bus.bitbang) {
        /* the firmware's reaction to a stuck bus: the nine-pulse clear begins (trace "fault") */
        urbsim_trace(b->tr, URBSIM_TR_FAULT, b->k->now, b->name, "bus_clear", ",\"lines\":%u",
                     urbsim_i2c_lines(&b->bus));
    }
    urbsim_i2c_drive(&b->bus, lines);
}

static void i2c_abort(void *ctx)
{
    sim_bridge_t *b = ctx;
    /* the firmware's reaction to a transaction that did not complete in time (trace "fault") */
    urbsim_trace(b->tr, URBSIM_TR_FAULT, b->k->now, b->name, "i2c_abort", ",\"lines\":%u", urbsim_i2c_lines(&b->bus));
    urbsim_i2c_abort(&b->bus);
    b->i2c_gen++; /* a completion interrupt already raised must not reach the firmware */
}

static void i2c_release(void *ctx)
{
    sim_bridge_t *b = ctx;
    if (b->bus.bitbang) {
        urbsim_trace(b->tr, URBSIM_TR_FAULT, b->k->now, b->name, "bus_released", ",\"lines\":%u",
                     urbsim_i2c_lines(&b->bus));
    }
    urbsim_i2c_release(&b->bus);
    b->i2c_gen++;
}

/* A transaction is in progress on the master: its main loop has nothing to do after a byte
 * (timeouts are covered by the busy poll). */
static bool master_mid_transaction(const sim_bridge_t *b)
{
    return urb_i2c_master_busy(&b->master);
}

/* The simulated bus's completion (URBSIM_I2C_*) as the firmware's event. */
static urb_i2c_event_t master_event(int ev)
{
    switch (ev) {
    case URBSIM_I2C_START:
        return URB_I2C_EV_START;
    case URBSIM_I2C_ACK:
        return URB_I2C_EV_ACK;
    case URBSIM_I2C_NACK:
        return URB_I2C_EV_NACK;
    case URBSIM_I2C_BYTE:
        return URB_I2C_EV_BYTE;
    default:
        return URB_I2C_EV_ERROR;
    }
}

/* The bus completed an operation at t_hw: the I2C interrupt's handler runs in its reserved
 * window [start, end). It is executed right away, with the bus told that what it issues starts no
 * earlier than `start`: nothing else on the bridge can run between t_hw and start (interrupts are
 * serialised, the main loop runs after end), so this is the same behaviour with one event less. */
static void bus_done(void *ctx, int ev, uint8_t byte, urbsim_ns_t t_hw)
{
    sim_bridge_t *b = ctx;
    if (!b->powered) {
        return;
    }
    urbsim_ns_t end;
    urbsim_ns_t start = urbsim_mcu_isr(&b->mcu, t_hw, b->cfg.i2c_isr_cycles, &end);
    b->bus.earliest = start;
    urb_i2c_master_event(&b->master, master_event(ev), byte);
    b->bus.earliest = 0;
    if (!master_mid_transaction(b)) {
        want_poll(b, end);
    }
}

/* ---------------------------------------------------------------- uplinks */

static void uart_rx(void *ctx, uint8_t byte, uint32_t flags, urbsim_ns_t t)
{
    sim_bridge_t *b = ctx;
    (void)flags; /* a framing error still delivers the (garbage) byte: the CRC and hunting catch it */
    if (!b->powered) {
        return;
    }
    irq(b, t, b->cfg.uart_isr_cycles, EV_RX_ISR, byte);
}

static void uart_txe(void *ctx, urbsim_ns_t t)
{
    sim_bridge_t *b = ctx;
    if (!b->powered) {
        return;
    }
    irq(b, t, b->cfg.uart_isr_cycles, EV_TXE_ISR, 0);
}

static void host_rx_byte(void *ctx, uint8_t byte, uint32_t flags, urbsim_ns_t t)
{
    sim_bridge_t *b = ctx;
    (void)flags;
    if (b->host) {
        b->host(b->hctx, b->id, &byte, 1u, t);
    }
}

/* The firmware's SOF hand-over (urb_bridge_usb_sof): notes the SOF that closed the batch when the
 * firmware swapped (it holds the swap while an earlier batch with responses is unread). */
static bool usb_take_sof(sim_bridge_t *b)
{
    uint32_t held = urb_bridge_stats(&b->br)->usb_late_reads;
    urb_bridge_usb_sof(&b->br);
    if (urb_bridge_stats(&b->br)->usb_late_reads != held) {
        return false;
    }
    b->usb_swap_sof = b->usb_sofs;
    return true;
}

/* A response batch goes out at an IN token: counts its responses, and those that go out one frame
 * or more after the SOF that closed their batch (it was due in that SOF's frame). */
static void usb_note_sent(sim_bridge_t *b, const uint8_t *d, size_t len, uint64_t closed_sof)
{
    urb_usb_batch_header_t h;
    if (len < URB_USB_BATCH_HEADER_MAX_SIZE || urb_usb_batch_header_decode(&h, d, URB_USB_BATCH_HEADER_MAX_SIZE) < 0 ||
        h.count == 0u) {
        return;
    }
    uint64_t late = b->usb_sofs - closed_sof;
    b->usb_resp_sent += h.count;
    if (late) {
        b->usb_resp_late += h.count;
        b->usb_batches_late++;
        if (late > b->usb_frames_late_max) {
            b->usb_frames_late_max = late;
        }
    }
}

/* The USB device controller's interrupt (SOF, OUT received, IN data acknowledged): its handler
 * notes the controller's flags and wakes the main loop, which does the work (bridge_port.c runs
 * USB in the main loop). One pending interrupt covers every flag raised before its handler runs. */
static void usb_irq(sim_bridge_t *b, urbsim_ns_t t)
{
    if (t < b->usb_irq_at) {
        return; /* pending, its handler not started yet: it will see this flag too */
    }
    urbsim_ns_t end;
    b->usb_irq_at = urbsim_mcu_isr(&b->mcu, t, b->cfg.usb_isr_cycles, &end);
    at(b, b->usb_irq_at, EV_USB_ISR, 0);
}

/* The main loop's USB work, in bridge_port.c's order, before urb_bridge_poll: a SOF seen since the
 * last iteration (one hand-over however many SOFs came), an OUT transfer received, and, when the IN
 * endpoint's buffer is free, the previous frame's batch armed there for the host's next IN token. */
static void usb_main_loop(sim_bridge_t *b, urbsim_ns_t now)
{
#ifndef URBSIM_MUTANT_USB_IN_AT_TOKEN
    if (b->usb_sof_flag) {
        b->usb_sof_flag = false;
        bool swapped = usb_take_sof(b);
        urbsim_trace(b->tr, URBSIM_TR_FRAME, now, b->name, "usb_sof", ",\"swapped\":%u", swapped ? 1u : 0u);
    }
#endif
    if (b->usb_out_pending) {
        b->usb_out_pending = false;
        (void)urb_bridge_usb_out(&b->br, b->usb_out, b->usb_out_len);
        urbsim_trace(b->tr, URBSIM_TR_FRAME, now, b->name, "usb_out", ",\"len\":%u", b->usb_out_len);
        obs_usb(b, b->usb_out, b->usb_out_len, true, now);
    }
#ifndef URBSIM_MUTANT_USB_IN_AT_TOKEN
    if (b->usb_in_state == SIM_USB_IN_FREE) {
        size_t n = urb_bridge_usb_in(&b->br, b->usb_in_buf, sizeof b->usb_in_buf);
        if (n) {
            urb_usb_batch_header_t h = {0u, 0u};
            (void)urb_usb_batch_header_decode(&h, b->usb_in_buf, URB_USB_BATCH_HEADER_MAX_SIZE);
            b->usb_in_state = SIM_USB_IN_ARMED;
            b->usb_in_len = (uint32_t)n;
            b->usb_in_closed_sof = b->usb_swap_sof;
            b->usb_in_armed++;
            urbsim_trace(b->tr, URBSIM_TR_FRAME, now, b->name, "in_arm", ",\"len\":%u,\"count\":%u",
                         (unsigned)n, (unsigned)h.count);
        }
    }
#endif
}

static void usb_sof(void *ctx, uint16_t frame, urbsim_ns_t t)
{
    sim_bridge_t *b = ctx;
    (void)frame;
    if (!b->powered) {
        return;
    }
    b->usb_sofs++;
    if (b->cfg.heartbeat_sof && b->hb_period_us) {
        /* a timer-like use of the SOF interrupt: the heartbeat tick is counted in its handler */
        b->hb_sof_us += 1000u;
        if (b->hb_sof_us >= b->hb_period_us) {
            b->hb_sof_us -= b->hb_period_us;
            irq(b, t, b->cfg.timer_isr_cycles, EV_HB_ISR, 0);
        }
    }
#ifdef URBSIM_MUTANT_USB_IN_AT_TOKEN /* seeded bug (tests/sim/test_usb_device.py): the swap at the SOF
                                        instant, as if the firmware ran inside the USB controller */
    bool swapped = usb_take_sof(b);
    urbsim_trace(b->tr, URBSIM_TR_FRAME, t, b->name, "usb_sof", ",\"swapped\":%u", swapped ? 1u : 0u);
#else
    b->usb_sof_flag = true;
    usb_irq(b, t);
#endif
}

static void usb_out(void *ctx, const uint8_t *data, uint32_t len, urbsim_ns_t t)
{
    sim_bridge_t *b = ctx;
    if (!b->powered) {
        return;
    }
    memcpy(b->usb_out, data, len);
    b->usb_out_len = len;
    b->usb_out_pending = true;
    usb_irq(b, t);
}

/* OUT token: NAKed while the main loop has not taken the previous transfer out of the buffer. */
static bool usb_out_busy(void *ctx)
{
    const sim_bridge_t *b = ctx;
    return b->powered && b->usb_out_pending;
}

/* IN token: the controller sends what is armed, or NAKs; the firmware cannot act in between. */
static uint32_t usb_in(void *ctx, uint8_t *buf, uint32_t cap, urbsim_ns_t t)
{
    sim_bridge_t *b = ctx;
    (void)t;
    if (!b->powered) {
        return 0u;
    }
#ifdef URBSIM_MUTANT_USB_IN_AT_TOKEN /* the firmware fills the IN transfer at the token */
    size_t n = urb_bridge_usb_in(&b->br, buf, cap);
    uint64_t closed = b->usb_swap_sof;
    if (n) {
        urb_usb_batch_header_t h = {0u, 0u};
        (void)urb_usb_batch_header_decode(&h, buf, URB_USB_BATCH_HEADER_MAX_SIZE);
        b->usb_in_armed++;
        urbsim_trace(b->tr, URBSIM_TR_FRAME, b->k->now, b->name, "in_arm", ",\"len\":%u,\"count\":%u",
                     (unsigned)n, (unsigned)h.count);
    }
#else
    if (b->usb_in_state != SIM_USB_IN_ARMED) {
        return 0u; /* NAK */
    }
    /* The host asks for a whole buffer (in_size, URBSIM_USB_MAX_XFER >= URB_BRIDGE_USB_BUF) */
    size_t n = b->usb_in_len < cap ? b->usb_in_len : cap;
    memcpy(buf, b->usb_in_buf, n);
    b->usb_in_state = SIM_USB_IN_BUSY;
    uint64_t closed = b->usb_in_closed_sof;
#endif
    if (n) {
        usb_note_sent(b, buf, n, closed);
        sim_log_put(&b->log, b->k->now, SIM_BMARK_EMIT, (uint32_t)n);
        obs_usb(b, buf, n, false, b->k->now);
    }
    return (uint32_t)n;
}

/* The host acknowledged the IN data: the buffer is free, the interrupt wakes the main loop to arm
 * the next batch. */
static void usb_in_done(void *ctx, urbsim_ns_t t)
{
    sim_bridge_t *b = ctx;
    if (!b->powered || b->usb_in_state != SIM_USB_IN_BUSY) {
        return;
    }
    b->usb_in_state = SIM_USB_IN_FREE;
    usb_irq(b, t);
}

static void usb_host_read(void *hctx, const uint8_t *data, uint32_t len, urbsim_ns_t t)
{
    sim_bridge_t *b = hctx;
    if (b->host) {
        b->host(b->hctx, b->id, data, len, t);
    }
}


/* ---------------------------------------------------------------- trace observer
 * Reassembles the uplink byte streams into frames with the generated decoders, the way a
 * protocol analyser on the bridge's pins would, and logs them (trace category "bridge"):
 *   {"ev":"req","addr":A,"box":M,"op":"read"|"write","len":N,"seq":S}   a request frame reached
 *                                                                       the firmware intact
 *   {"ev":"resp","seq":S,"status":C}                                    a response frame left it
 * Only active while the category is traced (sim/urb_sim/tracecheck.py checks these against
 * spec/tla/Bridge.tla). */

static size_t check_size(size_t covered)
{
    return covered <= 14u ? 1u : 2u;
}

static void obs_request(sim_bridge_t *b, const uint8_t *f, size_t n, urbsim_ns_t t)
{
    sim_pending_t p;
    if (f[0] & 1u) {
        urb_uplink_read_request_t r;
        if (urb_uplink_read_request_decode(&r, f, n) < 0) {
            return;
        }
        p = (sim_pending_t){r.address, r.mailbox, r.length, r.seq, true};
    } else {
        urb_uplink_write_request_t r;
        if (urb_uplink_write_request_decode(&r, f, n) < 0) {
            return;
        }
        p = (sim_pending_t){r.address, r.mailbox, r.length, r.seq, false};
    }
    urbsim_trace(b->tr, URBSIM_TR_BRIDGE, t, b->name, "req", ",\"addr\":%u,\"box\":%u,\"op\":\"%s\",\"len\":%u,\"seq\":%u",
                 p.address, p.mailbox, p.read ? "read" : "write", p.length, p.seq);
    if (b->obs_len < SIM_PENDING_MAX) {
        b->obs_pend[(b->obs_head + b->obs_len) % SIM_PENDING_MAX] = p;
        b->obs_len++;
    }
}

/* Length of the request frame starting at f (n >= 3 bytes known). */
static size_t request_size(const uint8_t *f)
{
    if (f[0] & 1u) {
        return 4u;
    }
    size_t covered = 3u + f[2];
    return covered + check_size(covered);
}

/* Length of the response to the oldest pending request, given its first byte. */
static size_t response_size(const sim_bridge_t *b, uint8_t first)
{
    const sim_pending_t *p = &b->obs_pend[b->obs_head];
    size_t data = (p->read && (first >> 4) == URB_STATUS_OK) ? p->length : 0u;
    return 1u + data + check_size(1u + data);
}

static void obs_response(sim_bridge_t *b, const uint8_t *f, size_t n, urbsim_ns_t t)
{
    urb_uplink_response_t r;
    if (b->obs_len == 0u || urb_uplink_response_decode(&r, f, n) < 0) {
        return;
    }
    urbsim_trace(b->tr, URBSIM_TR_BRIDGE, t, b->name, "resp", ",\"seq\":%u,\"status\":%u", r.seq, r.status);
    b->obs_head = (b->obs_head + 1u) % SIM_PENDING_MAX;
    b->obs_len--;
}

/* RS232: one byte handed to the firmware. */
static void obs_rx_byte(sim_bridge_t *b, uint8_t byte, urbsim_ns_t t)
{
    if (!urbsim_trace_on(b->tr, URBSIM_TR_BRIDGE)) {
        return;
    }
    if (b->obs_req_len && t - b->obs_req_last > 2u * 86806u) {
        b->obs_req_len = 0; /* idle gap: a partial frame is dropped, as the firmware does */
    }
    b->obs_req_last = t;
    if (b->obs_req_len < sizeof b->obs_req) {
        b->obs_req[b->obs_req_len++] = byte;
    }
    while (b->obs_req_len >= 3u && b->obs_req_len >= request_size(b->obs_req)) {
        size_t n = request_size(b->obs_req);
        obs_request(b, b->obs_req, n, t);
        memmove(b->obs_req, b->obs_req + n, b->obs_req_len - n);
        b->obs_req_len = (uint8_t)(b->obs_req_len - n);
    }
}

/* RS232: one byte the firmware sent. */
static void obs_tx_byte(sim_bridge_t *b, uint8_t byte, urbsim_ns_t t)
{
    if (!urbsim_trace_on(b->tr, URBSIM_TR_BRIDGE) || b->obs_len == 0u) {
        return;
    }
    if (b->obs_resp_len < sizeof b->obs_resp) {
        b->obs_resp[b->obs_resp_len++] = byte;
    }
    size_t n = response_size(b, b->obs_resp[0]);
    if (b->obs_resp_len >= n) {
        obs_response(b, b->obs_resp, n, t);
        b->obs_resp_len = 0;
    }
}

/* USB: an OUT batch handed to the firmware, an IN batch it returned. */
static void obs_usb(sim_bridge_t *b, const uint8_t *d, size_t len, bool out, urbsim_ns_t t)
{
    if (!urbsim_trace_on(b->tr, URBSIM_TR_BRIDGE) || len < URB_USB_BATCH_HEADER_MAX_SIZE) {
        return;
    }
    urb_usb_batch_header_t h;
    if (urb_usb_batch_header_decode(&h, d, URB_USB_BATCH_HEADER_MAX_SIZE) < 0) {
        return;
    }
    size_t at = URB_USB_BATCH_HEADER_MAX_SIZE;
    for (unsigned i = 0; i < h.count && at < len; i++) {
        size_t n;
        if (out) {
            if (len - at < 3u) {
                return;
            }
            n = request_size(d + at);
            if (at + n > len) {
                return;
            }
            obs_request(b, d + at, n, t);
        } else {
            if (b->obs_len == 0u) {
                return;
            }
            n = response_size(b, d[at]);
            if (at + n > len) {
                return;
            }
            obs_response(b, d + at, n, t);
        }
        at += n;
    }
}

/* ---------------------------------------------------------------- events */

static void bridge_event(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    sim_bridge_t *b = ctx;
    if (((arg >> 8) & 0xFFFFFFu) != (b->gen & 0xFFFFFFu) || !b->powered) {
        return;
    }
    uint32_t extra = (uint32_t)(arg >> 32);
    switch ((int)(arg & 0xFFu)) {
    case EV_POLL:
        if (extra != (uint32_t)(b->poll_gen & 0xFFFFFFFFu)) {
            return;
        }
        urbsim_ns_t const free_at = urbsim_mcu_thread_free(&b->mcu, now);
        if (free_at != now) {
            /* a handler runs: the iteration waits for it (still pending, same generation) */
            b->poll_at = free_at;
            urbsim_kernel_at_handle(b->k, free_at, bridge_event, b, arg, &b->poll_ev);
            return;
        }
        b->poll_pending = false;
        b->polls++;
        if (b->uplink == SIM_UPLINK_USB) {
            usb_main_loop(b, now);
        }
        urb_bridge_poll(&b->br);
        urbsim_mcu_thread_busy(&b->mcu, now, urbsim_clock_cycles_ns(&b->mcu.clk, now, b->cfg.poll_cycles));
        if (!urb_bridge_idle(&b->br)) {
            /* Busy: the real main loop keeps iterating. Iterations only matter when they can act:
             * every half clock of a bit-banged bus clear; during a transaction, only when its
             * timeout expires (urb_i2c_master_deadline, bridge clock); otherwise every
             * busy_poll_us. */
            urbsim_ns_t at;
            uint32_t deadline_us = 0u;
            if (b->bus.bitbang) {
                at = now + (urbsim_ns_t)b->mcfg.clear_half_us * 1000u;
            } else if (urb_i2c_master_deadline(&b->master, &deadline_us)) {
                double deadline = (double)deadline_us * 1000.0;
                double local_now = urbsim_clock_local_ns(&b->mcu.clk, now);
                /* now_us wraps at 2^32 us: rebase the deadline on the current local time */
                double wrap = 4294967296.0 * 1000.0;
                double base = floor(local_now / wrap) * wrap;
                deadline += base;
                if (deadline < local_now) {
                    deadline += wrap;
                }
                at = urbsim_clock_virtual_at(&b->mcu.clk, deadline);
            } else {
                at = now + b->cfg.busy_poll_ns;
            }
            want_poll(b, at);
        }
        break;
    case EV_HB_IRQ:
        if (extra != (uint32_t)(b->hb_gen & 0xFFFFFFFFu) || b->hb_period_us == 0u) {
            return;
        }
        irq(b, now, b->cfg.timer_isr_cycles, EV_HB_ISR, 0);
        b->hb_next_local += (double)b->hb_period_us * 1000.0;
        urbsim_kernel_at_handle(b->k, urbsim_clock_virtual_at(&b->mcu.clk, b->hb_next_local), bridge_event, b,
                                ARG(EV_HB_IRQ, b->gen, extra), &b->hb_ev);
        break;
    case EV_HB_ISR:
        urb_bridge_heartbeat(&b->br);
        want_poll(b, b->mcu.isr_free_at);
        break;
    case EV_RX_ISR:
        urb_bridge_uart_rx(&b->br, (uint8_t)extra, hal_now_us(b));
        obs_rx_byte(b, (uint8_t)extra, now);
        want_poll(b, b->mcu.isr_free_at);
        break;
    case EV_TXE_ISR: {
        uint8_t byte;
        if (urb_bridge_uart_tx_pop(&b->br, &byte)) {
            obs_tx_byte(b, byte, now);
            urbsim_uart_send(&b->to_host, &byte, 1u);
        } else {
            b->tx_active = false;
        }
        break;
    }
    case EV_I2C_ISR:
        if ((extra >> 16) != (uint32_t)(b->i2c_gen & 0xFFFFu)) {
            return; /* the firmware aborted the operation after the interrupt was raised */
        }
        urb_i2c_master_event(&b->master, master_event((int)(extra & 0xFFu)), (uint8_t)(extra >> 8));
        want_poll(b, b->mcu.isr_free_at);
        break;
    default: /* EV_USB_ISR: the flags are the controller's; the main loop acts on them */
        want_poll(b, b->mcu.isr_free_at);
        break;
    }
}

/* ---------------------------------------------------------------- lifecycle */

sim_bridge_t *sim_bridge_new(const char *name, int id, int uplink, urbsim_kernel_t *k, urbsim_trace_t *tr,
                             const sim_bridge_cfg_t *cfg, urbsim_usb_bus_t *usb_bus, sim_bridge_host_fn host,
                             void *hctx, const urbsim_rng_t *rng)
{
    sim_bridge_t *b = calloc(1, sizeof *b);
    if (b == NULL) {
        return NULL;
    }
    strncpy(b->name, name, sizeof b->name - 1u);
    b->id = id;
    b->uplink = uplink;
    b->k = k;
    b->tr = tr;
    b->cfg = *cfg;
    urb_bridge_default_config(&b->bcfg);
    b->bcfg.fifo_depth = cfg->fifo_depth;
    b->bcfg.baud = cfg->baud;
    b->bcfg.idle_gap_us = (uint32_t)(2.0 * 10.0 * 1e6 / (double)cfg->baud);
    b->bcfg.heartbeat_us = cfg->heartbeat_us;
    b->bcfg.scan_at_start = cfg->scan_at_start;
    b->host = host;
    b->hctx = hctx;
    urbsim_rng_t r = *rng;
    urbsim_mcu_init(&b->mcu, &cfg->clock, &r);
    urbsim_rng_t bus_rng, up_rng, down_rng;
    urbsim_rng_seed(&bus_rng, urbsim_rng_u64(&r));
    urbsim_rng_seed(&up_rng, urbsim_rng_u64(&r));
    urbsim_rng_seed(&down_rng, urbsim_rng_u64(&r));
    char nm[48];
    snprintf(nm, sizeof nm, "%s/i2c", name);
    urbsim_i2c_init(&b->bus, k, tr, nm, cfg->i2c_bitrate, &bus_rng);
    b->bus.master = bus_done;
    b->bus.master_ctx = b;
    b->hal.ctx = b;
    b->hal.now_us = hal_now_us;
    b->hal.heartbeat_period = hal_heartbeat_period;
    b->hal.uart_tx_kick = hal_uart_tx_kick;
    b->hal.mark = hal_mark;
    b->i2c_hal.ctx = b;
    b->i2c_hal.start = i2c_start;
    b->i2c_hal.write = i2c_write;
    b->i2c_hal.read = i2c_read;
    b->i2c_hal.stop = i2c_stop;
    b->i2c_hal.abort = i2c_abort;
    b->i2c_hal.lines = i2c_lines;
    b->i2c_hal.drive = i2c_drive;
    b->i2c_hal.release = i2c_release;
    urb_i2c_master_default_config(&b->mcfg);
    b->mcfg.bitrate_kbps = (uint16_t)(cfg->i2c_bitrate / 1000.0);
    /* the timeout follows the bit rate (2000 us, unchanged, from 336 kb/s up: so at 400 kb/s) */
    b->mcfg.timeout_us = urb_i2c_master_timeout_us(b->mcfg.bitrate_kbps);
    if (uplink == SIM_UPLINK_RS232) {
        snprintf(nm, sizeof nm, "%s/up", name);
        /* host -> bridge: a PC UART (1.8432 MHz crystal: exact 115200) */
        urbsim_uart_init(&b->to_bridge, k, tr, nm, (double)cfg->baud, 0.0, NULL, &up_rng);
        b->to_bridge.rx = uart_rx;
        b->to_bridge.rx_ctx = b;
        snprintf(nm, sizeof nm, "%s/down", name);
        /* bridge -> host: the bridge's UART, baud from its own clock through its divider */
        urbsim_uart_init(&b->to_host, k, tr, nm, (double)cfg->baud, cfg->uart_divider_hz, &b->mcu.clk, &down_rng);
        b->to_host.rx = host_rx_byte;
        b->to_host.rx_ctx = b;
        b->to_host.on_txe = uart_txe;
        b->to_host.txe_ctx = b;
    } else {
        b->usb_bus = usb_bus;
        strncpy(b->usb.name, name, sizeof b->usb.name - 1u);
        b->usb.ctx = b;
        b->usb.on_sof = usb_sof;
        b->usb.on_out = usb_out;
        b->usb.on_in = usb_in;
        b->usb.on_in_done = usb_in_done;
        b->usb.out_busy = usb_out_busy;
        b->usb.host_read = usb_host_read;
        b->usb.hctx = b;
        b->usb.auto_read = true;
        b->usb.read_always = cfg->usb_read_always;
        b->usb.in_size = URBSIM_USB_MAX_XFER;
        b->usb_index = urbsim_usb_attach(usb_bus, &b->usb);
    }
    return b;
}

void sim_bridge_free(sim_bridge_t *b)
{
    free(b);
}

int sim_bridge_uplink(const sim_bridge_t *b) { return b->uplink; }
int sim_bridge_usb_index(const sim_bridge_t *b) { return b->usb_index; }
const char *sim_bridge_name(const sim_bridge_t *b) { return b->name; }
urbsim_i2c_bus_t *sim_bridge_bus(sim_bridge_t *b) { return &b->bus; }
sim_log_t *sim_bridge_log(sim_bridge_t *b) { return &b->log; }

urbsim_uart_line_t *sim_bridge_uart(sim_bridge_t *b, int dir)
{
    if (b->uplink != SIM_UPLINK_RS232) {
        return NULL;
    }
    return dir ? &b->to_host : &b->to_bridge;
}

double sim_bridge_stat(const sim_bridge_t *b, const char *name)
{
    const urb_bridge_stats_t *st = urb_bridge_stats(&b->br);
    if (!strcmp(name, "bridge.ppm")) return b->mcu.clk.cfg.ppm0;
    if (!strcmp(name, "bridge.responses")) return st->responses;
    if (!strcmp(name, "bridge.frames")) return st->frames;
    if (!strcmp(name, "bridge.busy")) return st->busy;
    if (!strcmp(name, "bridge.syncs")) return st->syncs;
    if (!strcmp(name, "bridge.syncs_missed")) return st->syncs_missed;
    if (!strcmp(name, "bridge.scans")) return st->scans;
    if (!strcmp(name, "bridge.hunt_discards")) return st->hunt_discards;
    if (!strcmp(name, "bridge.gap_drops")) return st->gap_drops;
    if (!strcmp(name, "bridge.rx_overruns")) return st->rx_overruns;
    if (!strcmp(name, "bridge.usb_batches")) return st->usb_batches;
    if (!strcmp(name, "bridge.usb_bad_batches")) return st->usb_bad_batches;
    if (!strcmp(name, "bridge.usb_late_reads")) return st->usb_late_reads;
    if (!strcmp(name, "bridge.window_overflow")) return st->window_overflow;
    if (!strcmp(name, "bridge.outstanding")) return urb_bridge_outstanding(&b->br);
    if (!strcmp(name, "bridge.timeouts")) return urb_i2c_master_timeouts(&b->master);
    if (!strcmp(name, "bridge.bus_clears")) return urb_i2c_master_bus_clears(&b->master);
    if (!strcmp(name, "bridge.polls")) return (double)b->polls;
    if (!strcmp(name, "bridge.boots")) return (double)b->boots;
    if (!strcmp(name, "bridge.irqs")) return (double)b->mcu.irqs;
    if (!strcmp(name, "bridge.isr_ns")) return (double)b->mcu.isr_ns;
    if (!strcmp(name, "bridge.usb_naks")) return (double)b->usb.naks;
    if (!strcmp(name, "bridge.usb_deferred")) return (double)b->usb.deferred;
    if (!strcmp(name, "bridge.usb_out_naks")) return (double)b->usb.out_naks;
    if (!strcmp(name, "bridge.usb_in_armed")) return (double)b->usb_in_armed;
    if (!strcmp(name, "bridge.usb_responses_sent")) return (double)b->usb_resp_sent;
    if (!strcmp(name, "bridge.usb_responses_late")) return (double)b->usb_resp_late;
    if (!strcmp(name, "bridge.usb_batches_late")) return (double)b->usb_batches_late;
    if (!strcmp(name, "bridge.usb_frames_late_max")) return (double)b->usb_frames_late_max;
    if (!strcmp(name, "i2c.busy_ns")) return (double)b->bus.busy_ns;
    if (!strcmp(name, "i2c.stretch_ns")) return (double)b->bus.stretch_ns;
    if (!strcmp(name, "i2c.bytes")) return (double)b->bus.bytes;
    if (!strcmp(name, "i2c.starts")) return (double)b->bus.starts;
    if (!strcmp(name, "i2c.flipped_bits")) return (double)b->bus.flipped_bits;
    if (!strcmp(name, "i2c.stalls")) return (double)b->bus.stalls;
    if (b->uplink == SIM_UPLINK_RS232) {
        if (!strcmp(name, "uart.up_lost")) return (double)b->to_bridge.lost;
        if (!strcmp(name, "uart.down_lost")) return (double)b->to_host.lost;
        if (!strcmp(name, "uart.up_corrupted")) return (double)(b->to_bridge.corrupted + b->to_bridge.framing);
        if (!strcmp(name, "uart.down_corrupted")) return (double)(b->to_host.corrupted + b->to_host.framing);
        if (!strcmp(name, "uart.down_bytes")) return (double)b->to_host.sent;
        if (!strcmp(name, "uart.up_bytes")) return (double)b->to_bridge.sent;
    }
    return NAN;
}

void sim_bridge_power_on(sim_bridge_t *b)
{
    urbsim_ns_t now = b->k->now;
    b->powered = true;
    b->gen++;
    b->boots++;
    b->tx_active = false;
    b->poll_pending = false;
    b->usb_swap_sof = b->usb_sofs; /* the restarted firmware's first batch opens now */
    b->usb_sof_flag = false;       /* the USB controller restarts empty */
    b->usb_out_pending = false;
    b->usb_in_state = SIM_USB_IN_FREE;
    b->usb_irq_at = 0;
    urbsim_mcu_reset(&b->mcu, now);
    urbsim_i2c_release(&b->bus);
    if (b->uplink == SIM_UPLINK_RS232) {
        urbsim_uart_flush(&b->to_host);
    } else {
        b->usb.attached = true;
    }
    urbsim_trace(b->tr, URBSIM_TR_FAULT, now, b->name, "power_on", ",\"boot\":%llu", (unsigned long long)b->boots);
    urb_i2c_master_init(&b->master, &b->i2c_hal, &b->mcfg);
    urb_i2c_master_downlink(&b->master, &b->dl);
    b->init_result = (int)urb_bridge_init(&b->br, &b->bcfg, &b->hal, &b->dl);
    want_poll(b, now);
}

void sim_bridge_power_off(sim_bridge_t *b)
{
    b->powered = false;
    b->gen++; /* every pending event is stale now: withdraw those that can be */
    b->hb_gen++;
    urbsim_kernel_cancel(b->k, &b->hb_ev);
    urbsim_kernel_cancel(b->k, &b->poll_ev);
    urbsim_i2c_abort(&b->bus);
    if (b->uplink == SIM_UPLINK_RS232) {
        urbsim_uart_flush(&b->to_host);
    }
    urbsim_trace(b->tr, URBSIM_TR_FAULT, b->k->now, b->name, "power_off", "%s", "");
}

uint32_t sim_bridge_host_send(sim_bridge_t *b, const uint8_t *data, uint32_t n)
{
    if (b->uplink != SIM_UPLINK_RS232) {
        return 0u;
    }
    return urbsim_uart_send(&b->to_bridge, data, n);
}
