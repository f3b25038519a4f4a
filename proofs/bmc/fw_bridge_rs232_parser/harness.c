/*
 * Proof of the RS232 uplink parser (firmware/bridge/bridge_uplink.c): the UART interrupt
 * urb_bridge_uart_rx() (timestamps, idle-gap flag, receive ring) and the main loop's
 * urbb_uart_drain() (frame assembly, hunting, idle flush), by induction over the byte stream.
 *
 * Admission (urbb_frame, bridge.c) is replaced by a recorder that decides exactly as bridge.c
 * does: a candidate is a frame when the generated strict decoder does not report CHECKSUM, SHORT
 * or LONG (the FIFO proof covers what admission does with it). The check is abstracted (below);
 * part 3 proves, on the real generated decoders, the cost the recorder charges and the length rule
 * the abstraction uses.
 *
 * Part 1, the step lemma (induction over the stream). The invariant: the assembler holds the
 * bytes of one incomplete candidate (fewer bytes than its header announces, or too few to tell),
 * which is what the parser holds after any stream (it starts empty, and hunting stops only at
 * an incomplete candidate). From ANY such state of exactly FW_HELD bytes (a sweep item; the bytes
 * arbitrary), one arbitrary byte arrives after an arbitrary distance (an idle gap or not, any
 * 32-bit clock, so it may wrap), and the main loop drains at an arbitrary later time (after the
 * idle timeout or not). Properties:
 *   no overrun      every buffer access is in bounds (ESBMC), the assembler never holds more than
 *                   URB_BRIDGE_FRAME_MAX bytes, the ring does not overflow;
 *   exactly the reference's frames: the frames passed to admission are, in order, those an
 *                   index-based reference parser written from the schema finds (a complete
 *                   candidate that fails its check loses its first byte: hunting; an idle gap or
 *                   the idle timeout ends a candidate: it loses its first byte and the complete
 *                   frames behind it still count), and the bytes held afterwards are exactly the
 *                   reference's remaining candidate, so the invariant holds again.
 *   Since the reference's scan of a whole stream is this step repeated from its remaining
 *   candidate, the lemma gives the stream property for streams of any length whose candidates
 *   stay within the FW_HELD bound of the tier.
 * Part 2, the cost lemma (same step, same states): actual cycles + FW_HUNT_ROUND_CYCLES x (bytes
 * held after - bytes held before) <= FW_COST_BUDGET. The potential (FW_HUNT_ROUND_CYCLES per byte
 * held) starts at 0 and never goes negative, so summed over any stream the main loop spends at
 * most FW_COST_BUDGET cycles per received byte on average, whatever the bytes.
 *
 * The check, abstracted: by data independence the parser must be right for every check function,
 * so the proof uses an arbitrary one (a key per length, fixed per run, folded with the covered
 * bytes) instead of the CRC: cheap for the solver, and a function of the whole candidate, so the
 * reference and the firmware see the same verdict for the same bytes.
 */
#include "urb_verify.h"

#include "bridge_internal.h"
#include "urb_core.h"
#include "urb_runtime.h"

#include "../stubs/fw_budgets.h"

#define FW_COST_BUDGET FW_BRIDGE_RS232_BYTE_BUDGET

#if defined(URB_HELD)
#define FW_HELD ((uint8_t)URB_HELD) /* bytes held before the step (sweep item) */
#else
#define FW_HELD 4u
#endif
#ifndef FW_HELD_MAX
#define FW_HELD_MAX 36u /* part 3: candidates of up to FW_HELD_MAX + 1 bytes */
#endif
#define FW_N (FW_HELD + 1u) /* bytes of the step: the held ones and the new one */
#define FW_MAX_FRAMES (FW_N / 4u + 1u)
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

URB_PROOF_COST_STORAGE;

static urb_bridge_t bridge;
static uint8_t stream[FW_N]; /* the held bytes, then the new one */

/* What the parser handed to admission. */
static uint8_t got_len[FW_MAX_FRAMES];
static uint8_t got_first[FW_MAX_FRAMES];
static uint8_t got_last[FW_MAX_FRAMES];
static uint8_t got_count;
static bool record = true;

static const uint8_t *key; /* one arbitrary key per length (the harness's uninitialised local) */

/* Length rules as in the strict decoders: a read is 4 bytes, a write 3 + its length field + 1 or
 * 2 check bytes; the last byte must be the fold. */
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
    for (uint8_t k = 0u; k < FW_N; k++) {
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
    uint8_t copy[FW_N]; /* len <= rs232.len <= FW_N: constant offsets keep ESBMC's dereference simple */
    for (uint8_t k = 0u; k < FW_N; k++) {
        copy[k] = frame[k];
    }
    bool const ok = fw_is_frame(copy, len);
    if (ok && record) {
        URB_ASSERT(got_count < FW_MAX_FRAMES, "at most one frame per 4 bytes");
        got_len[got_count] = len;
        got_first[got_count] = copy[0];
        got_last[got_count] = copy[len - 1u];
        got_count++;
    }
    return ok;
}

/* Length of the request starting at stream[s] (bytes s..end-1 available): 0 = needs more bytes,
 * 0xFF = no request starts like this. Written from the schema, not from the firmware. */
static uint8_t ref_need(uint8_t s, uint8_t end)
{
    if (s >= end) {
        return 0u;
    }
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
    uint8_t buf[FW_N];
    for (uint8_t round = 0u; round < FW_N; round++) {
        if (s >= e) {
            break;
        }
        uint8_t const need = ref_need(s, e);
        bool const complete = (need != 0u) && (need != 0xFFu) && (need <= (uint8_t)(e - s));
        if (!complete && !flush && (need != 0xFFu)) {
            break; /* wait for more bytes */
        }
        if (complete) {
            for (uint8_t k = 0u; k < FW_N; k++) {
                buf[k] = ((uint8_t)(s + k) < FW_N) ? stream[s + k] : 0u;
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

/* Parts 1 and 2: one step from any state satisfying the invariant. */
static void step(void)
{
    urb_bridge_parser_t *p = &bridge.rs232;
    for (uint8_t k = 0u; k < FW_N; k++) {
        stream[k] = URB_NONDET_U8();
    }
    for (uint8_t k = 0u; k < FW_HELD; k++) {
        p->buf[k] = stream[k];
    }
    p->len = FW_HELD;
    /* the invariant: one incomplete candidate that may still complete */
    uint8_t const pending = ref_need(0u, FW_HELD);
    URB_ASSUME((pending == 0u) || ((pending != 0xFFu) && (pending > FW_HELD)));

    uint32_t const last = URB_NONDET_U32(); /* any clock: it may wrap */
    uint32_t const delta = URB_NONDET_U32();
    uint32_t const wait = URB_NONDET_U32();
    URB_ASSUME((delta >= FW_BYTE_US) && (delta <= FW_MAX_DELTA) && (wait <= FW_MAX_DELTA));
#if defined(URB_IDLE)
    /* sweep items with IDLE: only the byte that arrives without a gap and is followed by the idle
     * timeout (the flush after a push), so a larger HELD stays affordable */
    URB_ASSUME((delta <= FW_GAP_US) && (wait > FW_GAP_US));
#endif
    bridge.rx_started = true;
    bridge.rx_last_us = last;
    urb_bridge_uart_rx(&bridge, stream[FW_HELD], last + delta);
    URB_COST_BEGIN();
    urbb_uart_drain(&bridge, last + delta + wait);
    uint32_t const actual = urb_proof_cost;
    uint8_t const after = p->len;
    URB_ASSERT(after <= URB_BRIDGE_FRAME_MAX, "no overrun: the assembler holds at most one frame");
    URB_ASSERT(bridge.rx_head == bridge.rx_tail, "the drain empties the ring");
    URB_ASSERT(bridge.stats.rx_overruns == 0u, "the ring does not overflow");

#if URB_PART == 1
    record = false;
    uint8_t s = 0u;
    if (delta > FW_GAP_US) { /* an idle gap before the byte ends the held candidate */
        s = ref_scan(0u, FW_HELD, true);
        URB_ASSERT(s == FW_HELD, "reference: a gap ends every candidate");
    }
    s = ref_scan(s, FW_N, false);
    if (wait > FW_GAP_US) { /* the idle timeout: a partial frame is dropped without a next byte */
        s = ref_scan(s, FW_N, true);
        URB_ASSERT(s == FW_N, "reference: the idle time ends every candidate");
    }
    URB_ASSERT(got_count == ref_count, "as many frames as the reference finds");
    for (uint8_t i = 0u; i < FW_MAX_FRAMES; i++) {
        if (i < ref_count) {
            URB_ASSERT(got_len[i] == ref_len[i], "frame i has the reference's length");
            URB_ASSERT(got_first[i] == stream[ref_start[i]], "frame i starts where the reference's does");
            URB_ASSERT(got_last[i] == stream[ref_start[i] + ref_len[i] - 1u], "frame i ends where the reference's does");
        }
    }
    URB_ASSERT(after == (uint8_t)(FW_N - s), "the reference's remaining candidate is held");
    for (uint8_t k = 0u; k < FW_N; k++) {
        if (k < after) {
            URB_ASSERT(p->buf[k] == stream[s + k], "the held bytes are the reference's");
        }
    }
#else
    /* amortised cost = actual + potential after - potential before (clamped at 0 for the record) */
    uint32_t const credit = FW_HUNT_ROUND_CYCLES * (uint32_t)FW_HELD;
    uint32_t const charge = actual + FW_HUNT_ROUND_CYCLES * (uint32_t)after;
    urb_proof_cost = (charge > credit) ? (charge - credit) : 0u;
    URB_COST_END(FW_COST_BUDGET);
#endif
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

void harness(void)
{
    /* What urb_bridge_init / urbb_uplink_init set for the parser at 115200 Bd with the default gap. */
    bridge.cfg.baud = 115200u;
    bridge.cfg.idle_gap_us = 174u;
    bridge.rx_gap_us = FW_GAP_US;
    bridge.rx_head = 0u;
    bridge.rx_tail = 0u;
    bridge.rs232.len = 0u;
    uint8_t keys[URB_BRIDGE_FRAME_MAX + 1u];
    URB_NONDET_BYTES(keys, sizeof keys);
    key = keys;
#if !defined(URB_PART)
#error "give URB_PART (the Makefile's SWEEP does)"
#elif (URB_PART == 1) || (URB_PART == 2)
    step();
#elif URB_PART == 3
    part3_decode();
#endif
}
