/*
 * Eva environment of the CAN and RS485 downlink state machines (firmware/downlink): a bus-side
 * HAL whose every answer is arbitrary (Frama_C_*_interval), the downlink interface's transactions
 * with arbitrary fields (urb_downlink.h), and the node-side mailbox interface (urb_dl_slave.h)
 * as stubs that keep its documented contract with arbitrary outcomes. Used by
 * proofs/framac/eva_dl_can/main.c and proofs/framac/eva_dl_rs485/main.c, each of which drives every
 * entry point of one downlink's master and slave in an unbounded loop in any order, so Eva's fixpoint
 * covers every sequence of inputs.
 */
#ifndef EVA_DL_ENV_H
#define EVA_DL_ENV_H

#include "__fc_builtin.h"
#include "urb_dl_slave.h"
#include "urb_downlink.h"

/* ===== The bridge side: transactions as the bridge begins them (urb_downlink.h) ============== */

/* The caller's payload buffer: READ writes `length` bytes into it, WRITE reads them from it; the
 * bridge passes at most 32 (a data slot), which both masters clamp `length` to. */
static uint8_t eva_dl_data[32];

/* Begins a transaction of kind `op` (any byte, so unknown kinds too) with arbitrary fields through
 * the downlink interface at an arbitrary time. A READ or WRITE carries a 32-byte buffer; the other
 * kinds no buffer and length 0, as the bridge passes them (bridge.c: every READ/WRITE from a data
 * slot or the scan buffer, SYNC/CLEAR/PROBE with data NULL). */
static bool eva_dl_begin(const urb_downlink_t *dl, uint8_t op)
{
    urb_downlink_txn_t t;
    t.op = op;
    t.address = Frama_C_unsigned_char_interval(0u, 255u);
    t.mailbox = Frama_C_unsigned_char_interval(0u, 255u);
    t.counter = Frama_C_unsigned_char_interval(0u, 255u);
    t.reselect = Frama_C_nondet(0, 1) != 0;
    if ((op == URB_DL_READ) || (op == URB_DL_WRITE)) {
        t.length = Frama_C_unsigned_char_interval(0u, 255u); /* the masters clamp it to 32 */
        t.data = eva_dl_data;
        Frama_C_make_unknown((char *)eva_dl_data, sizeof eva_dl_data);
    } else {
        t.length = 0u;
        t.data = NULL;
    }
    return dl->begin(dl->ctx, &t, Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu));
}

/* ===== The node side: the mailbox interface (urb_dl_slave.h) ================================= */

/* Mailbox sizes as the node library reports them: 0 (not set up) or 1..32 bytes
 * (urb_node_setup_inbox/_outbox refuse larger), fixed once the node runs (eva_dl_mailbox_start).
 * Each buffer holds 32 bytes, so a write_begin/read_begin buffer is valid for its size. */
static uint8_t eva_dl_inbox_size[8];
static uint8_t eva_dl_outbox_size[8];
static uint8_t eva_dl_inbox[8][32];
static uint8_t eva_dl_outbox[8][32];

static uint8_t eva_dl_inbox_size_of(void *ctx, uint8_t m)
{
    (void)ctx;
    return (m < 8u) ? eva_dl_inbox_size[m] : 0u;
}

static uint8_t eva_dl_outbox_size_of(void *ctx, uint8_t m)
{
    (void)ctx;
    return (m < 8u) ? eva_dl_outbox_size[m] : 0u;
}

/* Each stub asserts that the slave passes a mailbox number 0..7 (its indexes are masked to 3 bits);
 * an assertion Eva cannot prove is an alarm of this file. The exactly-once calling rules
 * (urb_dl_slave.h) are ESBMC's (proofs/bmc/fw_rs485_slave; for the CAN slave proofs/bmc/wip/fw_can_slave, in progress), not this unit's.
 *
 * IsrWriteBegin: the inbox's free buffer, or NULL when both are in use (arbitrary). Called only for
 * a set-up inbox (the slaves check inbox_size first). */
static uint8_t *eva_dl_write_begin(void *ctx, uint8_t m)
{
    (void)ctx;
    //@ assert eva_dl_rule: m < 8;
    if (Frama_C_nondet(0, 1) != 0) {
        return NULL;
    }
    Frama_C_make_unknown((char *)eva_dl_inbox[m], sizeof eva_dl_inbox[m]);
    return eva_dl_inbox[m];
}

static void eva_dl_write_commit(void *ctx, uint8_t m)
{
    (void)ctx;
    //@ assert eva_dl_rule: m < 8;
}

static void eva_dl_write_abort(void *ctx, uint8_t m)
{
    (void)ctx;
    //@ assert eva_dl_rule: m < 8;
}

/* IsrReadBegin: the latest release of a set-up outbox, outbox_size(m) bytes of arbitrary data. */
static const uint8_t *eva_dl_read_begin(void *ctx, uint8_t m)
{
    (void)ctx;
    //@ assert eva_dl_rule: m < 8;
    Frama_C_make_unknown((char *)eva_dl_outbox[m], sizeof eva_dl_outbox[m]);
    return eva_dl_outbox[m];
}

static void eva_dl_read_end(void *ctx, uint8_t m, bool complete)
{
    (void)ctx;
    (void)complete;
    //@ assert eva_dl_rule: m < 8;
}

static void eva_dl_sync(void *ctx, uint32_t t, uint8_t counter)
{
    (void)ctx;
    (void)t;
    (void)counter;
}

static void eva_dl_fault(void *ctx, uint8_t code)
{
    (void)ctx;
    (void)code;
}

static urb_dl_mailbox_t eva_dl_mb;

/* Arbitrary mailbox sizes (0 or 1..32 each), every stub set (fault too, or NULL: both allowed). */
static void eva_dl_mailbox_start(void)
{
    for (uint8_t m = 0u; m < 8u; m++) {
        eva_dl_inbox_size[m] = Frama_C_unsigned_char_interval(0u, 32u);
        eva_dl_outbox_size[m] = Frama_C_unsigned_char_interval(0u, 32u);
            }
    eva_dl_mb.ctx = NULL;
    eva_dl_mb.inbox_size = eva_dl_inbox_size_of;
    eva_dl_mb.outbox_size = eva_dl_outbox_size_of;
    eva_dl_mb.write_begin = eva_dl_write_begin;
    eva_dl_mb.write_commit = eva_dl_write_commit;
    eva_dl_mb.write_abort = eva_dl_write_abort;
    eva_dl_mb.read_begin = eva_dl_read_begin;
    eva_dl_mb.read_end = eva_dl_read_end;
    eva_dl_mb.sync = eva_dl_sync;
    eva_dl_mb.fault = (Frama_C_nondet(0, 1) != 0) ? eva_dl_fault : NULL;
}

#endif /* EVA_DL_ENV_H */
