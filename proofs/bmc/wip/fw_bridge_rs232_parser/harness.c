/*
 * Proof of the RS232 uplink parser (firmware/bridge/bridge_uplink.c): the UART interrupt
 * urb_bridge_uart_rx() (timestamps, idle-gap flag, receive ring) and the main loop's
 * urbb_uart_drain() (frame assembly, hunting, idle flush), over arbitrary byte streams.
 *
 * Admission (urbb_frame, bridge.c) is replaced by a recorder that decides exactly as bridge.c
 * does: a candidate is a frame when the generated strict decoder does not report CHECKSUM, SHORT
 * or LONG (the FIFO proof covers what admission does with it). The decoders and the CRC are the
 * real generated code, cost-instrumented.
 *
 * Part 1, streams. FW_BYTES arbitrary bytes arrive at arbitrary distances (any 32-bit start time,
 * so the microsecond clock may wrap); the main loop drains after any of them at an arbitrary time
 * before the next byte, and once at the end after a long idle time. Properties:
 *   no overrun      every buffer access is in bounds (ESBMC), the assembler never holds more than
 *                   URB_BRIDGE_FRAME_MAX bytes;
 *   exactly the frames of the reference: the frames passed to admission are, in order, those of
 *                   an index-based reference parser over the whole stream (hunt: a complete
 *                   candidate that fails its check loses its first byte; idle gap: an incomplete
 *                   candidate loses its first byte and the complete frames behind it still count).
 *                   So only complete, checked candidates are admitted, each once, in stream
 *                   order, never spanning an idle gap, and hunting and gap resync lose no frame
 *                   the reference finds.
 * Part 2, cost. From any assembler state (any len <= FRAME_MAX - 1, any bytes), one byte arrives
 * (with or without a gap) and the main loop drains at any time. A byte can trigger up to 37 hunt
 * rounds, so the per-byte bound is amortised (potential method, potential FW_HUNT_ROUND_CYCLES per
 * byte held): actual cycles + FW_HUNT_ROUND_CYCLES x (len after - len before) must fit the budget.
 * Summed over any stream the potential telescopes (it starts at 0 and never goes negative), so the
 * main loop spends at most FW_COST_BUDGET cycles per received byte on average, whatever the bytes.
 */
#include "urb_verify.h"

#include "bridge_internal.h"
#include "urb_core.h"
#include "urb_runtime.h"

#include "../stubs/fw_budgets.h"

#define FW_COST_BUDGET FW_BRIDGE_RS232_BYTE_BUDGET

#ifndef FW_BYTES
#define FW_BYTES 8u /* stream length of part 1 */
#endif
#ifndef FW_HELD_MAX
#define FW_HELD_MAX 36u /* part 2: bytes held by the assembler before the byte arrives */
#endif
/* Frames the abstract check folds: part 1 sees none longer than its stream. */
#if defined(URB_PART) && (URB_PART == 1)
#define FW_FRAME_BOUND FW_BYTES
#else
#define FW_FRAME_BOUND (FW_HELD_MAX + 1u)
#endif
#ifndef FW_DECODE_CYCLES
/* Cycles of urbb_frame's decoding of an n-byte candidate (call, header, CRC over n - 1 bytes at
 * most, payload copy): proved by part 3 from the cost model. */
#define FW_DECODE_CYCLES(n) (800u + 52u * (uint32_t)(n))
#endif
#ifndef FW_HUNT_ROUND_CYCLES
/* Potential per byte held: at least one hunt round on the longest candidate (loop step,
 * candidate_len, urbb_frame on 37 bytes = FW_DECODE_CYCLES(37), discarding one byte of 37). */
#define FW_HUNT_ROUND_CYCLES 3300u
#endif
#define FW_BYTE_US 87u   /* one character at 115200 Bd (10 bits, rounded up) */
#define FW_GAP_US 261u   /* rx_gap_us: byte time + the default idle gap (2 byte times) */
#define FW_MAX_DELTA 5000u
#define FW_MAX_FRAMES (FW_BYTES / 4u + 1u)

URB_PROOF_COST_STORAGE;

static urb_bridge_t bridge;
static uint8_t stream[FW_BYTES];
static bool gap_before[FW_BYTES]; /* the line was idle longer than the gap before byte k */

/* What the parser handed to admission. */
static uint8_t got_len[FW_MAX_FRAMES];
static uint8_t got_first[FW_MAX_FRAMES];
static uint8_t got_last[FW_MAX_FRAMES];
static uint8_t got_count;
static bool record = true;

/* The frame check, abstracted: by data independence the parser must be right for every check
 * function, so the proof uses an arbitrary one (a key per length, fixed per run, folded with the
 * covered bytes) instead of the CRC: cheap for the solver, and a function of the whole candidate,
 * so the reference and the firmware see the same verdict for the same bytes. Length rules as in
 * the strict decoders: a read is 4 bytes, a write 3 + its length field + 1 or 2 check bytes. */
static uint8_t key[URB_BRIDGE_FRAME_MAX + 1u];

static bool fw_is_frame(const uint8_t *frame, uint8_t len)
{
    uint8_t want;
    if ((frame[0] & 1u) != 0u) {
        want = 4u;
    } else if ((len < 3u) || (frame[2] > 32u)) {
        return false;
    } else {
        want = (uint8_t)(3u + frame[2] + ((3u + frame[2] <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u));
    }
    if (len != want) {
        return false;
    }
    uint8_t fold = key[len];
    for (uint8_t k = 0u; k < FW_FRAME_BOUND; k++) {
        if ((uint8_t)(k + 1u) < len) {
            fold = (uint8_t)(fold ^ frame[k]);
        }
    }
    return frame[len - 1u] == fold;
}

bool urbb_frame(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    URB_ASSERT(b == &bridge, "admission: the bridge under proof");
    URB_ASSERT(uplink == URBB_UPLINK_RS232, "admission: RS232 frames come from the RS232 uplink");
    URB_ASSERT((len >= 4u) && (len <= URB_BRIDGE_FRAME_MAX), "admission: a candidate of a request's length");
    URB_ASSERT(frame == b->rs232.buf, "admission: the candidate starts the assembler's buffer");
    URB_ASSERT(len <= b->rs232.len, "admission: only complete candidates");
    /* urbb_frame's cost: the strict decoder on `len` bytes, as part 3 proves, and the call */
    URB_COST(FW_DECODE_CYCLES(len));
    bool const ok = fw_is_frame(frame, len);
    if (ok && record) {
        URB_ASSERT(got_count < FW_MAX_FRAMES, "at most one frame per 4 bytes");
        got_len[got_count] = len;
        got_first[got_count] = frame[0];
        got_last[got_count] = frame[len - 1u];
        got_count++;
    }
    return ok;
}

/* Length of the request starting at stream[s] (bytes s..end-1 available): 0 = needs more bytes,
 * 0xFF = no request starts like this. Written from the schema, not from the firmware. */
static uint8_t ref_need(uint8_t s, uint8_t end)
{
    if ((stream[s] & 1u) != 0u) {
        return 4u; /* UplinkReadRequest */
    }
    if ((uint8_t)(end - s) < 3u) {
        return 0u;
    }
    uint8_t const n = stream[s + 2u];
    if (n > 32u) {
        return 0xFFu;
    }
    return (uint8_t)(3u + n + ((3u + n <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u));
}

static uint8_t ref_len[FW_MAX_FRAMES];
static uint8_t ref_start[FW_MAX_FRAMES];
static uint8_t ref_count;

/* The reference parser on stream positions: candidate start s, bytes s..e-1 arrived since the
 * last gap. Returns the new start. `flush`: no more bytes will join this candidate. */
static uint8_t ref_scan(uint8_t s, uint8_t e, bool flush)
{
    uint8_t buf[URB_BRIDGE_FRAME_MAX];
    for (uint8_t round = 0u; round < FW_BYTES; round++) {
        if (s >= e) {
            break;
        }
        uint8_t const need = ref_need(s, e);
        bool const complete = (need != 0u) && (need != 0xFFu) && (need <= (uint8_t)(e - s));
        if (!complete && !flush && (need != 0xFFu)) {
            break; /* wait for more bytes */
        }
        if (complete) {
            for (uint8_t k = 0u; k < FW_BYTES; k++) {
                if (k < need) {
                    buf[k] = stream[s + k];
                }
            }
            if (fw_is_frame(buf, need)) {
                URB_ASSERT(ref_count < FW_MAX_FRAMES, "reference: at most one frame per 4 bytes");
                ref_len[ref_count] = need;
                ref_start[ref_count] = s;
                ref_count++;
                s = (uint8_t)(s + need);
                continue;
            }
        }
        s++; /* hunt: this byte starts no frame */
    }
    return s;
}

static void reference(void)
{
    uint8_t s = 0u;
    for (uint8_t k = 0u; k < FW_BYTES; k++) {
        if (gap_before[k]) {
            s = ref_scan(s, k, true);
            URB_ASSERT(s == k, "reference: a gap ends every candidate");
        }
        s = ref_scan(s, (uint8_t)(k + 1u), false);
    }
    s = ref_scan(s, FW_BYTES, true);
    URB_ASSERT(s == FW_BYTES, "reference: the final idle time ends every candidate");
}

static void part1_streams(void)
{
    uint32_t t = URB_NONDET_U32(); /* any start time: the clock may wrap during the stream */
    uint32_t delta[FW_BYTES + 1u];
    for (uint8_t k = 0u; k <= FW_BYTES; k++) {
        delta[k] = URB_NONDET_U32();
        URB_ASSUME((delta[k] >= FW_BYTE_US) && (delta[k] <= FW_MAX_DELTA)); /* one character takes a byte time */
    }
    for (uint8_t k = 0u; k < FW_BYTES; k++) {
        stream[k] = URB_NONDET_U8();
        gap_before[k] = (k > 0u) && (delta[k] > FW_GAP_US);
        t += delta[k];
        urb_bridge_uart_rx(&bridge, stream[k], t);
        /* The main loop drains after every byte, at any time before the next one. Draining several
         * bytes at once runs the same pushes and flushes; only its idle check comes later, which
         * is one of the times tried here. */
        uint32_t const wait = URB_NONDET_U32();
        URB_ASSUME(wait < delta[k + 1u]);
        urbb_uart_drain(&bridge, t + wait);
        URB_ASSERT(bridge.rs232.len <= URB_BRIDGE_FRAME_MAX, "no overrun: the assembler holds at most one frame");
        URB_ASSERT(bridge.rx_head == bridge.rx_tail, "the drain empties the ring");
    }
    /* the line stays idle: a partial frame is dropped without waiting for another byte */
    urbb_uart_drain(&bridge, t + FW_GAP_US + 1u);
    URB_ASSERT(bridge.rs232.len == 0u, "idle line: nothing held back");
    URB_ASSERT(bridge.stats.rx_overruns == 0u, "the ring never overflows on these streams");

    record = false;
    reference();
    URB_ASSERT(got_count == ref_count, "as many frames as the reference finds");
    for (uint8_t i = 0u; i < FW_MAX_FRAMES; i++) {
        if (i < ref_count) {
            URB_ASSERT(got_len[i] == ref_len[i], "frame i has the reference's length");
            URB_ASSERT(got_first[i] == stream[ref_start[i]], "frame i starts where the reference's does");
            URB_ASSERT(got_last[i] == stream[ref_start[i] + ref_len[i] - 1u], "frame i ends where the reference's does");
        }
    }
}

/* Part 3: the cost urbb_frame's decoding charges in parts 1 and 2 (FW_DECODE_CYCLES), proved on
 * the real generated decoders and CRC for any candidate of 4..37 bytes; and the abstraction's
 * length rule: the strict decoder never passes a frame of another length. */
static void part3_decode(void)
{
    uint8_t frame[URB_BRIDGE_FRAME_MAX];
    URB_NONDET_BYTES(frame, sizeof frame);
    uint8_t const len = URB_NONDET_U8();
    URB_ASSUME((len >= 4u) && (len <= FW_HELD_MAX + 1u));
    int32_t r;
    URB_COST_BEGIN();
    if ((frame[0] & 1u) != 0u) {
        urb_uplink_read_request_t q;
        r = urb_uplink_read_request_decode(&q, frame, len);
    } else {
        urb_uplink_write_request_t q;
        r = urb_uplink_write_request_decode(&q, frame, len);
    }
    URB_ASSERT(urb_proof_cost <= FW_DECODE_CYCLES(len), "decode lemma: the cost parts 1 and 2 charge");
    bool const checked = (r != URB_ERR_CHECKSUM) && (r != URB_ERR_SHORT) && (r != URB_ERR_LONG);
    if (checked) {
        uint8_t const want = ((frame[0] & 1u) != 0u) ? 4u
            : (uint8_t)(3u + frame[2] + ((3u + frame[2] <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u));
        URB_ASSERT((frame[0] & 1u) || (frame[2] <= 32u), "decode lemma: a checked write announces <= 32 bytes");
        URB_ASSERT(len == want, "decode lemma: a checked frame has its header's length");
    }
}

static void part2_cost(void)
{
    urb_bridge_parser_t *p = &bridge.rs232;
    uint8_t const held = URB_NONDET_U8();
    URB_ASSUME(held <= FW_HELD_MAX);
    p->len = held;
    for (uint8_t k = 0u; k < FW_HELD_MAX; k++) { /* any bytes held (the ones above are never read) */
        p->buf[k] = URB_NONDET_U8();
    }
    uint32_t const last = URB_NONDET_U32();
    bridge.rx_started = true;
    bridge.rx_last_us = last;
    uint32_t const delta = URB_NONDET_U32();
    uint32_t const wait = URB_NONDET_U32();
    URB_ASSUME((delta >= FW_BYTE_US) && (delta <= FW_MAX_DELTA) && (wait <= FW_MAX_DELTA));
    urb_bridge_uart_rx(&bridge, URB_NONDET_U8(), last + delta);
    URB_COST_BEGIN();
    urbb_uart_drain(&bridge, last + delta + wait);
    uint32_t const actual = urb_proof_cost;
    uint8_t const after = p->len;
    URB_ASSERT(after <= URB_BRIDGE_FRAME_MAX, "no overrun");
    /* amortised cost = actual + potential after - potential before (clamped at 0 for the record) */
    uint32_t const credit = FW_HUNT_ROUND_CYCLES * (uint32_t)held;
    uint32_t const charge = actual + FW_HUNT_ROUND_CYCLES * (uint32_t)after;
    urb_proof_cost = (charge > credit) ? (charge - credit) : 0u;
    URB_COST_END(FW_COST_BUDGET);
}

void harness(void)
{
    /* What urb_bridge_init / urbb_uplink_init set for the parser at 115200 Bd with the default gap. */
    bridge.cfg.baud = 115200u;
    bridge.cfg.idle_gap_us = 174u;
    bridge.rx_gap_us = FW_GAP_US;
    bridge.rx_head = 0u;
    bridge.rx_tail = 0u;
    bridge.rs232.len = 0u;
#if defined(URB_PART)
    uint8_t const part = (uint8_t)URB_PART;
#else
    uint8_t const part = URB_NONDET_U8(); /* every part, each on its own path */
#endif
    if (part == 1u) {
        part1_streams();
    } else if (part == 2u) {
        part2_cost();
    } else if (part == 3u) {
        part3_decode();
    } else {
        /* no such part */
    }
}
