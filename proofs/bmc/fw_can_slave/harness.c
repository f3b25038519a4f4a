/*
 * Proof: the CAN downlink slave (firmware/downlink/can/urb_can_slave.c) against the contract in
 * urb_can_slave.h and urb_can_master.h, over every sequence of URB_STEPS events after
 * urb_can_slave_init: a received frame (a request to this node on the run's session, or any other
 * identifier: another node's request, an answer, SYNC; any length 0..8, any bytes, any later time;
 * not a request to this node on another of its sessions),
 * a queued frame reported sent, the controller going bus-off or not, and a controller that refuses
 * any queued frame.
 *
 * Properties (the contract):
 *  - frames in any order and state give the documented results: no out-of-bounds access, overflow
 *    or undefined shift (ESBMC's checks), no byte of an inbox buffer written past its size;
 *  - only whole transfers with a good CRC reach the mailboxes: write_commit only when a reference
 *    reassembler fed the request's frames (urb_can_rx_frame under the header's rules: a new start
 *    frame drops the transfer in progress, a repeat of the request completed last within
 *    dup_window_us is ignored, bus-off drops it) completed the transfer in this frame, its length
 *    is the inbox size and the buffer holds its bytes;
 *  - and every such write is committed: when the reference completes a write (not a probe) with a
 *    good CRC whose length is the inbox's size (not 0) and write_begin took its start, the slave
 *    commits it in that frame (nothing in between, such as a repeated earlier request, drops it);
 *  - the duplicate filter: a repeat of the last completed request (same session and transfer id,
 *    its start within dup_window_us) is neither committed nor answered again;
 *  - the mailbox calling rules (MailboxInbox.tla, MailboxOutbox.tla): a write begun is committed or
 *    aborted once before the next begins, on its mailbox; at most one outstanding read, ended once,
 *    complete only when every frame of its answer was reported sent;
 *  - the answer: every queued frame carries the response identifier of the request's session and
 *    its transfer id, the start bit on the first frame; a write is answered empty only when it was
 *    committed or was a probe, and refused (one byte) with CHECKSUM exactly on a failed CRC,
 *    NODE_BUSY only when write_begin refused, BAD_REQUEST only for an inbox of size 0,
 *    SIZE_MISMATCH only for a transfer of another length; a read's answer carries the published
 *    buffer's bytes in order (read_begin's), or is empty when there is no such outbox;
 *  - SYNC passed on with the frame's counter and time stamp;
 *  - the segmenter holds the answer answer() started (after init and after every event, on the
 *    slave's own state; the Frama-C unit eva_dl_can admits it as a hypothesis): no payload and
 *    length 0, the one refusal byte and length 1, or the published outbox and its outbox_size;
 *  - each entry (rx, tx_done, state) within FW_CAN_FRAME_BUDGET (fw_budgets.h).
 * Cover points: a write committed, each refusal, a probe answered, a duplicate ignored, a read
 * begun and ended complete, a read abandoned for a new request or bus-off, a SYNC passed on.
 *
 * Parts (sweep items): PART=1 the run's session is a write session (inboxes), PART=2 a read
 * session (outboxes). OP says which events a step may be, so that the solver's share of one item
 * stays small (the items together are the whole event space at a bound; each item is a subset):
 * OP=0 any event (above); OP=1 every event a frame on the run's session's request identifier (any
 * length, tail and bytes: multi-frame transfers, CRC failures, repeats, new starts over a request or
 * an answer in progress); OP=2 the first event such a frame, every later one a frame reported sent or
 * a controller state (the answer's end, bus-off over a request or an answer); OP=3 the
 * dup-after-start scenario, as OP=1 from a slave that has completed and answered a request on the
 * session (its last session, transfer id and time set after init, and the reference's, to any
 * values: the state such a request leaves, with no write or answer in progress), every frame
 * URB_FLEN bytes long (set, so symbolic execution does not unroll the length), node 20, mailbox 1:
 * the first frame a start frame without the end bit (a multi-frame write begun), the second a
 * one-byte start frame (a repeat of the request completed last, which may not disturb the write in
 * progress, or another request's start), the third any frame of that length (the write's end).
 * Bounds: URB_STEPS events, mailboxes of at most URB_LEN_MAX bytes, every frame at most
 * URB_FLEN bytes long (8, a whole CAN frame, unless the item says less: two frames of at most 3
 * bytes still carry a multi-frame transfer, its CRC and a repeat, at a fraction of the solver's work).
 * The CRC step is the linear stand-in of stubs/fw_can_crc_stub.c (fw_can_transfer proves the CRC
 * and the reassembly themselves).
 */
/* lobster-trace: urb.DLK_002, urb.DLK_003 (the requirements this proof verifies: the fast tier's
 * items; the dup-after-start scenario item PART=1,OP=3 is full tier and not yet seen to finish) */
#include "urb_verify.h"

#include "fw_budgets.h"
#include "urb_can_slave.h"
#include "urb_can_wire.h"
#include "urb_core.h"

URB_PROOF_COST_STORAGE;

#ifndef URB_STEPS
#define URB_STEPS 3
#endif
#ifndef URB_PART
#define URB_PART 1
#endif
#ifndef URB_OP
#define URB_OP 0
#endif
#ifndef URB_LEN_MAX
#define URB_LEN_MAX 8u
#endif
#ifndef URB_FLEN
#define URB_FLEN 8u
#endif
#define CAN_SLOTS 3u
/* Cover points scoped to the items that can reach them (a point compiled into an item must be
 * reached by some item of its PART): the inbox paths in PART=1, the outbox paths in PART=2, SYNC and
 * other identifiers only where a step may be any frame (OP=0). */
#if URB_PART == 1
#define COVER_WRITE(name) URB_COVER(name)
#else
#define COVER_WRITE(name) ((void)0)
#endif
#if URB_PART == 2
#define COVER_READ(name) URB_COVER(name)
#else
#define COVER_READ(name) ((void)0)
#endif
#if URB_OP == 0
#define COVER_ANY_FRAME(name) URB_COVER(name)
#else
#define COVER_ANY_FRAME(name) ((void)0)
#endif
/* The budget of urb_can_slave_rx: a whole shortest frame at 1 Mb/s (2640 cycles), not half of one
 * as tx_done and state. ASSUMPTION (the port's, stated in firmware/downlink/README.md and urb.DLK_008):
 * the controller holds received frames in a receive FIFO of at least 2 frames, so a frame arrives
 * while the previous one is handled without being lost, and one shortest frame time per received
 * frame keeps up with a bus full of back-to-back shortest frames; the FIFO's other elements absorb the
 * interrupt's entry latency and the other interrupts. The target port has 3 (urb_cm0_fdcan.h,
 * URB_CM0_FDCAN_RX_ELEMENTS: the STM32G0B1 FDCAN's Rx FIFO 0); bxCAN has 2 x 3, the MCP2515 2
 * buffers. On a controller with a single receive buffer the budget would be half a frame, which the
 * slave does not meet: measured 2026-11-29, one frame of a write refused NODE_BUSY costs 1462 cycles
 * by the model (request start, the reassembly, the refusal's encoding, the first answer frame queued
 * in the same entry) against 1320. Kept here, not in fw_can_budgets.h, because fw_can_master reads
 * that header: a line there would make its recorded runs real again. */
#define SLAVE_RX_BUDGET (2u * FW_CAN_FRAME_BUDGET)
/* The harness's own checks inside a stub (decoding the queued refusal, the expected identifier,
 * the reference's length) call instrumented code: their cycles are not the slave's. */
#if defined(URB_PROOF_COST)
#define CHECKS_BEGIN() uint32_t const cost_before_checks = urb_proof_cost
#define CHECKS_END() ((void)(urb_proof_cost = cost_before_checks))
#else
#define CHECKS_BEGIN() ((void)0)
#define CHECKS_END() ((void)0)
#endif
#define DUP_WINDOW 1080u /* urb_can_slave_dup_window_us(1000) */

static uint8_t own;        /* this node's address */
static uint8_t sess;       /* the run's session (mailbox | 8 for a read) */
static uint8_t box_size;   /* inbox or outbox size of the session's mailbox */
static uint8_t ibuf[URB_LEN_MAX + 1u];
static uint8_t obuf[URB_LEN_MAX + 1u]; /* one byte past the largest outbox: a segmenter told a length
                                        * past its outbox fails "tx state", not the array bound */
static uint8_t queued;
static uint32_t now;

/* the reference */
static urb_can_rx_t ref_rx;
static uint8_t ref_out[40];
static bool done_now;      /* the frame just received completed the request with a good CRC */
static bool crc_now;       /* ... with a failed CRC */
static bool ref_probe;     /* the request's start frame was an empty single frame */
static bool last_valid;
static uint8_t last_tid;
static uint32_t last_t;

/* mailbox calls */
static bool write_open;
static bool begin_refused;     /* write_begin returned NULL for the request in progress */
static bool read_open;
static bool read_complete_ok;  /* every frame of the read's answer was reported sent */

/* the answer being sent */
static bool answering;
static uint8_t ans_tid;
static uint8_t ans_queued;
static uint8_t ans_sent;
static bool ans_read;          /* the answer carries obuf */
static bool ans_committed;     /* the answered write was committed */
static bool ans_crc;           /* the answered request failed its CRC */
static bool ans_probe;         /* the answered request was a probe */
static uint8_t ans_len;        /* the answered request's payload length */

static uint8_t sync_frame_counter;
static bool sync_expected;
static bool sync_seen;

/* ----- HAL ----- */

static bool hal_tx(void *ctx, const urb_can_frame_t *f)
{
    (void)ctx;
    CHECKS_BEGIN();
    URB_ASSERT(answering, "tx: only an answer is sent");
    URB_ASSERT(!(done_now || crc_now) || (ans_queued < URB_CAN_MAX_FRAMES), "tx: the answer's frames only");
    URB_ASSERT((f->len >= 1u) && (f->len <= URB_CAN_MTU), "tx: a frame holds 1..8 bytes");
    URB_ASSERT(f->id == urb_can_id(own, (uint8_t)(sess & 7u), (sess & 8u) != 0u, URB_CAN_RESPONSE),
               "tx: the response identifier of the request's session");
    uint8_t const tail = f->data[f->len - 1u];
    URB_ASSERT((tail & URB_CAN_TAIL_TID) == ans_tid, "tx: the request's transfer id");
    URB_ASSERT(((tail & URB_CAN_TAIL_START) != 0u) == (ans_queued == 0u), "tx: the start bit on the first frame");
    if (ans_read) {
        for (uint8_t i = 0u; i < URB_CAN_CHUNK; i++) {
            uint8_t const k = (uint8_t)(7u * ans_queued + i);
            if (((i + 1u) < f->len) && (k < box_size)) {
                URB_ASSERT(f->data[i] == obuf[k], "read answer: the published buffer's bytes in order");
            }
        }
    } else if ((URB_PART == 2) && (ans_queued == 0u)) {
        URB_ASSERT(f->len == 1u, "read answer: empty when nothing is read");
    }
    if ((URB_PART == 1) && (ans_queued == 0u)) {
        if (f->len == 1u) {
            URB_ASSERT(ans_committed || (ans_probe && !ans_crc), "write answered OK: committed, or a probe");
        } else {
            urb_can_write_refusal_t r;
            URB_ASSERT((f->len == 2u) && (urb_can_write_refusal_decode(&r, f->data, 1u) >= 0),
                       "write refused: one CanWriteRefusal byte");
            uint8_t const st = r.status;
            URB_ASSERT(!ans_committed, "write refused: nothing committed");
            URB_ASSERT((st == URB_STATUS_CHECKSUM) == ans_crc, "write refused CHECKSUM exactly on a failed CRC");
            if (st == URB_STATUS_NODE_BUSY) {
                COVER_WRITE("refused-node-busy");
                URB_ASSERT(begin_refused, "NODE_BUSY: only when write_begin refused");
            } else if (st == URB_STATUS_BAD_REQUEST) {
                COVER_WRITE("refused-bad-request");
                URB_ASSERT(box_size == 0u, "BAD_REQUEST: only for an inbox that is not set up");
            } else if (st == URB_STATUS_SIZE_MISMATCH) {
                COVER_WRITE("refused-size-mismatch");
                URB_ASSERT(ans_len != box_size, "SIZE_MISMATCH: only for another length");
            } else {
                COVER_WRITE("refused-checksum");
                URB_ASSERT(st == URB_STATUS_CHECKSUM, "write refused: a refusal status");
            }
        }
    }
    CHECKS_END();
    if ((queued >= CAN_SLOTS) || URB_NONDET_BOOL()) {
        URB_COVER("tx-refused");
        return false;
    }
    URB_COST(FW_HAL_CALL_CYCLES);
    queued++;
    ans_queued++;
    return true;
}

static void hal_tx_abort(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    queued = 0u;
    if (!(done_now || crc_now)) {
        answering = false; /* (an abort inside the call that completes a request drops the old answer) */
    }
}

static void hal_recover(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
}

/* ----- the node's mailboxes ----- */

static uint8_t mb_inbox_size(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT((URB_PART == 1) && (m == (sess & 7u)), "inbox_size: the request's inbox");
    return box_size;
}

static uint8_t mb_outbox_size(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT((URB_PART == 2) && (m == (sess & 7u)), "outbox_size: the request's outbox");
    return box_size;
}

static uint8_t *mb_write_begin(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(!write_open, "inbox: a write begun is committed or aborted before the next begins");
    URB_ASSERT((m == (sess & 7u)) && (box_size > 0u), "write_begin: a set-up inbox of the request");
    if (URB_NONDET_BOOL()) {
        COVER_WRITE("write-begin-refused");
        begin_refused = true; /* both buffers in use */
        return NULL;
    }
    write_open = true;
    return ibuf;
}

static void mb_write_commit(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(write_open && (m == (sess & 7u)), "commit: only a write begun, on its inbox");
    CHECKS_BEGIN();
    URB_ASSERT(done_now && (urb_can_rx_len(&ref_rx) == box_size),
               "commit: only a whole transfer with a good CRC, of the inbox's size");
    for (uint8_t i = 0u; i < URB_LEN_MAX; i++) {
        if (i < box_size) {
            URB_ASSERT(ibuf[i] == ref_out[i], "commit: the buffer holds the transfer's bytes");
        }
    }
    CHECKS_END();
    COVER_WRITE("write-committed");
    write_open = false;
    ans_committed = true;
}

static void mb_write_abort(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(write_open && (m == (sess & 7u)), "abort: only a write begun, on its inbox");
    write_open = false;
}

static const uint8_t *mb_read_begin(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(!read_open, "outbox: at most one outstanding read");
    URB_ASSERT((URB_PART == 2) && (m == (sess & 7u)) && (box_size > 0u), "read_begin: a set-up outbox of the request");
    CHECKS_BEGIN();
    URB_ASSERT(done_now && (urb_can_rx_len(&ref_rx) == 0u), "read_begin: only for a whole empty read request");
    CHECKS_END();
    read_open = true;
    ans_read = true;
    COVER_READ("read-begun");
    return obuf;
}

static void mb_read_end(void *ctx, uint8_t m, bool complete)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(read_open && (m == (sess & 7u)), "read_end: only a read begun, once");
    URB_ASSERT(!complete || read_complete_ok, "read_end complete: only when every frame was reported sent");
    if (complete) {
        COVER_READ("read-ended-complete");
    } else {
        COVER_READ("read-abandoned");
    }
    read_open = false;
    ans_read = false;
}

static void mb_sync(void *ctx, uint32_t t, uint8_t counter)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(sync_expected && (counter == sync_frame_counter) && (t == now), "sync: the frame's counter and time");
    COVER_ANY_FRAME("sync-passed-on");
    sync_seen = true;
}

static void mb_fault(void *ctx, uint8_t code)
{
    (void)ctx;
    (void)code;
    URB_COST(FW_HAL_CALL_CYCLES);
}

/* ----- events ----- */

static void ev_rx(urb_can_slave_t *s, uint8_t k)
{
    urb_can_frame_t f;
    bool const mine = (URB_OP != 0) || URB_NONDET_BOOL();
    f.id = mine ? urb_can_id(own, (uint8_t)(sess & 7u), (sess & 8u) != 0u, URB_CAN_REQUEST)
                : (uint16_t)(URB_NONDET_U16() & 0x7FFu);
    /* requests to this node on its other sessions are left out: the same code with another session
     * number, except that one drops the request in progress, which the run's session shows too */
    URB_ASSUME(mine || ((f.id >> 10) != URB_CAN_REQUEST) || (((f.id >> 4) & 0x3Fu) != own) || ((f.id & 15u) == sess));
    f.len = URB_NONDET_U8();
    URB_ASSUME((f.len <= URB_CAN_MTU) && (f.len <= URB_FLEN));
    URB_NONDET_BYTES(f.data, sizeof f.data);
    if (URB_OP == 3) {
        /* the scenario's frames (harness header), their lengths set rather than assumed: a start
         * frame without the end bit, a one-byte start frame, then any frame */
        uint8_t const st = URB_CAN_TAIL_START | URB_CAN_TAIL_TOGGLE;
        if (k == 0u) {
            f.len = (uint8_t)URB_FLEN;
            f.data[URB_FLEN - 1u] = (uint8_t)((f.data[URB_FLEN - 1u] & URB_CAN_TAIL_TID) | st);
        } else if (k == 1u) {
            f.len = 1u; /* the request completed last repeated, or another probe or start */
            f.data[0] = (uint8_t)(f.data[0] | st);
        } else {
            f.len = (uint8_t)URB_FLEN; /* any frame on the session, the write's end among them */
        }
    }
    now += URB_NONDET_U16();
    done_now = false;
    crc_now = false;
    urb_can_sync_t sync_msg;
    sync_expected = (f.id == URB_CAN_SYNC_ID) && (f.len == 2u) && ((f.data[1] & 0xE0u) == 0xE0u) &&
                    (urb_can_sync_decode(&sync_msg, f.data, 1u) >= 0);
    sync_frame_counter = f.data[0];
    sync_seen = false;
    bool const request = (f.id == urb_can_id(own, (uint8_t)(sess & 7u), (sess & 8u) != 0u, URB_CAN_REQUEST)) &&
                         (f.len > 0u);
    if (request) {
        uint8_t const tail = f.data[f.len - 1u];
        uint8_t const tid = (uint8_t)(tail & URB_CAN_TAIL_TID);
        bool take = true;
        if ((tail & URB_CAN_TAIL_START) != 0u) {
            bool const repeat_in_progress = urb_can_rx_active(&ref_rx) && (tid == urb_can_rx_tid(&ref_rx));
            if (!repeat_in_progress) {
                if (last_valid && (tid == last_tid) && ((uint32_t)(now - last_t) < DUP_WINDOW)) {
                    URB_COVER("duplicate-ignored");
                    take = false; /* the duplicate filter */
                } else {
                    urb_can_rx_reset(&ref_rx); /* a new request drops the one in progress */
                    ref_probe = ((tail & URB_CAN_TAIL_END) != 0u) && (f.len == 1u);
                    begin_refused = false;
                }
            }
        }
        if (take) {
            urb_can_rx_result_t const r = urb_can_rx_frame(&ref_rx, f.data, f.len, ref_out, sizeof ref_out);
            if ((r == URB_CAN_RX_DONE) || (r == URB_CAN_RX_CRC)) {
                done_now = r == URB_CAN_RX_DONE;
                crc_now = r == URB_CAN_RX_CRC;
                last_valid = true;
                last_tid = tid;
                last_t = now;
                /* the answer to this request starts now */
                answering = true;
                ans_tid = tid;
                ans_queued = 0u;
                ans_sent = 0u;
                ans_read = false;
                ans_committed = false;
                ans_crc = crc_now;
                ans_probe = ref_probe;
                ans_len = urb_can_rx_len(&ref_rx);
                read_complete_ok = false;
            }
        }
    }
    uint8_t before[URB_LEN_MAX];
    for (uint8_t i = 0u; i < URB_LEN_MAX; i++) {
        before[i] = ibuf[i];
    }
    uint8_t const guard = ibuf[URB_LEN_MAX];
    URB_COST_BEGIN();
    urb_can_slave_rx(s, &f, now);
    URB_COST_END(SLAVE_RX_BUDGET);
    for (uint8_t i = 0u; i < URB_LEN_MAX; i++) {
        if (i >= box_size) {
            URB_ASSERT(ibuf[i] == before[i], "rx: no byte past the inbox size");
        }
    }
    URB_ASSERT(ibuf[URB_LEN_MAX] == guard, "rx: no byte past the inbox size");
    URB_ASSERT(sync_seen == sync_expected, "sync: every well-formed SYNC frame passed on, nothing else");
    if ((URB_PART == 1) && done_now && !ref_probe && !begin_refused && (box_size > 0u) &&
        (urb_can_rx_len(&ref_rx) == box_size)) {
        URB_ASSERT(ans_committed, "commit: every whole accepted write of the inbox's size is committed");
    }
    if (done_now || crc_now) {
        URB_ASSERT(!write_open, "a completed write request leaves no write open");
        if (ref_probe && done_now && (URB_PART == 1)) {
            COVER_WRITE("probe-answered");
        }
    }
}

static void ev_tx_done(urb_can_slave_t *s)
{
    URB_ASSUME(queued > 0u);
    queued--;
    if (answering) {
        ans_sent++;
        if ((ans_sent == ans_queued) && ans_read && (ans_sent >= urb_can_frames(box_size))) {
            read_complete_ok = true;
        }
    }
    URB_COST_BEGIN();
    urb_can_slave_tx_done(s);
    URB_COST_END(FW_CAN_FRAME_BUDGET);
}

static void ev_state(urb_can_slave_t *s)
{
    uint8_t const st = URB_NONDET_U8();
    URB_ASSUME(st <= (uint8_t)URB_CAN_BUS_OFF);
    if (st == (uint8_t)URB_CAN_BUS_OFF) {
        urb_can_rx_reset(&ref_rx); /* bus-off drops the request in progress */
        if (read_open) {
            COVER_READ("read-abandoned-bus-off");
        }
    }
    URB_COST_BEGIN();
    urb_can_slave_state(s, st);
    URB_COST_END(FW_CAN_FRAME_BUDGET);
    if (st == (uint8_t)URB_CAN_BUS_OFF) {
        URB_ASSERT(!write_open && !read_open, "bus-off: the write and the read in progress abandoned");
    }
}

static urb_can_slave_t slave;
/* the slave's frame and refusal byte in the proof view (stubs/can_slave_view.py) */
urb_can_frame_t urb_view_slave_frame;
uint8_t urb_view_slave_answer[1];

/* The segmenter's payload and length are a pair answer() set (the only writer after init, which
 * sets NULL and 0; urb_can_tx_next advances only the position, CRC and tail): what the Frama-C unit
 * eva_dl_can admits, here checked on the slave's own state between events. The outbox pair is the
 * published buffer and outbox_size (PART=2 only: no read in a write session). */
static void check_tx_state(void)
{
    const uint8_t *const p = slave.tx.payload;
    uint8_t const n = slave.tx.len;
    URB_ASSERT(((p == NULL) && (n == 0u)) || ((p == urb_view_slave_answer) && (n == 1u)) ||
                   ((URB_PART == 2) && (p == obuf) && (n == box_size)),
               "tx state: the answer answer() started (none and 0, the refusal byte and 1, the outbox and its size)");
}

void harness(void)
{
    own = URB_NONDET_U8();
    URB_ASSUME((own >= URB_CAN_FIRST_ADDRESS) && (own <= URB_CAN_LAST_ADDRESS));
    uint8_t box = URB_NONDET_U8();
    URB_ASSUME(box <= 7u);
    if (URB_OP == 3) {
        /* one node address and mailbox (the identifier then a constant: symbolic execution takes
         * only the write session's paths); the other items cover every address and mailbox */
        own = 20u;
        box = 1u;
    }
    sess = (URB_PART == 2) ? (uint8_t)(box | 8u) : box;
    box_size = URB_NONDET_U8();
    URB_ASSUME(box_size <= URB_LEN_MAX);
    for (uint8_t i = 0u; i < URB_LEN_MAX; i++) {
        obuf[i] = URB_NONDET_U8();
        ibuf[i] = URB_NONDET_U8();
    }
    obuf[URB_LEN_MAX] = URB_NONDET_U8();
    ibuf[URB_LEN_MAX] = URB_NONDET_U8();
    now = URB_NONDET_U32();
    urb_can_rx_reset(&ref_rx);
    urb_can_hal_t hal;
    hal.ctx = NULL;
    hal.tx = hal_tx;
    hal.tx_abort = hal_tx_abort;
    hal.state = NULL;
    hal.recover = hal_recover;
    hal.lock = NULL;
    urb_dl_mailbox_t mb;
    mb.ctx = NULL;
    mb.inbox_size = mb_inbox_size;
    mb.outbox_size = mb_outbox_size;
    mb.write_begin = mb_write_begin;
    mb.write_commit = mb_write_commit;
    mb.write_abort = mb_write_abort;
    mb.read_begin = mb_read_begin;
    mb.read_end = mb_read_end;
    mb.sync = mb_sync;
    mb.fault = URB_NONDET_BOOL() ? mb_fault : NULL;
    bool const ok = urb_can_slave_init(&slave, &hal, &mb, own, DUP_WINDOW);
    URB_ASSERT(ok, "init: a valid address and a complete table are taken");
    if (URB_OP == 3) {
        /* a request on the session completed and answered before the run (harness header): the
         * slave's duplicate filter and the reference's hold the same last request */
        slave.last_session = sess;
        slave.last_tid = (uint8_t)(URB_NONDET_U8() & URB_CAN_TAIL_TID);
        slave.last_t = URB_NONDET_U32();
        last_valid = true;
        last_tid = slave.last_tid;
        last_t = slave.last_t;
    }
    check_tx_state();
    for (uint8_t k = 0u; k < URB_STEPS; k++) {
        uint8_t e = URB_NONDET_U8();
        if ((URB_OP == 1) || (URB_OP == 3) || ((URB_OP == 2) && (k == 0u))) {
            e = 2u; /* a frame on the run's session */
        } else if (URB_OP == 2) {
            URB_ASSUME(e <= 1u); /* sent, or a controller state */
        } else {
            /* any event */
        }
        if (e == 0u) {
            ev_tx_done(&slave);
        } else if (e == 1u) {
            ev_state(&slave);
        } else {
            ev_rx(&slave, k);
        }
        check_tx_state();
    }
}
