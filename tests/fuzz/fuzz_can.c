/*
 * libFuzzer target: the CAN downlink's receive paths (tests/fuzz/README.md). A bridge master and two
 * node slaves (urb_can_master.h, urb_can_slave.h) on the in-memory bus (tests/firmware/can/can_bus.h)
 * with fake mailboxes; the input is a script of operations: a write, read, probe or SYNC run to its
 * outcome, an arbitrary frame delivered to everybody (any identifier, length and bytes), faults of
 * the next frames (error frame, end-of-frame repeat, a receiver losing it, taken from the script),
 * the application holding an inbox, bus-off of the bridge or a node, time passing.
 * Oracles: sanitizers; the mailbox calling rules (begin, then one commit or abort; read begin, then
 * one end); every transaction ends within its timeout with a status the contract names; an OK read
 * returns the outbox, an OK write leaves the inbox holding the data written; in a transaction with no
 * injected frame, a write reported CHECKSUM, NODE_BUSY, SIZE_MISMATCH, BAD_REQUEST or BUS_STUCK stored
 * nothing (Bridge.tla WriteStatusTruthful). NO_NODE is not in that list: it means no frame of the
 * answer came, and the bridge's controller may have lost the answer of a write the node stored (the
 * fuzzer found this at once); the bridge core probes a present node after NO_NODE and answers the
 * host TIMEOUT when the probe is answered (bridge.c served/probed), so the host is not told a lie.
 */
/* lobster-trace: urb.DLK_002, urb.DLK_003, urb.MEM_006 (the requirements this fuzz target verifies) */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "can_bus.h"
#include "fake_mailbox.h"
#include "fuzz_require.h"
#include "urb_can_master.h"
#include "urb_can_slave.h"
#include "urb_core.h"

typedef struct {
    const uint8_t *data;
    size_t size, pos;
} script_t;

static uint8_t next(script_t *s)
{
    return (s->pos < s->size) ? s->data[s->pos++] : 0u;
}

typedef struct {
    can_bus_t bus;
    can_port_t bport, nport[2];
    urb_can_master_t master;
    urb_downlink_t dl;
    urb_can_slave_t slave[2];
    fake_mailbox_t fm[2];
    script_t *script;
    uint8_t faults_left; /* frames whose fault the script decides */
    uint8_t data[32];
} rig_t;

static void m_rx(void *o, const urb_can_frame_t *f, uint32_t t)
{
    (void)t;
    urb_can_master_rx((urb_can_master_t *)o, f);
}
static void m_txd(void *o)
{
    urb_can_master_tx_done((urb_can_master_t *)o);
}
static void s_rx(void *o, const urb_can_frame_t *f, uint32_t t)
{
    urb_can_slave_rx((urb_can_slave_t *)o, f, t);
}
static void s_txd(void *o)
{
    urb_can_slave_tx_done((urb_can_slave_t *)o);
}
static void s_state(void *o, uint8_t st)
{
    urb_can_slave_state((urb_can_slave_t *)o, st);
}

static uint16_t script_fault(void *ctx, const can_port_t *sender, const urb_can_frame_t *f)
{
    rig_t *r = (rig_t *)ctx;
    (void)sender;
    (void)f;
    if (r->faults_left == 0u) {
        return CAN_FAULT_NONE;
    }
    r->faults_left--;
    uint8_t const b = next(r->script);
    switch (b & 3u) {
    case 1u:
        return CAN_FAULT_ERROR;
    case 2u:
        return CAN_FAULT_EOF;
    case 3u:
        return (uint16_t)(1u << ((b >> 2) % r->bus.n));
    default:
        return CAN_FAULT_NONE;
    }
}

static bool valid_status(int8_t st)
{
    return (st == URB_STATUS_OK) || (st == URB_STATUS_TIMEOUT) || (st == URB_STATUS_CHECKSUM) ||
           (st == URB_STATUS_NO_NODE) || (st == URB_STATUS_SIZE_MISMATCH) || (st == URB_STATUS_BAD_REQUEST) ||
           (st == URB_STATUS_BUS_STUCK) || (st == URB_STATUS_NODE_BUSY);
}

/* Runs one transaction to its outcome; it must end within timeout + recovery. */
static int8_t run(rig_t *r, uint8_t op, uint8_t address, uint8_t mailbox, uint8_t length)
{
    urb_downlink_txn_t t = {op, address, mailbox, length, 7u, false, r->data};
    REQUIRE(r->dl.begin(r->dl.ctx, &t, r->bus.now_us));
    uint32_t const t0 = r->bus.now_us;
    for (;;) {
        if (!can_bus_step(&r->bus)) {
            r->bus.now_us += 20u;
        }
        int8_t const st = r->dl.poll(r->dl.ctx, r->bus.now_us);
        if (st != URB_DOWNLINK_BUSY) {
            REQUIRE(valid_status(st));
            return st;
        }
        REQUIRE(r->bus.now_us - t0 <= r->master.cfg.timeout_us + r->master.cfg.recover_us + 2000u);
    }
}

static void settle(rig_t *r, uint32_t us)
{
    uint32_t const end = r->bus.now_us + us;
    while ((int32_t)(r->bus.now_us - end) < 0) {
        if (!can_bus_step(&r->bus)) {
            r->bus.now_us += 20u;
        }
    }
}

static void check_rules(const rig_t *r)
{
    REQUIRE(r->fm[0].rule_violations == 0u);
    REQUIRE(r->fm[1].rule_violations == 0u);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    script_t s = {data, size, 0u};
    rig_t *const r = calloc(1u, sizeof *r);
    REQUIRE(r != NULL);
    r->script = &s;
    can_bus_init(&r->bus, 1000u);
    r->bus.fault = script_fault;
    r->bus.fault_ctx = r;
    urb_can_master_config_t cfg;
    urb_can_master_default_config(&cfg);
    REQUIRE(can_bus_attach(&r->bus, &r->bport, 3u, &r->master, m_rx, m_txd, NULL));
    urb_can_master_init(&r->master, &r->bport.hal, &cfg);
    urb_can_master_downlink(&r->master, &r->dl);
    static const uint8_t in0[8] = {6u, 2u, 32u, 8u, 0u, 7u, 1u, 13u};
    static const uint8_t out0[8] = {25u, 6u, 32u, 0u, 7u, 8u, 1u, 13u};
    for (uint8_t i = 0u; i < 2u; i++) {
        fake_mailbox_init(&r->fm[i], in0, out0);
        REQUIRE(can_bus_attach(&r->bus, &r->nport[i], 3u, &r->slave[i], s_rx, s_txd, s_state));
        REQUIRE(urb_can_slave_init(&r->slave[i], &r->nport[i].hal, &r->fm[i].ops, (uint8_t)(10u + i),
                                   urb_can_slave_dup_window_us(1000u)));
    }
    bool injected = false;
    unsigned ops = 0u;
    while ((s.pos < s.size) && (ops++ < 64u)) {
        uint8_t const op = next(&s);
        uint8_t const a = (uint8_t)(10u + (op >> 7)); /* node 10 or 11; 12: nobody */
        uint8_t const addr = ((op & 0x40u) != 0u) ? 12u : a;
        switch (op & 7u) {
        case 0u:
        case 1u: { /* write or read */
            bool const write = (op & 7u) == 0u;
            uint8_t const m = (uint8_t)(next(&s) & 7u);
            uint8_t const len = (uint8_t)(1u + next(&s) % 32u);
            for (uint8_t i = 0u; i < len; i++) {
                r->data[i] = next(&s);
            }
            uint8_t written[32];
            memcpy(written, r->data, len);
            fake_mailbox_t *fm = (addr == 12u) ? NULL : &r->fm[addr - 10u];
            uint32_t const commits = (fm != NULL) ? fm->commits[m] : 0u;
            r->faults_left = (uint8_t)(next(&s) & 3u);
            int8_t const st = run(r, write ? (uint8_t)URB_DL_WRITE : (uint8_t)URB_DL_READ, addr, m, len);
            if ((st == URB_STATUS_OK) && (fm != NULL)) {
                if (write) {
                    REQUIRE(fm->in_size[m] == len && memcmp(fm->inbox[m], written, len) == 0);
                } else {
                    REQUIRE(fm->out_size[m] == len && memcmp(r->data, fm->outbox[m], len) == 0);
                }
            }
            if (write && (fm != NULL) && !injected && (st != URB_STATUS_OK) && (st != URB_STATUS_TIMEOUT) &&
                (st != URB_STATUS_NO_NODE)) {
                REQUIRE(fm->commits[m] == commits); /* "not stored" is true */
            }
            r->faults_left = 0u;
            injected = false;
            break;
        }
        case 2u: /* probe */
            (void)run(r, URB_DL_PROBE, addr, 0u, 0u);
            break;
        case 3u: /* SYNC */
            (void)run(r, URB_DL_SYNC, 0u, 0u, 0u);
            break;
        case 4u: { /* an arbitrary frame, to every controller but the bridge's own sender */
            urb_can_frame_t f;
            f.id = (uint16_t)((next(&s) | (next(&s) << 8)) & 0x7FFu);
            f.len = (uint8_t)(next(&s) % 9u);
            for (uint8_t i = 0u; i < 8u; i++) {
                f.data[i] = next(&s);
            }
            urb_can_master_rx(&r->master, &f);
            urb_can_slave_rx(&r->slave[0], &f, r->bus.now_us);
            urb_can_slave_rx(&r->slave[1], &f, r->bus.now_us);
            injected = true;
            break;
        }
        case 5u: /* the application holds (or lets go of) an inbox */
            r->fm[op >> 7].app_holds[next(&s) & 7u] = (op & 0x08u) != 0u;
            break;
        case 6u: /* bus-off of the bridge or a node */
            if ((op & 0x08u) != 0u) {
                r->bport.tec = 256u;
                r->bport.state = URB_CAN_BUS_OFF;
            } else {
                r->nport[op >> 7].tec = 256u;
                r->nport[op >> 7].state = URB_CAN_BUS_OFF;
                urb_can_slave_state(&r->slave[op >> 7], URB_CAN_BUS_OFF);
            }
            break;
        default: /* time passes */
            settle(r, 100u * (uint32_t)(next(&s) & 31u));
            break;
        }
        check_rules(r);
    }
    settle(r, 5000u);
    check_rules(r);
    /* nothing stays latched or half-written once the bus is quiet */
    for (uint8_t i = 0u; i < 2u; i++) {
        for (uint8_t m = 0u; m < 8u; m++) {
            REQUIRE(!r->fm[i].latched[m] || urb_can_slave_sending(&r->slave[i]) || r->nport[i].state == URB_CAN_BUS_OFF);
        }
    }
    free(r);
    return 0;
}
