/*
 * The I2C downlink master alone (firmware/bridge/i2c_master.c), for the mutation score
 * (tests/mutation/README.md): every HAL operation it issues is recorded as a text trace ("S" start,
 * "Wxx" write, "R1"/"R0" read with or without ACK, "P" stop, "A" abort, "Dx" drive, "L" release)
 * and compared whole with the bus sequence of urb_downlink.h's contract for each transaction kind,
 * outcome, fault, timeout and bus clear. The groups through the bridge see only the outcomes.
 */
#include <stdio.h>
#include <string.h>

#include "support.h"
#include "urb_runtime.h"

#define ADDR 0x21u
#define BOTH (URB_I2C_SCL | URB_I2C_SDA)

static char trace[512];
static uint8_t lines_now = BOTH;

static void put(const char *fmt, unsigned v)
{
    size_t const n = strlen(trace);
    assert_true(n + 8u < sizeof trace);
    (void)snprintf(trace + n, sizeof trace - n, fmt, v);
}

/* When set, start() delivers its START event at once, as an interrupt arriving right after the
 * call returns to begin() in the main loop would. */
static urb_i2c_master_t *start_at_once;

static void t_start(void *ctx)
{
    (void)ctx;
    put("S ", 0u);
    if (start_at_once != NULL) {
        urb_i2c_master_t *m = start_at_once;
        start_at_once = NULL;
        urb_i2c_master_event(m, URB_I2C_EV_START, 0u);
    }
}
static void t_write(void *ctx, uint8_t b) { (void)ctx; put("W%02X ", b); }
static void t_read(void *ctx, bool ack) { (void)ctx; put("R%u ", ack ? 1u : 0u); }
static void t_stop(void *ctx) { (void)ctx; put("P ", 0u); }
static void t_abort(void *ctx) { (void)ctx; put("A ", 0u); }
static uint8_t t_lines(void *ctx) { (void)ctx; return lines_now; }
static void t_drive(void *ctx, uint8_t l) { (void)ctx; put("D%u ", l); }
static void t_release(void *ctx) { (void)ctx; put("L ", 0u); }
static urb_i2c_hal_t const HAL = {NULL, t_start, t_write, t_read, t_stop, t_abort, t_lines, t_drive, t_release};

typedef struct {
    urb_i2c_master_t m;
    urb_downlink_t dl;
} rig_t;

static void fresh(rig_t *r)
{
    memset(r, 0xA5, sizeof *r); /* init must not depend on what the memory held */
    urb_i2c_master_config_t cfg;
    urb_i2c_master_default_config(&cfg);
    urb_i2c_master_init(&r->m, &HAL, &cfg);
    urb_i2c_master_downlink(&r->m, &r->dl);
    trace[0] = '\0';
    lines_now = BOTH;
}

static void begin(rig_t *r, uint8_t op, uint8_t mailbox, uint8_t len, uint8_t *data, bool reselect, uint32_t now)
{
    urb_downlink_txn_t const t = {op, ADDR, mailbox, len, 7u, reselect, data};
    assert_true(r->dl.begin(r->dl.ctx, &t, now));
}

static void ev(rig_t *r, urb_i2c_event_t e, unsigned n)
{
    for (unsigned k = 0u; k < n; k++) {
        urb_i2c_master_event(&r->m, e, 0u);
    }
}

static int8_t poll(rig_t *r, uint32_t now)
{
    return r->dl.poll(r->dl.ctx, now);
}

/* The write's bus sequence: address, select, data, check (CRC-8 up to 14 covered bytes, CRC-16 low
 * byte first above), STOP; OK once, then IDLE. Longer data is cut at 32 bytes. */
static void master_write_sequence(void **state)
{
    (void)state;
    static uint8_t const lens[] = {4u, 20u, 32u, 33u, 40u};
    for (unsigned i = 0u; i < sizeof lens; i++) {
        uint8_t data[40];
        for (uint8_t k = 0u; k < 40u; k++) {
            data[k] = (uint8_t)(0x10u + k);
        }
        rig_t r;
        fresh(&r);
        begin(&r, URB_DL_WRITE, 3u, lens[i], data, false, 0u);
        assert_true(urb_i2c_master_busy(&r.m));
        uint8_t const n = (lens[i] > 32u) ? 32u : lens[i];
        uint8_t const sel = 3u;
        uint32_t const check = urb_link_check(&sel, 1u, data, n);
        size_t const tail = urb_link_check_size(1u + (size_t)n);
        char want[512] = "S W42 W03 ";
        for (uint8_t k = 0u; k < n; k++) {
            (void)snprintf(want + strlen(want), sizeof want - strlen(want), "W%02X ", data[k]);
        }
        (void)snprintf(want + strlen(want), sizeof want - strlen(want), "W%02X ", (unsigned)(check & 0xFFu));
        if (tail == 2u) {
            (void)snprintf(want + strlen(want), sizeof want - strlen(want), "W%02X ", (unsigned)(check >> 8));
        }
        strcat(want, "P ");
        ev(&r, URB_I2C_EV_START, 1u);
        ev(&r, URB_I2C_EV_ACK, 2u + n + (unsigned)tail);
        assert_string_equal(trace, want);
        assert_false(urb_i2c_master_busy(&r.m));
        assert_int_equal(poll(&r, 1u), (int8_t)URB_STATUS_OK);
        assert_int_equal(poll(&r, 2u), URB_DOWNLINK_IDLE);
    }
}

/* Delivers a node's read answer: `len` data bytes and its check (corrupted when asked). */
static void answer(rig_t *r, uint8_t mailbox, const uint8_t *data, uint8_t len, bool corrupt)
{
    uint8_t const sel = (uint8_t)(mailbox | 0x80u);
    uint32_t const check = urb_link_check(&sel, 1u, data, len) ^ (corrupt ? 0x100u : 0u);
    for (uint8_t k = 0u; k < len; k++) {
        urb_i2c_master_event(&r->m, URB_I2C_EV_BYTE, data[k]);
    }
    urb_i2c_master_event(&r->m, URB_I2C_EV_BYTE, (uint8_t)(check & 0xFFu));
    if (urb_link_check_size(1u + (size_t)len) == 2u) {
        urb_i2c_master_event(&r->m, URB_I2C_EV_BYTE, (uint8_t)(check >> 8));
    }
}

/* A read: select, repeated START, read address, data and check acknowledged but the last byte; the
 * selection is cached after a good check, so the next read of that mailbox goes straight to the
 * read address, unless `reselect`; a bad check (in the CRC-16's high byte) is CHECKSUM and forgets
 * the selection; a NACKed read address is NO_NODE and forgets it too. */
static void master_read_sequence(void **state)
{
    (void)state;
    uint8_t const want[20] = {9u, 8u, 7u, 6u, 5u, 4u, 3u, 2u, 1u, 0u, 11u, 12u, 13u, 14u, 15u, 16u, 17u, 18u, 19u, 20u};
    uint8_t got[20];
    rig_t r;
    fresh(&r);
    assert_int_equal(urb_i2c_master_selection(&r.m, ADDR), URB_I2C_NO_SELECTION);
    begin(&r, URB_DL_READ, 2u, 3u, got, false, 0u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 2u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 1u);
    assert_true(urb_i2c_master_busy(&r.m)); /* reading */
    answer(&r, 2u, want, 3u, false);
    assert_string_equal(trace, "S W42 W82 S W43 R1 R1 R1 R0 P ");
    assert_int_equal(poll(&r, 1u), (int8_t)URB_STATUS_OK);
    assert_memory_equal(got, want, 3u);
    assert_int_equal(urb_i2c_master_selection(&r.m, ADDR), 2u);
    assert_int_equal(urb_i2c_master_selection(&r.m, ADDR | 0x80u), 2u); /* the address is 7 bits */

    /* the cached selection: no select; a 20-byte mailbox has a CRC-16 check */
    trace[0] = '\0';
    memset(got, 0, sizeof got);
    begin(&r, URB_DL_READ, 2u, 20u, got, false, 5u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 1u);
    answer(&r, 2u, want, 20u, false);
    assert_string_equal(trace, "S W43 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R1 R0 P ");
    assert_int_equal(poll(&r, 6u), (int8_t)URB_STATUS_OK);
    assert_memory_equal(got, want, 20u);

    /* reselect asked for: the select is sent again; its check's high byte is wrong: CHECKSUM */
    trace[0] = '\0';
    begin(&r, URB_DL_READ, 2u, 20u, got, true, 10u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 2u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 1u);
    answer(&r, 2u, want, 20u, true);
    assert_true(strncmp(trace, "S W42 W82 S W43 R1 ", 19u) == 0);
    assert_int_equal(poll(&r, 11u), (int8_t)URB_STATUS_CHECKSUM);
    assert_int_equal(urb_i2c_master_selection(&r.m, ADDR), URB_I2C_NO_SELECTION);

    /* another mailbox than the cached one is selected first */
    begin(&r, URB_DL_READ, 1u, 1u, got, false, 20u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 2u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 1u);
    answer(&r, 1u, want, 1u, false);
    assert_int_equal(poll(&r, 21u), (int8_t)URB_STATUS_OK);
    trace[0] = '\0';
    begin(&r, URB_DL_READ, 4u, 1u, got, false, 30u);
    ev(&r, URB_I2C_EV_START, 1u);
    assert_string_equal(trace, "S W42 ");

    /* the read address NACKed: NO_NODE, the selection is forgotten */
    fresh(&r);
    begin(&r, URB_DL_READ, 1u, 1u, got, false, 0u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 2u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_NACK, 1u);
    assert_string_equal(trace, "S W42 W81 S W43 P ");
    assert_int_equal(poll(&r, 1u), (int8_t)URB_STATUS_NO_NODE);
    assert_int_equal(urb_i2c_master_selection(&r.m, ADDR), URB_I2C_NO_SELECTION);
}

/* SYNC is the general call, the magic and the counter; nobody acknowledging it is still OK. A probe
 * is the address alone: OK when acknowledged, NO_NODE when not. */
static void master_sync_and_probe_sequences(void **state)
{
    (void)state;
    rig_t r;
    fresh(&r);
    begin(&r, URB_DL_SYNC, 0u, 0u, NULL, false, 0u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 3u);
    assert_string_equal(trace, "S W00 WA5 W07 P ");
    assert_int_equal(poll(&r, 1u), (int8_t)URB_STATUS_OK);
    trace[0] = '\0';
    begin(&r, URB_DL_SYNC, 0u, 0u, NULL, false, 2u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_NACK, 1u);
    assert_string_equal(trace, "S W00 P ");
    assert_int_equal(poll(&r, 3u), (int8_t)URB_STATUS_OK);
    trace[0] = '\0';
    begin(&r, URB_DL_PROBE, 0u, 0u, NULL, false, 4u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_ACK, 1u);
    assert_string_equal(trace, "S W42 P ");
    assert_int_equal(poll(&r, 5u), (int8_t)URB_STATUS_OK);
    trace[0] = '\0';
    begin(&r, URB_DL_PROBE, 0u, 0u, NULL, false, 6u);
    ev(&r, URB_I2C_EV_START, 1u);
    ev(&r, URB_I2C_EV_NACK, 1u);
    assert_string_equal(trace, "S W42 P ");
    assert_int_equal(poll(&r, 7u), (int8_t)URB_STATUS_NO_NODE);
}

/* Caches a selection of mailbox 2 at ADDR (a good read). */
static void cache_selection(rig_t *r)
{
    uint8_t buf[1];
    uint8_t const one = 0x33u;
    begin(r, URB_DL_READ, 2u, 1u, buf, false, 0u);
    ev(r, URB_I2C_EV_START, 1u);
    ev(r, URB_I2C_EV_ACK, 2u);
    ev(r, URB_I2C_EV_START, 1u);
    ev(r, URB_I2C_EV_ACK, 1u);
    answer(r, 2u, &one, 1u, false);
    assert_int_equal(poll(r, 0u), (int8_t)URB_STATUS_OK);
    assert_int_equal(urb_i2c_master_selection(&r->m, ADDR), 2u);
    trace[0] = '\0';
}

/* An event the phase does not expect, or the controller's error, ends the transaction in poll():
 * free lines give TIMEOUT after releasing the controller, and a node's selection is forgotten
 * (not for SYNC, which addresses nobody). Late events after that change nothing. */
static void master_unexpected_events_fault(void **state)
{
    (void)state;
    static struct {
        uint8_t op;
        urb_i2c_event_t first, second;
        unsigned acks;
    } const cases[] = {
        {URB_DL_WRITE, URB_I2C_EV_ACK, URB_I2C_EV_ACK, 0u},    /* an ACK before the START */
        {URB_DL_WRITE, URB_I2C_EV_START, URB_I2C_EV_BYTE, 0u}, /* a byte while writing */
        {URB_DL_READ, URB_I2C_EV_START, URB_I2C_EV_ACK, 2u},   /* an ACK for the repeated START */
        {URB_DL_READ, URB_I2C_EV_START, URB_I2C_EV_START, 3u}, /* a START for the read address */
        {URB_DL_READ, URB_I2C_EV_START, URB_I2C_EV_ACK, 4u},   /* an ACK while reading */
        {URB_DL_WRITE, URB_I2C_EV_START, URB_I2C_EV_ERROR, 1u},
        {URB_DL_SYNC, URB_I2C_EV_START, URB_I2C_EV_BYTE, 1u},
    };
    for (unsigned i = 0u; i < sizeof cases / sizeof cases[0]; i++) {
        rig_t r;
        fresh(&r);
        cache_selection(&r);
        uint8_t data[4] = {1u, 2u, 3u, 4u};
        begin(&r, cases[i].op, 2u, 4u, data, true, 100u);
        ev(&r, cases[i].first, 1u);
        if (cases[i].acks >= 2u && cases[i].op == URB_DL_READ) {
            ev(&r, URB_I2C_EV_ACK, 2u); /* address and select: the repeated START is next */
            if (cases[i].acks >= 3u) {
                ev(&r, URB_I2C_EV_START, 1u); /* the read address is next */
            }
            if (cases[i].acks >= 4u) {
                ev(&r, URB_I2C_EV_ACK, 1u); /* reading */
            }
        } else if (cases[i].acks == 1u) {
            ev(&r, URB_I2C_EV_ACK, 1u);
        }
        assert_true(urb_i2c_master_busy(&r.m) || cases[i].second != URB_I2C_EV_ERROR);
        size_t const before = strlen(trace);
        ev(&r, cases[i].second, 1u);
        assert_int_equal(strlen(trace), before); /* no bus operation from the interrupt */
        assert_false(urb_i2c_master_busy(&r.m));
        ev(&r, URB_I2C_EV_ACK, 1u); /* late: ignored */
        assert_int_equal(strlen(trace), before);
        assert_int_equal(poll(&r, 101u), (int8_t)URB_STATUS_TIMEOUT);
        assert_string_equal(trace + before, "L ");
        assert_int_equal(urb_i2c_master_selection(&r.m, ADDR),
                         (cases[i].op == URB_DL_SYNC) ? 2u : URB_I2C_NO_SELECTION);
        assert_int_equal(poll(&r, 102u), URB_DOWNLINK_IDLE);
        assert_int_equal(urb_i2c_master_timeouts(&r.m), 0u);
    }
}

/* The timeout: busy up to timeout_us after begin, then the controller is aborted, counted, and the
 * fault handling runs; deadline() names the first poll time that times out. */
static void master_times_out_exactly(void **state)
{
    (void)state;
    rig_t r;
    fresh(&r);
    uint32_t const limit = r.m.cfg.timeout_us;
    uint8_t data[1] = {1u};
    uint32_t deadline = 0u;
    assert_false(urb_i2c_master_deadline(&r.m, &deadline));
    begin(&r, URB_DL_WRITE, 1u, 1u, data, false, 1000u);
    assert_false(r.dl.begin(r.dl.ctx, &(urb_downlink_txn_t){URB_DL_SYNC, 0u, 0u, 0u, 1u, false, NULL}, 1000u));
    assert_true(urb_i2c_master_deadline(&r.m, &deadline));
    assert_int_equal(deadline, 1000u + limit + 1u);
    ev(&r, URB_I2C_EV_START, 1u);
    assert_int_equal(poll(&r, 1000u + limit), URB_DOWNLINK_BUSY);
    assert_string_equal(trace, "S W42 ");
    assert_int_equal(poll(&r, 1000u + limit + 1u), (int8_t)URB_STATUS_TIMEOUT);
    assert_string_equal(trace, "S W42 A L ");
    assert_int_equal(urb_i2c_master_timeouts(&r.m), 1u);
    assert_false(urb_i2c_master_deadline(&r.m, &deadline));
}

/* Runs a bus clear to its end: one step per half clock (clear_half_us), none before; returns the
 * outcome and checks the drive sequence of UM10204 3.1.16 (nine pulses, then a STOP). */
static int8_t run_clear(rig_t *r, uint32_t t, uint8_t after)
{
    uint32_t const half = r->m.cfg.clear_half_us;
    char want[256] = "";
    for (unsigned k = 0u; k < 18u; k++) {
        (void)snprintf(want + strlen(want), sizeof want - strlen(want), "D%u ", (k & 1u) ? BOTH : URB_I2C_SDA);
    }
    strcat(want, "D0 D1 D3 L ");
    trace[0] = '\0';
    assert_int_equal(poll(r, t), URB_DOWNLINK_BUSY); /* the first step at once */
    for (unsigned k = 1u; k < 21u; k++) {
        assert_int_equal(poll(r, t + k * half - 1u), URB_DOWNLINK_BUSY);
        assert_int_equal(strlen(trace), 3u * k); /* too early: no step */
        assert_int_equal(poll(r, t + k * half), URB_DOWNLINK_BUSY);
    }
    lines_now = after;
    int8_t const out = poll(r, t + 21u * half);
    assert_string_equal(trace, want);
    return out;
}

/* A line held low: at begin (the request is not executed: BUS_STUCK after the clear, whatever the
 * lines then), after a fault (likewise), and the explicit CLEAR command (OK when the bus is free
 * after it, BUS_STUCK when not). Every clear is counted and forgets every cached selection. */
static void master_bus_clears(void **state)
{
    (void)state;
    rig_t r;
    fresh(&r);
    cache_selection(&r);
    uint8_t data[1] = {1u};
    lines_now = URB_I2C_SCL; /* SDA low */
    begin(&r, URB_DL_WRITE, 1u, 1u, data, false, 50u);
    assert_string_equal(trace, "");
    assert_int_equal(urb_i2c_master_bus_clears(&r.m), 1u);
    assert_int_equal(urb_i2c_master_selection(&r.m, ADDR), URB_I2C_NO_SELECTION);
    assert_false(urb_i2c_master_busy(&r.m));
    assert_int_equal(run_clear(&r, 60u, BOTH), (int8_t)URB_STATUS_BUS_STUCK);
    assert_int_equal(poll(&r, 200u), URB_DOWNLINK_IDLE);

    /* a fault with SDA held low: cleared, then BUS_STUCK */
    cache_selection(&r);
    begin(&r, URB_DL_SYNC, 0u, 0u, NULL, false, 300u);
    ev(&r, URB_I2C_EV_ERROR, 1u);
    lines_now = URB_I2C_SCL;
    assert_int_equal(poll(&r, 301u), URB_DOWNLINK_BUSY);
    assert_string_equal(trace, "S "); /* straight to the clear: the controller is not handed the stuck bus */
    assert_int_equal(urb_i2c_master_bus_clears(&r.m), 2u);
    assert_int_equal(urb_i2c_master_selection(&r.m, ADDR), URB_I2C_NO_SELECTION);
    assert_int_equal(run_clear(&r, 302u, BOTH), (int8_t)URB_STATUS_BUS_STUCK);

    /* the CLEAR command, whatever the lines at begin */
    begin(&r, URB_DL_CLEAR, 0u, 0u, NULL, false, 500u);
    assert_int_equal(urb_i2c_master_bus_clears(&r.m), 3u);
    assert_int_equal(run_clear(&r, 501u, BOTH), (int8_t)URB_STATUS_OK);
    lines_now = BOTH;
    begin(&r, URB_DL_CLEAR, 0u, 0u, NULL, false, 600u);
    assert_int_equal(run_clear(&r, 601u, URB_I2C_SCL), (int8_t)URB_STATUS_BUS_STUCK);
    assert_int_equal(urb_i2c_master_bus_clears(&r.m), 4u);
    assert_int_equal(urb_i2c_master_timeouts(&r.m), 0u);
}

/* The timeout for a bit rate: twice the longest transaction's bits at that rate, rounded up, never
 * below the minimum; 0 (rate unknown) gives the minimum. The defaults are 400 kb/s and its timeout. */
static void master_timeout_follows_the_rate(void **state)
{
    (void)state;
    static uint32_t const rates[] = {1u, 10u, 100u, 333u, 335u, 336u, 337u, 400u, 1000u, 65535u, 0xFFFFFFFFu};
    uint64_t const bits_ms = 2u * (uint64_t)URB_I2C_LONGEST_BITS * 1000u;
    for (unsigned i = 0u; i < sizeof rates / sizeof rates[0]; i++) {
        uint64_t const bus = (bits_ms + rates[i] - 1u) / rates[i];
        uint64_t const want = (bus > URB_I2C_MIN_TIMEOUT_US) ? bus : URB_I2C_MIN_TIMEOUT_US;
        assert_int_equal(urb_i2c_master_timeout_us(rates[i]), want);
    }
    assert_int_equal(urb_i2c_master_timeout_us(0u), URB_I2C_MIN_TIMEOUT_US);
    assert_int_equal(urb_i2c_master_timeout_us(335u), 2006u);
    urb_i2c_master_config_t cfg;
    memset(&cfg, 0xA5, sizeof cfg);
    urb_i2c_master_default_config(&cfg);
    assert_int_equal(cfg.bitrate_kbps, 400u);
    assert_int_equal(cfg.timeout_us, urb_i2c_master_timeout_us(400u));
    assert_int_equal(cfg.clear_half_us, 5u);
    rig_t r;
    fresh(&r);
    assert_int_equal(r.dl.bitrate_kbps, 400u);
    assert_int_equal(r.dl.kind, URB_DOWNLINK_KIND_I2C);
    assert_int_equal(r.dl.first_address, URB_I2C_FIRST_ADDRESS);
    assert_int_equal(r.dl.last_address, URB_I2C_LAST_ADDRESS);
    for (unsigned a = 0u; a < 256u; a++) {
        assert_int_equal(urb_i2c_master_selection(&r.m, (uint8_t)a), URB_I2C_NO_SELECTION);
    }
    assert_int_equal(poll(&r, 0u), URB_DOWNLINK_IDLE);
    assert_int_equal(urb_i2c_master_timeouts(&r.m), 0u);
    assert_int_equal(urb_i2c_master_bus_clears(&r.m), 0u);
}

/* A START event arriving as soon as begin() has called start() finds the transaction started; a
 * write NACKed at the address (NO_NODE) or the select (BAD_REQUEST) forgets the node's cached
 * selection (it may have reset), one NACKed at its first data byte (NODE_BUSY) keeps it. */
static void master_start_at_once_and_write_failures(void **state)
{
    (void)state;
    rig_t r;
    fresh(&r);
    uint8_t data[4] = {1u, 2u, 3u, 4u};
    start_at_once = &r.m;
    begin(&r, URB_DL_WRITE, 1u, 4u, data, false, 0u);
    assert_string_equal(trace, "S W42 ");
    static struct {
        unsigned acks;
        uint8_t status;
        bool kept;
    } const cases[] = {{0u, URB_STATUS_NO_NODE, false}, {1u, URB_STATUS_BAD_REQUEST, false},
                       {2u, URB_STATUS_NODE_BUSY, true}};
    for (unsigned i = 0u; i < sizeof cases / sizeof cases[0]; i++) {
        fresh(&r);
        cache_selection(&r);
        begin(&r, URB_DL_WRITE, 1u, 4u, data, false, 0u);
        ev(&r, URB_I2C_EV_START, 1u);
        ev(&r, URB_I2C_EV_ACK, cases[i].acks);
        ev(&r, URB_I2C_EV_NACK, 1u);
        assert_int_equal(poll(&r, 1u), (int8_t)cases[i].status);
        assert_int_equal(urb_i2c_master_selection(&r.m, ADDR), cases[i].kept ? 2u : URB_I2C_NO_SELECTION);
    }
}

int run_master_trace_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(master_write_sequence),
        cmocka_unit_test(master_read_sequence),
        cmocka_unit_test(master_sync_and_probe_sequences),
        cmocka_unit_test(master_unexpected_events_fault),
        cmocka_unit_test(master_times_out_exactly),
        cmocka_unit_test(master_bus_clears),
        cmocka_unit_test(master_timeout_follows_the_rate),
        cmocka_unit_test(master_start_at_once_and_write_failures),
    };
    return cmocka_run_group_tests_name("bridge_master_trace", tests, NULL, NULL);
}
