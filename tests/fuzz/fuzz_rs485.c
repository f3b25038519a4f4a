/*
 * libFuzzer target: the RS485 downlink's receive paths (tests/fuzz/README.md). A bridge master and two
 * node slaves (urb_rs485_master.h, urb_rs485_slave.h) on an in-memory half-duplex line at 1 Mb/s
 * (a character takes 10 us; every end hears every byte, its own included; two drivers at once give
 * the AND of their bytes); the input is a script: writes, reads, probes and SYNCs run to their
 * outcome, arbitrary bytes on the line at arbitrary times (a babbler), a byte corrupted at the
 * nodes or everywhere, a node's answer stalled, the application holding an inbox.
 * Oracles: sanitizers; the mailbox calling rules; every transaction ends within its timeout with a
 * status the contract names; an OK read returns the outbox, an OK write leaves the inbox holding the
 * data; in a transaction with no injected byte, a write reported CHECKSUM, NODE_BUSY, SIZE_MISMATCH,
 * BAD_REQUEST, NO_NODE or BUS_STUCK stored nothing (Rs485Poll.tla StatusTruthful); the receivers
 * never hold more than 36 bytes.
 */
/* lobster-trace: urb.DLK_006, urb.MEM_006 (the requirements this fuzz target verifies) */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fake_mailbox.h"
#include "fuzz_require.h"
#include "urb_core.h"
#include "urb_rs485_master.h"
#include "urb_rs485_slave.h"

typedef struct {
    const uint8_t *data;
    size_t size, pos;
} script_t;

static uint8_t next(script_t *s)
{
    return (s->pos < s->size) ? s->data[s->pos++] : 0u;
}

typedef struct {
    urb_rs485_hal_t hal;
    bool driving;
} end_t;

typedef struct {
    end_t bridge, node[2];
    urb_rs485_master_t master;
    urb_downlink_t dl;
    urb_rs485_slave_t slave[2];
    fake_mailbox_t fm[2];
    uint32_t now, busy_until;
    bool pending;
    uint8_t pending_byte;
    uint8_t junk[64];     /* bytes a babbler puts on the line, back to back */
    uint8_t junk_n;
    uint32_t junk_at;
    uint8_t corrupt_in;   /* corrupt the byte this many characters ahead (0: none) */
    uint8_t corrupt_xor;
    bool corrupt_nodes_only;
    uint8_t stall_node;   /* node index + 1 whose next answer stalls after 2 bytes (0: none) */
    uint8_t data[32];
} rig_t;

static void hal_tx_start(void *ctx)
{
    ((end_t *)ctx)->driving = true;
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
    e->hal.ctx = e;
    e->hal.tx_start = hal_tx_start;
    e->hal.tx_abort = hal_tx_abort;
    e->hal.wake_at = hal_wake;
    e->hal.lock = NULL;
    e->driving = false;
}

static void tick(rig_t *r)
{
    r->now++;
    if (r->pending && (r->now == r->busy_until)) {
        r->pending = false;
        uint8_t b = r->pending_byte;
        uint8_t at_bridge = b;
        if (r->corrupt_in != 0u && --r->corrupt_in == 0u) {
            b ^= r->corrupt_xor;
            at_bridge = r->corrupt_nodes_only ? at_bridge : b;
        }
        urb_rs485_master_rx(&r->master, at_bridge, r->now);
        urb_rs485_slave_rx(&r->slave[0], b, r->now);
        urb_rs485_slave_rx(&r->slave[1], b, r->now);
        REQUIRE(urb_rs485_rx_count(&r->master.rx) <= URB_RS485_MAX_FRAME);
    }
    urb_rs485_slave_poll(&r->slave[0], r->now);
    urb_rs485_slave_poll(&r->slave[1], r->now);
    if ((int32_t)(r->now - r->busy_until) < 0) {
        return;
    }
    uint8_t combined = 0xFFu;
    bool any = false;
    uint8_t b;
    if (r->bridge.driving) {
        if (urb_rs485_master_tx_next(&r->master, &b)) {
            combined &= b;
            any = true;
        } else {
            r->bridge.driving = false;
        }
    }
    for (uint8_t i = 0u; i < 2u; i++) {
        if (!r->node[i].driving) {
            continue;
        }
        if ((r->stall_node == i + 1u) && (r->slave[i].tx_pos == 2u)) {
            r->stall_node = 0u;
            r->busy_until = r->now + 25u; /* a silence over t1.5 inside the answer */
            return;
        }
        if (urb_rs485_slave_tx_next(&r->slave[i], &b)) {
            combined &= b;
            any = true;
        } else {
            r->node[i].driving = false;
        }
    }
    if ((r->junk_n > 0u) && ((int32_t)(r->now - r->junk_at) >= 0)) {
        combined &= r->junk[--r->junk_n];
        any = true;
    }
    if (any) {
        r->busy_until = r->now + 10u;
        r->pending = true;
        r->pending_byte = combined;
    }
}

static bool valid_status(int8_t st)
{
    return (st == URB_STATUS_OK) || (st == URB_STATUS_TIMEOUT) || (st == URB_STATUS_CHECKSUM) ||
           (st == URB_STATUS_NO_NODE) || (st == URB_STATUS_SIZE_MISMATCH) || (st == URB_STATUS_BAD_REQUEST) ||
           (st == URB_STATUS_BUS_STUCK) || (st == URB_STATUS_NODE_BUSY);
}

static int8_t run(rig_t *r, uint8_t op, uint8_t address, uint8_t mailbox, uint8_t length)
{
    urb_downlink_txn_t t = {op, address, mailbox, length, 9u, false, r->data};
    REQUIRE(r->dl.begin(r->dl.ctx, &t, r->now));
    uint32_t const t0 = r->now;
    for (;;) {
        tick(r);
        int8_t const st = r->dl.poll(r->dl.ctx, r->now);
        if (st != URB_DOWNLINK_BUSY) {
            REQUIRE(valid_status(st));
            return st;
        }
        REQUIRE(r->now - t0 <= r->master.timeout_us + 1000u);
    }
}

static void settle(rig_t *r, uint32_t us)
{
    for (uint32_t i = 0u; i < us; i++) {
        tick(r);
        (void)r->dl.poll(r->dl.ctx, r->now);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    script_t s = {data, size, 0u};
    rig_t *const r = calloc(1u, sizeof *r);
    REQUIRE(r != NULL);
    urb_rs485_timing_t tm;
    urb_rs485_timing(&tm, 1000000u);
    end_init(&r->bridge);
    urb_rs485_master_init(&r->master, &r->bridge.hal, 1000000u, 0u);
    urb_rs485_master_downlink(&r->master, &r->dl);
    static const uint8_t in0[8] = {6u, 2u, 32u, 1u, 0u, 7u, 0u, 13u};
    static const uint8_t out0[8] = {25u, 6u, 32u, 0u, 1u, 8u, 0u, 13u};
    for (uint8_t i = 0u; i < 2u; i++) {
        end_init(&r->node[i]);
        fake_mailbox_init(&r->fm[i], in0, out0);
        REQUIRE(urb_rs485_slave_init(&r->slave[i], &r->node[i].hal, &r->fm[i].ops, (uint8_t)(20u + i), &tm, 0u));
    }
    bool injected = false;
    unsigned ops = 0u;
    while ((s.pos < s.size) && (ops++ < 48u)) {
        uint8_t const op = next(&s);
        uint8_t const addr = ((op & 0x40u) != 0u) ? 22u : (uint8_t)(20u + (op >> 7));
        switch (op & 7u) {
        case 0u:
        case 1u: {
            bool const write = (op & 7u) == 0u;
            uint8_t const m = (uint8_t)(next(&s) & 7u);
            uint8_t const len = (uint8_t)(1u + next(&s) % 32u);
            for (uint8_t i = 0u; i < len; i++) {
                r->data[i] = next(&s);
            }
            uint8_t written[32];
            memcpy(written, r->data, len);
            fake_mailbox_t *fm = (addr == 22u) ? NULL : &r->fm[addr - 20u];
            uint32_t const commits = (fm != NULL) ? fm->commits[m] : 0u;
            int8_t const st = run(r, write ? (uint8_t)URB_DL_WRITE : (uint8_t)URB_DL_READ, addr, m, len);
            if ((st == URB_STATUS_OK) && (fm != NULL) && !injected) {
                if (write) {
                    REQUIRE(fm->in_size[m] == len && memcmp(fm->inbox[m], written, len) == 0);
                } else {
                    REQUIRE(fm->out_size[m] == len && memcmp(r->data, fm->outbox[m], len) == 0);
                }
            }
            if (write && (fm != NULL) && !injected && (st != URB_STATUS_OK) && (st != URB_STATUS_TIMEOUT)) {
                REQUIRE(fm->commits[m] == commits);
            }
            settle(r, 200u);
            injected = false;
            break;
        }
        case 2u:
            (void)run(r, URB_DL_PROBE, addr, 0u, 0u);
            break;
        case 3u:
            (void)run(r, URB_DL_SYNC, 0u, 0u, 0u);
            break;
        case 4u: /* a babbler: up to 63 bytes (longer than any frame) from some microseconds on */
            r->junk_n = (uint8_t)(next(&s) & 63u);
            for (uint8_t i = 0u; i < r->junk_n; i++) {
                r->junk[i] = next(&s);
            }
            r->junk_at = r->now + next(&s);
            injected = injected || (r->junk_n > 0u);
            break;
        case 5u: /* corrupt a coming byte, at the nodes or everywhere */
            r->corrupt_in = (uint8_t)(next(&s) & 63u);
            r->corrupt_xor = (uint8_t)(next(&s) | 1u);
            r->corrupt_nodes_only = (op & 0x08u) != 0u;
            break;
        case 6u: /* the application holds an inbox, or a node's next answer stalls */
            if ((op & 0x08u) != 0u) {
                r->stall_node = (uint8_t)(1u + (op >> 7));
            } else {
                r->fm[op >> 7].app_holds[next(&s) & 7u] = (op & 0x10u) != 0u;
            }
            break;
        default:
            settle(r, (uint32_t)next(&s) * 4u);
            break;
        }
        REQUIRE(r->fm[0].rule_violations == 0u && r->fm[1].rule_violations == 0u);
    }
    settle(r, 2000u);
    REQUIRE(r->fm[0].rule_violations == 0u && r->fm[1].rule_violations == 0u);
    free(r);
    return 0;
}
