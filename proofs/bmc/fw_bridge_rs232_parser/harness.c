/*
 * Proof of the RS232 uplink parser (firmware/bridge/bridge_uplink.c): the UART interrupt
 * urb_bridge_uart_rx() (timestamps, idle-gap flag, receive ring) and the main loop's parsing
 * urbb_uart_parse() (frame assembly, hunting, idle flush, under a budget of frame checks;
 * urbb_uart_drain() is it with URB_BRIDGE_HUNT_CHECKS), by induction over the byte stream.
 *
 * Admission (urbb_frame, bridge.c) is replaced by a recorder that decides exactly as bridge.c
 * does: a candidate is a frame when the generated strict decoder does not report CHECKSUM, SHORT
 * or LONG (the FIFO proof covers what admission does with it). The check is abstracted (end of
 * this comment); part 3 proves, on the real generated decoders, the cost the recorder charges and
 * the length rule the abstraction uses.
 *
 * Part 1, the step lemma. The state between two polls: the assembler holds FW_HELD bytes (a sweep
 * item; any bytes: a poll that ran out of checks leaves a complete candidate first, one that did
 * not an incomplete one) at any place in its buffer, hunting or flushing (a flush stopped by the
 * budget); one arbitrary byte arrives or not (after an arbitrary distance: an idle gap or not, any
 * 32-bit clock, so it may wrap), and the main loop polls at an arbitrary later time (after the
 * idle timeout or not) with ANY check budget k.
 * Or the poll's `now` is EARLIER than the last byte's stamp (LATE, by 1 us .. 2^31 us): the UART
 * interrupt ran after the poll read its clock, before the parser's ring check (the byte is taken)
 * or between that check and the idle test (ARRIVE=0: the byte waits in the ring for the next step).
 * Properties:
 *   no overrun      every buffer access is in bounds (ESBMC), the assembler never holds more than
 *                   URB_BRIDGE_FRAME_MAX bytes nor runs past its buffer;
 *   budget          the poll makes at most k checks; it stops early (counted in hunt_yields)
 *                   exactly where the reference does, a check due and k spent, and leaves the held
 *                   bytes, the mode and the ring byte as the reference does, so the next step
 *                   starts with that check (one poll is run: polls compose by this induction);
 *   exactly the reference's frames: the poll hands admission exactly, in order, the
 *                   frames an index-based reference parser written from the schema finds (a
 *                   complete candidate that fails its check loses its first byte: hunting; an idle
 *                   gap or the idle timeout ends a candidate: it loses its first byte and the
 *                   complete frames behind it still count), hold exactly the reference's remaining
 *                   candidate afterwards, and move the hunting and gap counters as it does. The
 *                   reference's idle timeout is "now is more than rx_gap_us after the last stamp",
 *                   never a wrapped difference: a byte stamped after `now` is no idle gap (the
 *                   held candidate waits; firmware fix 66c5bff, seeded bug rx-newer-than-now).
 *   Every state a poll leaves is again such a state, and the reference's scan of a whole stream is
 *   this step repeated, so for streams whose candidates stay within the FW_HELD bound of the tier,
 *   any split of the work into polls (any budgets) admits exactly the reference's frames.
 * Part 2, the cost lemma (the first poll of the same step, any budget):
 *   per poll    cycles <= FW_POLL_CYCLES + (FW_PULL_CYCLES + FW_FILL_CYCLES) x (bytes taken from
 *                 the ring) + FW_ROUND_CYCLES x (bytes dropped + checks) + the checks' decoding
 *                 + FW_FILL_CYCLES x (buffer fill before - after),
 *               a linear form in what the poll did. A poll takes at most URB_BRIDGE_RX_PER_POLL
 *               bytes, makes at most URB_BRIDGE_HUNT_CHECKS checks and drops at most the bytes it
 *               held and took, so one poll costs at most FW_POLL_WORST cycles, which the static
 *               check below keeps within FW_BRIDGE_RS232_POLL_BUDGET (half the 1-ms cycle);
 *   per byte    the amortised cost with a potential of FW_HUNT_ROUND_CYCLES per byte held or
 *               waiting in the ring and FW_FILL_CYCLES per byte of buffer fill is at most
 *               FW_BRIDGE_RS232_BYTE_BUDGET (7/8 of a UART byte time) per received byte: the
 *               potentials start at 0 and never go negative, so summed over any stream the main
 *               loop spends at most that per byte (plus FW_POLL_CYCLES per poll), whatever the
 *               bytes. This is the value recorded in COST.
 * Part 4, the interrupt alone from ANY receive-ring state (parts 1 and 2 start with an empty ring
 * and no overrun pending): a byte into a full ring is lost (counted, the overrun remembered, head and
 * every slot unchanged); otherwise it is stored at the head with the gap flag exactly when the line
 * was idle longer than rx_gap_us or bytes were lost before it, and only then published; the stamp is
 * kept either way. Parts 1 and 2 parse what the flag means.
 *
 * The full-size frames. Items with LONG run the step with the longest request (a write of 32
 * bytes, 37 bytes on the wire) at the front of the held bytes, every other byte and the state
 * arbitrary but for its shape (its first byte a write's, its length field 32, its payload zero):
 * HELD=36 with its last byte arriving (the longest candidate completes and is checked: admitted,
 * or failed with its first byte dropped), and HELD=37 (a poll that ran out of checks left it
 * complete) with the first byte of the next frame arriving (the longest frame admitted, the frame
 * behind it started at the front of the buffer). The Makefile says where in the buffer the held
 * bytes start (START0 or its end) and why.
 * Their poll has a budget of one check (FW_LONG_CHECKS), the longest candidate's: every path of the
 * poll then ends within 3 hunt rounds, so the Makefile unwinds the hunt loops (the firmware's and
 * the reference's) and the parse loop (one byte in the ring) only that far, with the unwinding
 * assertions on: ESBMC proves that no path runs longer, so the bound cuts nothing. With the main
 * loop's 4 checks a failed longest candidate is hunted through 3 more candidates in the same poll
 * and the 39 rounds of both loops had to be unwound in full: the seeded bug's run timed out after
 * 1200 s of wall time (443 s of CPU), still in symbolic execution.
 * The check of a LONG item reads a sample of the candidate (fw_sample_is_frame): its header (bytes
 * 0..2) and its last two bytes, the arbitrary key of its length folded with the covered ones. It is
 * still a function of the candidate's bytes, so the reference and the firmware get the same verdict
 * for the same bytes, at a fraction of the 37-byte copy and fold per check (proofs/README.md,
 * "Full-size frames", has the measurements). That the assembler keeps the other bytes (the zero
 * payload) is the held-bytes assertion's, which compares every held byte with the reference's, and
 * the small items' (full fold, compaction).
 * What a poll does after a check, with any budget left or none, is what the small items prove for
 * any budget; in the LONG items a failed longest candidate ends the poll with its other 36 bytes
 * held, exactly as the reference holds them (the held-bytes assertion compares every one).
 * By the induction the longest frame followed by any other is then admitted exactly as the
 * reference says. The payload is zero and the first byte fixed because the parser never reads them
 * beyond bit 0: it measures a candidate by its first and third byte and hands it whole to
 * admission, whose abstract verdict still passes or fails it through the arbitrary key and check
 * bytes. The bounds of the other items (at most 6 bytes) hold no such frame, and a cap one byte too
 * short for the longest frame (seeded bug frame-max-one-short, killed at HELD=36) passed them.
 *
 * Cover points (URB_COVER, checked by the reach run) per part: part 1 a frame admitted, a failed
 * check hunted, a gap drop, an idle flush, a poll stopped by its budget, a byte stamped after the
 * poll's now; in LONG items the longest frame admitted, the longest candidate failing its check,
 * (HELD=36) the arriving byte completing the longest candidate and (HELD=37) the longest frame
 * admitted with the next frame's first byte at the front of the buffer;
 * part 2 a poll that compacts the buffer and one that admits a frame (in LONG items the longest);
 * part 3 a checked read and a checked write of 37 bytes; part 4 a full ring, a gap flag, an
 * overrun flag.
 *
 * The check is abstracted (proofs/bmc/stubs/fw_uplink_model.h, shared with the USB proof).
 */
/* lobster-trace: urb.CRC_005, urb.MEM_003, urb.WCET_005 (the requirements this proof verifies) */
#include "urb_verify.h"

#include "bridge_internal.h"
#include "urb_core.h"
#include "urb_runtime.h"

#include "../stubs/fw_budgets.h"

#define FW_COST_BUDGET FW_BRIDGE_RS232_BYTE_BUDGET
/* The longest request, from the schema (not the firmware's own URB_BRIDGE_FRAME_MAX, which a bug
 * may get wrong): a write of URB_MAX_MAILBOX_SIZE bytes. */
#define FW_REQUEST_MAX URB_UPLINK_WRITE_REQUEST_MAX_SIZE

#if defined(URB_HELD)
#define FW_HELD ((uint8_t)URB_HELD) /* bytes held before the step (sweep item) */
#else
#define FW_HELD 4u
#endif
#ifndef FW_HELD_MAX
#define FW_HELD_MAX 36u /* part 3: candidates of up to FW_HELD_MAX + 1 bytes */
#endif
#if !defined(URB_ARRIVE)
#define URB_ARRIVE 1 /* 1: a byte arrives before the poll; 0: none (sweep item) */
#endif
#define FW_ARRIVE ((uint8_t)URB_ARRIVE)
#define FW_N (FW_HELD + FW_ARRIVE) /* bytes of the step: the held ones and the new one */
#define FW_MAX_FRAMES (FW_N / 4u + 1u)
#ifndef FW_DECODE_CYCLES
/* Cycles of urbb_frame's decoding of an n-byte candidate (call, header, CRC over n - 1 bytes at
 * most, payload copy): proved by part 3 from the cost model. */
#define FW_DECODE_CYCLES(n) (800u + 52u * (uint32_t)(n))
#endif
/* The poll's cost terms, exactly as prepare.py instruments the sources (function entry 24 cycles +
 * 3 per statement outside loops, 10 per loop round; cost_model.json):
 *   FW_POLL_CYCLES  urbb_uart_parse's entry (27) and its last round (10), the hunt call of that
 *                   round (30) and the hunt round that finds nothing more to do (10, candidate_len
 *                   42 + urb_link_check_size 30): 149;
 *   FW_PULL_CYCLES  per byte taken from the ring: a parse round (10), push (39), the hunt call
 *                   after it (30) and its closing round (82): 161;
 *   FW_ROUND_CYCLES per hunt round that removes bytes (a check or a drop): the round (10),
 *                   candidate_len (72) and consume (33): 115; a check adds its decoding;
 *   FW_FILL_CYCLES  a compaction moves a byte for 10 cycles, once per 38 bytes of fill at most, so
 *                   10 per byte of buffer fill (start + len) pays for it; each byte taken raises
 *                   the fill by one, so it brings that much too.
 * Part 2 proves the form with these numbers, no slack: a parser doing more work per byte fails it. */
#define FW_POLL_CYCLES 149u
#define FW_PULL_CYCLES 161u
#define FW_ROUND_CYCLES 115u
#define FW_FILL_CYCLES 10u
/* Potential per byte held or waiting: pays one hunt round with a check of the longest candidate. */
#define FW_HUNT_ROUND_CYCLES (FW_ROUND_CYCLES + FW_DECODE_CYCLES(FW_REQUEST_MAX))
/* The worst poll: URB_BRIDGE_RX_PER_POLL bytes taken, URB_BRIDGE_HUNT_CHECKS checks of 37 bytes,
 * every other byte held or taken dropped, the buffer emptied from full. */
#define FW_POLL_WORST                                                                              \
    (FW_POLL_CYCLES + (FW_PULL_CYCLES + FW_FILL_CYCLES) * URB_BRIDGE_RX_PER_POLL +                 \
     FW_ROUND_CYCLES * (URB_BRIDGE_FRAME_MAX + URB_BRIDGE_RX_PER_POLL) +                           \
     FW_DECODE_CYCLES(URB_BRIDGE_FRAME_MAX) * URB_BRIDGE_HUNT_CHECKS + FW_FILL_CYCLES * URB_BRIDGE_PARSE_BUF)
/* Static checks: the worst poll fits half the 1-ms cycle, and a received byte's share (taken once,
 * starting at most one check, its fill) plus the poll's fixed part fits the per-byte budget. */
typedef char fw_poll_fits_its_budget[(FW_POLL_WORST <= FW_BRIDGE_RS232_POLL_BUDGET) ? 1 : -1];
typedef char fw_byte_fits_its_budget[(FW_POLL_CYCLES + FW_PULL_CYCLES + FW_HUNT_ROUND_CYCLES + FW_FILL_CYCLES <=
                                      FW_BRIDGE_RS232_BYTE_BUDGET) ? 1 : -1];
#define FW_BYTE_US 87u   /* one character at 115200 Bd (10 bits, rounded up) */
#define FW_GAP_US 261u   /* rx_gap_us: byte time + the default idle gap (2 byte times) */
#define FW_MAX_DELTA 5000u
/* LONG items: the poll's check budget. One check (the longest candidate's) keeps every path of the
 * poll within a few hunt rounds, which --unwindsetname bounds (the Makefile; unwinding assertions on). */
#define FW_LONG_CHECKS 1u

URB_PROOF_COST_STORAGE;

static urb_bridge_t bridge;
static uint8_t stream[FW_N]; /* the held bytes, then the new one */

/* What the parser handed to admission. */
static uint8_t got_len[FW_MAX_FRAMES];
static uint8_t got_first[FW_MAX_FRAMES];
static uint8_t got_last[FW_MAX_FRAMES];
static uint8_t got_count;
static uint8_t got_checks;      /* candidates checked */
static uint8_t got_first_check; /* the length of the first candidate checked */
static uint8_t got_failed;      /* ... of which failed */
static uint8_t got_frame_bytes; /* bytes of the frames admitted */
static uint32_t got_decode;     /* their decoding cycles */

static const uint8_t *key; /* one arbitrary key per length (the harness's uninitialised local) */

#define FW_FRAME_WIDTH FW_N
#include "../stubs/fw_uplink_model.h"

#if defined(URB_LONG)
/* LONG items: the check reads a sample of the candidate, its header (bytes 0..2) and its last two
 * bytes (see the header comment): sample[0..2] the header, sample[3] byte len - 2, sample[4] byte
 * len - 1. A function of the candidate's bytes like fw_is_frame, with its length rule: the last byte
 * must be the fold of the key with the other sampled covered bytes. */
#define FW_SAMPLE 5u
static bool fw_sample_is_frame(const uint8_t *sample, uint8_t len)
{
    uint8_t const want = fw_request_len(sample[0], sample[2]);
    if (len != want) {
        return false; /* FW_NOT_A_REQUEST is no length */
    }
    uint8_t fold = (uint8_t)(key[len] ^ sample[0] ^ sample[1] ^ sample[2]);
    if (len > 4u) {
        fold = (uint8_t)(fold ^ sample[3]); /* byte len - 2 is no header byte */
    }
    return sample[4] == fold;
}
#endif

bool urbb_frame(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    URB_ASSERT(b == &bridge, "admission: the bridge under proof");
    URB_ASSERT(uplink == URBB_UPLINK_RS232, "admission: RS232 frames come from the RS232 uplink");
    URB_ASSERT((len >= 4u) && (len <= FW_REQUEST_MAX), "admission: a candidate of a request's length");
    URB_ASSERT(frame == &b->rs232.buf[b->rs232.start], "admission: the candidate starts at the held bytes' start");
    URB_ASSERT(len <= b->rs232.len, "admission: only complete candidates");
    /* urbb_frame's cost: the strict decoder on `len` bytes, as part 3 proves, and the call */
    URB_COST(FW_DECODE_CYCLES(len));
    got_decode += FW_DECODE_CYCLES(len);
    if (got_checks == 0u) {
        got_first_check = len;
    }
    got_checks++;
    /* Read the candidate through the assembler's array, not through `frame`: a pointer at a variable
     * offset into the bridge makes ESBMC resolve every access over the whole struct. */
    uint8_t const at = b->rs232.start;
#if defined(URB_LONG)
    uint8_t const copy[FW_SAMPLE] = {b->rs232.buf[at], b->rs232.buf[at + 1u], b->rs232.buf[at + 2u],
                                     b->rs232.buf[at + len - 2u], b->rs232.buf[at + len - 1u]};
    bool const ok = fw_sample_is_frame(copy, len);
    uint8_t const last = copy[FW_SAMPLE - 1u];
#else
    uint8_t copy[FW_N]; /* len <= rs232.len <= FW_N */
    for (uint8_t k = 0u; k < FW_N; k++) {
        copy[k] = (k < len) ? b->rs232.buf[at + k] : 0u;
    }
    bool const ok = fw_is_frame(copy, len);
    uint8_t const last = copy[len - 1u];
#endif
    if (ok) {
        URB_ASSERT(got_count < FW_MAX_FRAMES, "at most one frame per 4 bytes");
        got_len[got_count] = len;
        got_first[got_count] = copy[0];
        got_last[got_count] = last;
        got_count++;
        got_frame_bytes = (uint8_t)(got_frame_bytes + len);
    } else {
        got_failed++;
    }
    return ok;
}

static uint8_t ref_len[FW_MAX_FRAMES];
static uint8_t ref_start[FW_MAX_FRAMES];
static uint8_t ref_count;
static bool ref_flushing;     /* an idle gap ended the candidate: drop until nothing is left */
static uint8_t ref_budget;    /* checks left in this poll */
static bool ref_stopped;      /* a check was due with none left: the poll ends here */
static uint32_t ref_discards; /* bytes discarded while hunting (failed checks, impossible headers) */
static uint32_t ref_gaps;     /* partial frames dropped at a gap */

/* Each part's functions are compiled into its items only, and with them its cover points. */
#if (URB_PART == 1) || (URB_PART == 2)
/* The reference parser on stream positions: candidate start s, bytes s..e-1 arrived since the
 * last gap. Hunting waits at an incomplete candidate, unless the candidate has `ended` (an idle gap
 * follows): then it is not a frame, and from there on every byte that starts no complete frame is
 * dropped until nothing is left. Returns the new start. */
static uint8_t ref_scan(uint8_t s, uint8_t e, bool ended)
{
#if !defined(URB_LONG)
    uint8_t buf[FW_N];
#endif
    for (uint8_t round = 0u; (round < FW_N) && (s < e); round++) {
        uint8_t const need = fw_request_need(&stream[s], (uint8_t)(e - s));
        bool const complete = (need != 0u) && (need != FW_NOT_A_REQUEST) && (need <= (uint8_t)(e - s));
        if (complete) {
            if (ref_budget == 0u) {
                ref_stopped = true; /* the rest waits for the next poll, which starts right here */
                break;
            }
            ref_budget--;
#if defined(URB_LONG)
            uint8_t const buf[FW_SAMPLE] = {stream[s], stream[s + 1u], stream[s + 2u], stream[s + need - 2u],
                                            stream[s + need - 1u]};
            bool const ok = fw_sample_is_frame(buf, need);
#else
            for (uint8_t k = 0u; k < FW_N; k++) {
                buf[k] = ((uint8_t)(s + k) < FW_N) ? stream[s + k] : 0u;
            }
            bool const ok = fw_is_frame(buf, need);
#endif
            if (ok) {
                URB_ASSERT(ref_count < FW_MAX_FRAMES, "reference: at most one frame per 4 bytes");
                ref_len[ref_count] = need;
                ref_start[ref_count] = s;
                ref_count++;
                s = (uint8_t)(s + need);
                continue;
            }
            ref_discards++; /* hunt: this byte starts no frame */
        } else if (ref_flushing || (ended && (need != FW_NOT_A_REQUEST))) {
            if (!ref_flushing) {
                ref_gaps++;
                ref_flushing = true;
            }
        } else if (need == FW_NOT_A_REQUEST) {
            ref_discards++;
        } else {
            break; /* wait for more bytes */
        }
        s++;
    }
    if (!ref_stopped && (s >= e)) {
        ref_flushing = false;
    }
    return s;
}

/* Parts 1 and 2: one step from any state between two polls. */
static void step(void)
{
    urb_bridge_parser_t *p = &bridge.rs232;
    for (uint8_t k = 0u; k < FW_N; k++) {
        stream[k] = URB_NONDET_U8();
    }
#if defined(URB_LONG)
    /* the held bytes start the longest request (assigned, not assumed: its length is a constant) */
    stream[0] = 0x22u; /* a write (bit 0 clear) to node 0x11 */
    stream[2] = URB_MAX_MAILBOX_SIZE;
    for (uint8_t k = 3u; k < (uint8_t)(FW_REQUEST_MAX - 2u); k++) {
        stream[k] = 0u; /* the payload: see the header comment */
    }
#endif
#if defined(URB_START0)
    uint8_t const start = 0u; /* sweep items with START0: the held bytes at the front */
#else
    /* The held bytes end at the end of the buffer, the worst place: the next byte compacts them,
     * unless they are all consumed first and it goes to the front (both branches of push). Other
     * starts take the same paths without the compaction (Frama-C Eva checks every index). */
    uint8_t const start = (uint8_t)(URB_BRIDGE_PARSE_BUF - FW_HELD);
#endif
    for (uint8_t k = 0u; k < FW_HELD; k++) {
        p->buf[start + k] = stream[k];
    }
    p->start = (FW_HELD > 0u) ? start : 0u;
    p->len = FW_HELD;
    bool const flushing = URB_NONDET_BOOL(); /* hunting, or a flush the budget stopped */
    URB_ASSUME(!flushing || (FW_HELD > 0u));
    p->flushing = flushing;

    bool const arrive = FW_ARRIVE != 0u;
    uint32_t const last = URB_NONDET_U32(); /* any clock: it may wrap */
    uint32_t const delta = URB_NONDET_U32();
    uint32_t const wait = URB_NONDET_U32();
    URB_ASSUME((delta >= FW_BYTE_US) && (delta <= FW_MAX_DELTA) && (wait <= FW_MAX_DELTA));
    /* LATE: the last byte's stamp is `ahead` us after the poll's `now` (the interrupt ran after the
     * poll read its clock); the firmware reads a difference of 2^31 us or more as such a byte. */
    bool const late = URB_NONDET_BOOL();
    uint32_t const ahead = URB_NONDET_U32();
    URB_ASSUME(!late || ((ahead >= 1u) && (ahead <= 0x80000000u)));
#if defined(URB_IDLE)
    /* sweep items with IDLE: only polls after the idle timeout, so a larger HELD stays affordable */
    URB_ASSUME(!late && (wait > FW_GAP_US));
#endif
    bridge.rx_started = true;
    bridge.rx_last_us = last;
    uint32_t stamp = last; /* the last byte's stamp */
#if URB_ARRIVE
    urb_bridge_uart_rx(&bridge, stream[FW_HELD], last + delta);
    stamp = last + delta;
#endif
    uint32_t const now = late ? (uint32_t)(stamp - ahead) : (uint32_t)(stamp + wait);
#if defined(URB_LONG)
    uint8_t const k1 = FW_LONG_CHECKS; /* LONG items: the longest candidate's check is the poll's only one */
#else
    uint8_t const k1 = URB_NONDET_U8(); /* the poll's budget: any */
#endif
    uint32_t const yields = bridge.stats.hunt_yields;
    uint32_t const discards = bridge.stats.hunt_discards;
    uint32_t const gaps = bridge.stats.gap_drops;
    uint8_t const tail = bridge.rx_tail;
    uint32_t const fill = (uint32_t)p->start + p->len;
    URB_COST_BEGIN();
    urbb_uart_parse(&bridge, now, k1);
    uint32_t const actual = urb_proof_cost;
    uint8_t const after = p->len;
    uint8_t const pulled = (uint8_t)(bridge.rx_tail - tail);
    URB_ASSERT(after <= FW_REQUEST_MAX, "no overrun: the assembler holds at most one frame");
    URB_ASSERT((uint32_t)p->start + after <= URB_BRIDGE_PARSE_BUF, "no overrun: the held bytes lie in the buffer");
    URB_ASSERT(got_checks <= k1, "budget: at most k checks in a poll");
    URB_ASSERT(pulled <= (arrive ? 1u : 0u), "only the bytes that arrived are taken");

#if URB_PART == 1
    /* The reference on the same events with the same budget: the held bytes in their mode (an idle
     * gap before the byte ends them), the byte, the idle timeout. It stops before a check it has
     * no budget for; its state (start, end, mode, whether the byte was taken) is then all the next
     * poll needs, so polls compose into the reference's scan of the whole stream. */
    bool const gap = arrive && (delta > FW_GAP_US);
    /* idle: `now` at least rx_gap_us after the last stamp, from the harness's own unwrapped times */
    bool const idle = !late && (wait > FW_GAP_US);
    ref_flushing = flushing;
    ref_budget = k1;
    uint8_t s = 0u;
    uint8_t e = FW_HELD;
    if (arrive) {
        s = ref_scan(s, e, gap);
        if (!ref_stopped) {
            URB_ASSERT(!gap || (s == e), "reference: a gap ends every candidate");
            e = FW_N; /* the byte joins once the candidate before it is settled */
        }
    }
    if (!ref_stopped) {
        s = ref_scan(s, e, idle);
        URB_ASSERT(ref_stopped || !idle || (s == e), "reference: the idle time ends every candidate");
    }
    URB_ASSERT((bridge.stats.hunt_yields - yields) == (ref_stopped ? 1u : 0u),
               "budget: a poll stops early exactly where a check is due and none is left");
    URB_ASSERT(pulled == (uint8_t)(e - FW_HELD), "the byte is taken exactly when the reference takes it");
    URB_ASSERT(got_count == ref_count, "as many frames as the reference finds");
    for (uint8_t i = 0u; i < FW_MAX_FRAMES; i++) {
        if (i < ref_count) {
            URB_ASSERT(got_len[i] == ref_len[i], "frame i has the reference's length");
            URB_ASSERT(got_first[i] == stream[ref_start[i]], "frame i starts where the reference's does");
            URB_ASSERT(got_last[i] == stream[ref_start[i] + ref_len[i] - 1u], "frame i ends where the reference's does");
        }
    }
    URB_ASSERT(after == (uint8_t)(e - s), "the reference's remaining candidate is held");
    for (uint8_t k = 0u; k < FW_N; k++) {
        if (k < after) {
            URB_ASSERT(p->buf[p->start + k] == stream[s + k], "the held bytes are the reference's");
        }
    }
    URB_ASSERT(p->flushing == ref_flushing, "a flush in progress is remembered exactly when the reference is in one");
    URB_ASSERT(bridge.stats.hunt_discards - discards == ref_discards, "hunting discards counted as the reference");
    URB_ASSERT(bridge.stats.gap_drops - gaps == ref_gaps, "gap drops counted as the reference");
    URB_ASSERT(!late || gap || (bridge.stats.gap_drops == gaps),
               "a byte stamped after the poll's now is no idle gap: no partial frame dropped");
#if defined(URB_LONG)
    if ((got_count >= 1u) && (got_len[0] == FW_REQUEST_MAX)) {
        URB_COVER("part1-longest-frame-admitted");
    }
    if ((got_failed >= 1u) && (got_count == 0u) && (got_first_check == FW_REQUEST_MAX)) {
        URB_COVER("part1-longest-candidate-fails-its-check");
    }
#if URB_HELD < 37 /* the arriving byte completes the longest candidate */
    if ((pulled == 1u) && (got_checks >= 1u) && (got_first_check == FW_REQUEST_MAX)) {
        URB_COVER("part1-the-arriving-byte-completes-the-longest-candidate");
    }
#else /* a complete longest candidate held, the next frame's first byte arriving */
    if ((got_count >= 1u) && (got_len[0] == FW_REQUEST_MAX) && (pulled == 1u) && (after == 1u) && (p->start == 0u)) {
        URB_COVER("part1-longest-frame-admitted-then-the-next-frame-starts-at-the-front");
    }
#endif
#else
    if (got_count >= 1u) {
        URB_COVER("part1-frame-admitted");
    }
    if (got_failed >= 1u) {
        URB_COVER("part1-failed-check-hunted");
    }
    if (gap && (ref_gaps > 0u)) {
        URB_COVER("part1-partial-frame-dropped-at-a-gap");
    }
    if (!gap && idle && (ref_gaps > 0u)) {
        URB_COVER("part1-partial-frame-flushed-when-idle");
    }
    if (ref_stopped) {
        URB_COVER("part1-poll-stopped-by-its-budget");
    }
    if (late) {
        URB_COVER("part1-byte-stamped-after-the-polls-now");
    }
#endif
#else
    /* Part 2. The linear form: bytes consumed = frames' bytes + failed checks + dropped bytes. */
    uint8_t const consumed = (uint8_t)(FW_HELD + pulled - after);
    uint8_t const dropped = (uint8_t)(consumed - got_frame_bytes - got_failed);
    uint32_t const fill_after = (uint32_t)p->start + after;
    URB_ASSERT(actual + FW_FILL_CYCLES * fill_after <=
                   FW_POLL_CYCLES + (FW_PULL_CYCLES + FW_FILL_CYCLES) * pulled +
                       FW_ROUND_CYCLES * ((uint32_t)dropped + got_checks) +
                       got_decode + FW_FILL_CYCLES * fill,
               "cost: one poll within its linear form (so within FW_POLL_WORST)");
    /* Amortised per received byte: potentials of the bytes held or waiting in the ring and of the
     * fill; the arriving byte brings its own (the poll without one pays only its fixed part). */
    uint32_t const credit = FW_HUNT_ROUND_CYCLES * (uint32_t)FW_HELD + FW_FILL_CYCLES * fill;
    uint32_t const charge = actual + FW_HUNT_ROUND_CYCLES * ((uint32_t)after + FW_ARRIVE - pulled) +
                            FW_FILL_CYCLES * fill_after;
    urb_proof_cost = (charge > credit) ? (charge - credit) : 0u;
    URB_COST_END(FW_COST_BUDGET);
#if defined(URB_LONG)
    if ((got_count >= 1u) && (got_len[0] == FW_REQUEST_MAX)) {
        URB_COVER("part2-longest-frame-admitted");
    }
#else
    if (got_count >= 1u) {
        URB_COVER("part2-frame-admitted");
    }
    if ((pulled == 1u) && (fill + 1u > URB_BRIDGE_PARSE_BUF)) {
        URB_COVER("part2-the-byte-compacts-the-buffer");
    }
#endif
#endif
}

#endif /* URB_PART == 1 || URB_PART == 2 */

#if URB_PART == 3
/* Part 3: the cost urbb_frame's decoding charges in parts 1 and 2 (FW_DECODE_CYCLES), proved on
 * the real generated decoders and CRC for any candidate of 4..37 bytes; and the abstraction's
 * length rule: the strict decoder never passes a frame of another length. */
static void part3_decode(void)
{
    uint8_t frame[FW_REQUEST_MAX];
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
        if ((frame[0] & 1u) != 0u) {
            URB_COVER("part3-read-request-checked");
        } else if (len == FW_REQUEST_MAX) {
            URB_COVER("part3-longest-write-checked");
        }
    }
}

#endif /* URB_PART == 3 */

#if URB_PART == 4
/* Part 4: one byte from the UART interrupt, from any receive-ring state. */
static void part4_rx(void)
{
    uint8_t const head = URB_NONDET_U8();
    uint8_t const tail = URB_NONDET_U8();
    URB_ASSUME((uint8_t)(head - tail) <= URB_BRIDGE_RX_RING);
    bool const started = URB_NONDET_BOOL();
    bool const overrun = URB_NONDET_BOOL();
    uint32_t const last = URB_NONDET_U32();
    uint32_t const t = URB_NONDET_U32();
    uint8_t const byte = URB_NONDET_U8();
    uint8_t const other = URB_NONDET_U8(); /* any other slot keeps its contents */
    URB_ASSUME(other < URB_BRIDGE_RX_RING);
    uint16_t const seen = URB_NONDET_U16();
    uint16_t const at_head = URB_NONDET_U16();
    bridge.rx_ring[other] = seen;
    bridge.rx_ring[head & (URB_BRIDGE_RX_RING - 1u)] = at_head;
    bridge.rx_head = head;
    bridge.rx_tail = tail;
    bridge.rx_started = started;
    bridge.rx_overrun = overrun ? 1u : 0u;
    bridge.rx_last_us = last;
    bool const full = (uint8_t)(head - tail) == URB_BRIDGE_RX_RING;
    /* stamps mark byte ends on a free-running 32-bit microsecond clock: the difference wraps */
    bool const gap = started && ((uint32_t)(t - last) > FW_GAP_US);
    URB_COST_BEGIN();
    urb_bridge_uart_rx(&bridge, byte, t);
    URB_ASSERT(bridge.rx_started && (bridge.rx_last_us == t), "rx: the stamp is kept, lost byte or not");
    URB_ASSERT(bridge.stats.rx_bytes == 1u, "rx: every byte counted");
    URB_ASSERT(bridge.rx_tail == tail, "rx: the interrupt never moves the tail");
    if (full) {
        URB_ASSERT(bridge.rx_head == head, "rx: a full ring publishes nothing");
        URB_ASSERT(bridge.rx_ring[head & (URB_BRIDGE_RX_RING - 1u)] == at_head, "rx: a full ring's oldest byte is kept");
        URB_ASSERT((bridge.rx_overrun != 0u) && (bridge.stats.rx_overruns == 1u), "rx: the lost byte is remembered and counted");
    } else {
        URB_ASSERT(bridge.rx_head == (uint8_t)(head + 1u), "rx: the byte is published");
        URB_ASSERT(bridge.rx_ring[head & (URB_BRIDGE_RX_RING - 1u)] ==
                       (uint16_t)(byte | ((gap || overrun) ? URB_BRIDGE_RX_GAP : 0u)),
                   "rx: stored at the head, flagged exactly after an idle gap or lost bytes");
        URB_ASSERT((bridge.rx_overrun == 0u) && (bridge.stats.rx_overruns == 0u), "rx: a stored byte clears the overrun");
    }
    if (other != (head & (URB_BRIDGE_RX_RING - 1u))) {
        URB_ASSERT(bridge.rx_ring[other] == seen, "rx: no other slot is written");
    }
    if (full) {
        URB_COVER("part4-a-full-ring-loses-the-byte");
    } else if (overrun) {
        URB_COVER("part4-the-byte-after-a-loss-is-flagged");
    } else if (gap) {
        URB_COVER("part4-the-byte-after-an-idle-gap-is-flagged");
    }
    URB_ASSERT(urb_proof_cost <= FW_UART_EVENT_BUDGET, "cost: the interrupt within half a UART byte time");
}

#endif /* URB_PART == 4 */
void harness(void)
{
    /* What urb_bridge_init / urbb_uplink_init set for the parser at 115200 Bd with the default gap. */
    bridge.cfg.baud = 115200u;
    bridge.cfg.idle_gap_us = 174u;
    bridge.rx_gap_us = FW_GAP_US;
    bridge.rx_head = 0u;
    bridge.rx_tail = 0u;
    bridge.rs232.len = 0u;
    uint8_t keys[FW_REQUEST_MAX + 1u];
    URB_NONDET_BYTES(keys, sizeof keys);
    key = keys;
#if !defined(URB_PART)
#error "give URB_PART (the Makefile's SWEEP does)"
#elif (URB_PART == 1) || (URB_PART == 2)
    step();
#elif URB_PART == 3
    part3_decode();
#elif URB_PART == 4
    part4_rx();
#endif
}
