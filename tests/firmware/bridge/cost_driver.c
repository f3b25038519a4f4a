/*
 * Worst-case cost driver for the bridge: puts a bridge (with the real I2C master on a null I2C HAL
 * whose operations only store a byte, like a data register write) into the worst state for each
 * interrupt handler and per-request path, and calls that path once through a measure_* wrapper.
 * tests/firmware/bridge/cost_table.py runs it under callgrind (collecting only inside measure_*)
 * and turns the inclusive instruction counts into build/firmware/bridge_costs.md.
 *
 * stdout: one line per measurement: name, context, calls, budget (Ir per call), worst input.
 */
#include <stdio.h>
#include <string.h>

#include "bridge_internal.h"
#include "urb_bridge.h"
#include "urb_core.h"
#include "urb_runtime.h"

#define NOINLINE __attribute__((noinline, used))

/* ===== Null HALs ============================================================================== */

static uint32_t g_now;
static volatile uint8_t g_reg;

static uint32_t c_now(void *ctx) { (void)ctx; return g_now; }
static void c_period(void *ctx, uint32_t us) { (void)ctx; g_reg = (uint8_t)us; }
static void c_kick(void *ctx) { (void)ctx; g_reg = 1u; }
static void c_mark(void *ctx, uint8_t id, bool level) { (void)ctx; g_reg = (uint8_t)(id + (level ? 1u : 0u)); }
static void i_start(void *ctx) { (void)ctx; g_reg = 0x10u; }
static void i_write(void *ctx, uint8_t b) { (void)ctx; g_reg = b; }
static void i_read(void *ctx, bool ack) { (void)ctx; g_reg = ack ? 1u : 0u; }
static void i_stop(void *ctx) { (void)ctx; g_reg = 0x20u; }
static void i_abort(void *ctx) { (void)ctx; g_reg = 0x30u; }
static uint8_t g_lines = URB_I2C_SCL | URB_I2C_SDA;
static uint8_t i_lines(void *ctx) { (void)ctx; return g_lines; }
static void i_drive(void *ctx, uint8_t l) { (void)ctx; g_reg = l; }
static void i_release(void *ctx) { (void)ctx; g_reg = 0x40u; }

static const urb_bridge_hal_t HAL = {NULL, c_now, c_period, c_kick, c_mark};
static const urb_i2c_hal_t I2C = {NULL, i_start, i_write, i_read, i_stop, i_abort, i_lines, i_drive, i_release};

static urb_bridge_t B;
static urb_i2c_master_t M;

static void fresh(bool scan)
{
    urb_bridge_config_t cfg;
    urb_i2c_master_config_t mcfg;
    urb_downlink_t dl;
    urb_bridge_default_config(&cfg);
    cfg.scan_at_start = scan;
    urb_i2c_master_default_config(&mcfg);
    urb_i2c_master_init(&M, &I2C, &mcfg);
    urb_i2c_master_downlink(&M, &dl);
    g_now = 1000u;
    g_lines = URB_I2C_SCL | URB_I2C_SDA;
    (void)urb_bridge_init(&B, &cfg, &HAL, &dl);
}

static void report(const char *name, const char *context, unsigned calls, unsigned budget, const char *input)
{
    printf("%s\t%s\t%u\t%u\t%s\n", name, context, calls, budget, input);
}

static size_t write_req(uint8_t *buf, uint8_t address, uint8_t mailbox, uint8_t len)
{
    urb_uplink_write_request_t q;
    memset(&q, 0, sizeof q);
    q.address = address;
    q.mailbox = mailbox;
    q.seq = 1u;
    q.length = len;
    for (uint8_t i = 0u; i < len; i++) {
        q.data[i] = (uint8_t)(i * 7u);
    }
    return (size_t)urb_uplink_write_request_encode(&q, buf, 37u);
}

static size_t read_req(uint8_t *buf, uint8_t address, uint8_t mailbox, uint8_t len)
{
    urb_uplink_read_request_t q = {address, mailbox, 2u, len};
    return (size_t)urb_uplink_read_request_encode(&q, buf, 4u);
}

/* ===== Wrappers (one call of the path each) =================================================== */

NOINLINE void measure_uart_rx(uint8_t byte, uint32_t t) { urb_bridge_uart_rx(&B, byte, t); }
NOINLINE void measure_uart_rx_overrun(uint8_t byte, uint32_t t) { urb_bridge_uart_rx(&B, byte, t); }
NOINLINE bool measure_uart_tx_pop(uint8_t *byte) { return urb_bridge_uart_tx_pop(&B, byte); }
NOINLINE void measure_heartbeat(void) { urb_bridge_heartbeat(&B); }
NOINLINE void measure_i2c_ev_start(void) { urb_i2c_master_event(&M, URB_I2C_EV_START, 0u); }
NOINLINE void measure_i2c_ev_ack_data(void) { urb_i2c_master_event(&M, URB_I2C_EV_ACK, 0u); }
NOINLINE void measure_i2c_ev_ack_check(void) { urb_i2c_master_event(&M, URB_I2C_EV_ACK, 0u); }
NOINLINE void measure_i2c_ev_ack_last(void) { urb_i2c_master_event(&M, URB_I2C_EV_ACK, 0u); }
NOINLINE void measure_i2c_ev_nack(void) { urb_i2c_master_event(&M, URB_I2C_EV_NACK, 0u); }
NOINLINE void measure_i2c_ev_rx_byte(void) { urb_i2c_master_event(&M, URB_I2C_EV_BYTE, 0x5Au); }
NOINLINE void measure_i2c_ev_rx_last(void) { urb_i2c_master_event(&M, URB_I2C_EV_BYTE, 0x5Au); }
NOINLINE void measure_i2c_ev_error(void) { urb_i2c_master_event(&M, URB_I2C_EV_ERROR, 0u); }
NOINLINE void measure_poll_write_request(void) { urb_bridge_poll(&B); }
NOINLINE void measure_poll_hunt_ring(void) { urb_bridge_poll(&B); }
NOINLINE void measure_poll_gap_flush(void) { urb_bridge_poll(&B); }
NOINLINE void measure_poll_read_done(void) { urb_bridge_poll(&B); }
NOINLINE void measure_poll_scan_step(void) { urb_bridge_poll(&B); }
NOINLINE void measure_poll_clear_step(void) { urb_bridge_poll(&B); }
NOINLINE void measure_poll_bridge_scan(void) { urb_bridge_poll(&B); }
NOINLINE void measure_poll_emit_ring(void) { urb_bridge_poll(&B); }
NOINLINE void measure_poll_idle(void) { urb_bridge_poll(&B); }
NOINLINE bool measure_usb_out(const uint8_t *d, size_t n) { return urb_bridge_usb_out(&B, d, n); }
NOINLINE bool measure_usb_out_garbage(const uint8_t *d, size_t n) { return urb_bridge_usb_out(&B, d, n); }
NOINLINE void measure_usb_sof(void) { urb_bridge_usb_sof(&B); }
NOINLINE size_t measure_usb_in(uint8_t *buf, size_t cap) { return urb_bridge_usb_in(&B, buf, cap); }

/* Drive the master through a transaction until byte `stop_at` of its sequence is the next event. */
static void events(urb_i2c_event_t ev, unsigned n)
{
    for (unsigned i = 0u; i < n; i++) {
        urb_i2c_master_event(&M, ev, 0x5Au);
    }
}

int main(void)
{
    uint8_t f[64];
    uint8_t buf[600];

    /* ---- interrupt handlers ---- */
    fresh(false);
    B.rx_started = true;
    B.rx_last_us = 0u;
    measure_uart_rx(0x55u, 5000u);
    report("measure_uart_rx", "ISR", 1, 60, "UART byte after an idle gap (gap flag set, ring store)");
    for (unsigned i = 0u; i < URB_BRIDGE_RX_RING; i++) {
        urb_bridge_uart_rx(&B, 0x55u, 5000u);
    }
    measure_uart_rx_overrun(0x55u, 5001u);
    report("measure_uart_rx_overrun", "ISR", 1, 60, "UART byte with the receive ring full (overrun)");

    fresh(false);
    uint8_t one[35];
    memset(one, 0xAB, sizeof one);
    (void)urbb_uplink_send(&B, 0u, one, 35u);
    uint8_t byte;
    (void)measure_uart_tx_pop(&byte);
    report("measure_uart_tx_pop", "ISR", 1, 40, "UART transmit-empty: next response byte");
    measure_heartbeat();
    report("measure_heartbeat", "ISR", 1, 20, "heartbeat timer tick");

    /* I2C: a 32-byte write (CRC-16 check), then a 32-byte read with select */
    fresh(false);
    uint8_t data[32] = {0};
    urb_downlink_txn_t w = {URB_DL_WRITE, 0x20u, 1u, 32u, 0u, false, data};
    (void)B.dl.begin(B.dl.ctx, &w, g_now);
    measure_i2c_ev_start();
    events(URB_I2C_EV_ACK, 5u);   /* address, select, 3 data */
    measure_i2c_ev_ack_data();    /* a data byte: the deepest byte lookup */
    events(URB_I2C_EV_ACK, 28u);  /* up to the first check byte */
    measure_i2c_ev_ack_check();   /* ACK of the first check byte: the next is the last */
    measure_i2c_ev_ack_last();    /* ACK of the last check byte: STOP, done */
    (void)B.dl.poll(B.dl.ctx, g_now);
    report("measure_i2c_ev_start", "ISR", 1, 80, "I2C START done: first byte out");
    report("measure_i2c_ev_ack_data", "ISR", 1, 80, "I2C ACK of a data byte: next data byte out");
    report("measure_i2c_ev_ack_check", "ISR", 1, 80, "I2C ACK before the last check byte");
    report("measure_i2c_ev_ack_last", "ISR", 1, 80, "I2C ACK of the last check byte: STOP");
    (void)B.dl.begin(B.dl.ctx, &w, g_now);
    events(URB_I2C_EV_START, 1u);
    events(URB_I2C_EV_ACK, 3u);
    measure_i2c_ev_nack();
    (void)B.dl.poll(B.dl.ctx, g_now);
    report("measure_i2c_ev_nack", "ISR", 1, 80, "I2C NACK of a data byte: status by position, STOP");
    urb_downlink_txn_t rd = {URB_DL_READ, 0x21u, 1u, 32u, 0u, true, data};
    (void)B.dl.begin(B.dl.ctx, &rd, g_now);
    events(URB_I2C_EV_START, 1u);
    events(URB_I2C_EV_ACK, 2u);   /* address, select */
    events(URB_I2C_EV_START, 1u); /* repeated START */
    events(URB_I2C_EV_ACK, 1u);   /* read address */
    events(URB_I2C_EV_BYTE, 32u);
    measure_i2c_ev_rx_byte();     /* first check byte */
    measure_i2c_ev_rx_last();     /* last check byte: STOP */
    report("measure_i2c_ev_rx_byte", "ISR", 1, 80, "I2C byte read (check byte), next read issued");
    report("measure_i2c_ev_rx_last", "ISR", 1, 80, "I2C last byte read: STOP");
    (void)B.dl.poll(B.dl.ctx, g_now);
    (void)B.dl.begin(B.dl.ctx, &rd, g_now);
    measure_i2c_ev_error();
    report("measure_i2c_ev_error", "ISR", 1, 40, "I2C controller error (arbitration lost)");

    /* ---- per-request paths in the main loop ---- */
    fresh(false);
    size_t n = write_req(f, 0x20u, 1u, 32u);
    for (size_t i = 0u; i < n; i++) {
        urb_bridge_uart_rx(&B, f[i], g_now);
    }
    measure_poll_write_request();
    report("measure_poll_write_request", "main", 1, 40000,
           "poll: 37-byte write (32 data, CRC-16) parsed, admitted, I2C write begun (check computed)");

    fresh(false);
    for (unsigned i = 0u; i < URB_BRIDGE_RX_RING; i++) {
        urb_bridge_uart_rx(&B, 0x20u, g_now); /* every byte starts a 37-byte write candidate */
    }
    urb_bridge_poll(&B); /* 16 bytes per poll: the first two polls only collect the first candidate */
    urb_bridge_poll(&B);
    measure_poll_hunt_ring();
    report("measure_poll_hunt_ring", "main", 1, 20000,
           "poll: full receive ring (64 bytes) of 0x20, each byte a failing 37-byte CRC-16 candidate, third poll: "
           "URB_BRIDGE_HUNT_CHECKS of them checked, the rest left for the next polls");
    {
        uint32_t yields;
        do { /* the next polls check the rest, a few each */
            yields = B.stats.hunt_yields;
            urb_bridge_poll(&B);
        } while (B.stats.hunt_yields != yields);
    }
    g_now += 1000u;
    measure_poll_gap_flush();
    report("measure_poll_gap_flush", "main", 1, 40000, "poll: idle gap flushes the 36 left-over bytes");

    /* a 32-byte read completes: check verified, response encoded and queued */
    fresh(false);
    n = read_req(f, 0x20u, 1u, 32u);
    for (size_t i = 0u; i < n; i++) {
        urb_bridge_uart_rx(&B, f[i], g_now);
    }
    urb_bridge_poll(&B); /* admitted, read begun */
    events(URB_I2C_EV_START, 1u);
    events(URB_I2C_EV_ACK, 2u);
    events(URB_I2C_EV_START, 1u);
    events(URB_I2C_EV_ACK, 1u);
    events(URB_I2C_EV_BYTE, 34u);
    measure_poll_read_done();
    report("measure_poll_read_done", "main", 1, 40000,
           "poll: 32-byte read done: CRC-16 verified, response (35 bytes, CRC-16) encoded to the UART ring");

    /* scan: an identification read completes, the node is learnt, the next address begins */
    fresh(true);
    urb_bridge_poll(&B); /* scan read of 0x08 begun */
    events(URB_I2C_EV_START, 1u);
    events(URB_I2C_EV_ACK, 2u);
    events(URB_I2C_EV_START, 1u);
    events(URB_I2C_EV_ACK, 1u);
    {
        /* feed a valid identification so that node_learn runs */
        urb_identification_t id;
        memset(&id, 0, sizeof id);
        id.class_id = 0x10u;
        id.inbox_sizes[0] = 6u;
        id.outbox_sizes[0] = 25u;
        uint8_t frame[27];
        (void)urb_identification_encode(&id, frame, 25u);
        uint8_t const sel = 0x80u;
        uint32_t const check = urb_link_check(&sel, 1u, frame, 25u);
        frame[25] = (uint8_t)check;
        frame[26] = (uint8_t)(check >> 8);
        for (unsigned i = 0u; i < 27u; i++) {
            urb_i2c_master_event(&M, URB_I2C_EV_BYTE, frame[i]);
        }
    }
    measure_poll_scan_step();
    report("measure_poll_scan_step", "main", 1, 40000,
           "poll: scan read done: CRC-16 verified, identification decoded, sizes learnt, next address begun");

    fresh(false);
    g_lines = URB_I2C_SCL;
    n = read_req(f, 0x20u, 1u, 4u);
    for (size_t i = 0u; i < n; i++) {
        urb_bridge_uart_rx(&B, f[i], g_now);
    }
    urb_bridge_poll(&B); /* stuck bus found: clear begins */
    g_now += 10u;
    measure_poll_clear_step();
    report("measure_poll_clear_step", "main", 1, 2000, "poll: one half clock of the bus clear");

    fresh(false);
    n = read_req(f, 0u, 1u, 16u);
    for (size_t i = 0u; i < n; i++) {
        urb_bridge_uart_rx(&B, f[i], g_now);
    }
    measure_poll_bridge_scan();
    report("measure_poll_bridge_scan", "main", 1, 40000,
           "poll: read of the bridge's BridgeScan (128-address map encoded), response queued");

    /* a full response ring of BUSY answers leaves in one poll (bounded by URB_BRIDGE_RING_MAX) */
    fresh(false);
    {
        urb_bridge_config_t c = B.cfg;
        (void)c;
    }
    n = 4u;
    for (unsigned i = 0u; i < 8u; i++) {
        n += read_req(buf + n, 0x7Eu, 1u, 4u); /* reserved address: BAD_REQUEST at admission */
    }
    {
        urb_usb_batch_header_t h = {1u, 8u};
        (void)urb_usb_batch_header_encode(&h, buf, 4u);
    }
    (void)urb_bridge_usb_out(&B, buf, n);
    measure_poll_emit_ring();
    report("measure_poll_emit_ring", "main", 1, 40000, "poll: 8 admission-error responses emitted to USB");

    fresh(false);
    measure_poll_idle();
    report("measure_poll_idle", "main", 1, 300, "poll with nothing to do");

    /* USB: a full 512-byte OUT batch of 13 32-byte writes and 6 reads */
    fresh(false);
    n = 4u;
    for (unsigned i = 0u; i < 13u; i++) {
        n += write_req(buf + n, (uint8_t)(0x20u + i), 1u, 32u);
    }
    for (unsigned i = 0u; i < 6u; i++) {
        n += read_req(buf + n, (uint8_t)(0x40u + i), 1u, 4u);
    }
    {
        urb_usb_batch_header_t h = {7u, 19u};
        (void)urb_usb_batch_header_encode(&h, buf, 4u);
    }
    (void)measure_usb_out(buf, n);
    printf("# usb_out batch bytes: %zu\n", n);
    report("measure_usb_out", "main", 1, 250000,
           "USB OUT: 509-byte batch (13 x 37-byte writes, 6 reads) parsed and admitted (16 slots, 3 BUSY)");
    /* a 512-byte transfer of garbage behind a good header: cut at its first (failing) frame */
    fresh(false);
    memset(buf, 0x20, URB_BRIDGE_USB_BUF);
    {
        urb_usb_batch_header_t h = {8u, 13u};
        (void)urb_usb_batch_header_encode(&h, buf, 4u);
    }
    (void)measure_usb_out_garbage(buf, URB_BRIDGE_USB_BUF);
    report("measure_usb_out_garbage", "main", 1, 4000,
           "USB OUT: 512-byte transfer of 0x20 after its header: one failing 37-byte candidate, the rest dropped");
    /* fill the current response batch to the brim, then SOF and IN */
    fresh(false);
    for (unsigned i = 0u; i < 14u; i++) {
        memset(one, (int)i, sizeof one);
        (void)urbb_uplink_send(&B, 1u, one, 35u);
    }
    measure_usb_sof();
    report("measure_usb_sof", "main", 1, 60, "USB start of frame: response batches swap");
    size_t got = measure_usb_in(buf, sizeof buf);
    printf("# usb_in bytes: %zu\n", got);
    report("measure_usb_in", "main", 1, 8000, "USB IN: a 494-byte response batch (14 x 35) copied out");
    return 0;
}
