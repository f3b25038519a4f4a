/*
 * cmocka tests of the RS485 downlink: line timing, the silence-delimited receiver (every path:
 * end by t3.5, a gap over t1.5, a frame too long, start-up, the delayed CRCs against the schema's
 * encoder for every length), and the master and slave end to end on an in-memory half-duplex line
 * (every outcome of urb_rs485_master.h: OK, refusals, silence, collision, babble, a stalled answer,
 * a corrupted request, SYNC).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "fake_mailbox.h"
#include "urb_core.h"
#include "urb_rs485.h"
#include "urb_rs485_master.h"
#include "urb_rs485_slave.h"
#include "urb_rs485_wire.h"
#include "urb_runtime.h"

/* ===== Timing and the receiver ================================================================= */

static void test_timing(void **state)
{
    (void)state;
    urb_rs485_timing_t t;
    urb_rs485_timing(&t, 115200u);
    assert_int_equal(t.char_us, 87u);
    assert_int_equal(t.t15_us, 131u);
    assert_int_equal(t.t35_us, 304u);
    urb_rs485_timing(&t, 1000000u);
    assert_int_equal(t.char_us, 10u);
    assert_int_equal(t.t15_us, 15u);
    assert_int_equal(t.t35_us, 35u);
    assert_int_equal(t.turnaround_us, 90u);
    urb_rs485_timing(&t, 0u);
    assert_int_equal(t.baud, 115200u);
    assert_int_equal(urb_rs485_master_timeout_us(1000000u), 2000u);
    assert_int_equal(urb_rs485_master_timeout_us(115200u), 14366u);
    /* the check's length follows link_check's tiers */
    assert_int_equal(urb_rs485_check_len(1u), 0u);
    assert_int_equal(urb_rs485_check_len(2u), 1u);
    assert_int_equal(urb_rs485_check_len(15u), 1u);
    assert_int_equal(urb_rs485_check_len(16u), 0u);
    assert_int_equal(urb_rs485_check_len(17u), 2u);
    for (uint8_t n = 2u; n <= 36u; n++) {
        uint8_t const cl = urb_rs485_check_len(n);
        if (cl != 0u) {
            assert_int_equal(urb_link_check_size((size_t)(n - cl)), cl);
        }
    }
}

/* Feeds `len` bytes back to back from time t (one character each); returns the time of the last. */
static uint32_t feed(urb_rs485_rx_t *rx, const uint8_t *b, uint8_t len, uint32_t t, uint8_t *ev_or)
{
    for (uint8_t i = 0u; i < len; i++) {
        t += rx->tm.char_us;
        *ev_or = (uint8_t)(*ev_or | urb_rs485_rx_byte(rx, b[i], t));
    }
    return t;
}

static void test_receiver_checks_every_length(void **state)
{
    (void)state;
    urb_rs485_timing_t tm;
    urb_rs485_timing(&tm, 1000000u);
    urb_rs485_rx_t rx;
    urb_rs485_rx_init(&rx, &tm, 0u);
    uint32_t t = 100u;
    for (uint8_t len = 0u; len <= 32u; len++) {
        urb_rs485_request_t q;
        memset(&q, 0, sizeof q);
        q.address = 5u;
        q.select.mailbox = 3u;
        q.data_len = len;
        for (uint8_t i = 0u; i < len; i++) {
            q.data[i] = (uint8_t)(i ^ 0xA7u);
        }
        uint8_t buf[URB_RS485_MAX_FRAME];
        int32_t const n = urb_rs485_request_encode(&q, buf, sizeof buf);
        assert_true(n >= 3);
        for (int flip = -1; flip < n * 8; flip += 13) {
            uint8_t b[URB_RS485_MAX_FRAME];
            memcpy(b, buf, (size_t)n);
            if (flip >= 0) {
                b[flip / 8] ^= (uint8_t)(1u << (flip % 8));
            }
            uint8_t ev = 0u;
            t = feed(&rx, b, (uint8_t)n, t + 100u, &ev);
            assert_int_equal(ev & URB_RS485_EV_START, URB_RS485_EV_START);
            assert_int_equal(urb_rs485_rx_count(&rx), n);
            assert_int_equal(urb_rs485_rx_poll(&rx, t + tm.char_us + tm.t35_us - 1u), 0u); /* not yet */
            assert_int_equal(urb_rs485_rx_poll(&rx, t + tm.char_us + tm.t35_us), URB_RS485_EV_END);
            assert_int_equal(rx.last.n, n);
            assert_int_equal(rx.last.check_ok, flip < 0); /* a one-bit error is always found (HD 4) */
            assert_int_equal(rx.last.head[0], b[0]);
            assert_int_equal(rx.last.head[1], b[1]);
            t += tm.t35_us;
        }
    }
}

static void test_receiver_silences(void **state)
{
    (void)state;
    urb_rs485_timing_t tm;
    urb_rs485_timing(&tm, 1000000u);
    urb_rs485_rx_t rx;
    urb_rs485_rx_init(&rx, &tm, 0u);
    /* start-up: a byte before t3.5 of silence is discarded, with what follows it */
    assert_int_equal(urb_rs485_rx_byte(&rx, 1u, 20u), URB_RS485_EV_BROKEN);
    assert_false(urb_rs485_rx_silent(&rx, 20u + 44u)); /* a character may be on its way */
    assert_true(urb_rs485_rx_silent(&rx, 20u + 45u));
    assert_int_equal(urb_rs485_rx_deadline(&rx), 65u);
    assert_int_equal(urb_rs485_rx_poll(&rx, 65u), 0u); /* a broken frame ends without an event */
    /* a silence of t1.5 inside a frame is allowed, more breaks it */
    uint32_t t = 100u;
    assert_int_equal(urb_rs485_rx_byte(&rx, 1u, t), URB_RS485_EV_START);
    t += tm.char_us + tm.t15_us;
    assert_int_equal(urb_rs485_rx_byte(&rx, 2u, t), URB_RS485_EV_BYTE);
    t += tm.char_us + tm.t15_us + 1u;
    assert_int_equal(urb_rs485_rx_byte(&rx, 3u, t), URB_RS485_EV_BROKEN);
    assert_int_equal(rx.broken, 1u);
    t += tm.char_us + tm.t35_us - 1u;
    assert_int_equal(urb_rs485_rx_byte(&rx, 4u, t), URB_RS485_EV_BROKEN); /* still discarding */
    /* after t3.5 the next byte starts a frame; a byte after t3.5 ends the previous one itself */
    t += tm.char_us + tm.t35_us;
    assert_int_equal(urb_rs485_rx_byte(&rx, 5u, t), URB_RS485_EV_START);
    t += tm.char_us;
    assert_int_equal(urb_rs485_rx_byte(&rx, 6u, t), URB_RS485_EV_BYTE);
    t += tm.char_us + tm.t35_us;
    assert_int_equal(urb_rs485_rx_byte(&rx, 7u, t), URB_RS485_EV_END | URB_RS485_EV_START);
    assert_int_equal(rx.last.n, 2u);
    /* a frame longer than 36 bytes: a babbler */
    uint8_t junk[40];
    memset(junk, 0x55, sizeof junk);
    uint8_t ev = 0u;
    t = feed(&rx, junk, 40u, t + 100u, &ev);
    assert_int_equal(ev & URB_RS485_EV_BROKEN, URB_RS485_EV_BROKEN);
    assert_int_equal(rx.too_long, 1u);
    assert_int_equal(urb_rs485_rx_poll(&rx, t + tm.char_us + tm.t35_us), 0u);
    /* a one-byte frame has no check */
    assert_int_equal(urb_rs485_rx_byte(&rx, 9u, t + 200u), URB_RS485_EV_START);
    assert_int_equal(urb_rs485_rx_poll(&rx, t + 200u + tm.char_us + tm.t35_us), URB_RS485_EV_END);
    assert_false(rx.last.check_ok);
}

/* ===== End to end on an in-memory half-duplex line ============================================= */

typedef struct {
    urb_rs485_hal_t hal;
    bool driving;
    uint32_t delay_after; /* test: pause this long (us) after this many bytes sent (stall) */
    uint8_t delay_at;
    uint8_t sent;
} end_t;

typedef struct {
    end_t bridge, node[2];
    urb_rs485_master_t master;
    urb_downlink_t dl;
    urb_rs485_slave_t slave[2];
    fake_mailbox_t fm[2];
    urb_rs485_timing_t tm;
    uint32_t now;
    uint8_t data[32];
    /* a babbler: drives `babble` bytes from time babble_at */
    uint32_t babble_at;
    uint8_t babble;
    /* corrupt the n-th byte on the line (1-based; 0: none) by xor */
    uint32_t corrupt_nth, line_bytes;
    uint8_t corrupt_xor;
    bool corrupt_at_nodes; /* only the nodes receive the corrupted byte (a receiver-side error) */
} line_t;

static line_t L;
static uint32_t busy_until;
static bool pending;
static uint8_t pending_byte;

static void hal_tx_start(void *ctx)
{
    end_t *e = (end_t *)ctx;
    e->driving = true;
    e->sent = 0u;
}
static void hal_tx_abort(void *ctx)
{
    ((end_t *)ctx)->driving = false;
}
static void hal_wake(void *ctx, uint32_t at)
{
    (void)ctx;
    (void)at; /* the loop polls every microsecond */
}

static void end_init(end_t *e)
{
    memset(e, 0, sizeof *e);
    e->hal.ctx = e;
    e->hal.tx_start = hal_tx_start;
    e->hal.tx_abort = hal_tx_abort;
    e->hal.wake_at = hal_wake;
    e->hal.lock = NULL;
}

static int line_setup(void **state)
{
    (void)state;
    memset(&L, 0, sizeof L);
    urb_rs485_timing(&L.tm, 1000000u);
    end_init(&L.bridge);
    urb_rs485_master_init(&L.master, &L.bridge.hal, 1000000u, 0u);
    urb_rs485_master_downlink(&L.master, &L.dl);
    static const uint8_t in0[8] = {6u, 2u, 32u, 1u, 0u, 0u, 0u, 0u};
    static const uint8_t out0[8] = {25u, 6u, 32u, 0u, 1u, 0u, 0u, 0u};
    for (uint8_t i = 0u; i < 2u; i++) {
        end_init(&L.node[i]);
        fake_mailbox_init(&L.fm[i], in0, out0);
        assert_true(urb_rs485_slave_init(&L.slave[i], &L.node[i].hal, &L.fm[i].ops, (uint8_t)(20u + i), &L.tm, 0u));
    }
    L.babble = 0u;
    busy_until = 0u;
    pending = false;
    return 0;
}

/* One microsecond of the line: a character starts when nothing is on the line and is received by
 * every end (its senders too: the echo) when its stop bit ends, char_us later. */
static bool pull(end_t *e, uint8_t i, uint8_t *b)
{
    if (e == &L.bridge) {
        return urb_rs485_master_tx_next(&L.master, b);
    }
    return urb_rs485_slave_tx_next(&L.slave[i], b);
}

static void line_tick(void)
{
    L.now++;
    if (pending && (L.now == busy_until)) {
        pending = false;
        bool const hit = L.line_bytes == L.corrupt_nth;
        uint8_t const at_bridge = (hit && !L.corrupt_at_nodes) ? (uint8_t)(pending_byte ^ L.corrupt_xor) : pending_byte;
        uint8_t const at_nodes = hit ? (uint8_t)(pending_byte ^ L.corrupt_xor) : pending_byte;
        urb_rs485_master_rx(&L.master, at_bridge, L.now);
        for (uint8_t i = 0u; i < 2u; i++) {
            urb_rs485_slave_rx(&L.slave[i], at_nodes, L.now);
        }
    }
    for (uint8_t i = 0u; i < 2u; i++) {
        urb_rs485_slave_poll(&L.slave[i], L.now);
    }
    if ((int32_t)(L.now - busy_until) < 0) {
        return;
    }
    uint8_t combined = 0xFFu;
    bool any = false;
    end_t *ends[3] = {&L.bridge, &L.node[0], &L.node[1]};
    for (uint8_t k = 0u; k < 3u; k++) {
        end_t *e = ends[k];
        if (!e->driving) {
            continue;
        }
        if ((e->delay_after != 0u) && (e->sent == e->delay_at)) {
            e->delay_at = 0xFFu;
            busy_until = L.now + e->delay_after;
            return;
        }
        uint8_t b;
        if (!pull(e, (uint8_t)(k == 0u ? 0u : k - 1u), &b)) {
            e->driving = false;
            continue;
        }
        e->sent++;
        combined &= b;
        any = true;
    }
    if ((L.babble > 0u) && ((int32_t)(L.now - L.babble_at) >= 0)) {
        combined &= 0x5Au;
        L.babble--;
        any = true;
    }
    if (!any) {
        return;
    }
    L.line_bytes++;
    busy_until = L.now + L.tm.char_us;
    pending = true;
    pending_byte = combined;
}

static int run(uint8_t op, uint8_t address, uint8_t mailbox, uint8_t length)
{
    urb_downlink_txn_t t = {op, address, mailbox, length, 0x37u, false, L.data};
    assert_true(L.dl.begin(L.dl.ctx, &t, L.now));
    assert_false(L.dl.begin(L.dl.ctx, &t, L.now));
    for (int i = 0; i < 200000; i++) {
        line_tick();
        int8_t const r = L.dl.poll(L.dl.ctx, L.now);
        if (r != URB_DOWNLINK_BUSY) {
            assert_int_equal(L.dl.poll(L.dl.ctx, L.now), URB_DOWNLINK_IDLE);
            /* the rest of the line's activity (an answer still going out), then silence */
            for (int k = 0; k < 1000; k++) {
                line_tick();
                (void)L.dl.poll(L.dl.ctx, L.now);
            }
            return r;
        }
    }
    fail_msg("the transaction never ended");
    return -100;
}

static void test_write_read(void **state)
{
    (void)state;
    for (uint8_t i = 0u; i < 32u; i++) {
        L.data[i] = (uint8_t)(i + 100u);
    }
    assert_int_equal(run(URB_DL_WRITE, 20u, 2u, 32u), URB_STATUS_OK);
    assert_memory_equal(L.fm[0].inbox[2], L.data, 32u);
    assert_int_equal(run(URB_DL_WRITE, 20u, 3u, 1u), URB_STATUS_OK); /* the shortest write */
    assert_int_equal(L.fm[0].inbox[3][0], 100u);
    assert_int_equal(run(URB_DL_WRITE, 21u, 0u, 6u), URB_STATUS_OK);
    assert_int_equal(L.fm[1].commits[0], 1u);
    memset(L.data, 0, sizeof L.data);
    assert_int_equal(run(URB_DL_READ, 20u, 2u, 32u), URB_STATUS_OK);
    assert_memory_equal(L.data, L.fm[0].outbox[2], 32u);
    assert_int_equal(run(URB_DL_READ, 21u, 4u, 1u), URB_STATUS_OK);
    assert_int_equal(L.data[0], L.fm[1].outbox[4][0]);
    assert_int_equal(run(URB_DL_READ, 21u, 0u, 25u), URB_STATUS_OK);
    assert_int_equal(L.fm[1].reads_complete[0], 1u);
    assert_false(L.fm[1].latched[0]);
    assert_int_equal(L.fm[0].rule_violations + L.fm[1].rule_violations, 0u);
    assert_int_equal(fake_mailbox_commits(&L.fm[0]), 2u);
    urb_rs485_master_stats_t st;
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.collisions + st.babble + st.bad + st.broken, 0u);
}

static void test_refusals_probe_silence(void **state)
{
    (void)state;
    assert_int_equal(run(URB_DL_READ, 20u, 3u, 4u), URB_STATUS_BAD_REQUEST);
    assert_int_equal(run(URB_DL_WRITE, 20u, 4u, 4u), URB_STATUS_BAD_REQUEST);
    assert_int_equal(run(URB_DL_READ, 20u, 1u, 5u), URB_STATUS_SIZE_MISMATCH);
    assert_int_equal(run(URB_DL_WRITE, 20u, 1u, 3u), URB_STATUS_SIZE_MISMATCH);
    L.fm[0].app_holds[1] = true;
    assert_int_equal(run(URB_DL_WRITE, 20u, 1u, 2u), URB_STATUS_NODE_BUSY);
    assert_int_equal(L.fm[0].faults[URB_DL_FAULT_OVERRUN], 1u);
    L.fm[0].app_holds[1] = false;
    assert_int_equal(run(URB_DL_PROBE, 21u, 0u, 0u), URB_STATUS_OK);
    assert_int_equal(L.fm[1].commits[0] + L.fm[1].aborts[0] + L.fm[1].refusals[0], 0u); /* untouched */
    assert_int_equal(run(URB_DL_PROBE, 22u, 0u, 0u), URB_STATUS_NO_NODE);
    assert_int_equal(run(URB_DL_READ, 99u, 1u, 6u), URB_STATUS_NO_NODE);
    assert_int_equal(fake_mailbox_commits(&L.fm[0]), 0u);
    assert_int_equal(L.fm[0].rule_violations, 0u);
    urb_rs485_master_stats_t st;
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.silences, 2u);
}

static void test_sync(void **state)
{
    (void)state;
    assert_int_equal(run(URB_DL_SYNC, 0u, 0u, 0u), URB_STATUS_OK);
    for (uint8_t i = 0u; i < 2u; i++) {
        assert_int_equal(L.fm[i].syncs, 1u);
        assert_int_equal(L.fm[i].sync_counter, 0x37u);
    }
    assert_int_equal(L.fm[0].sync_t, L.fm[1].sync_t);
}

/* A request corrupted on the line: the node answers CHECKSUM (its check failed) and stores
 * nothing; the answer corrupted: the bridge says CHECKSUM. */
static void test_corruption(void **state)
{
    (void)state;
    L.corrupt_nth = L.line_bytes + 4u; /* a data byte of the request, as the nodes receive it */
    L.corrupt_xor = 0x01u;
    L.corrupt_at_nodes = true;
    assert_int_equal(run(URB_DL_WRITE, 20u, 1u, 2u), URB_STATUS_CHECKSUM);
    assert_int_equal(L.fm[0].commits[1], 0u);
    assert_int_equal(L.fm[0].faults[URB_DL_FAULT_CHECKSUM], 1u);
    L.corrupt_at_nodes = false;
    L.corrupt_nth = L.line_bytes + 3u + 2u; /* the answer's second data byte */
    assert_int_equal(run(URB_DL_READ, 20u, 1u, 6u), URB_STATUS_CHECKSUM);
    /* a write's answer garbled: the node stored it, so not CHECKSUM but TIMEOUT (Rs485Poll.tla) */
    L.corrupt_nth = L.line_bytes + 5u + 1u; /* the answer's header */
    assert_int_equal(run(URB_DL_WRITE, 20u, 1u, 2u), URB_STATUS_TIMEOUT);
    assert_int_equal(L.fm[0].commits[1], 1u);
    assert_int_equal(L.fm[0].rule_violations, 0u);
}

/* A babbler talks over the request: the echo differs, the bridge stops and the request is not
 * executed (BUS_STUCK); bytes while nobody was polled are counted; a line never silent keeps the
 * bridge from sending (BUS_STUCK after the timeout); CLEAR waits for silence. */
static void test_collision_and_babble(void **state)
{
    (void)state;
    memset(L.data, 0xFF, sizeof L.data);
    L.babble_at = L.now + 60u; /* during the request's third byte (sent from t3.5 on) */
    L.babble = 1u;
    assert_int_equal(run(URB_DL_WRITE, 20u, 2u, 32u), URB_STATUS_BUS_STUCK);
    assert_int_equal(L.fm[0].commits[2], 0u);
    urb_rs485_master_stats_t st;
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.collisions, 1u);
    /* babble while idle */
    uint32_t const before = st.babble;
    L.babble_at = L.now + 1u;
    L.babble = 3u;
    for (int k = 0; k < 100; k++) {
        line_tick();
    }
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.babble, before + 3u);
    /* a line that never goes quiet */
    L.babble_at = L.now;
    L.babble = 255u;
    for (int k = 0; k < 20; k++) {
        line_tick(); /* the babbler is talking when the request comes */
    }
    assert_int_equal(run(URB_DL_READ, 20u, 1u, 6u), URB_STATUS_BUS_STUCK);
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.busy_line, 1u);
    L.babble = 0u;
    for (int k = 0; k < 100; k++) {
        line_tick();
    }
    assert_int_equal(run(URB_DL_CLEAR, 0u, 0u, 0u), URB_STATUS_OK);
    assert_int_equal(run(URB_DL_READ, 20u, 1u, 6u), URB_STATUS_OK);
    assert_int_equal(L.fm[0].rule_violations, 0u);
}

/* A node that stalls inside its answer (a silence over t1.5): TIMEOUT. */
static void test_stalled_answer(void **state)
{
    (void)state;
    L.node[0].delay_at = 3u;
    L.node[0].delay_after = 30u;
    assert_int_equal(run(URB_DL_READ, 20u, 2u, 32u), URB_STATUS_TIMEOUT);
    urb_rs485_master_stats_t st;
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.broken, 1u);
    /* the outbox was released when the answer was all out */
    assert_false(L.fm[0].latched[2]);
}

/* ===== The slave alone: a read's latch when its answer does not finish ======================= */

typedef struct {
    urb_rs485_hal_t hal;
    uint32_t tx_starts;
} lone_port_t;

static void lone_tx_start(void *ctx)
{
    ((lone_port_t *)ctx)->tx_starts++;
}

/* Encodes a request to node 20 and feeds it to *s byte by byte from time t (one character each),
 * then polls at its t3.5 end; returns that time. */
static uint32_t lone_request(urb_rs485_slave_t *s, bool read, uint8_t mailbox, uint8_t data_len, uint32_t t)
{
    urb_rs485_request_t q;
    memset(&q, 0, sizeof q);
    q.address = 20u;
    q.select.mailbox = mailbox;
    q.select.read = read;
    q.data_len = data_len;
    uint8_t buf[URB_RS485_MAX_FRAME];
    int32_t const n = urb_rs485_request_encode(&q, buf, sizeof buf);
    assert_true(n >= 3);
    for (int32_t i = 0; i < n; i++) {
        t += s->rx.tm.char_us;
        urb_rs485_slave_rx(s, buf[i], t);
    }
    t += s->rx.tm.char_us + s->rx.tm.t35_us;
    urb_rs485_slave_poll(s, t);
    return t;
}

/* The port takes `count` bytes of the answer and the node hears their echo; then it stops (the
 * UART stalled, or the driver lost the line): the answer is cut. Returns the last echo's time. */
static uint32_t lone_send(urb_rs485_slave_t *s, uint8_t count, uint32_t t)
{
    for (uint8_t i = 0u; i < count; i++) {
        uint8_t b;
        assert_true(urb_rs485_slave_tx_next(s, &b));
        t += s->rx.tm.char_us;
        urb_rs485_slave_rx(s, b, t);
    }
    return t;
}

/* A read's answer cut after its header, then (the bridge timed out and moved on) another request
 * to the node: the first read must end (cut) before anything else is begun: read_begin and
 * read_end pair up per outbox (urb_dl_slave.h: a read is begun and ended exactly once), for a
 * second read of the same outbox, of another outbox, and a write after the cut read. */
static void test_slave_read_latch_released_when_answer_cut(void **state)
{
    (void)state;
    static const uint8_t in0[8] = {6u, 2u, 32u, 1u, 0u, 0u, 0u, 0u};
    static const uint8_t out0[8] = {25u, 6u, 32u, 0u, 1u, 0u, 0u, 0u};
    lone_port_t port;
    memset(&port, 0, sizeof port);
    port.hal.ctx = &port;
    port.hal.tx_start = lone_tx_start;
    port.hal.wake_at = hal_wake;
    fake_mailbox_t fm;
    fake_mailbox_init(&fm, in0, out0);
    urb_rs485_timing_t tm;
    urb_rs485_timing(&tm, 1000000u);
    urb_rs485_slave_t s;
    assert_true(urb_rs485_slave_init(&s, &port.hal, &fm.ops, 20u, &tm, 0u));
    uint32_t t = 100u;
    /* a read of outbox 2 answered, its answer cut after 2 bytes; the bridge then reads it again */
    t = lone_request(&s, true, 2u, 0u, t);
    assert_int_equal(fm.reads_begun[2], 1u);
    t = lone_send(&s, 2u, t) + 3000u;
    t = lone_request(&s, true, 2u, 0u, t);
    assert_int_equal(fm.rule_violations, 0u); /* not begun while latched */
    assert_int_equal(fm.reads_begun[2], 2u);
    assert_int_equal(fm.reads_cut[2], 1u); /* the cut answer ended, not complete */
    (void)lone_send(&s, 1u + 32u + 2u, t);
    assert_false(urb_rs485_slave_sending(&s));
    assert_int_equal(fm.reads_complete[2], 1u);
    assert_false(fm.latched[2]);
    /* cut again, then a read of another outbox: outbox 2 must not stay latched */
    t = lone_request(&s, true, 2u, 0u, t + 3000u);
    t = lone_send(&s, 1u, t) + 3000u;
    t = lone_request(&s, true, 0u, 0u, t);
    t = lone_send(&s, 1u + 25u + 2u, t);
    assert_false(fm.latched[2]);
    assert_false(fm.latched[0]);
    assert_int_equal(fm.reads_cut[2], 2u);
    assert_int_equal(fm.reads_complete[0], 1u);
    /* cut once more, then a write: its answer's end must not report the old read complete */
    t = lone_request(&s, true, 2u, 0u, t + 3000u);
    t = lone_send(&s, 1u, t) + 3000u;
    t = lone_request(&s, false, 1u, 2u, t);
    (void)lone_send(&s, 2u, t); /* the write's answer: header and CRC-8 */
    assert_int_equal(fm.commits[1], 1u);
    assert_false(fm.latched[2]);
    assert_int_equal(fm.reads_complete[2], 1u);
    assert_int_equal(fm.reads_cut[2], 3u);
    assert_int_equal(fm.rule_violations, 0u);
    assert_int_equal(port.tx_starts, 6u); /* every request answered */
}

static void test_slave_init_refuses(void **state)
{
    (void)state;
    urb_rs485_slave_t s;
    assert_false(urb_rs485_slave_init(&s, &L.node[0].hal, &L.fm[0].ops, 0u, &L.tm, 0u));
    assert_false(urb_rs485_slave_init(&s, &L.node[0].hal, &L.fm[0].ops, 128u, &L.tm, 0u));
    urb_rs485_hal_t h = L.node[0].hal;
    h.wake_at = NULL;
    assert_false(urb_rs485_slave_init(&s, &h, &L.fm[0].ops, 5u, &L.tm, 0u));
    assert_true(urb_rs485_slave_init(&s, &L.node[0].hal, &L.fm[0].ops, 127u, &L.tm, 0u));
}

/* ===== Paths the end-to-end tests above do not take (make coverage lists them) ================= */

/* The link check appended to the `covered` bytes in buf (CRC-8 low tier, CRC-16 little-endian):
 * the frame's length. */
static uint8_t seal(uint8_t *buf, uint8_t covered)
{
    uint32_t const c = urb_link_check(buf, covered, NULL, 0u);
    size_t const size = urb_link_check_size(covered);
    buf[covered] = (uint8_t)(c & 0xFFu);
    if (size == 2u) {
        buf[covered + 1u] = (uint8_t)(c >> 8);
    }
    return (uint8_t)(covered + size);
}

/* The bridge alone, driven byte by byte at 1 Mbaud (a character 10 us, t1.5 15 us, t3.5 35 us). */
static uint32_t mt;

static void master_begin_at(uint8_t op, uint8_t address, uint8_t mailbox, uint8_t length)
{
    urb_downlink_txn_t t = {op, address, mailbox, length, 0x37u, false, L.data};
    mt += 1000u; /* after a silence */
    assert_true(L.dl.begin(L.dl.ctx, &t, mt));
    assert_int_equal(L.master.phase, 2u); /* sending */
}

/* Pulls the request and hands each byte back as its echo (`count` of them); returns the bytes. */
static uint8_t master_echo(uint8_t *sent, uint8_t count)
{
    uint8_t n = 0u;
    while ((n < count) && urb_rs485_master_tx_next(&L.master, &sent[n])) {
        mt += 10u;
        urb_rs485_master_rx(&L.master, sent[n], mt);
        n++;
    }
    return n;
}

/* The whole request echoed and ended by silence: the node's turn. */
static void master_request_out(void)
{
    uint8_t sent[URB_RS485_MAX_FRAME];
    (void)master_echo(sent, URB_RS485_MAX_FRAME);
    mt += 50u;
    assert_int_equal(L.dl.poll(L.dl.ctx, mt), URB_DOWNLINK_BUSY);
    assert_int_equal(L.master.phase, 4u); /* waiting for the answer */
}

/* An answer frame on the line, then the silence that ends it; returns the poll's outcome. */
static int master_answer(const uint8_t *a, uint8_t n)
{
    for (uint8_t i = 0u; i < n; i++) {
        mt += 10u;
        urb_rs485_master_rx(&L.master, a[i], mt);
    }
    mt += 50u;
    return L.dl.poll(L.dl.ctx, mt);
}

static int answered(uint8_t op, uint8_t status, uint8_t mailbox, uint8_t data_len)
{
    master_begin_at(op, 20u, mailbox, (op == URB_DL_WRITE) ? 2u : data_len);
    master_request_out();
    urb_rs485_response_t r;
    memset(&r, 0, sizeof r);
    r.status = status;
    r.mailbox = mailbox;
    r.data_len = data_len;
    uint8_t a[URB_RS485_MAX_FRAME];
    int32_t const n = urb_rs485_response_encode(&r, a, sizeof a);
    assert_true(n > 0);
    return master_answer(a, (uint8_t)n);
}

static void test_master_answers(void **state)
{
    (void)state;
    mt = 0u;
    /* the refusals a node sends come through; a status no node sends is garbled */
    static const uint8_t refusals[4] = {URB_STATUS_NODE_BUSY, URB_STATUS_CHECKSUM, URB_STATUS_SIZE_MISMATCH,
                                        URB_STATUS_BAD_REQUEST};
    for (uint8_t i = 0u; i < 4u; i++) {
        assert_int_equal(answered(URB_DL_WRITE, refusals[i], 1u, 0u), refusals[i]);
    }
    urb_rs485_master_stats_t st;
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.bad, 0u);
    assert_int_equal(answered(URB_DL_WRITE, URB_STATUS_BUSY, 1u, 0u), URB_STATUS_TIMEOUT);
    /* OK with data to a write: not an answer a node sends; the write may be stored: TIMEOUT */
    assert_int_equal(answered(URB_DL_WRITE, URB_STATUS_OK, 1u, 3u), URB_STATUS_TIMEOUT);
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.bad, 2u);
    /* a frame whose check passes and that is no response (its response bit clear): garbled */
    master_begin_at(URB_DL_READ, 20u, 1u, 6u);
    master_request_out();
    uint8_t a[4] = {(uint8_t)(0x10u | URB_STATUS_OK), 0u, 0u, 0u};
    assert_int_equal(master_answer(a, seal(a, 1u)), URB_STATUS_CHECKSUM);
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.bad, 3u);
    /* an answer longer than any frame: a babbler, garbled */
    master_begin_at(URB_DL_READ, 20u, 1u, 6u);
    master_request_out();
    uint8_t junk[40];
    memset(junk, 0x81, sizeof junk);
    assert_int_equal(master_answer(junk, 40u), URB_STATUS_CHECKSUM);
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.bad, 4u);
    assert_int_equal(st.broken, 0u);
}

/* A collision cuts the request after its n-th byte: the cut frame reaches no node unless what the
 * line carried is a frame whose check passes (then the node's check decides: TIMEOUT). With
 * CRC-16 (17 bytes and more) both check bytes must match; a 16-byte cut has no check at all. */
static int cut_at(uint8_t n, int lo_ok, int hi_ok)
{
    urb_rs485_request_t q;
    memset(&q, 0, sizeof q);
    q.address = 20u;
    q.select.mailbox = 2u;
    q.data_len = 32u;
    for (uint8_t i = 0u; i < 32u; i++) {
        q.data[i] = (uint8_t)(i * 11u + 3u);
        L.data[i] = q.data[i];
    }
    uint8_t frame[URB_RS485_MAX_FRAME + 2u];
    assert_true(urb_rs485_request_encode(&q, frame, sizeof frame) > 0);
    uint8_t last = (uint8_t)~frame[n - 1u]; /* a byte other than the one sent */
    if (n >= 17u) {
        /* data[k] is frame byte k + 2: the cut frame's check bytes are frame[n - 2] and `last` */
        uint32_t const c = urb_link_check(frame, (size_t)n - 2u, NULL, 0u);
        L.data[n - 4u] = (uint8_t)(lo_ok ? (c & 0xFFu) : ((c & 0xFFu) ^ 1u));
        if (hi_ok) {
            last = (uint8_t)(c >> 8);
            if (last == frame[n - 1u]) {
                L.data[n - 3u] = (uint8_t)~last; /* the sent byte differs from the line's */
            }
        }
    }
    master_begin_at(URB_DL_WRITE, 20u, 2u, 32u);
    uint8_t sent[URB_RS485_MAX_FRAME];
    assert_int_equal(master_echo(sent, (uint8_t)(n - 1u)), n - 1u);
    uint8_t b;
    assert_true(urb_rs485_master_tx_next(&L.master, &b));
    assert_true(b != last);
    mt += 10u;
    urb_rs485_master_rx(&L.master, last, mt); /* the collision */
    assert_false(L.bridge.driving);
    mt += 50u;
    return L.dl.poll(L.dl.ctx, mt);
}

static void test_master_collisions(void **state)
{
    (void)state;
    mt = 0u;
    L.bridge.driving = true;
    assert_int_equal(cut_at(16u, 0, 0), URB_STATUS_BUS_STUCK); /* no check: no frame */
    L.bridge.driving = true;
    assert_int_equal(cut_at(20u, 0, 1), URB_STATUS_BUS_STUCK); /* first check byte wrong */
    L.bridge.driving = true;
    assert_int_equal(cut_at(20u, 1, 0), URB_STATUS_BUS_STUCK); /* second check byte wrong */
    L.bridge.driving = true;
    /* both right: a 20-byte frame a node would take; the bridge sees its frame end short */
    assert_int_equal(cut_at(20u, 1, 1), URB_STATUS_TIMEOUT);
    urb_rs485_master_stats_t st;
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.collisions, 4u); /* one each: a cut that passes drains, its frame not counted again */
    /* the echo right but broken by a silence over t1.5 inside the frame: a collision too */
    master_begin_at(URB_DL_READ, 20u, 1u, 6u);
    uint8_t b0, b1;
    assert_true(urb_rs485_master_tx_next(&L.master, &b0));
    mt += 10u;
    urb_rs485_master_rx(&L.master, b0, mt);
    assert_true(urb_rs485_master_tx_next(&L.master, &b1));
    mt += 10u + 16u;
    urb_rs485_master_rx(&L.master, b1, mt);
    /* the receiver discards a broken frame without an end event: the drain ends at t3.5 of
     * silence all the same, not at the transaction's timeout (issue #39) */
    mt += 44u;
    assert_int_equal(L.dl.poll(L.dl.ctx, mt), URB_DOWNLINK_BUSY);
    mt += 1u;
    assert_int_equal(L.dl.poll(L.dl.ctx, mt), URB_STATUS_BUS_STUCK);
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.collisions, 5u);
}

/* The cut frame's verdict as the master computed it before issue #39's fix: the link check
 * recomputed over the cut bytes (up to 33 CRC steps inside the byte's interrupt). The master now
 * finishes the receiver's running CRCs in at most two steps; its verdict must be this one. */
static bool cut_passes_recomputed(const uint8_t *buf, uint8_t n, uint8_t last)
{
    uint8_t const cl = urb_rs485_check_len(n);
    if ((n < 3u) || (cl == 0u)) {
        return false;
    }
    uint32_t const c = urb_link_check(buf, (size_t)n - (size_t)cl, NULL, 0u);
    if (cl == 1u) {
        return (uint8_t)c == last;
    }
    return ((uint8_t)c == buf[n - 2u]) && ((uint8_t)(c >> 8) == last);
}

/* A write of `len` bytes cut after its n-th byte, `last` on the line in its slot, right after the
 * previous byte or after a silence over t1.5 (the frame breaks); returns the master's `cut`
 * (true: the cut frame reaches nobody) and checks it against the recomputed verdict. */
static bool cut_verdict(uint8_t len, uint8_t n, uint8_t last, bool breaks, uint8_t *passes)
{
    master_begin_at(URB_DL_WRITE, 20u, 2u, len);
    uint8_t sent[URB_RS485_MAX_FRAME];
    assert_int_equal(master_echo(sent, (uint8_t)(n - 1u)), n - 1u);
    uint8_t b;
    assert_true(urb_rs485_master_tx_next(&L.master, &b));
    sent[n - 1u] = b;
    uint8_t const n_tx = L.master.n_tx;
    mt += breaks ? 26u : 10u;
    urb_rs485_master_rx(&L.master, last, mt); /* the collision */
    assert_false(L.bridge.driving);
    bool const ok = cut_passes_recomputed(sent, n, last);
    *passes = (uint8_t)(*passes + ((ok && (n < n_tx)) ? 1u : 0u));
    bool const cut = L.master.cut;
    /* the last byte: cut only when it broke the frame (nobody takes a broken frame) */
    assert_int_equal(cut, (n < n_tx) ? !ok : breaks);
    int out = URB_DOWNLINK_BUSY; /* back to idle */
    for (uint32_t i = 0u; (i < 40u) && (out == URB_DOWNLINK_BUSY); i++) {
        mt += 100u;
        out = L.dl.poll(L.dl.ctx, mt);
    }
    /* a collision on the last byte (unbroken) leaves the node's check to decide: then silence */
    assert_true((out == URB_STATUS_TIMEOUT) || (out == URB_STATUS_BUS_STUCK) ||
                ((out == URB_STATUS_NO_NODE) && (n == n_tx) && !breaks));
    L.bridge.driving = true;
    return cut;
}

/* Every cut position of writes of 1..32 bytes (CRC-8 and CRC-16 requests, the 16-byte cut without
 * a check, the cut on the last byte), the line's byte in the slot making the cut frame pass its
 * check or not, joined or breaking the frame: the master's verdict is the recomputed one. */
static void test_master_cut_verdict(void **state)
{
    (void)state;
    mt = 0u;
    L.bridge.driving = true;
    static const uint8_t lens[6] = {1u, 5u, 11u, 12u, 13u, 32u};
    uint8_t passes[2][2] = {{0u, 0u}, {0u, 0u}}; /* [CRC-16][breaks] */
    for (uint8_t li = 0u; li < 6u; li++) {
        uint8_t const len = lens[li];
        uint8_t const n_tx = (uint8_t)(len + ((len <= 12u) ? 3u : 4u));
        for (uint8_t n = 1u; n <= n_tx; n++) {
            for (uint8_t tune = 0u; tune < 2u; tune++) {
                urb_rs485_request_t q;
                memset(&q, 0, sizeof q);
                q.address = 20u;
                q.select.mailbox = 2u;
                q.data_len = len;
                for (uint8_t i = 0u; i < 32u; i++) {
                    q.data[i] = (uint8_t)(i * 29u + len);
                }
                uint8_t req[URB_RS485_MAX_FRAME + 2u];
                assert_int_equal(urb_rs485_request_encode(&q, req, sizeof req), n_tx);
                if ((tune != 0u) && (n >= 6u) && ((uint8_t)(n - 4u) < len)) {
                    /* the data byte before the slot is the check's low byte: a CRC-16 cut passes */
                    q.data[n - 4u] = (uint8_t)urb_link_check(req, (size_t)n - 2u, NULL, 0u);
                    assert_int_equal(urb_rs485_request_encode(&q, req, sizeof req), n_tx);
                }
                memcpy(L.data, q.data, sizeof q.data);
                uint8_t const cl = urb_rs485_check_len(n);
                uint32_t const c = urb_link_check(req, (size_t)n - ((cl == 2u) ? 2u : 1u), NULL, 0u);
                uint8_t const good = (uint8_t)((cl == 2u) ? (c >> 8) : c); /* the passing byte */
                uint8_t const lasts[3] = {good, (uint8_t)~good, (uint8_t)(good ^ 0x5Au)};
                for (uint8_t bi = 0u; bi < 2u; bi++) {
                    for (uint8_t j = 0u; j < 3u; j++) {
                        if (((bi == 0u) || (n == 1u)) && (lasts[j] == req[n - 1u])) {
                            continue; /* the byte sent, unbroken (a first byte breaks nothing): its echo */
                        }
                        (void)cut_verdict(len, n, lasts[j], bi != 0u, &passes[cl == 2u][bi]);
                    }
                }
            }
        }
    }
    /* not vacuous: cut frames that pass, with each tier, the last byte joined or breaking */
    assert_true(passes[0][0] > 0u);
    assert_true(passes[0][1] > 0u);
    assert_true(passes[1][0] > 0u);
    assert_true(passes[1][1] > 0u);
}

/* A cut frame that passes its check, then the other talker's byte brings the line's frame to the
 * request's length: the request never went out whole, so neither the node's silence (NO_NODE)
 * nor its answer may be reported as the request's (found by fw_rs485_master PART=1,OP=1 after the
 * issue #39 fix: the master took the passing cut for a collision on the last byte and waited for
 * the node's turn when the frame ended with the request's length). */
static int cut_passes_then_joined(bool answer)
{
    L.data[0] = 0x55u;
    master_begin_at(URB_DL_WRITE, 20u, 2u, 1u); /* 4 bytes: 20, 2, 0x55, check */
    uint8_t sent[URB_RS485_MAX_FRAME];
    assert_int_equal(master_echo(sent, 2u), 2u);
    uint8_t b;
    assert_true(urb_rs485_master_tx_next(&L.master, &b));
    uint8_t const x = (uint8_t)urb_link_check(sent, 2u, NULL, 0u); /* [20, 2, x] passes */
    assert_true(x != b);
    mt += 10u;
    urb_rs485_master_rx(&L.master, x, mt);
    assert_false(L.bridge.driving);
    mt += 10u;
    urb_rs485_master_rx(&L.master, 0x99u, mt); /* the other talker: 4 bytes on the line */
    mt += 50u;
    int out = L.dl.poll(L.dl.ctx, mt);
    if (answer && (out == URB_DOWNLINK_BUSY)) {
        urb_rs485_response_t r; /* the node's OK to a write of mailbox 2 */
        memset(&r, 0, sizeof r);
        r.status = URB_STATUS_OK;
        r.mailbox = 2u;
        uint8_t a[URB_RS485_MAX_FRAME];
        int32_t const an = urb_rs485_response_encode(&r, a, sizeof a);
        assert_true(an > 0);
        out = master_answer(a, (uint8_t)an);
    }
    for (uint32_t i = 0u; (i < 40u) && (out == URB_DOWNLINK_BUSY); i++) {
        mt += 100u;
        out = L.dl.poll(L.dl.ctx, mt);
    }
    return out;
}

static void test_master_cut_passes_then_joined(void **state)
{
    (void)state;
    mt = 0u;
    L.bridge.driving = true;
    assert_int_equal(cut_passes_then_joined(false), URB_STATUS_TIMEOUT);
    L.bridge.driving = true;
    assert_int_equal(cut_passes_then_joined(true), URB_STATUS_TIMEOUT);
}

/* A collision cuts a write, and the other talker goes on: the frame the line carried is the cut
 * request and the bytes that joined it. When that frame's check passes, a node may have taken it
 * (here a 1-byte write of the collided byte): TIMEOUT, never BUS_STUCK (found by fw_rs485_master,
 * 2026-11-29: the bridge judged the cut frame alone). When it fails, BUS_STUCK as before. */
static int cut_then_joined(bool joined_passes)
{
    L.data[0] = 0x55u;
    L.data[1] = 0x66u;
    master_begin_at(URB_DL_WRITE, 20u, 2u, 2u);
    uint8_t sent[URB_RS485_MAX_FRAME];
    assert_int_equal(master_echo(sent, 2u), 2u);
    uint8_t b;
    assert_true(urb_rs485_master_tx_next(&L.master, &b));
    uint8_t line[4] = {sent[0], sent[1], 0u, 0u};
    uint8_t const cut_check = (uint8_t)urb_link_check(line, 2u, NULL, 0u);
    line[2] = (uint8_t)(b ^ 0x0Fu); /* the collision: neither the byte sent ... */
    if (line[2] == cut_check) {
        line[2] ^= 0x30u; /* ... nor the check that would make the cut frame pass */
    }
    mt += 10u;
    urb_rs485_master_rx(&L.master, line[2], mt);
    assert_false(L.bridge.driving);
    uint8_t const joined_check = (uint8_t)urb_link_check(line, 3u, NULL, 0u);
    line[3] = joined_passes ? joined_check : (uint8_t)(joined_check ^ 1u);
    mt += 10u;
    urb_rs485_master_rx(&L.master, line[3], mt); /* the other talker's next byte */
    mt += 50u;
    return L.dl.poll(L.dl.ctx, mt);
}

static void test_master_cut_then_joined(void **state)
{
    (void)state;
    mt = 0u;
    L.bridge.driving = true;
    assert_int_equal(cut_then_joined(true), URB_STATUS_TIMEOUT);
    L.bridge.driving = true;
    assert_int_equal(cut_then_joined(false), URB_STATUS_BUS_STUCK);
}

/* The request's frame breaks on or after its last byte: a byte after a silence over t1.5 and before
 * its t3.5 end (`how` 0: after the last echo; 1: the last echo itself comes late), or another
 * talker's bytes joining until the frame is longer than any (2). Every receiver discards a broken
 * frame (without an end event), so no node took the request: BUS_STUCK. Then another talker's
 * frame of the request's length (`line_n` bytes, the last making its check fail or pass) ends with
 * no poll in the silence before it: the master took it for the request's end, waited for the node's
 * turn and reported its silence NO_NODE (a SYNC: OK), for a request no node received (issue #39,
 * fw_rs485_master's "Found, not fixed" of 2026-11-30, outside its one byte after the request). */
static int broken_after_sent(uint8_t op, uint8_t how, bool line_passes)
{
    L.data[0] = 0x55u;
    if (op == URB_DL_SYNC) {
        master_begin_at(URB_DL_SYNC, 0u, 0u, 0u); /* 3 bytes: 0, counter, check */
    } else {
        master_begin_at(URB_DL_WRITE, 20u, 2u, 1u); /* 4 bytes: 20, 2, 0x55, check */
    }
    uint8_t const n_tx = L.master.n_tx;
    uint8_t sent[URB_RS485_MAX_FRAME];
    assert_int_equal(master_echo(sent, (uint8_t)(n_tx - 1u)), n_tx - 1u);
    assert_true(urb_rs485_master_tx_next(&L.master, &sent[n_tx - 1u]));
    mt += (how == 1u) ? 30u : 10u; /* 30: a silence of 20 us (over t1.5, 15) before the last echo */
    urb_rs485_master_rx(&L.master, sent[n_tx - 1u], mt);
    if (how == 0u) {
        mt += 30u;
        urb_rs485_master_rx(&L.master, 0xA5u, mt); /* the byte that breaks the request's frame */
    } else if (how == 2u) {
        for (uint8_t i = n_tx; i <= URB_RS485_MAX_FRAME; i++) {
            mt += 10u;
            urb_rs485_master_rx(&L.master, 0xA5u, mt); /* joins it, and the 37th byte breaks it */
        }
    } else {
        /* the late last echo broke it */
    }
    /* another talker's frame of the request's length, after t3.5 of silence (no poll in it) */
    uint8_t line[URB_RS485_MAX_FRAME] = {0x21u, 0x02u, 0x33u, 0u};
    uint8_t const c = (uint8_t)urb_link_check(line, (size_t)n_tx - 1u, NULL, 0u);
    line[n_tx - 1u] = line_passes ? c : (uint8_t)(c ^ 1u);
    mt += 10u + 40u;
    for (uint8_t i = 0u; i < n_tx; i++) {
        urb_rs485_master_rx(&L.master, line[i], mt);
        mt += 10u;
    }
    int out = URB_DOWNLINK_BUSY;
    for (uint32_t i = 0u; (i < 40u) && (out == URB_DOWNLINK_BUSY); i++) {
        mt += 50u;
        out = L.dl.poll(L.dl.ctx, mt);
    }
    L.bridge.driving = true;
    return out;
}

static void test_master_broken_after_sent(void **state)
{
    (void)state;
    mt = 0u;
    L.bridge.driving = true;
    urb_rs485_master_stats_t st;
    for (uint8_t how = 0u; how < 3u; how++) {
        /* the other talker's frame fails its check: it is no frame, and the request reached nobody */
        assert_int_equal(broken_after_sent(URB_DL_WRITE, how, false), URB_STATUS_BUS_STUCK);
        assert_int_equal(broken_after_sent(URB_DL_SYNC, how, false), URB_STATUS_BUS_STUCK);
        /* it passes its check: the drain takes it for what a node may have stored (TIMEOUT, which
         * claims nothing), never for the request's end */
        assert_int_equal(broken_after_sent(URB_DL_WRITE, how, true), URB_STATUS_TIMEOUT);
    }
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.collisions, 9u); /* one per transaction */
    assert_int_equal(st.silences, 0u);
    /* a poll in the silence after the break ends the drain there: BUS_STUCK */
    L.data[0] = 0x55u;
    master_begin_at(URB_DL_WRITE, 20u, 2u, 1u);
    uint8_t sent[URB_RS485_MAX_FRAME];
    assert_int_equal(master_echo(sent, URB_RS485_MAX_FRAME), 4u);
    mt += 30u;
    urb_rs485_master_rx(&L.master, 0xA5u, mt);
    assert_int_equal(L.dl.poll(L.dl.ctx, mt + 44u), URB_DOWNLINK_BUSY);
    assert_int_equal(L.dl.poll(L.dl.ctx, mt + 45u), URB_STATUS_BUS_STUCK);
    /* a byte that joins the request's frame (within t1.5) is a longer frame, not a break: its end
     * is the request's end with bytes joined, TIMEOUT as before */
    L.bridge.driving = true;
    master_begin_at(URB_DL_WRITE, 20u, 2u, 1u);
    assert_int_equal(master_echo(sent, URB_RS485_MAX_FRAME), 4u);
    mt += 10u;
    urb_rs485_master_rx(&L.master, 0xA5u, mt);
    mt += 50u;
    assert_int_equal(L.dl.poll(L.dl.ctx, mt), URB_STATUS_TIMEOUT);
}

/* The UART stalls for t3.5 inside the request: the line carried a shorter frame that ended. When
 * its check passes (a write's data byte equal to the check of the bytes before it) a node may have
 * taken it: the bridge stops and reports TIMEOUT (found by fw_rs485_master, 2026-11-29); when it
 * fails, the frame reached nobody: BUS_STUCK. */
static int split_by_stall(bool short_passes)
{
    uint8_t head[2] = {20u, 2u};
    uint8_t const c = (uint8_t)urb_link_check(head, 2u, NULL, 0u);
    L.data[0] = short_passes ? c : (uint8_t)(c ^ 1u); /* [20, 2, data0]: its check passes or not */
    L.data[1] = 0x66u;
    master_begin_at(URB_DL_WRITE, 20u, 2u, 2u);
    uint8_t sent[URB_RS485_MAX_FRAME];
    assert_int_equal(master_echo(sent, 3u), 3u);
    uint8_t b;
    assert_true(urb_rs485_master_tx_next(&L.master, &b));
    mt += 60u; /* the stall: the 3-byte frame ended */
    urb_rs485_master_rx(&L.master, b, mt);
    assert_false(L.bridge.driving);
    mt += 50u;
    return L.dl.poll(L.dl.ctx, mt);
}

static void test_master_request_split_by_stall(void **state)
{
    (void)state;
    uint8_t b;
    mt = 0u;
    L.bridge.driving = true;
    assert_int_equal(split_by_stall(true), URB_STATUS_TIMEOUT);
    L.bridge.driving = true;
    assert_int_equal(split_by_stall(false), URB_STATUS_BUS_STUCK);
    /* a babbler's frame still open when the request starts ends at the first echo: it is not the
     * request's, which goes on whole (then the node's silence: NO_NODE) */
    L.bridge.driving = true;
    mt += 1000u;
    urb_rs485_master_rx(&L.master, 0x42u, mt);
    L.data[0] = 0x55u;
    master_begin_at(URB_DL_WRITE, 20u, 2u, 2u);
    uint8_t sent[URB_RS485_MAX_FRAME];
    assert_int_equal(master_echo(sent, URB_RS485_MAX_FRAME), 5u);
    assert_true(L.bridge.driving);
    mt += 50u;
    assert_int_equal(L.dl.poll(L.dl.ctx, mt), URB_DOWNLINK_BUSY);
    mt += 200u;
    assert_int_equal(L.dl.poll(L.dl.ctx, mt), URB_STATUS_NO_NODE);
    /* a SYNC whose last echo comes after a silence over t1.5: a collision on its last byte that
     * broke its frame (without an end event): it reached no node, and the drain ends at t3.5 of
     * silence: BUS_STUCK (TIMEOUT before issue #39's fix for frames broken on the last byte) */
    L.bridge.driving = true;
    master_begin_at(URB_DL_SYNC, 0u, 0u, 0u);
    assert_int_equal(master_echo(sent, 2u), 2u);
    assert_true(urb_rs485_master_tx_next(&L.master, &b));
    mt += 26u;
    urb_rs485_master_rx(&L.master, b, mt);
    assert_false(L.bridge.driving);
    assert_int_equal(L.dl.poll(L.dl.ctx, mt + 44u), URB_DOWNLINK_BUSY);
    assert_int_equal(L.dl.poll(L.dl.ctx, mt + 45u), URB_STATUS_BUS_STUCK);
}

/* After a collision the other talker never stops: its bytes come with gaps over t1.5 (each breaks
 * the frame, which the receiver drops without an end event) and under t3.5 (the line never
 * quiet), so the drain ends only at the transaction's timeout. A request cut before a frame a node
 * could take reached nobody: BUS_STUCK; a collision on the last byte (the whole request was on the
 * line) may have reached a node: TIMEOUT. */
static int drain_never_quiet(bool cut)
{
    uint8_t sent[URB_RS485_MAX_FRAME];
    uint8_t b;
    uint32_t t_begin;
    if (cut) {
        L.data[0] = 0x55u;
        L.data[1] = 0x66u;
        master_begin_at(URB_DL_WRITE, 20u, 2u, 2u);
        t_begin = mt;
        assert_int_equal(master_echo(sent, 1u), 1u);
    } else {
        master_begin_at(URB_DL_SYNC, 0u, 0u, 0u);
        t_begin = mt;
        assert_int_equal(master_echo(sent, 2u), 2u);
    }
    assert_true(urb_rs485_master_tx_next(&L.master, &b));
    mt += 10u;
    urb_rs485_master_rx(&L.master, (uint8_t)(b ^ 0x0Fu), mt); /* the collision */
    assert_false(L.bridge.driving);
    uint32_t const end = mt + L.master.timeout_us + 100u;
    int out = URB_DOWNLINK_BUSY;
    while ((out == URB_DOWNLINK_BUSY) && (mt < end)) {
        mt += 25u;
        urb_rs485_master_rx(&L.master, 0x5Au, mt); /* the other talker goes on */
        out = L.dl.poll(L.dl.ctx, mt);
    }
    assert_true(mt - t_begin > L.master.timeout_us); /* it ended at the timeout, not before */
    return out;
}

static void test_master_drain_never_quiet(void **state)
{
    (void)state;
    mt = 0u;
    L.bridge.driving = true;
    assert_int_equal(drain_never_quiet(true), URB_STATUS_BUS_STUCK);
    L.bridge.driving = true;
    assert_int_equal(drain_never_quiet(false), URB_STATUS_TIMEOUT);
}

typedef struct {
    uint32_t locks, unlocks;
    bool held;
} rs_lock_t;

static rs_lock_t rs_lock;

static void rs_hal_lock(void *ctx, bool locked)
{
    (void)ctx;
    assert_true(rs_lock.held != locked); /* never nested */
    if (locked) {
        rs_lock.locks++;
    } else {
        rs_lock.unlocks++;
    }
    rs_lock.held = locked;
}

static void test_master_edges(void **state)
{
    (void)state;
    mt = 0u;
    /* the HAL's optional lock: taken and released around every main-loop step */
    memset(&rs_lock, 0, sizeof rs_lock);
    L.bridge.hal.lock = rs_hal_lock;
    assert_false(urb_rs485_master_busy(&L.master));
    assert_int_equal(run(URB_DL_READ, 20u, 1u, 6u), URB_STATUS_OK);
    assert_true(rs_lock.locks > 2u);
    assert_int_equal(rs_lock.locks, rs_lock.unlocks);
    L.bridge.hal.lock = NULL;
    mt = L.now;
    /* a request to address 0 goes to address 1 (0 is the broadcast); nothing more to pull at the end */
    master_begin_at(URB_DL_READ, 0u, 1u, 6u);
    assert_true(urb_rs485_master_busy(&L.master));
    uint8_t sent[URB_RS485_MAX_FRAME];
    uint8_t const n = master_echo(sent, URB_RS485_MAX_FRAME);
    assert_int_equal(sent[0], 1u);
    assert_int_equal(n, 3u);
    uint8_t b;
    assert_false(urb_rs485_master_tx_next(&L.master, &b));
    /* node 1 answers, and a byte right after the answer's end reaches the bridge before its poll */
    mt += 50u;
    assert_int_equal(L.dl.poll(L.dl.ctx, mt), URB_DOWNLINK_BUSY);
    urb_rs485_response_t r = {URB_STATUS_OK, 1u, {1u, 2u, 3u, 4u, 5u, 6u}, 6u};
    uint8_t a[URB_RS485_MAX_FRAME];
    int32_t const an = urb_rs485_response_encode(&r, a, sizeof a);
    for (int32_t i = 0; i < an; i++) {
        mt += 10u;
        urb_rs485_master_rx(&L.master, a[i], mt);
    }
    mt += 50u;
    urb_rs485_master_rx(&L.master, 0x55u, mt); /* ends the answer: outcome ready, heard as babble */
    assert_false(urb_rs485_master_busy(&L.master));
    urb_rs485_master_stats_t st;
    urb_rs485_master_stats(&L.master, &st);
    assert_int_equal(st.babble, 1u);
    assert_int_equal(L.dl.poll(L.dl.ctx, mt), URB_STATUS_OK);
    assert_memory_equal(L.data, r.data, 6u);
    /* a transceiver that never echoes: every byte pulled, none more; the request times out and
     * the line is let go */
    master_begin_at(URB_DL_READ, 20u, 1u, 6u);
    assert_true(L.bridge.driving);
    for (uint8_t i = 0u; i < 3u; i++) {
        assert_true(urb_rs485_master_tx_next(&L.master, &b));
    }
    assert_false(urb_rs485_master_tx_next(&L.master, &b));
    assert_int_equal(L.dl.poll(L.dl.ctx, mt + L.master.timeout_us + 1u), URB_STATUS_TIMEOUT);
    assert_false(L.bridge.driving);
    mt += L.master.timeout_us + 1u;
    /* a SYNC cut at its last byte and a line that stays busy past the timeout: TIMEOUT (the cut
     * frame was whole up to its check: not BUS_STUCK) */
    master_begin_at(URB_DL_SYNC, 0u, 0u, 0u);
    assert_int_equal(master_echo(sent, 2u), 2u);
    assert_true(urb_rs485_master_tx_next(&L.master, &b));
    mt += 10u;
    urb_rs485_master_rx(&L.master, (uint8_t)~b, mt);
    uint32_t const begun = mt - 30u;
    while ((uint32_t)(mt - begun) <= L.master.timeout_us) {
        mt += 10u;
        urb_rs485_master_rx(&L.master, 0x5Au, mt);
    }
    assert_int_equal(L.dl.poll(L.dl.ctx, mt), URB_STATUS_TIMEOUT);
}

/* The node alone, fed byte by byte at 1 Mbaud. */
static void node_frame(urb_rs485_slave_t *s, const uint8_t *b, uint8_t n, uint32_t *t)
{
    *t += 100u;
    for (uint8_t i = 0u; i < n; i++) {
        *t += 10u;
        urb_rs485_slave_rx(s, b[i], *t);
    }
}

/* The answer the node started: its status (pulled from the slave, decoded). */
static uint8_t node_answer_status(urb_rs485_slave_t *s)
{
    uint8_t a[URB_RS485_MAX_FRAME];
    uint8_t n = 0u;
    while ((n < sizeof a) && urb_rs485_slave_tx_next(s, &a[n])) {
        n++;
    }
    urb_rs485_response_t r;
    assert_true(urb_rs485_response_decode(&r, a, n) > 0);
    return r.status;
}

static void test_slave_edges(void **state)
{
    (void)state;
    urb_rs485_slave_t *s = &L.slave[0];
    uint32_t t = 1000u;
    /* reserved select bits: BAD_REQUEST */
    uint8_t req[8] = {20u, 0x08u | 1u, 0u, 0u, 0u, 0u, 0u, 0u};
    node_frame(s, req, seal(req, 2u), &t);
    assert_false(urb_rs485_slave_sending(s));
    urb_rs485_slave_poll(s, t + 50u);
    assert_true(urb_rs485_slave_sending(s));
    assert_int_equal(node_answer_status(s), URB_STATUS_BAD_REQUEST);
    assert_false(urb_rs485_slave_sending(s));
    /* a read with data: BAD_REQUEST, the outbox not latched */
    uint8_t rd[8] = {20u, 0x80u | 1u, 7u, 0u, 0u, 0u, 0u, 0u};
    node_frame(s, rd, seal(rd, 3u), &t);
    urb_rs485_slave_poll(s, t + 50u);
    assert_int_equal(node_answer_status(s), URB_STATUS_BAD_REQUEST);
    assert_int_equal(L.fm[0].reads_begun[1], 0u);
    /* a write whose frame the port ends late (by the next frame's first byte, no poll between):
     * dropped unanswered, the write aborted */
    uint8_t wr[8] = {20u, 1u, 0xAAu, 0xBBu, 0u, 0u, 0u, 0u};
    node_frame(s, wr, seal(wr, 4u), &t);
    assert_true(L.fm[0].writing[1]);
    t += 100u;
    urb_rs485_slave_rx(s, 99u, t); /* another node's frame begins */
    assert_false(urb_rs485_slave_sending(s));
    assert_false(L.fm[0].writing[1]);
    assert_int_equal(L.fm[0].commits[1], 0u);
    assert_int_equal(L.fm[0].aborts[1], 1u);
    urb_rs485_slave_stats_t ss;
    urb_rs485_slave_stats(s, &ss);
    assert_int_equal(ss.answered, 2u);
    /* no fault hook: a bad check is answered and counted, no fault reported */
    urb_dl_mailbox_t ops = L.fm[0].ops;
    ops.fault = NULL;
    urb_rs485_slave_t quiet;
    assert_true(urb_rs485_slave_init(&quiet, &L.node[0].hal, &ops, 20u, &L.tm, t));
    uint8_t bad[8] = {20u, 1u, 1u, 2u, 0u, 0u, 0u, 0u};
    uint8_t const bn = seal(bad, 4u);
    bad[bn - 1u] ^= 1u;
    node_frame(&quiet, bad, bn, &t);
    urb_rs485_slave_poll(&quiet, t + 50u);
    assert_int_equal(node_answer_status(&quiet), URB_STATUS_CHECKSUM);
    urb_rs485_slave_stats(&quiet, &ss);
    assert_int_equal(ss.bad_check, 1u);
    assert_int_equal(L.fm[0].faults[URB_DL_FAULT_CHECKSUM], 0u);
    assert_int_equal(L.fm[0].rule_violations, 0u);
}

static void test_slave_init_each_entry_point(void **state)
{
    (void)state;
    urb_rs485_slave_t s;
    assert_false(urb_rs485_slave_init(NULL, &L.node[0].hal, &L.fm[0].ops, 5u, &L.tm, 0u));
    assert_false(urb_rs485_slave_init(&s, NULL, &L.fm[0].ops, 5u, &L.tm, 0u));
    assert_false(urb_rs485_slave_init(&s, &L.node[0].hal, NULL, 5u, &L.tm, 0u));
    assert_false(urb_rs485_slave_init(&s, &L.node[0].hal, &L.fm[0].ops, 5u, NULL, 0u));
    urb_rs485_hal_t h = L.node[0].hal;
    h.tx_start = NULL;
    assert_false(urb_rs485_slave_init(&s, &h, &L.fm[0].ops, 5u, &L.tm, 0u));
    for (int k = 0; k < FAKE_MAILBOX_OPS; k++) {
        urb_dl_mailbox_t ops = fake_mailbox_ops_without(&L.fm[0], k);
        assert_false(urb_rs485_slave_init(&s, &L.node[0].hal, &ops, 5u, &L.tm, 0u));
    }
    urb_dl_mailbox_t ops = L.fm[0].ops;
    ops.fault = NULL; /* optional */
    assert_true(urb_rs485_slave_init(&s, &L.node[0].hal, &ops, 5u, &L.tm, 0u));
}

/* The generated RS485 codecs' refusals the line tests never provoke: members out of range and the
 * schema's rules (a read carries no data; only a successful read answer does) on encode. */
static void test_codec_refusals(void **state)
{
    (void)state;
    uint8_t buf[URB_RS485_MAX_FRAME];
    urb_rs485_request_t q;
    memset(&q, 0, sizeof q);
    q.address = 0u;
    assert_int_equal(urb_rs485_request_encode(&q, buf, sizeof buf), URB_ERR_RANGE);
    q.address = 128u;
    assert_int_equal(urb_rs485_request_encode(&q, buf, sizeof buf), URB_ERR_RANGE);
    q.address = 5u;
    q.select.mailbox = 8u;
    assert_int_equal(urb_rs485_request_encode(&q, buf, sizeof buf), URB_ERR_RANGE);
    q.select.mailbox = 1u;
    q.data_len = 33u;
    assert_int_equal(urb_rs485_request_encode(&q, buf, sizeof buf), URB_ERR_RANGE);
    q.data_len = 1u;
    q.select.read = true; /* a read with data */
    assert_int_equal(urb_rs485_request_encode(&q, buf, sizeof buf), URB_ERR_RANGE);
    q.data_len = 0u;
    assert_int_equal(urb_rs485_request_encode(&q, buf, sizeof buf), 3);
    urb_rs485_response_t r;
    memset(&r, 0, sizeof r);
    r.status = 9u; /* not a status */
    assert_int_equal(urb_rs485_response_encode(&r, buf, sizeof buf), URB_ERR_RANGE);
    r.status = URB_STATUS_OK;
    r.mailbox = 8u;
    assert_int_equal(urb_rs485_response_encode(&r, buf, sizeof buf), URB_ERR_RANGE);
    r.mailbox = 1u;
    r.data_len = 33u;
    assert_int_equal(urb_rs485_response_encode(&r, buf, sizeof buf), URB_ERR_RANGE);
    r.status = URB_STATUS_CHECKSUM; /* a refusal with data */
    r.data_len = 1u;
    assert_int_equal(urb_rs485_response_encode(&r, buf, sizeof buf), URB_ERR_RANGE);
    r.data_len = 0u;
    assert_int_equal(urb_rs485_response_encode(&r, buf, sizeof buf), 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_timing),
        cmocka_unit_test(test_receiver_checks_every_length),
        cmocka_unit_test(test_receiver_silences),
        cmocka_unit_test_setup(test_write_read, line_setup),
        cmocka_unit_test_setup(test_refusals_probe_silence, line_setup),
        cmocka_unit_test_setup(test_sync, line_setup),
        cmocka_unit_test_setup(test_corruption, line_setup),
        cmocka_unit_test_setup(test_collision_and_babble, line_setup),
        cmocka_unit_test_setup(test_stalled_answer, line_setup),
        cmocka_unit_test_setup(test_slave_init_refuses, line_setup),
        cmocka_unit_test(test_slave_read_latch_released_when_answer_cut),
        cmocka_unit_test_setup(test_master_answers, line_setup),
        cmocka_unit_test_setup(test_master_collisions, line_setup),
        cmocka_unit_test_setup(test_master_cut_verdict, line_setup),
        cmocka_unit_test_setup(test_master_cut_then_joined, line_setup),
        cmocka_unit_test_setup(test_master_cut_passes_then_joined, line_setup),
        cmocka_unit_test_setup(test_master_broken_after_sent, line_setup),
        cmocka_unit_test_setup(test_master_request_split_by_stall, line_setup),
        cmocka_unit_test_setup(test_master_drain_never_quiet, line_setup),
        cmocka_unit_test_setup(test_master_edges, line_setup),
        cmocka_unit_test_setup(test_slave_edges, line_setup),
        cmocka_unit_test_setup(test_slave_init_each_entry_point, line_setup),
        cmocka_unit_test(test_codec_refusals),
    };
    return cmocka_run_group_tests_name("rs485", tests, NULL, NULL);
}
