/*
 * Proof: the CAN downlink master (firmware/downlink/can/urb_can_master.c) against the contract in
 * urb_can_master.h, over every sequence of URB_STEPS events after urb_can_master_init on a struct
 * of arbitrary contents (a caller's stack): begin() of any transaction (read, write, probe, SYNC,
 * clear) to one node, poll() at any later time, a received frame (the awaited answer's identifier
 * or any other, any length 0..8, any bytes), a queued frame reported sent, the controller changing
 * state (error-active, passive, bus-off), and a controller that refuses any queued frame.
 *
 * Properties (the contract):
 *  - one status per transaction: begin() is refused exactly while one runs, poll() says IDLE only
 *    when none runs and gives each transaction exactly one final status, BUSY never past its
 *    deadline (timeout_us after begin(); recover_us for a clear or a recovery);
 *  - only the statuses the contract names for the operation, each for its cause (a reference
 *    reassembler fed the frames of the awaited identifier and transfer id decides): a read OK only
 *    with exactly `length` bytes of a complete answer, copied to `data`; SIZE_MISMATCH, BAD_REQUEST
 *    only from a complete answer of another length or an empty one; a write OK only on an empty
 *    answer and NODE_BUSY, CHECKSUM, SIZE_MISMATCH, BAD_REQUEST only on the node's one-byte refusal
 *    naming it (a write reported failed was refused by the node: it stored nothing); CHECKSUM
 *    (read) only on a failed transfer CRC; NO_NODE only when the request was all sent and no frame
 *    of the answer came; BUS_STUCK only after a bus-off begin() (nothing sent) or a clear whose
 *    recovery did not end; TIMEOUT only late or for a write's garbled answer;
 *  - a bus-off begin() asks for the recovery unless one was asked for within recover_us;
 *  - the request on the bus: every queued frame carries the request's identifier and the transfer
 *    id the (node, session) is at (advancing by one per request), the first one the start bit, a
 *    write's payload in order; SYNC its counter;
 *  - the HAL's rules: the interrupt masked and unmasked in turn, never left masked; no frame
 *    reported sent that was not queued; no byte of `data` past `length` written;
 *  - no out-of-bounds access, overflow or undefined shift (ESBMC's checks); each interrupt entry
 *    (rx, tx_done) within FW_CAN_FRAME_BUDGET, begin() and poll() within
 *    FW_CAN_MASTER_CALL_BUDGET (fw_can_budgets.h).
 * Cover points: every operation begun, every status of the contract reported, a begin() refused, a
 * bus-off begin() with and without a new recovery, a refused queue slot, a stale answer ignored, a
 * second request on the same session.
 *
 * Two parts, each one sweep item per operation (OP=n, urb_dl_op_t; every begin() of a run has it):
 *   PART=1 the request side: begin() (again, any time), poll(), frames reported sent, the
 *          controller's state; no frame received (timeouts, NO_NODE, bus-off, clear, SYNC, the
 *          transfer ids of successive requests, refused transmit slots)
 *   PART=2 the answer side: an error-active controller took the request and reported it sent, then
 *          any received frames and polls, then a poll (the statuses an answer gives, CRC failures,
 *          stale ids)
 * Assumption: a frame of the awaited identifier arrives only after the request was reported sent
 * (the node answers a request it received whole, whose last frame's end the bus reported to both).
 * The CRC step is a cheap linear stand-in (stubs/fw_can_crc_stub.c): the master only carries the
 * reassembler's verdict; fw_can_transfer proves the CRC and the reassembly themselves.
 * Bounds: URB_STEPS events after the first begin(), reads and writes of at most URB_LEN_MAX bytes
 * (a two-frame transfer).
 * Found by writing these properties (fixed in the firmware, kept as the seeded bugs
 * init-leaves-recovering and write-crc-as-checksum): init did not set `recovering` and
 * `recover_t0`, so a bus-off at the first request could be reported BUS_STUCK without any recovery
 * asked for; a write whose answer failed its transfer CRC was reported CHECKSUM ("not stored"),
 * though the node may have stored it (Bridge.tla WriteStatusTruthful): now TIMEOUT.
 */
/* lobster-trace: urb.DLK_001, urb.DLK_002 (the requirements this proof verifies: the fast tier's
 * answer side, a read's answer taken only whole, with the request's transfer id and a good CRC) */
#include "urb_verify.h"

#include "fw_can_budgets.h"
#include "urb_can_master.h"
#include "urb_can_wire.h"
#include "urb_core.h"

URB_PROOF_COST_STORAGE;


#ifndef URB_STEPS
#define URB_STEPS 4
#endif
#ifndef URB_PART
#define URB_PART 1
#endif
#ifndef URB_OP
#define URB_OP 0 /* the operation of every begin() (urb_dl_op_t): one sweep item each */
#endif
#ifndef URB_LEN_MAX
#define URB_LEN_MAX 8u
#endif

/* Cover points are judged over the items of their part (tools/proofs.py --covers), and the items
 * fix the operation at compile time: a point of one operation, or of the request side alone, is
 * compiled only into the items that can reach it, so the fast tier's one item (PART=2,OP=0, the
 * read's answer side) lists only the points a read's answer reaches. */
#if URB_OP == 0
#define COVER_READ(name) URB_COVER(name)
#else
#define COVER_READ(name) ((void)0)
#endif
#if URB_OP == 1
#define COVER_WRITE(name) URB_COVER(name)
#else
#define COVER_WRITE(name) ((void)0)
#endif
#if URB_OP == 2
#define COVER_SYNC(name) URB_COVER(name)
#else
#define COVER_SYNC(name) ((void)0)
#endif
#if URB_OP == 3
#define COVER_CLEAR(name) URB_COVER(name)
#else
#define COVER_CLEAR(name) ((void)0)
#endif
#if URB_OP == 4
#define COVER_PROBE(name) URB_COVER(name)
#else
#define COVER_PROBE(name) ((void)0)
#endif
#if URB_PART == 1
#define COVER_REQUEST_SIDE(name) URB_COVER(name)
#else
#define COVER_REQUEST_SIDE(name) ((void)0)
#endif

#define CAN_SLOTS 3u /* transmit slots of the controller (bxCAN, FDCAN in classic mode) */

/* ----- ghost state: the controller and the contract's bookkeeping ----- */
static bool locked;
static bool tx_always;         /* part 2: the controller takes every frame */
static uint8_t ctrl_state;     /* urb_can_state_t the controller reports */
static uint8_t queued;         /* frames queued, not yet reported sent */
static uint32_t now;
static bool recover_asked;     /* recover() was ever called */
static uint32_t recover_at;    /* when last */
static uint8_t recovers_in_call;

static bool open;              /* a transaction runs (begin() true, no status yet) */
static uint8_t op;
static uint8_t length;
static uint32_t t_begin;
static bool recovery_txn;      /* a clear, or a begin() on a bus-off controller */
static bool busoff_txn;
static uint16_t req_id;
static uint16_t answer_id;
static uint8_t req_tid;
static uint8_t req_frames;     /* frames the request has (urb_can_frames) */
static uint8_t frames_queued;  /* frames of this request the controller took */
static uint8_t frames_sent;    /* of them reported sent */
static uint8_t next_tid[16];   /* the node's sessions */
static uint8_t data[URB_LEN_MAX + 1u]; /* the transaction's buffer and a guard byte */
static uint8_t guard;
static uint8_t payload[URB_LEN_MAX];   /* a write's bytes */
static uint8_t counter;

static urb_can_rx_t ref_rx;    /* reference reassembler of the awaited answer */
static uint8_t ref_out[32];
static bool ref_taken;         /* a frame of the answer was accepted (MORE, DONE or CRC) */
static bool ref_done;          /* the answer completed (DONE) */
static bool ref_crc;           /* the answer completed with a failed CRC */
static uint8_t ref_len;

/* ----- HAL ----- */

static bool hal_tx(void *ctx, const urb_can_frame_t *f)
{
    (void)ctx;
    URB_ASSERT(open && !busoff_txn && (op != (uint8_t)URB_DL_CLEAR), "tx: only a running request is sent");
    URB_ASSERT((f->len >= 1u) && (f->len <= URB_CAN_MTU), "tx: a frame holds 1..8 bytes");
    URB_ASSERT(f->id == req_id, "tx: the request's identifier");
    uint8_t const tail = f->data[f->len - 1u];
    URB_ASSERT((tail & URB_CAN_TAIL_TID) == req_tid, "tx: the session's transfer id");
    URB_ASSERT(((tail & URB_CAN_TAIL_START) != 0u) == (frames_queued == 0u), "tx: the start bit on the first frame");
    if (op == (uint8_t)URB_DL_WRITE) {
        for (uint8_t i = 0u; i < URB_CAN_CHUNK; i++) {
            uint8_t const k = (uint8_t)(7u * frames_queued + i);
            if (((i + 1u) < f->len) && (k < length)) {
                URB_ASSERT(f->data[i] == payload[k], "tx: the write's bytes in order");
            }
        }
    }
    if (op == (uint8_t)URB_DL_SYNC) {
        URB_ASSERT((f->len == 2u) && (f->data[0] == counter), "tx: SYNC carries its counter");
    }
    if (!tx_always && ((queued >= CAN_SLOTS) || URB_NONDET_BOOL())) {
        COVER_REQUEST_SIDE("tx-refused");
        return false;
    }
    URB_COST(FW_HAL_CALL_CYCLES);
    queued++;
    frames_queued++;
    return true;
}

static void hal_tx_abort(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    queued = 0u;
}

static uint8_t hal_state(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    return ctrl_state;
}

static void hal_recover(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    recover_asked = true;
    recover_at = now;
    recovers_in_call++;
}

static void hal_lock(void *ctx, bool l)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(l != locked, "lock: masked and unmasked in turn");
    locked = l;
}

/* ----- the contract's statuses ----- */

static bool write_refusal(uint8_t st)
{
    return (st == URB_STATUS_NODE_BUSY) || (st == URB_STATUS_CHECKSUM) || (st == URB_STATUS_SIZE_MISMATCH) ||
           (st == URB_STATUS_BAD_REQUEST);
}

/* The final status `st` of the running transaction, reported at `now`. */
static void judge(uint8_t st)
{
    if (st == URB_STATUS_BUS_STUCK) {
        COVER_REQUEST_SIDE("status-bus-stuck");
        URB_ASSERT(busoff_txn || (op == (uint8_t)URB_DL_CLEAR), "BUS_STUCK: only after bus-off or a clear");
        return;
    }
    URB_ASSERT(!busoff_txn, "bus-off begin: BUS_STUCK, not executed");
    if (op == (uint8_t)URB_DL_CLEAR) {
        COVER_CLEAR("status-clear-ok");
        URB_ASSERT(st == URB_STATUS_OK, "clear: OK or BUS_STUCK");
        return;
    }
    if (st == URB_STATUS_TIMEOUT) {
        URB_COVER("status-timeout");
        URB_ASSERT(((uint32_t)(now - t_begin) > urb_can_master_timeout_us(1000u)) ||
                       ((op == (uint8_t)URB_DL_WRITE) && (ref_done || ref_crc)),
                   "TIMEOUT: only late, or for a write's garbled answer");
        return;
    }
    if (op == (uint8_t)URB_DL_SYNC) {
        COVER_SYNC("status-sync-ok");
        URB_ASSERT((st == URB_STATUS_OK) && (frames_sent == req_frames), "SYNC: OK once sent");
        return;
    }
    if (st == URB_STATUS_NO_NODE) {
        URB_COVER("status-no-node");
        URB_ASSERT(!ref_taken && (frames_sent == req_frames), "NO_NODE: request sent, no frame of the answer");
        return;
    }
    if ((st == URB_STATUS_CHECKSUM) && ref_crc && (op != (uint8_t)URB_DL_WRITE)) {
        URB_COVER("status-crc");
        return; /* a write's garbled answer is TIMEOUT: the node may have stored it */
    }
    URB_ASSERT(ref_done, "a node's status only from its complete answer");
    if (op == (uint8_t)URB_DL_PROBE) {
        COVER_PROBE("status-probe-ok");
        URB_ASSERT(st == URB_STATUS_OK, "probe: any answer is OK");
        return;
    }
    if (op == (uint8_t)URB_DL_READ) {
        if (st == URB_STATUS_OK) {
            COVER_READ("status-read-ok");
            URB_ASSERT(ref_len == length, "read OK: the answer has length bytes");
            for (uint8_t i = 0u; i < URB_LEN_MAX; i++) {
                if (i < length) {
                    URB_ASSERT(data[i] == ref_out[i], "read OK: data holds the answer");
                }
            }
        } else if (st == URB_STATUS_SIZE_MISMATCH) {
            COVER_READ("status-read-size");
            URB_ASSERT((ref_len != length) && (ref_len != 0u), "read SIZE_MISMATCH: an answer of another length");
        } else {
            COVER_READ("status-read-bad-request");
            URB_ASSERT((st == URB_STATUS_BAD_REQUEST) && (ref_len == 0u), "read: BAD_REQUEST on an empty answer");
        }
        return;
    }
    /* write */
    if (st == URB_STATUS_OK) {
        COVER_WRITE("status-write-ok");
        URB_ASSERT(ref_len == 0u, "write OK: only on an empty answer (stored)");
        return;
    }
    COVER_WRITE("status-write-refused");
    URB_ASSERT(write_refusal(st) && (ref_len == 1u) && ((ref_out[0] & 0x0Fu) == st),
               "write failed: only the node's refusal naming it (nothing stored)");
}

/* ----- events ----- */

static void ev_begin(urb_downlink_t *dl, uint8_t address)
{
    urb_downlink_txn_t t;
    t.op = (uint8_t)URB_OP;
    t.address = address;
    t.mailbox = URB_NONDET_U8();
    URB_ASSUME(t.mailbox <= 7u);
    t.length = URB_NONDET_U8();
    URB_ASSUME((t.length >= 1u) && (t.length <= URB_LEN_MAX));
    t.counter = URB_NONDET_U8();
    t.reselect = false;
    t.data = data;
    bool const was_open = open;
    bool const was_busoff = ctrl_state == (uint8_t)URB_CAN_BUS_OFF;
    bool const was_recover_asked = recover_asked;
    uint32_t const was_recover_at = recover_at;
    if (!was_open) {
        /* the request the contract plans, set before begin() so the HAL stub can check it */
        bool const read = t.op == (uint8_t)URB_DL_READ;
        uint8_t const box = (t.op == (uint8_t)URB_DL_PROBE) ? 0u : t.mailbox;
        uint8_t const s = urb_can_session(box, read);
        op = t.op;
        length = t.length;
        counter = t.counter;
        t_begin = now;
        busoff_txn = was_busoff && (t.op != (uint8_t)URB_DL_CLEAR);
        recovery_txn = was_busoff || (t.op == (uint8_t)URB_DL_CLEAR);
        frames_queued = 0u;
        frames_sent = 0u;
        urb_can_rx_reset(&ref_rx);
        ref_taken = false;
        ref_done = false;
        ref_crc = false;
        ref_len = 0u;
        for (uint8_t i = 0u; i < URB_LEN_MAX; i++) {
            data[i] = URB_NONDET_U8();
            payload[i] = data[i];
        }
        guard = data[URB_LEN_MAX];
        if (t.op == (uint8_t)URB_DL_SYNC) {
            req_id = URB_CAN_SYNC_ID;
            answer_id = 0xFFFFu;
            req_tid = (uint8_t)(t.counter & URB_CAN_TAIL_TID);
            req_frames = 1u;
        } else {
            req_id = urb_can_id(address, box, read, URB_CAN_REQUEST);
            answer_id = urb_can_id(address, box, read, URB_CAN_RESPONSE);
            req_tid = next_tid[s];
            req_frames = urb_can_frames((t.op == (uint8_t)URB_DL_WRITE) ? t.length : 0u);
            if (!recovery_txn) {
                if (next_tid[s] != 0u) {
                    COVER_REQUEST_SIDE("second-request-on-session");
                }
                next_tid[s] = (uint8_t)((next_tid[s] + 1u) & URB_CAN_TAIL_TID);
            }
        }
        open = true; /* before the call: the HAL stub checks the frames begin() queues */
    }
    recovers_in_call = 0u;
    URB_COST_BEGIN();
    bool const ok = dl->begin(dl->ctx, &t, now);
    URB_COST_END(FW_CAN_MASTER_CALL_BUDGET);
    URB_ASSERT(!locked, "begin: the interrupt unmasked on return");
    URB_ASSERT(ok == !was_open, "begin: refused exactly while a transaction runs");
    if (!ok) {
        COVER_REQUEST_SIDE("begin-refused");
        return;
    }
    if (busoff_txn) {
        URB_ASSERT((recovers_in_call > 0u) ||
                       (was_recover_asked && ((uint32_t)(now - was_recover_at) <= urb_can_master_recover_us(1000u))),
                   "bus-off begin: the recovery asked for (unless asked within recover_us)");
        if (recovers_in_call == 0u) {
            COVER_REQUEST_SIDE("busoff-begin-no-new-recovery");
        } else {
            COVER_REQUEST_SIDE("busoff-begin-recovers");
        }
    }
    if (t.op == (uint8_t)URB_DL_READ) {
        COVER_READ("begin-read");
    } else if (t.op == (uint8_t)URB_DL_WRITE) {
        COVER_WRITE("begin-write");
    } else if (t.op == (uint8_t)URB_DL_SYNC) {
        COVER_SYNC("begin-sync");
    } else if (t.op == (uint8_t)URB_DL_CLEAR) {
        COVER_CLEAR("begin-clear");
    } else {
        COVER_PROBE("begin-probe");
    }
}

static void ev_poll(urb_downlink_t *dl)
{
    now += URB_NONDET_U16(); /* any later time (at most 65 ms on) */
    URB_COST_BEGIN();
    int8_t const r = dl->poll(dl->ctx, now);
    URB_COST_END(FW_CAN_MASTER_CALL_BUDGET);
    URB_ASSERT(!locked, "poll: the interrupt unmasked on return");
    if (!open) {
        URB_ASSERT(r == URB_DOWNLINK_IDLE, "poll: IDLE when no transaction runs (one status each)");
        return;
    }
    URB_ASSERT(r != URB_DOWNLINK_IDLE, "poll: a running transaction is not IDLE");
    if (r == URB_DOWNLINK_BUSY) {
        uint32_t const limit = recovery_txn ? urb_can_master_recover_us(1000u) : urb_can_master_timeout_us(1000u);
        URB_ASSERT((uint32_t)(now - t_begin) <= limit, "poll: BUSY only within the timeout");
        return;
    }
    URB_ASSERT((r >= 0) && (r <= (int8_t)URB_STATUS_NODE_BUSY) && (r != (int8_t)URB_STATUS_BUSY),
               "poll: a downlink status");
    judge((uint8_t)r);
    open = false;
}

static void ev_rx(urb_can_master_t *mp)
{
    urb_can_frame_t f;
    f.id = URB_NONDET_BOOL() ? answer_id : (uint16_t)(URB_NONDET_U16() & 0x7FFu);
    f.len = URB_NONDET_U8();
    URB_ASSUME(f.len <= URB_CAN_MTU);
    URB_NONDET_BYTES(f.data, sizeof f.data);
    if (open && (f.id == answer_id)) {
        /* the node answers a request it received whole: the bus reported its last frame sent
         * (at the same end of frame) before the answer's first frame ends */
        URB_ASSUME(frames_sent == req_frames);
    }
    /* the reference: the awaited identifier and transfer id, until the answer completes */
    if (open && !busoff_txn && !ref_done && !ref_crc && (f.id == answer_id) && (f.len > 0u) &&
        ((f.data[f.len - 1u] & URB_CAN_TAIL_TID) == req_tid)) {
        urb_can_rx_result_t const r = urb_can_rx_frame(&ref_rx, f.data, f.len, ref_out, sizeof ref_out);
        if ((r == URB_CAN_RX_MORE) || (r == URB_CAN_RX_DONE) || (r == URB_CAN_RX_CRC)) {
            ref_taken = true;
        }
        if (r == URB_CAN_RX_DONE) {
            ref_done = true;
            ref_len = urb_can_rx_len(&ref_rx);
        }
        if (r == URB_CAN_RX_CRC) {
            ref_crc = true;
        }
    } else if (open && (f.id == answer_id) && (f.len > 0u)) {
        URB_COVER("stale-or-late-answer");
    }
    URB_COST_BEGIN();
    urb_can_master_rx(mp, &f);
    URB_COST_END(FW_CAN_FRAME_BUDGET);
    URB_ASSERT(data[URB_LEN_MAX] == guard, "rx: no byte past the buffer");
    for (uint8_t i = 0u; i < URB_LEN_MAX; i++) {
        if ((i >= length) || (op != (uint8_t)URB_DL_READ)) {
            URB_ASSERT(data[i] == payload[i], "rx: no byte of data past length (none for a write)");
        }
    }
}

static void ev_tx_done(urb_can_master_t *mp)
{
    URB_ASSUME(queued > 0u); /* the controller reports only frames it took */
    queued--;
    if (open) {
        frames_sent++;
    }
    URB_COST_BEGIN();
    urb_can_master_tx_done(mp);
    URB_COST_END(FW_CAN_FRAME_BUDGET);
}

/* A caller's struct holds garbage before init: every scalar member arbitrary. (The transfer-id
 * table starts zero, which is sound because init writes all of it, and lets ESBMC fold init's 1024
 * constant stores instead of carrying them as array updates into every later read.) */
static urb_can_master_t m;
/* the master's arrays in the proof view (stubs/can_master_view.py): the one row of its transfer-id
 * table, of the node at urb_view_tid_address */
uint8_t urb_view_tid_address;
uint8_t urb_view_next_tid[1][16];
uint8_t urb_view_refusal[1];
uint8_t urb_view_sync_payload[1];
urb_can_frame_t urb_view_frame;

static void garbage_before_init(void)
{
    m.op = URB_NONDET_U8();
    m.address = URB_NONDET_U8();
    m.mailbox = URB_NONDET_U8();
    m.length = URB_NONDET_U8();
    m.tid = URB_NONDET_U8();
    m.expect_id = URB_NONDET_U16();
    m.frames_total = URB_NONDET_U8();
    m.frames_sent = URB_NONDET_U8();
    m.clear_result = URB_NONDET_U8();
    m.frame_ready = URB_NONDET_BOOL();
    m.answered = URB_NONDET_BOOL();
    m.t0 = URB_NONDET_U32();
    m.recover_t0 = URB_NONDET_U32();
    m.recovering = URB_NONDET_BOOL();
    m.phase = URB_NONDET_U8();
    m.result = URB_NONDET_U8();
}

void harness(void)
{
    garbage_before_init();
    uint8_t const address = URB_NONDET_U8();
    URB_ASSUME((address >= URB_CAN_FIRST_ADDRESS) && (address <= URB_CAN_LAST_ADDRESS));
    urb_view_tid_address = address;
    urb_can_hal_t hal;
    hal.ctx = NULL;
    hal.tx = hal_tx;
    hal.tx_abort = hal_tx_abort;
    hal.state = hal_state;
    hal.recover = hal_recover;
    hal.lock = URB_NONDET_BOOL() ? hal_lock : NULL;
    urb_can_master_config_t cfg;
    urb_can_master_default_config(&cfg);
    urb_can_master_init(&m, &hal, &cfg);
    urb_downlink_t dl;
    urb_can_master_downlink(&m, &dl);
    ctrl_state = URB_NONDET_U8();
    URB_ASSUME(ctrl_state <= (uint8_t)URB_CAN_BUS_OFF);
    now = URB_NONDET_U32();
#if URB_PART == 1
    /* the request side: begin() (again), poll(), frames sent, the controller's state; no answer */
    ev_begin(&dl, address);
    for (uint8_t k = 0u; k < URB_STEPS; k++) {
        uint8_t const e = URB_NONDET_U8();
        if (e == 0u) {
            ev_begin(&dl, address);
        } else if (e == 1u) {
            ev_poll(&dl);
        } else if (e == 2u) {
            ev_tx_done(&m);
        } else {
            ctrl_state = URB_NONDET_U8(); /* the controller's fault confinement moved */
            URB_ASSUME(ctrl_state <= (uint8_t)URB_CAN_BUS_OFF);
        }
    }
#else
    /* the answer side: the request is all sent (an error-active controller takes every frame and
     * reports each sent), then any frames and polls */
    URB_ASSUME(ctrl_state != (uint8_t)URB_CAN_BUS_OFF);
    tx_always = true;
    ev_begin(&dl, address);
    for (uint8_t k = 0u; k < 2u; k++) {
        if (frames_sent < req_frames) {
            ev_tx_done(&m);
        }
    }
    for (uint8_t k = 0u; k < URB_STEPS; k++) {
        if (URB_NONDET_BOOL()) {
            ev_rx(&m);
        } else {
            ev_poll(&dl);
        }
    }
    ev_poll(&dl); /* what the frames gave (STEPS answer frames then a poll: a two-frame answer's status) */
#endif
}
