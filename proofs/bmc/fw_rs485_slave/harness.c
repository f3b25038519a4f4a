/*
 * Proof: the RS485 downlink slave (firmware/downlink/rs485/urb_rs485_slave.c) against the contract
 * in urb_rs485_slave.h, over every sequence of URB_STEPS events after urb_rs485_slave_init as node
 * 20 at 1 Mb/s (character 10 us, t1.5 15 us, t3.5 35 us), with mailboxes of arbitrary sizes
 * 0..URB_SZ and arbitrary outbox contents:
 *   frame  1..URB_NMAX bytes of any value on the line (the address byte, the select byte, the data
 *          and the check: the right link_check or any bytes), the first after any silence (a new
 *          frame, or one that joins or breaks the frame before), the others after silences up to
 *          one over t1.5 (a break); the port did or did not poll in between;
 *   poll   the port's poll at any later time (the deadline it asked for, or later);
 *   pull   (PART=2) the UART takes one byte of the answer, and the node hears its echo after any
 *          silence (a stall that breaks or ends the answer) or hears nothing.
 * PART=1: URB_STEPS steps, each a frame or none, then a poll or none. PART=2 (the answer): a request
 * to this node with a good check, a poll, up to 1 + URB_SZ + 2 pulls, then a frame of up to 3 bytes
 * and a poll, or nothing more.
 * A reference receiver in the harness (the rules of urb_rs485.h: a frame is the bytes between
 * silences of t3.5, a silence over t1.5 inside breaks it, a poll ends it t3.5 + a character after
 * its last byte) decides where frames end and what each one is; the slave's calls are compared
 * with the contract's decision after every event, as counts of each call.
 *
 * Properties (the contract):
 *  - the mailbox calling rules (urb_dl_slave.h): a write is begun, then committed or aborted
 *    exactly once; read_begin and read_end pair up per outbox (a read is never begun while latched,
 *    never ended unlatched); an outbox is latched only while its answer is being sent; no write is
 *    open when a frame has ended (issue #39: the slave called read_begin twice when an answer was
 *    cut, fixed 2026-11-29 and kept as the seeded bug read-kept-when-cut);
 *  - only whole frames with a good check reach the mailboxes: a commit only at the poll that ends a
 *    frame addressed to this node, not broken, whose check matches, a write of exactly the inbox's
 *    size, with the frame's data bytes; a read begun only for such a read of a set-up outbox; a
 *    write begun only at the second data byte of an addressed write (a probe touches nothing);
 *  - answers only when addressed: tx_start only in the poll that ends an addressed, unbroken frame
 *    with a select byte, exactly once then, t3.5 + a character after its last byte (the turnaround
 *    starts there: the port is woken at that deadline); a frame for another node, a broadcast, a
 *    broken frame and a frame the port polled too late for get no answer and touch no mailbox but
 *    the abort of a write in progress; SYNC exactly for a good 3-byte frame to address 0, with its
 *    counter and first byte's time stamp;
 *  - the answer's bytes: the header (status, mailbox, response bit) the contract's decision names
 *    (CHECKSUM, BAD_REQUEST, SIZE_MISMATCH, NODE_BUSY, OK), a read's outbox bytes, the link_check
 *    over them, and nothing after (tx_next false); the read ended complete at its last byte; an
 *    answer unfinished when a frame ends is dropped and its read ended not complete;
 *  - the faults CHECKSUM and OVERRUN exactly with their answers;
 *  - no out-of-bounds access (a write past the inbox buffer or a read past the outbox is a bounds
 *    failure: each buffer is its own object), overflow or undefined shift;
 *  - each urb_rs485_slave_rx, urb_rs485_slave_poll and urb_rs485_slave_tx_next call within
 *    FW_RS485_BYTE_BUDGET (one character at 1 Mb/s), but a received byte after t3.5 + a character
 *    of silence (it may end a frame: FW_RS485_LATE_END_BUDGET, two characters) and a poll (it
 *    decides and starts the answer: FW_RS485_POLL_BUDGET, two characters; below says why);
 *    the mailbox and HAL calls charged FW_HAL_CALL_CYCLES each.
 * Cover points (part 1): a commit, NODE_BUSY, SIZE_MISMATCH, BAD_REQUEST, CHECKSUM, a read begun, a
 * probe answered, a SYNC, a frame for another node, a broken addressed frame, a request the port
 * polled too late for, an answer dropped by the next request with its read ended not complete;
 * (part 2): an answer sent whole, a read ended complete, an answer cut by a stall and dropped, the
 * echo heard.
 * The CRC steps are cheap stand-ins (stubs/fw_rs485_crc_stub.c, used by the slave's receiver, its
 * answer's check and the reference alike); fw_rs485_frame proves the receiver's verdict with the
 * real CRCs. Bounds: URB_STEPS events, frames of at most URB_NMAX bytes, mailboxes of at most URB_SZ
 * bytes (the answer's check is one urb_link_check over 1 + size bytes in the tx_next of the last
 * data byte: its cost for 32-byte outboxes is not covered by these bounds).
 */
/* lobster-trace: urb.DLK_004 (the requirements this proof verifies) */
/* lobster-trace: urb.DLK_006 */
#include "urb_verify.h"

#include "../stubs/fw_budgets.h"
#include "urb_core.h"
#include "urb_rs485_slave.h"
#include "urb_runtime.h"

URB_PROOF_COST_STORAGE;

/* A received byte that ends the frame before it (the port polled too late: the byte came t3.5 + a
 * character or more after the previous one, so the receive FIFO is empty) may take two characters:
 * the receiver's step, the frame's end (a write aborted, a cut answer's read ended, a SYNC) and the
 * new frame's start. The next byte comes one character later and waits in the UART's 8-byte FIFO
 * (fw_budgets.h: the port takes bytes from the FIFO at 1 Mb/s). Every other byte: one character.
 * Defined here, not in fw_budgets.h: every firmware proof reads fw_budgets.h, so editing it re-runs
 * all of them instead of replaying their cache entries. */
#define FW_RS485_LATE_END_BUDGET (2u * FW_RS485_BYTE_BUDGET)
/* The poll at a frame's deadline decides and starts the answer. The bridge waits the turnaround
 * (4 characters + 50 us for the node's interrupt, urb_rs485_timing) after t3.5 for its first byte:
 * half of the 4 characters (the rule for interrupt paths) is two characters. */
#define FW_RS485_POLL_BUDGET (2u * FW_RS485_BYTE_BUDGET)

#ifndef URB_PART
#define URB_PART 1
#endif
#ifndef URB_STEPS
#define URB_STEPS 3
#endif
#ifndef URB_NMAX
#define URB_NMAX 5 /* a write of 2 data bytes: address, select, 2 data, CRC-8 */
#endif
#ifndef URB_SZ
#define URB_SZ 2u
#endif

#define NODE 20u
#define CHAR_US 10u
#define GAP_END 45u   /* a byte this long after the previous one, or a poll: t3.5 + a character */
#define GAP_BREAK 25u /* longer than this (a character + t1.5) and shorter than GAP_END: breaks */
#define ANS_MAX (1u + URB_SZ + 1u)
#define NONE 0xFFu
/* a cover point of one part: points are judged per part (tools/proofs.py --covers) */
#if URB_PART == 1
#define COVER1(name) URB_COVER(name)
#else
#define COVER1(name) ((void)0)
#endif

static urb_rs485_slave_t s;
static urb_rs485_hal_t hal;
static urb_dl_mailbox_t mb;
static uint32_t now;

/* ----- the node's mailboxes, each buffer its own object ----- */
static uint8_t in_size[8], out_size[8];
static uint8_t ob0[URB_SZ], ob1[URB_SZ], ob2[URB_SZ], ob3[URB_SZ], ob4[URB_SZ], ob5[URB_SZ], ob6[URB_SZ], ob7[URB_SZ];
static uint8_t *const outbox[8] = {ob0, ob1, ob2, ob3, ob4, ob5, ob6, ob7};
static uint8_t fill[URB_SZ];      /* the buffer write_begin hands out (one write at a time) */
static uint8_t committed[URB_SZ]; /* its contents at the last commit */
static uint8_t writing;           /* inbox of the open write, NONE */
static uint8_t latched;           /* outbox latched, NONE (the contract allows one at a time) */
/* counts of each call (the harness compares them with the contract after every event) */
static uint8_t n_begin, n_refused, n_commit, n_abort, n_read, n_end_whole, n_end_cut, n_sync;
static uint8_t n_fault_check, n_fault_overrun, n_tx_start;
static uint8_t commit_box, read_box, sync_counter;
static uint32_t sync_t, wake;
static bool in_poll;

static uint8_t inbox_size(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(m < 8u, "mailbox: a mailbox number 0..7");
    return in_size[m & 7u];
}

static uint8_t outbox_size(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(m < 8u, "mailbox: a mailbox number 0..7");
    return out_size[m & 7u];
}

static uint8_t *write_begin(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT((m < 8u) && (in_size[m & 7u] != 0u), "mailbox: a write begun on a set-up inbox");
    URB_ASSERT(writing == NONE, "mailbox: no write begun while one is open");
    n_begin++;
    if (URB_NONDET_BOOL()) {
        n_refused++; /* the application holds the other buffer */
        return NULL;
    }
    writing = m;
    for (uint8_t i = 0u; i < URB_SZ; i++) {
        fill[i] = URB_NONDET_U8(); /* the buffer's old contents: anything */
    }
    return fill;
}

static void write_commit(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT((writing != NONE) && (writing == m), "mailbox: commit only the open write");
    for (uint8_t i = 0u; i < URB_SZ; i++) {
        committed[i] = fill[i];
    }
    writing = NONE;
    commit_box = m;
    n_commit++;
}

static void write_abort(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT((writing != NONE) && (writing == m), "mailbox: abort only the open write");
    writing = NONE;
    n_abort++;
}

static const uint8_t *read_begin(void *ctx, uint8_t m)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT((m < 8u) && (out_size[m & 7u] != 0u), "mailbox: a read begun on a set-up outbox");
    URB_ASSERT(latched == NONE, "mailbox: read_begin never while an outbox is latched");
    latched = m;
    read_box = m;
    n_read++;
    return outbox[m & 7u];
}

static void read_end(void *ctx, uint8_t m, bool complete)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT((latched != NONE) && (latched == m), "mailbox: read_end only of the latched outbox");
    latched = NONE;
    if (complete) {
        n_end_whole++;
    } else {
        n_end_cut++;
    }
}

static void sync(void *ctx, uint32_t t, uint8_t counter)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    sync_t = t;
    sync_counter = counter;
    n_sync++;
}

static void fault(void *ctx, uint8_t code)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    if (code == URB_DL_FAULT_CHECKSUM) {
        n_fault_check++;
    } else if (code == URB_DL_FAULT_OVERRUN) {
        n_fault_overrun++;
    } else {
        URB_ASSERT(false, "fault: only CHECKSUM and OVERRUN");
    }
}

static void hal_tx_start(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(in_poll, "answer: started only by a poll (at a frame's t3.5 end), never by a received byte");
    n_tx_start++;
}

static void hal_wake_at(void *ctx, uint32_t at)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    wake = at;
}

/* ----- the reference receiver and the contract ----- */
enum { R_DISCARD = 0u, R_FRAME = 1u, R_IDLE = 2u };
static uint8_t r_state = R_DISCARD; /* after start-up: nothing before t3.5 of silence */
static uint32_t r_t;                /* the last byte's time stamp (start-up: 0) */
static uint32_t r_t_first;
static uint8_t r_n;
static uint8_t r_b[URB_NMAX];
/* the answer the contract expects on the line */
static bool a_active;
static uint8_t a_total, a_pos, a_read; /* a_read: the outbox latched for it, NONE */
static uint8_t a_bytes[ANS_MAX + 1u];

/* What the calls of one event must add up to (compared after it). */
static uint8_t e_begin, e_commit, e_read, e_end_whole, e_end_cut, e_sync, e_fault_check, e_fault_overrun, e_tx;
static bool e_commit_check;
static uint8_t e_box;

static void expect_none(void)
{
    e_begin = 0u;
    e_commit = 0u;
    e_read = 0u;
    e_end_whole = 0u;
    e_end_cut = 0u;
    e_sync = 0u;
    e_fault_check = 0u;
    e_fault_overrun = 0u;
    e_tx = 0u;
    e_commit_check = false;
    n_begin = 0u;
    n_refused = 0u;
    n_commit = 0u;
    n_abort = 0u;
    n_read = 0u;
    n_end_whole = 0u;
    n_end_cut = 0u;
    n_sync = 0u;
    n_fault_check = 0u;
    n_fault_overrun = 0u;
    n_tx_start = 0u;
}

static void plan_answer(uint8_t status, uint8_t m, uint8_t len)
{
    uint8_t const head = (uint8_t)(status | (uint8_t)(m << 4) | 0x80u);
    a_bytes[0] = head;
    for (uint8_t i = 0u; i < URB_SZ; i++) {
        if (i < len) {
            a_bytes[1u + i] = outbox[m][i];
        }
    }
    uint32_t const c = urb_link_check(&head, 1u, outbox[m], len);
    a_bytes[1u + len] = (uint8_t)c; /* 1 + len <= 1 + URB_SZ covered bytes: the CRC-8 tier */
    a_total = (uint8_t)(len + 2u);
    a_pos = 0u;
    a_active = true;
    a_read = NONE;
    e_tx = 1u;
}

static bool frame_check_good(void)
{
    uint8_t const cl = urb_rs485_check_len(r_n);
    if (cl == 0u) {
        return false;
    }
    uint32_t const c = urb_link_check(NULL, 0u, r_b, (size_t)(r_n - cl));
    bool good = r_b[r_n - cl] == (uint8_t)c;
    if (cl == 2u) {
        good = good && (r_b[r_n - 1u] == (uint8_t)(c >> 8));
    }
    return good;
}

/* The contract's decision for an addressed frame that ended at its t3.5 (urb_rs485_slave.h). */
static void decide(void)
{
    if (r_n < 3u) {
        return; /* no select byte: no answer */
    }
    uint8_t const sel = r_b[1];
    uint8_t const m = (uint8_t)(sel & 7u);
    uint8_t const cl = urb_rs485_check_len(r_n);
    if (!frame_check_good()) {
        COVER1("part1-checksum");
        e_fault_check = 1u;
        plan_answer(URB_STATUS_CHECKSUM, m, 0u);
        return;
    }
    uint8_t const data_len = (uint8_t)(r_n - 2u - cl);
    if ((sel & 0x78u) != 0u) {
        COVER1("part1-bad-request-reserved");
        plan_answer(URB_STATUS_BAD_REQUEST, m, 0u);
        return;
    }
    if ((sel & 0x80u) != 0u) {
        if ((data_len != 0u) || (out_size[m] == 0u)) {
            plan_answer(URB_STATUS_BAD_REQUEST, m, 0u);
            return;
        }
        COVER1("part1-read-begun");
        e_read = 1u;
        e_box = m;
        plan_answer(URB_STATUS_OK, m, out_size[m]);
        a_read = m;
        return;
    }
    if (data_len == 0u) {
        COVER1("part1-probe");
        plan_answer(URB_STATUS_OK, m, 0u);
        return;
    }
    if (in_size[m] == 0u) {
        plan_answer(URB_STATUS_BAD_REQUEST, m, 0u);
        return;
    }
    if (data_len != in_size[m]) {
        COVER1("part1-size-mismatch");
        plan_answer(URB_STATUS_SIZE_MISMATCH, m, 0u);
        return;
    }
    if (writing == NONE) {
        COVER1("part1-node-busy");
        e_fault_overrun = 1u;
        plan_answer(URB_STATUS_NODE_BUSY, m, 0u);
        return;
    }
    COVER1("part1-commit");
    e_commit = 1u;
    e_commit_check = true;
    e_box = m;
    plan_answer(URB_STATUS_OK, m, 0u);
}

/* A frame ends (the reference): `in_time` at a poll, else a byte after t3.5 ended it. */
static void ref_end(bool in_time)
{
    if (a_active) {
        /* the line was silent for t3.5 with the answer unfinished: dropped */
        a_active = false;
        if (a_read != NONE) {
            COVER1("part1-answer-dropped-read-cut");
            e_end_cut = 1u;
        }
    }
    bool const mine = r_b[0] == NODE;
    if (mine && in_time) {
        decide();
        return;
    }
    if (mine) {
        COVER1("part1-polled-too-late");
    } else if ((r_n >= 3u) && ((r_b[0] & 0x80u) == 0u) && (r_b[0] != 0u)) {
        COVER1("part1-other-node");
    } else {
        /* a broadcast or an answer's echo */
    }
    if ((r_n == 3u) && (r_b[0] == 0u) && frame_check_good()) {
        COVER1("part1-sync");
        e_sync = 1u;
    }
}

/* One byte on the line at time t (t >= r_t): the reference, then the slave, then the comparison. */
static void line_byte(uint8_t b, uint32_t t)
{
    expect_none();
    uint32_t const d = t - r_t;
    uint8_t const ended_counter = r_b[1]; /* of the frame this byte may end */
    uint32_t const ended_t_first = r_t_first;
    if (d >= GAP_END) {
        if (r_state == R_FRAME) {
            ref_end(false);
        }
        r_state = R_FRAME;
        r_n = 0u;
        r_t_first = t;
    } else if ((r_state == R_FRAME) && (d > GAP_BREAK)) {
        if (r_b[0] == NODE) {
            COVER1("part1-addressed-frame-broken");
        }
        r_state = R_DISCARD;
    } else {
        /* joins the frame in progress, or is discarded with it */
    }
    r_t = t;
    if (r_state == R_FRAME) {
        URB_ASSUME(r_n < URB_NMAX); /* the bound on a frame's bytes */
        r_b[r_n] = b;
        r_n++;
        if ((r_n == 4u) && (r_b[0] == NODE) && ((r_b[1] & 0xF8u) == 0u) && (in_size[r_b[1] & 7u] != 0u)) {
            e_begin = 1u; /* the second data position of an addressed write */
        }
    }
    bool const ends_before = d >= GAP_END;
    URB_COST_BEGIN();
    urb_rs485_slave_rx(&s, b, t);
    if (ends_before) {
        URB_COST_END(FW_RS485_LATE_END_BUDGET);
    } else {
        URB_COST_END(FW_RS485_BYTE_BUDGET);
    }
    URB_ASSERT(wake == t + GAP_END, "rx: the port is woken at the frame's t3.5 end (t3.5 + a character)");
    URB_ASSERT(n_begin == e_begin, "rx: a write begun exactly at an addressed write's second data byte");
    URB_ASSERT(n_commit == 0u && n_read == 0u && n_tx_start == 0u && n_end_whole == 0u,
               "rx: no commit, read or answer on a received byte");
    URB_ASSERT(n_end_cut == e_end_cut, "rx: an unfinished answer's read ended not complete at a frame's end");
    URB_ASSERT(n_sync == e_sync, "rx: SYNC exactly for a good 3-byte frame to address 0");
    if (n_sync != 0u) {
        URB_ASSERT(sync_counter == ended_counter && sync_t == ended_t_first, "rx: SYNC's counter and time stamp");
    }
    if ((r_state != R_FRAME) || (r_b[0] != NODE)) {
        URB_ASSERT(writing == NONE, "rx: no write open outside an addressed frame in progress");
    }
}

static void check_frame_end_calls(bool ended, uint8_t ended_sync_counter, uint32_t ended_t_first)
{
    URB_ASSERT(n_tx_start == e_tx, "answer: exactly for an addressed frame with a select byte ended at t3.5");
    URB_ASSERT(n_commit == e_commit, "commit: exactly a whole, good, addressed write of the inbox's size");
    URB_ASSERT(n_read == e_read, "read: begun exactly for a good addressed read of a set-up outbox");
    URB_ASSERT(n_end_cut == e_end_cut && n_end_whole == 0u, "read: an unfinished answer's read ended not complete");
    URB_ASSERT(n_fault_check == e_fault_check && n_fault_overrun == e_fault_overrun, "faults: CHECKSUM, OVERRUN with their answers");
    URB_ASSERT(n_sync == e_sync, "poll: SYNC exactly for a good 3-byte frame to address 0");
    if (n_sync != 0u) {
        URB_ASSERT(sync_counter == ended_sync_counter && sync_t == ended_t_first, "poll: SYNC's counter and time stamp");
    }
    if (ended) {
        URB_ASSERT(writing == NONE, "poll: no write open once a frame has ended");
    }
    if (e_commit_check) {
        URB_ASSERT(commit_box == e_box, "commit: the select byte's inbox");
        for (uint8_t i = 0u; i < URB_SZ; i++) {
            if (i < in_size[e_box]) {
                URB_ASSERT(committed[i] == r_b[2u + i], "commit: the frame's data bytes");
            }
        }
    }
    if (e_read != 0u) {
        URB_ASSERT(read_box == e_box, "read: the select byte's outbox");
    }
}

static void ev_poll(void)
{
    uint32_t const step = URB_NONDET_U32();
    URB_ASSUME(step <= 100u);
    now = ((now > r_t) ? now : r_t) + step;
    expect_none();
    bool const ends = (r_state == R_FRAME) && ((uint32_t)(now - r_t) >= GAP_END);
    uint8_t const counter = r_b[1];
    uint32_t const t_first = r_t_first;
    if (ends) {
        ref_end(true);
        r_state = R_IDLE;
    } else if ((r_state == R_DISCARD) && ((uint32_t)(now - r_t) >= GAP_END)) {
        r_state = R_IDLE;
    } else {
        /* nothing ends */
    }
    in_poll = true;
    URB_COST_BEGIN();
    urb_rs485_slave_poll(&s, now);
    URB_COST_END(FW_RS485_POLL_BUDGET);
    in_poll = false;
    check_frame_end_calls(ends, counter, t_first);
    if (n_tx_start != 0u) {
        URB_ASSERT((uint32_t)(now - r_t) >= GAP_END, "answer: begun t3.5 + a character after the request's last byte");
    }
}

/* A frame of 1..nmax bytes; `request`: a request to this node with its right check. */
static void ev_frame(uint8_t nmax, bool request)
{
    uint8_t const n = URB_NONDET_U8();
    URB_ASSUME((n >= 1u) && (n <= nmax));
    uint8_t b[URB_NMAX];
    URB_NONDET_BYTES(b, sizeof b);
    if (request) {
        URB_ASSUME((n >= 3u) && (b[0] == NODE));
    }
    if (request || URB_NONDET_BOOL()) {
        /* the right check over the bytes before it (the tier its length gives) */
        uint8_t const cl = urb_rs485_check_len(n);
        if (cl != 0u) {
            uint32_t const c = urb_link_check(NULL, 0u, b, (size_t)(n - cl));
            b[n - cl] = (uint8_t)c;
            if (cl == 2u) {
                b[n - 1u] = (uint8_t)(c >> 8);
            }
        }
    }
    for (uint8_t k = 0u; k < (uint8_t)URB_NMAX; k++) {
        if (k < n) {
            uint32_t const gap = URB_NONDET_U32();
            URB_ASSUME((gap >= CHAR_US) && (gap <= 100u));
            uint32_t const base = (now > r_t) ? now : r_t;
            now = base + gap;
            line_byte(b[k], now);
        }
    }
}

#if URB_PART == 2
static void ev_pull(void)
{
    expect_none();
    bool const more = a_active && (a_pos < a_total);
    uint8_t const pos = a_pos;
    uint8_t byte = 0u;
    URB_COST_BEGIN();
    bool const got = urb_rs485_slave_tx_next(&s, &byte);
    URB_COST_END(FW_RS485_BYTE_BUDGET);
    URB_ASSERT(got == more, "tx: a byte exactly while the answer has bytes left");
    URB_ASSERT(n_read == 0u && n_commit == 0u && n_tx_start == 0u && n_end_cut == 0u, "tx: no mailbox call but the read's end");
    if (!got) {
        URB_ASSERT(n_end_whole == 0u, "tx: nothing ended past the answer");
        return;
    }
    URB_ASSERT(byte == a_bytes[pos], "tx: the answer's header, data and check in order");
    a_pos++;
    bool const last = a_pos == a_total;
    URB_ASSERT(n_end_whole == ((last && (a_read != NONE)) ? 1u : 0u), "tx: a read ended complete exactly at its last byte");
    if (last) {
        URB_COVER("part2-answer-sent-whole");
        if (a_read != NONE) {
            URB_COVER("part2-read-ended-complete");
        }
        a_active = false;
    }
    if (URB_NONDET_BOOL()) {
        /* the echo, after any silence (the UART stalled: the answer may break or end) */
        uint32_t const gap = URB_NONDET_U32();
        URB_ASSUME((gap >= CHAR_US) && (gap <= 100u));
        uint32_t const base = (now > r_t) ? now : r_t;
        now = base + gap;
        URB_COVER("part2-echo-heard");
        if (a_active && (gap >= GAP_END)) {
            URB_COVER("part2-answer-cut-by-stall");
        }
        line_byte(byte, now);
    }
}
#endif

/* the latch is held only for the answer being sent */
static void check_latch(void)
{
    URB_ASSERT((latched == NONE) || (a_active && (a_read == latched)), "read: an outbox latched only while its answer is out");
    URB_ASSERT((latched != NONE) || !a_active || (a_read == NONE), "read: the answer's outbox latched while it is out");
}

void harness(void)
{
    static const urb_dl_mailbox_t ops = {NULL, inbox_size, outbox_size, write_begin, write_commit, write_abort,
                                         read_begin, read_end, sync, fault};
    mb = ops;
    hal.ctx = NULL;
    hal.tx_start = hal_tx_start;
    hal.tx_abort = NULL;
    hal.wake_at = hal_wake_at;
    hal.lock = NULL;
    for (uint8_t m = 0u; m < 8u; m++) {
        in_size[m] = URB_NONDET_U8();
        out_size[m] = URB_NONDET_U8();
        URB_ASSUME((in_size[m] <= URB_SZ) && (out_size[m] <= URB_SZ));
    }
    for (uint8_t m = 0u; m < 8u; m++) {
        for (uint8_t i = 0u; i < URB_SZ; i++) {
            outbox[m][i] = URB_NONDET_U8();
        }
    }
    writing = NONE;
    latched = NONE;
    a_active = false;
    a_read = NONE;
    urb_rs485_timing_t tm;
    urb_rs485_timing(&tm, 1000000u);
    URB_ASSERT(urb_rs485_slave_init(&s, &hal, &mb, (uint8_t)NODE, &tm, 0u), "init: node 20 on a complete HAL");
    URB_ASSERT(wake == GAP_END, "init: woken when the start-up silence has lasted t3.5");
    URB_ASSERT(GAP_END <= (uint32_t)tm.t35_us + tm.turnaround_us, "the deadline is within the turnaround");
    now = 0u;
#if URB_PART == 1
    /* each step: a frame or not, then a poll or not */
    for (uint8_t step = 0u; step < (uint8_t)URB_STEPS; step++) {
        if (URB_NONDET_BOOL()) {
            ev_frame((uint8_t)URB_NMAX, false);
            check_latch();
        }
        if (URB_NONDET_BOOL()) {
            ev_poll();
            check_latch();
        }
    }
#else
    /* a request to this node with a good check and the poll that answers it; some of the answer's
     * bytes pulled (each echoed or not, after any silence); then another frame of up to 3 bytes
     * (a read request, a probe, anything) and a poll, or not */
    ev_frame((uint8_t)URB_NMAX, true);
    ev_poll();
    check_latch();
    for (uint8_t k = 0u; k < (uint8_t)(ANS_MAX + 1u); k++) {
        if (URB_NONDET_BOOL()) {
            ev_pull();
            check_latch();
        }
    }
    if (URB_NONDET_BOOL()) {
        ev_frame(3u, false);
        check_latch();
        ev_poll();
        check_latch();
    }
#endif
}
