/*
 * Proof of the host library's response matching (host/c/core/matcher.c, urbh_deliver: the matching
 * step of urb_matcher_feed), by induction: from an arbitrary matcher within its invariant, given a
 * response as the framing hands it over, ONE matching step, then the invariant and the contract.
 *
 * Assumption (assume-guarantee with proofs/bmc/host_framing, which proves it of urbh_frame_at_head
 * for any 64 held bytes): urbh_deliver is called only on a URBH_FRAME_WHOLE candidate, whose
 *   - position k is the OLDEST request in flight with the response's number (no position before k
 *     has that number), with at least one request in flight (parse() frames only then);
 *   - response carries that number, a status 0..8, and data_len = the request's length for an OK
 *     read, 0 otherwise (the data bytes are arbitrary: the framing copies them from rx);
 *   - size n is what that request and status give (1 + data_len + a check of 1 byte, 2 beyond 14
 *     covered bytes), and all n bytes are held (n <= rx_len).
 * The harness assumes exactly this and nothing more about the candidate.
 *
 * The matcher's invariant and how the state is built: proofs/bmc/include/host_matcher_state.h (shared
 * with host_matcher): distinct numbers below 16, lengths URB_LEN_MIN..URB_LEN, a live slot pointing to
 * its own IN_FLIGHT transfer, the held bytes within rx, 0..2 COMPLETED transfers waiting.
 *
 * The contract (header urb_host_internal.h; the Python reference rs232_core.ResponseMatcher.parse;
 * Bridge.tla HostMatch):
 *   - no false match: the one request completed with the response is the one at k, the oldest with
 *     its number: status, flags (the bridge Status as its one flag bit, none for OK), data (an OK
 *     read's bytes, else none), time; a placeholder at k completes nothing and counts one late
 *     response;
 *   - the live requests before k complete unanswered (status -1, no data, UPLINK_CHECKSUM when
 *     corrupt bytes stood in their place, else UPLINK_TIMEOUT); the placeholders before k are
 *     released and counted;
 *   - the window: positions k+1.. move to the front of the ring in order with their transfer,
 *     number, times, size and direction, still in flight; count falls by k+1;
 *   - exactly n held bytes are dropped, none counted stray;
 *   - exactly once: the completion list is exactly the completions waiting before, then the live
 *     requests at positions 0..k in request order, each once (checked object by object: every
 *     transfer is a distinct object, so the list is compared with the expected one node by node,
 *     without walking it through pointers); every other live request is in exactly one slot.
 * Memory safety, overflow and shift checks are ESBMC's (always on).
 *
 * Bounds (the Makefile): a ring of URB_MATCHER_SLOTS slots whose head index (HEAD), requests in
 * flight (COUNT) and answered position (K) are constants of the sweep item: every combination at a
 * ring of 2 (the answer to the first or the second request, with and without the ring wrapping);
 * each request live or a placeholder, any numbers, directions, corrupt-bytes marks and times
 * 0..255 ns; 0..2 completions waiting; rx_start and rx_len arbitrary within the library's 64-byte rx.
 * Requests of 1..URB_LEN bytes: 2 in the ring items (the OK read's data copy runs data_len rounds),
 * 32 in the LEN=32 item at a ring of 1 (every length, the longest response of 35 bytes with its
 * 2-byte check, the check-width switch at 14 covered bytes).
 */
/* lobster-trace: urb.HOST_002 (a response completes the oldest request in flight with its number, never another) */
/* lobster-trace: urb.HOST_001 (matching completes every request it passes exactly once) */
#include "urb_verify.h"

#include "host_matcher_state.h"
#include "urb_host_core.h"
#include "urb_host_internal.h"

URB_PROOF_COST_STORAGE;

#if !defined(URB_COUNT) || !defined(URB_K) || (URB_COUNT < 1) || (URB_COUNT > URB_MATCHER_SLOTS) || (URB_K >= URB_COUNT)
#error "an item sets URB_COUNT in 1..URB_MATCHER_SLOTS and URB_K < URB_COUNT"
#endif

#define HEAD_AFTER RING(URB_HEAD, URB_K + 1u)

/* The bridge Status as its flag (urb_flags.h: the low eight bits, one per status), written out. */
static const urb_flags_t flag_of_status[9] = {
    URB_FLAG_NONE,          URB_FLAG_TIMEOUT,     URB_FLAG_CHECKSUM,    URB_FLAG_BUSY,      URB_FLAG_NO_NODE,
    URB_FLAG_SIZE_MISMATCH, URB_FLAG_BAD_REQUEST, URB_FLAG_BUS_STUCK, URB_FLAG_NODE_BUSY};

/* Exactly once: the completion list is the expected sequence (waiting ones, then the live positions
 * 0..K in order). Each node is a known object, so the list is that sequence exactly when done_head is
 * its first node, every node's next is its successor in it (NULL after the last) and done_tail is its
 * last. The nodes in order: wait0, wait1, tr0, tr1, tr2. */
#define NODES 5u
static urb_transfer_t *node(uint32_t j)
{
    return (j == 0u) ? &wait0 : ((j == 1u) ? &wait1 : transfer_at(j - 2u));
}

static bool expected_in_list(uint32_t j)
{
    return (j < 2u) ? (j < waiting0) : ((j - 2u <= URB_K) && pos[j - 2u].live);
}

static void check_completion_list(const urb_matcher_t *m)
{
    urb_transfer_t *successor = NULL;
    urb_transfer_t *last = NULL;
    for (uint32_t r = 0u; r < NODES; r++) { /* backwards: each node's successor is known when it is reached */
        uint32_t const j = NODES - 1u - r;
        if (expected_in_list(j)) {
            URB_ASSERT(node(j)->next == successor && node(j)->state == URB_XFER_COMPLETED,
                       "exactly once: the completion list is the waiting ones, then the requests answered or passed over, in request order");
            if (last == NULL) {
                last = node(j);
            }
            successor = node(j);
        }
    }
    URB_ASSERT(m->done_head == successor && m->done_tail == last,
               "exactly once: the completion list starts and ends where expected");
}

void harness(void)
{
    static urb_matcher_t m;
    arbitrary_state(&m);
    uint8_t const rx_start = m.rx_start;
    uint8_t const rx_len = m.rx_len;
    uint64_t const stray = m.stray_bytes;
    uint64_t const late = m.late_responses;
    uint64_t const released = m.released_placeholders;

    /* The candidate, as urbh_frame_at_head hands over a URBH_FRAME_WHOLE one (the assumption above).
     * c is an uninitialised local (its data bytes arbitrary); its members are stored once each, k
     * last: ESBMC loses the known members of a struct written in a loop. */
    urbh_candidate_t c;
    for (uint32_t j = 0u; j < URB_K; j++) {
        URB_ASSUME(pos[j].seq != pos[URB_K].seq); /* K is the oldest with the number */
    }
    position_t const answered = pos[URB_K];
    uint8_t const status = URB_NONDET_U8();
    URB_ASSUME(status <= 8u);
    bool const data = answered.read && (status == 0u);
    uint8_t const data_len = data ? answered.length : 0u;
    uint32_t const covered = 1u + data_len;
    uint32_t const n = covered + ((covered <= 14u) ? 1u : 2u);
    URB_ASSUME(n <= rx_len);
    c.resp.seq = answered.seq;
    c.resp.status = status;
    c.resp.data_len = data_len;
    c.n = n;
    c.k = URB_K;
    urb_ns_t const now = (urb_ns_t)URB_NONDET_U8();

    urbh_deliver(&m, &c, now);

    URB_ASSERT(m.rx_len == rx_len - n && (m.rx_len == 0u || m.rx_start == rx_start + n) &&
                   (uint32_t)m.rx_start + m.rx_len <= URB_MATCHER_RX && m.stray_bytes == stray,
               "matching: exactly the response's bytes are dropped, none counted stray");
    URB_ASSERT(m.count == URB_COUNT - (URB_K + 1u) && m.head == HEAD_AFTER,
               "window: the answered request and the ones before it leave the ring");
    check_completion_list(&m);
    uint32_t placeholders_before = 0u;
    for (uint32_t i = 0u; i < SLOTS; i++) {
        urb_transfer_t const *const t = transfer_at(i);
        if (i < URB_K) {
            if (pos[i].live) {
                URB_ASSERT(t->status == -1 && t->response_len == 0u && t->completed_ns == now &&
                               t->flags == (pos[i].garbage ? URB_FLAG_UPLINK_CHECKSUM : URB_FLAG_UPLINK_TIMEOUT),
                           "matching: a live request passed over completes unanswered, UPLINK_CHECKSUM exactly after corrupt bytes");
                URB_COVER("passed-over-live");
                if (pos[i].garbage) {
                    URB_COVER("passed-over-after-corrupt-bytes");
                }
            } else {
                placeholders_before++;
                URB_COVER("passed-over-placeholder");
            }
        } else if (i == URB_K) {
            if (pos[i].live) {
                URB_ASSERT(t->seq == (int8_t)c.resp.seq && t->status == (int8_t)status && t->completed_ns == now &&
                               t->flags == flag_of_status[status] && t->response_len == data_len,
                           "no false match: the request with the response's number completes with its status, flag and length");
                for (uint32_t b = 0u; b < URB_LEN; b++) {
                    URB_ASSERT(b >= data_len || t->response[b] == c.resp.data[b],
                               "no false match: an OK read gets the response's data");
                }
                URB_COVER("matched-live");
                if (data) {
                    URB_COVER("matched-read-with-data");
                }
                if (status != 0u) {
                    URB_COVER("matched-error-status");
                }
                if (answered.read && status != 0u) {
                    URB_COVER("matched-read-error-without-data");
                }
                if (URB_K > 0u) {
                    URB_COVER("matched-behind-another");
                }
            } else {
                URB_COVER("late-response");
            }
        } else if (i < URB_COUNT) {
            urb_slot_t const *const s = &m.slot[RING(HEAD_AFTER, i - URB_K - 1u)];
            URB_ASSERT(s->t == (pos[i].live ? t : NULL) && s->seq == pos[i].seq && s->due_ns == pos[i].due &&
                           s->expires_ns == pos[i].expires && s->length == pos[i].length && s->read == pos[i].read,
                       "window: the newer requests stay in order, unchanged");
            if (pos[i].live) {
                URB_ASSERT(t->state == URB_XFER_IN_FLIGHT && t->status == -1,
                           "window: a newer request stays in flight, unanswered");
            }
            URB_COVER("newer-request-stays");
            if (URB_HEAD + URB_COUNT > SLOTS) {
                URB_COVER("newer-request-stays-across-the-wrap");
            }
        }
    }
    URB_ASSERT(m.released_placeholders == released + placeholders_before,
               "matching: placeholders passed over are released, counted");
    URB_ASSERT(m.late_responses == late + (pos[URB_K].live ? 0u : 1u), "matching: a placeholder's response counted late");
    if (waiting0 > 0u && pos[URB_K].live) {
        URB_COVER("completion-behind-waiting-ones");
    }
    if (n == URB_RESPONSE_MAX) {
        URB_COVER("longest-response");
    }
}
