/*
 * Proof: the RS485 downlink master (firmware/downlink/rs485/urb_rs485_master.c, with the real frame
 * receiver urb_rs485_frame.c) against its contract (urb_rs485_master.h, Rs485Poll.tla) over every
 * sequence of line events of one transaction after urb_rs485_master_init at 1 Mb/s (character
 * 10 us, t1.5 15 us, t3.5 35 us, turnaround 90 us, transaction timeout 2000 us):
 * PART=1 (the request side):
 *   babble  a byte on the line before begin() or not (a babbler: the line may be busy at begin());
 *   begin   one transaction of operation URB_OP (READ 0, WRITE 1, SYNC 2, CLEAR 3, PROBE 4) to any
 *           address 1..127 and mailbox, URB_LEN_MIN..URB_LEN bytes of any contents;
 *   quiet   a poll at any later time while the line is busy, or not;
 *   request the UART pulls the request's bytes (tx_next) one by one; each is heard back (its echo)
 *           after any silence up to 200 us (a stall that breaks or ends the frame), as the byte sent
 *           or as any other byte (a collision), or not at all (a transceiver fault: nothing more);
 *   after   URB_AFTER byte(s) of anything or none (a colliding talker going on, noise, a late
 *           answer), each after any silence up to 200 us;
 * PART=2 (the answer side): begin() on a silent line, the request echoed as sent one character
 * apart, a poll at any time or not, then up to URB_ANS bytes, each the next byte of a node's
 * well-formed Rs485Response of any status, mailbox and data (the generated encoder's) or any byte,
 * each after any silence up to 200 us;
 * both parts end with two polls after the timeout and the node's turn (at least 136 us after the
 * last byte on the line).
 * Bounds: URB_LEN 1 (the fast tier: a read's answer of 3 bytes, a write of 4), URB_AFTER 1 (the
 * fast tier's PART=1,OP=0,AFTER=4 item: the request's length + 1, so a byte that breaks the request's
 * frame after its last byte, then another talker's frame of the request's length: issue #39's
 * untrue NO_NODE), URB_ANS = the longest answer (3 for a 1-byte read, 2 otherwise); the full tier's
 * PART=2,OP=1,LEN=32,LEN_MIN=32 item is the full-size write (36 bytes, CRC-16).
 * A reference receiver in the harness (urb_rs485.h's rules: a frame is the bytes between silences of
 * t3.5, a silence over t1.5 inside or a 37th byte discards it) tracks R, the frame that starts with
 * the first byte after tx_start (the request's first echo, or another talker's byte in its slot;
 * whatever joins it), and A, the frame after it (the answer).
 *
 * Properties (the contract):
 *  - exactly one status per transaction: poll() returns BUSY until it returns one status, then
 *    IDLE; the status has come by the second final poll; begin() is taken (the master was idle);
 *  - the status is true (Rs485Poll.tla StatusTruthful, DLK_004): OK only when R carried the
 *    request whole (every byte but possibly the last as sent, by whoever: the master hears only
 *    the line; the node's check decides the last) and
 *    A passed its check, decodes as an Rs485Response for the request's mailbox, with status OK (a
 *    read: with `length` bytes, which are then in data[]; a write: with none; a probe: any answer);
 *    a SYNC OK only when R holds its bytes (each as sent, by whoever: the master hears only the
 *    line); a CLEAR OK only after t3.5 of silence; NO_NODE only when R carried the request
 *    (whole and unbroken: Rs485Poll.tla NoNodeOnlyWhole) and nothing was heard for the node's
 *    whole turn (t3.5 + the turnaround after R's last byte); a node's refusal (NODE_BUSY,
 *    SIZE_MISMATCH, BAD_REQUEST, a write's or probe's CHECKSUM) only when A is a well-formed answer carrying it (a read's
 *    SIZE_MISMATCH also for an OK answer of another length); a read's CHECKSUM only when an answer
 *    was heard; BUS_STUCK (not executed) only when no node can have taken the request: R was broken,
 *    too short, for another address or failed its check (the cut frame that passes a check is
 *    TIMEOUT: Rs485Poll.tla ReachCutFrameStored); TIMEOUT says nothing;
 *  - the status names what happened: when R carried the request exactly and A ended whole, the
 *    status is the contract's decision for A (urb_rs485_master.h: garbled -> a read's CHECKSUM, a
 *    write's or probe's TIMEOUT; a refusal; SIZE_MISMATCH; OK), and with nothing heard NO_NODE (a
 *    SYNC: OK); an echo that differs from the byte sent before the last byte -> BUS_STUCK or TIMEOUT;
 *  - the line rules (OnlyPolledNodeTalks, DLK_004): tx_start only after t3.5 of silence on the line
 *    (never into a frame or a node's turn), at most once per transaction (no request sent twice);
 *    tx_next gives exactly the request's bytes in order (address, select with the read bit, the
 *    data, the link_check at the tier its length gives; SYNC: address 0, counter, check), nothing
 *    after the request or after tx_abort, and tx_abort at the first echo that differs;
 *  - the bridge's own echo is never counted as babble, and a byte before begin() is (DLK_005);
 *  - no out-of-bounds access (data[] is its own object of `length` bytes), overflow or undefined
 *    shift; the HAL's lock calls pair up;
 *  - budgets: urb_rs485_master_rx and tx_next within one character at 1 Mb/s (480 cycles), a byte
 *    that ends a frame (it may judge the answer) within four (below); begin() and poll() within
 *    the bridge master's call budget (FW_BRIDGE_MASTER_CALL_BUDGET, two I2C bytes, 2160 cycles).
 *    These hold for the bounds below (payloads of URB_LEN bytes), not for a 32-byte read's answer.
 * Not modelled: the UART pulling a byte ahead of the previous echo (the harness alternates pull and
 * echo), babble during the QUIET wait after begin() (a line held busy for the whole 2000-us timeout
 * needs about 45 bytes: QUIET's BUS_STUCK is the cmocka tests'), timestamps that wrap.
 * The CRC steps are cheap stand-ins (stubs/fw_rs485_crc_stub.c, used by the receiver, the encoders
 * and the reference alike); fw_rs485_frame proves the receiver's verdict with the real CRCs.
 */
/* lobster-trace: urb.DLK_004 (the requirement this proof verifies; its babble count, DLK_005, is
 * checked too, but DLK_005 is verified by model checking) */
#include "urb_verify.h"

#include "../stubs/fw_budgets.h"
#include "urb_core.h"
#include "urb_rs485_master.h"
#include "urb_runtime.h"

URB_PROOF_COST_STORAGE;

/* A byte that ends a frame may judge the answer there (decode, copy to data[]): four characters.
 * It comes after t3.5 + a character of silence (4.5 idle characters), and the bytes after it wait
 * in the UART's 8-byte FIFO. Two characters (the slave's budget) are not enough: the proof's first
 * run found 1216 cycles for a byte ending a 1-byte read's answer (its decode alone about 500). */
#define FW_RS485_LATE_END_BUDGET (4u * FW_RS485_BYTE_BUDGET)

#ifndef URB_OP
#define URB_OP 0
#endif
#ifndef URB_LEN
#define URB_LEN 1u
#endif
#ifndef URB_LEN_MIN
#define URB_LEN_MIN 1u
#endif
/* the request's bytes: a write of URB_LEN (CRC-8 up to 12 data bytes, CRC-16 from 13), else 3 */
#if URB_OP == 1
#define REQ_MAX ((URB_LEN <= 12u) ? (URB_LEN + 3u) : (URB_LEN + 4u))
#elif URB_OP == 3
#define REQ_MAX 1u
#else
#define REQ_MAX 3u
#endif
#ifndef URB_AFTER
#define URB_AFTER 1u /* part 1: bytes after the request */
#endif
#ifndef URB_ANS
#if URB_OP == 0
#define URB_ANS (URB_LEN + 2u) /* a read's answer: status, data, CRC-8 */
#else
#define URB_ANS 2u /* an empty answer: status, CRC-8 */
#endif
#endif
#define R_CAP (REQ_MAX + ((URB_ANS > URB_AFTER) ? URB_ANS : URB_AFTER))
/* A's bytes: part 1's bytes after the request may all fall in A (AFTER over ANS: the item with the
 * bytes after a break, below) */
#if (URB_PART == 1) && (URB_AFTER > URB_ANS)
#define A_CAP URB_AFTER
#else
#define A_CAP URB_ANS
#endif
#define PLAN_CAP (URB_LEN + 4u)

#define CHAR_US 10u
#define GAP_END 45u     /* a byte this long after the previous one starts a frame: t3.5 + a character */
#define GAP_BREAK 25u   /* longer than this (a character + t1.5) and shorter than GAP_END: breaks */
#define NODE_TURN 125u  /* t3.5 + the turnaround: the node's answer starts by then */
#define WAIT_LIMIT 135u /* the master's wait for an answer: t3.5 + turnaround + a character */
#define TIMEOUT_US 2000u
#define GAP_MAX 200u
#define NOFRAME 0xFFu

#define OP_READ 0u
#define OP_WRITE 1u
#define OP_SYNC 2u
#define OP_CLEAR 3u
#define OP_PROBE 4u
#define ADDRESSED ((URB_OP == 0) || (URB_OP == 1) || (URB_OP == 4))

#ifndef URB_PART
#define URB_PART 1
#endif
/* cover points: in the read items of both parts (the fast tier's items; part 1's with one byte
 * after the request: the AFTER=4 item's reach run is the plain vacuity check, which keeps it cheap) */
#if (URB_PART == 1) && (URB_OP == 0) && (URB_AFTER == 1)
#define COVER1(name) URB_COVER(name)
#else
#define COVER1(name) ((void)0)
#endif
#if (URB_PART == 2) && (URB_OP == 0)
#define COVER2(name) URB_COVER(name)
#else
#define COVER2(name) ((void)0)
#endif

static urb_rs485_master_t m;
static urb_rs485_hal_t hal;
static urb_downlink_t dl;
static uint32_t now;
static uint8_t data[URB_LEN]; /* the caller's buffer: its own object, `length` bytes used */
static uint8_t sent_data[URB_LEN];
static uint8_t len, address, mailbox;

/* ----- the HAL ----- */
static bool locked;
static bool in_call; /* inside begin() or poll() (tx_start is theirs) */
static uint8_t n_tx_start, n_tx_abort;
static uint32_t line_t; /* the last byte on the line (start-up: 0, the receiver waits for t3.5) */

static void hal_tx_start(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(in_call, "tx: started by begin() or poll() only");
    URB_ASSERT((uint32_t)(now - line_t) >= GAP_END, "tx: started only after t3.5 of silence on the line");
    URB_ASSERT(n_tx_start == 0u, "tx: a request is sent at most once");
    URB_ASSERT(URB_OP != 3, "tx: CLEAR sends nothing");
    n_tx_start++;
}

static void hal_tx_abort(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(n_tx_start != 0u, "tx: abort only after start");
    n_tx_abort++;
}

static void hal_lock(void *ctx, bool on)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    URB_ASSERT(on != locked, "lock: lock and unlock pair up");
    locked = on;
}

/* ----- the contract's request ----- */
static uint8_t req[REQ_MAX];
static uint8_t req_n;

static void plan_request(uint8_t counter)
{
    uint8_t n = 0u;
#if URB_OP == 3
    (void)counter;
    req[0] = 0u;
#else
#if URB_OP == 2
    req[0] = 0u;
    req[1] = counter;
    n = 2u;
#else
    (void)counter;
    req[0] = address;
    req[1] = (uint8_t)(((URB_OP == 0) ? 0x80u : 0u) | ((URB_OP == 4) ? 0u : mailbox));
    n = 2u;
#if URB_OP == 1
    for (uint8_t i = 0u; i < URB_LEN; i++) {
        if (i < len) {
            req[n] = sent_data[i];
            n++;
        }
    }
#endif
#endif
    uint8_t const cl = (n <= 14u) ? 1u : 2u;
    uint32_t const c = urb_link_check(NULL, 0u, req, n);
    req[n] = (uint8_t)c;
    if (cl == 2u) {
        req[n + 1u] = (uint8_t)(c >> 8);
    }
    n = (uint8_t)(n + cl);
    URB_ASSERT(urb_rs485_check_len(n) == cl, "the reference request's check tier");
#endif
    req_n = n;
}

/* ----- the reference receiver: R (from the first echo) and A (the frame after it) ----- */
static uint8_t fcur = NOFRAME; /* 0 while R, 1 while A, 2 after; NOFRAME before the first echo */
static bool f_open;            /* the frame in progress is being taken (not broken) */
static uint8_t fcount;         /* bytes of the frame in progress */
static uint8_t rb[R_CAP], rn;
static bool r_broken;
static uint32_t r_t_last;
static uint8_t ab[A_CAP], an;
static bool a_started, a_broken;
static uint8_t echo_good; /* leading echoes as sent, each joining the frame (R holds them) */
static uint8_t echo_same; /* leading echoes as sent, none breaking the frame (one may split it) */
static bool echo_differed; /* an echo differed (or broke the frame) before the request's last byte */
static bool wait_expired;  /* a poll came after the node's turn with R ended and nothing heard */

static void frame_broken(void)
{
    f_open = false;
    if (fcur == 0u) {
        r_broken = true;
    } else if (fcur == 1u) {
        a_broken = true;
    } else {
        /* later frames are not judged */
    }
}

static void line_byte(uint8_t b, uint32_t t, bool own)
{
    uint32_t const d = t - line_t;
    line_t = t;
    if (fcur == NOFRAME) {
        if (!own && (n_tx_start == 0u)) {
            return; /* before the request: babble */
        }
        /* the first byte after tx_start: the request's first echo, or another talker's byte in its
         * slot when the echo is lost (the master hears only the line; found by the AFTER=4 item,
         * 2026-11-30: a talker sending the request's bytes was a request the reference missed) */
        URB_ASSERT(d >= GAP_END, "the request's first byte starts a frame");
        fcur = 0u;
        f_open = true;
        fcount = 0u;
    } else if (d >= GAP_END) {
        if (fcur < 2u) {
            fcur++;
        }
        if (fcur == 1u) {
            a_started = true;
        }
        f_open = true;
        fcount = 0u;
    } else if (f_open && (d > GAP_BREAK)) {
        frame_broken();
    } else {
        /* joins the frame in progress, or is discarded with it */
    }
    if (!f_open) {
        return;
    }
    if (fcount >= URB_RS485_MAX_FRAME) {
        frame_broken(); /* a 37th byte: longer than any frame */
        return;
    }
    fcount++;
    if (fcur == 0u) {
        URB_ASSUME(rn < R_CAP);
        rb[rn] = b;
        rn++;
        r_t_last = t;
    } else if (fcur == 1u) {
        URB_ASSUME(an < A_CAP);
        ab[an] = b;
        an++;
    } else {
        /* later frames are not judged */
    }
}

static bool ended(uint8_t frame)
{
    return (fcur != NOFRAME) && ((fcur > frame) || ((fcur == frame) && ((uint32_t)(now - line_t) >= GAP_END)));
}

static bool check_good(const uint8_t *b, uint8_t n)
{
    uint8_t const cl = urb_rs485_check_len(n);
    if (cl == 0u) {
        return false;
    }
    uint32_t const c = urb_link_check(NULL, 0u, b, (size_t)(n - cl));
    bool good = b[n - cl] == (uint8_t)c;
    if (cl == 2u) {
        good = good && (b[n - 1u] == (uint8_t)(c >> 8));
    }
    return good;
}

/* A node may have taken R: it ended whole with a select byte, its check passes, and it is for the
 * polled node (the address byte). */
static bool r_may_be_taken(void)
{
    return ended(0u) && !r_broken && (rn >= 3u) && check_good(rb, rn) && (rb[0] == req[0]);
}

/* R carried the request: every byte but possibly the last as sent, by whoever (the master hears only
 * the line: its echo lost, a talker sending the same bytes in their slots is the same frame to
 * every node; found by the AFTER=4 item, 2026-11-30: the own echoes alone, echo_good, were too
 * strong), nothing joined. */
static bool r_carried_request(void)
{
    bool same = ended(0u) && !r_broken && (rn == req_n);
    for (uint8_t i = 0u; (uint8_t)(i + 1u) < (uint8_t)REQ_MAX; i++) {
        if ((uint8_t)(i + 1u) < req_n) {
            same = same && (rb[i] == req[i]);
        }
    }
    return same;
}

/* R holds the request's bytes: the line carried them, each as sent (by whoever: a SYNC's last echo
 * lost while another talker sends the same value in its slot is the same frame to every node), at
 * the start of one frame that ended whole (bytes joining after them: SYNC OK all the same, as
 * urb_rs485_master.h says, "OK once sent"). What the master, which hears only the line, can know. */
static bool r_holds_request(void)
{
    bool same = ended(0u) && !r_broken && (rn >= req_n);
    for (uint8_t i = 0u; i < (uint8_t)REQ_MAX; i++) {
        if (i < req_n) {
            same = same && (i < rn) && (rb[i] == req[i]);
        }
    }
    return same;
}

/* ----- the status ----- */
static uint8_t statuses;
static urb_rs485_response_t ar;
static bool a_valid; /* A ended whole, passed its check, decodes, names the request's mailbox */

static void judge_answer(void)
{
    a_valid = ended(1u) && !a_broken && check_good(ab, an) && (urb_rs485_response_decode(&ar, ab, an) >= 0) &&
              (ar.mailbox == ((URB_OP == 4) ? 0u : mailbox));
}

static bool refusal(uint8_t s)
{
    return (s == URB_STATUS_NODE_BUSY) || (s == URB_STATUS_CHECKSUM) || (s == URB_STATUS_SIZE_MISMATCH) ||
           (s == URB_STATUS_BAD_REQUEST);
}

/* urb_rs485_master.h's decision for a whole answer A */
static uint8_t decision(void)
{
    uint8_t const garbled = (URB_OP == 0) ? (uint8_t)URB_STATUS_CHECKSUM : (uint8_t)URB_STATUS_TIMEOUT;
    if (!a_valid) {
        return garbled;
    }
    if (URB_OP == 4) {
        return URB_STATUS_OK;
    }
    if (ar.status == URB_STATUS_OK) {
        if (URB_OP == 0) {
            return (ar.data_len == len) ? (uint8_t)URB_STATUS_OK : (uint8_t)URB_STATUS_SIZE_MISMATCH;
        }
        return (ar.data_len == 0u) ? (uint8_t)URB_STATUS_OK : garbled;
    }
    return ((ar.data_len == 0u) && refusal(ar.status)) ? ar.status : garbled;
}

/* The reference's state when the status came (the frames only grow after it, so R's and A's bytes
 * up to rn and an stay as they were): the status is judged once, at the end (one copy of the
 * reference's checks instead of one per poll). */
static uint8_t st_value;
static uint32_t st_now, st_line_t;
static uint8_t st_fcur, st_rn, st_an, st_echo_good, st_echo_same;
static bool st_r_broken, st_a_broken, st_a_started, st_echo_differed, st_wait_expired;

static void status_reported(uint8_t s)
{
    URB_ASSERT(statuses == 0u, "poll: exactly one status per transaction");
    statuses++;
    st_value = s;
    st_now = now;
    st_line_t = line_t;
    st_fcur = fcur;
    st_rn = rn;
    st_an = an;
    st_echo_good = echo_good;
    st_echo_same = echo_same;
    st_r_broken = r_broken;
    st_a_broken = a_broken;
    st_a_started = a_started;
    st_echo_differed = echo_differed;
    st_wait_expired = wait_expired;
}

/* The status against what the line carried (the state restored from the snapshot). */
static void status_judged(void)
{
    uint8_t const s = st_value;
    now = st_now;
    line_t = st_line_t;
    fcur = st_fcur;
    rn = st_rn;
    an = st_an;
    echo_good = st_echo_good;
    echo_same = st_echo_same;
    r_broken = st_r_broken;
    a_broken = st_a_broken;
    a_started = st_a_started;
    echo_differed = st_echo_differed;
    wait_expired = st_wait_expired;
    judge_answer();
    bool const exact = r_carried_request() && (echo_good == req_n);
    if (s == URB_STATUS_OK) {
#if URB_OP == 2
        URB_ASSERT(r_holds_request(), "SYNC OK: the line carried the SYNC's bytes");
#elif URB_OP == 3
        URB_ASSERT((uint32_t)(now - line_t) >= GAP_END, "CLEAR OK: only after t3.5 of silence");
#else
        URB_ASSERT(r_carried_request(), "OK: the line carried the request");
        URB_ASSERT(a_valid, "OK: the answer passed its check and names the request's mailbox");
#if URB_OP == 0
        URB_ASSERT((ar.status == URB_STATUS_OK) && (ar.data_len == len), "read OK: an OK answer of length bytes");
        for (uint8_t i = 0u; i < URB_LEN; i++) {
            if (i < len) {
                URB_ASSERT(data[i] == ar.data[i], "read OK: data holds the answer's bytes");
            }
        }
        COVER2("read-ok");
#elif URB_OP == 1
        URB_ASSERT((ar.status == URB_STATUS_OK) && (ar.data_len == 0u), "write OK: an OK answer without data");
#else
#endif
#endif
    } else if (s == URB_STATUS_NO_NODE) {
        URB_ASSERT(ADDRESSED && r_carried_request() && !a_started && ((uint32_t)(now - r_t_last) > NODE_TURN),
                   "NO_NODE: the request went out and the line was silent for the node's whole turn");
        COVER1("no-node");
    } else if (s == URB_STATUS_BUS_STUCK) {
        URB_ASSERT(!r_may_be_taken(), "BUS_STUCK: no node can have taken what the line carried");
        if (echo_differed) {
            COVER1("cut-bus-stuck");
        }
        if ((echo_good == req_n) && r_broken) {
            COVER1("broken-after-request-bus-stuck"); /* Rs485Poll.tla ReachBrokenAfterSent */
        }
    } else if (s == URB_STATUS_TIMEOUT) {
        if (echo_differed && r_may_be_taken()) {
            COVER1("cut-frame-taken-timeout"); /* Rs485Poll.tla ReachCutFrameStored */
        }
        if (a_broken) {
            COVER2("answer-broken-timeout");
        }
    } else {
        URB_ASSERT(refusal(s), "poll: only the contract's statuses");
        URB_ASSERT(ADDRESSED && r_carried_request(), "a node's status: only after the line carried the request");
        if ((URB_OP == 0) && (s == URB_STATUS_CHECKSUM)) {
            URB_ASSERT(a_started, "read CHECKSUM: an answer was heard");
            if (!a_valid) {
                COVER2("garbled-checksum");
            }
        } else if ((URB_OP == 0) && (s == URB_STATUS_SIZE_MISMATCH) && a_valid && (ar.status == URB_STATUS_OK)) {
            URB_ASSERT(ar.data_len != len, "read SIZE_MISMATCH: an OK answer of another length");
            COVER2("size-mismatch");
        } else {
            URB_ASSERT(a_valid && (ar.status == s) && (ar.data_len == 0u), "a refusal: only a well-formed answer carrying it");
            COVER2("refused");
        }
    }
    if (echo_differed) {
        URB_ASSERT((s == URB_STATUS_BUS_STUCK) || (s == URB_STATUS_TIMEOUT) || (URB_OP == 3),
                   "an echo that differs before the last byte: BUS_STUCK or TIMEOUT");
    }
    if (exact && ADDRESSED && !wait_expired && a_started && ended(1u) && !a_broken) {
        URB_ASSERT(s == decision(), "the status is the contract's decision for a whole answer");
    }
    if (exact && !a_started) {
        URB_ASSERT(s == ((URB_OP == 2) ? (uint8_t)URB_STATUS_OK : (uint8_t)URB_STATUS_NO_NODE),
                   "with nothing heard after the request: NO_NODE (SYNC: OK)");
    }
}

static void do_poll(void)
{
    if (ended(0u) && !a_started && ((uint32_t)(now - r_t_last) > WAIT_LIMIT)) {
        wait_expired = true;
    }
    in_call = true;
    URB_COST_BEGIN();
    int8_t const out = dl.poll(dl.ctx, now);
    URB_COST_END(FW_BRIDGE_MASTER_CALL_BUDGET);
    in_call = false;
    URB_ASSERT(!locked, "lock: released at the end of poll()");
    if (out >= 0) {
        status_reported((uint8_t)out);
    } else if (out == URB_DOWNLINK_IDLE) {
        URB_ASSERT(statuses == 1u, "poll: IDLE only after the status");
    } else {
        URB_ASSERT(out == URB_DOWNLINK_BUSY, "poll: BUSY, IDLE or a status");
        URB_ASSERT(statuses == 0u, "poll: BUSY only before the status");
    }
}

static void poll_later(uint32_t max_step)
{
    uint32_t const step = URB_NONDET_U32();
    URB_ASSUME(step <= max_step);
    now = ((now > line_t) ? now : line_t) + step;
    do_poll();
}

static void rx_at(uint8_t b, uint32_t t, bool own)
{
    bool const ends_frame = (uint32_t)(t - line_t) >= GAP_END;
    uint32_t const babble0 = m.stats.babble;
    line_byte(b, t, own);
    now = t;
    URB_COST_BEGIN();
    urb_rs485_master_rx(&m, b, t);
    if (ends_frame) {
        URB_COST_END(FW_RS485_LATE_END_BUDGET);
    } else {
        URB_COST_END(FW_RS485_BYTE_BUDGET);
    }
    if (own) {
        URB_ASSERT(m.stats.babble == babble0, "babble: the bridge's own echo is never babble");
    }
}

static uint32_t gap_after(uint32_t min)
{
    uint32_t const gap = URB_NONDET_U32();
    URB_ASSUME((gap >= min) && (gap <= GAP_MAX));
    return ((now > line_t) ? now : line_t) + gap;
}

/* The UART pulls the request; each byte is echoed (part 1: as sent or not, after any silence, or
 * nothing more is heard; part 2: as sent, one character after the previous one). */
static void request_phase(void)
{
    uint8_t pulled = 0u;
    bool heard = true;
    for (uint8_t i = 0u; i < (uint8_t)REQ_MAX; i++) {
        if (!heard) {
            break;
        }
        bool const more = (n_tx_start != 0u) && (n_tx_abort == 0u) && (pulled < req_n);
        uint8_t b = 0u;
        URB_COST_BEGIN();
        bool const got = urb_rs485_master_tx_next(&m, &b);
        URB_COST_END(FW_RS485_BYTE_BUDGET);
        URB_ASSERT(got == more, "tx: a byte exactly while the request has bytes left and was not aborted");
        if (!got) {
            break;
        }
        URB_ASSERT(b == req[pulled], "tx: the request's bytes in order (address, select, data, check)");
        pulled++;
#if URB_PART == 1
        heard = URB_NONDET_BOOL();
        if (heard) {
            uint8_t const echo = URB_NONDET_BOOL() ? b : URB_NONDET_U8();
            uint32_t const t = gap_after(CHAR_US);
#else
        {
            uint8_t const echo = b;
            uint32_t const t = ((pulled == 1u) ? now : line_t) + CHAR_US;
#endif
            uint32_t const d = t - line_t;
            bool const first = pulled == 1u;
            bool const breaks = !first && (d > GAP_BREAK) && (d < GAP_END);
            bool const differs = (echo != b) || breaks;
            bool const all_before = echo_same + 1u == pulled; /* every earlier echo as sent */
            if (all_before && !differs) {
                echo_same = pulled;
                if (first || (d <= GAP_BREAK)) {
                    echo_good = (echo_good + 1u == pulled) ? pulled : echo_good;
                }
            } else if (all_before && (pulled < req_n)) {
                echo_differed = true;
            } else if (all_before) {
                COVER1("collision-on-last-byte");
            } else {
                /* after an earlier difference the master has stopped sending */
            }
            uint8_t const aborts0 = n_tx_abort;
            rx_at(echo, t, true);
            if (all_before && differs) {
                URB_ASSERT(n_tx_abort == (uint8_t)(aborts0 + 1u), "tx: aborted at the first echo that differs");
            }
        }
    }
    if (heard && (pulled == req_n) && (echo_good == req_n)) {
        COVER1("request-echoed-whole");
    }
}

/* After the request: part 1 up to URB_AFTER bytes of anything (noise, a colliding talker going on,
 * a late answer); part 2 a poll or not, then up to URB_ANS bytes, each the next byte of a node's
 * well-formed answer or any byte. Each after any silence up to GAP_MAX. */
static void after_phase(void)
{
#if URB_PART == 1
    for (uint8_t k = 0u; k < (uint8_t)URB_AFTER; k++) {
        if (URB_NONDET_BOOL()) {
            rx_at(URB_NONDET_U8(), gap_after(CHAR_US), false);
        }
    }
#else
    urb_rs485_response_t plan;
    plan.status = URB_NONDET_U8();
    plan.mailbox = URB_NONDET_U8();
    plan.data_len = URB_NONDET_U8();
    URB_ASSUME(plan.data_len <= URB_LEN);
    for (uint8_t i = 0u; i < URB_LEN; i++) {
        plan.data[i] = URB_NONDET_U8();
    }
    uint8_t planned[PLAN_CAP];
    int32_t const pn = urb_rs485_response_encode(&plan, planned, sizeof planned);
    if (URB_NONDET_BOOL()) {
        poll_later(GAP_MAX);
    }
    for (uint8_t k = 0u; k < (uint8_t)URB_ANS; k++) {
        if (URB_NONDET_BOOL()) {
            bool const answer_byte = (pn > (int32_t)k) && URB_NONDET_BOOL();
            uint8_t const b = answer_byte ? planned[k] : URB_NONDET_U8();
            rx_at(b, gap_after(CHAR_US), false);
        }
    }
#endif
}

static void begin_transaction(void)
{
    len = URB_NONDET_U8();
    URB_ASSUME((len >= URB_LEN_MIN) && (len <= URB_LEN));
    address = URB_NONDET_U8();
    URB_ASSUME((address >= 1u) && (address <= 127u));
    mailbox = URB_NONDET_U8();
    URB_ASSUME(mailbox <= 7u);
    uint8_t const counter = URB_NONDET_U8();
    for (uint8_t i = 0u; i < URB_LEN; i++) {
        sent_data[i] = URB_NONDET_U8();
        data[i] = (URB_OP == 1) ? sent_data[i] : URB_NONDET_U8();
    }
    plan_request(counter);
    urb_downlink_txn_t txn;
    txn.op = (uint8_t)URB_OP;
    txn.address = address;
    txn.mailbox = mailbox;
    txn.length = len;
    txn.counter = counter;
    txn.reselect = false;
    txn.data = data;
    in_call = true;
    URB_COST_BEGIN();
    bool const taken = dl.begin(dl.ctx, &txn, now);
    URB_COST_END(FW_BRIDGE_MASTER_CALL_BUDGET);
    in_call = false;
    URB_ASSERT(taken, "begin: taken by an idle master");
    URB_ASSERT(!locked, "lock: released at the end of begin()");
}

void harness(void)
{
    hal.ctx = NULL;
    hal.tx_start = hal_tx_start;
    hal.tx_abort = hal_tx_abort;
    hal.wake_at = NULL;
    hal.lock = hal_lock;
    urb_rs485_master_init(&m, &hal, 1000000u, 0u);
    urb_rs485_master_downlink(&m, &dl);
    URB_ASSERT(m.timeout_us == TIMEOUT_US, "init: the timeout at 1 Mb/s");
    now = 0u;
    line_t = 0u;
#if URB_PART == 1
    /* a babbler before begin() */
    if (URB_NONDET_BOOL()) {
        uint32_t const t = URB_NONDET_U32();
        URB_ASSUME(t <= 60u);
        uint8_t const b = URB_NONDET_U8();
        uint32_t const babble0 = m.stats.babble;
        line_byte(b, t, false);
        now = t;
        urb_rs485_master_rx(&m, b, t);
        URB_ASSERT(m.stats.babble == babble0 + 1u, "babble: a byte while nobody was polled is counted");
        COVER1("babble-counted");
    }
    uint32_t const step = URB_NONDET_U32();
    URB_ASSUME(step <= 100u);
    now = line_t + step;
#else
    now = 100u; /* the line has been silent since start-up */
#endif
    uint32_t const t0 = now;
    begin_transaction();
#if URB_PART == 1
    if (n_tx_start == 0u) {
        COVER1("waited-for-silence");
        if (URB_NONDET_BOOL()) {
            poll_later(100u); /* the line is busy: a poll when it may be silent */
        }
    }
#endif
    request_phase();
    after_phase();

    /* the final polls: after the timeout and the node's turn */
    uint32_t const last = ((uint32_t)(t0 + TIMEOUT_US) > line_t) ? (uint32_t)(t0 + TIMEOUT_US) : line_t;
    uint32_t const after = URB_NONDET_U32();
    URB_ASSUME(after <= 50u);
    now = last + WAIT_LIMIT + 1u + after;
    do_poll();
    uint32_t const after2 = URB_NONDET_U32();
    URB_ASSUME(after2 <= 50u);
    now = now + after2;
    do_poll();
    URB_ASSERT(statuses == 1u, "poll: the status has come by the second poll after the timeout");
    status_judged();
}
