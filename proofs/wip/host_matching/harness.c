/*
 * Proof of the host library's response matching (host/c/core/matcher.c, urbh_deliver: the matching
 * step of urb_matcher_feed), by induction: from an arbitrary matcher within its invariant, given a
 * decoded response as the framing hands it over, ONE matching step, the invariant and the contract.
 *
 * What the framing guarantees (proofs/bmc/host_framing proves it of urbh_frame_at_head; here it is
 * assumed: assume-guarantee): the response (number, status 0..8, data) answers position k of the
 * ring, the OLDEST request in flight with its number; its size n is what that request and status
 * give, and all n bytes are held; an OK read carries exactly the request's length of data, any
 * other response none.
 *
 * The matcher's invariant is host_matcher's (its harness.c): the ring (head, count <= SLOTS) of
 * distinct numbers below 16, a live slot pointing to its IN_FLIGHT transfer, the held bytes within
 * rx, a NULL-terminated completion list of up to 2 COMPLETED transfers ending at done_tail.
 *
 * The contract (Bridge.tla HostMatch):
 *   - no false match: the request completed with the response is the one at position k, whose
 *     number the response carries: its status, flags (urb_flags_from_status), data (an OK read's
 *     bytes, else none) and time; a placeholder at k completes nothing and counts one late response;
 *   - the live requests before k complete unanswered (status -1, UPLINK_CHECKSUM after corrupt
 *     bytes, else UPLINK_TIMEOUT) and the placeholders before k are released and counted;
 *   - positions k+1.. keep their order, numbers and times at the front of the ring (the window: the
 *     k+1 numbers answered or passed are free, count falls by k+1);
 *   - exactly n held bytes are dropped, nothing counted stray;
 *   - exactly once: every request live before the step is either still in exactly one slot or in
 *     the completion list exactly once, behind the completions already waiting, in request order.
 *
 * Bounds (the Makefile): a ring of URB_MATCHER_SLOTS (1 or 2) whose head index (HEAD), number of
 * requests in flight (COUNT) and answered position (K) are constants of the sweep item: every
 * combination at a ring of 2 (the response to the second request passing over the first, with and
 * without the ring wrapping), so that every ring index is a constant (a symbolic one makes each
 * store an update of the whole matcher; host_matcher's Makefile says what that cost); requests of 1..URB_LEN bytes (the data bytes are
 * copied by a loop of data_len rounds: URB_LEN = 2 keeps that short; the framing proof covers the
 * 32-byte frames), up to 2 completions waiting, times 0..255 ns.
 */
/* Would verify urb.HOST_002 (a response completes the oldest request in flight with its number, never another) and
 * urb.HOST_001 (matching completes every request it passes exactly once): not cited while it does not verify. */
#include "urb_verify.h"

#include "urb_host_core.h"
#include "urb_host_internal.h"

URB_PROOF_COST_STORAGE;

#define SLOTS URB_MATCHER_SLOTS

#ifndef URB_LEN
#define URB_LEN 2
#endif
#ifndef URB_HEAD
#define URB_HEAD 0
#endif
#if !defined(URB_COUNT) || !defined(URB_K) || (URB_COUNT < 1) || (URB_COUNT > URB_MATCHER_SLOTS) || (URB_K >= URB_COUNT) || \
    (URB_HEAD >= URB_MATCHER_SLOTS)
#error "an item sets URB_MATCHER_SLOTS, URB_HEAD < SLOTS, URB_COUNT in 1..SLOTS and URB_K < URB_COUNT"
#endif

typedef struct {
    bool live;
    uint8_t seq;
    uint8_t length;
    bool read;
    bool garbage;
    urb_ns_t due;
    urb_ns_t expires;
} position_t;

static urb_transfer_t tr[SLOTS];
static urb_transfer_t waiting[2];
static position_t pos[SLOTS];
static uint32_t count0;
static uint32_t waiting0;

static uint32_t ring(const urb_matcher_t *m, uint32_t i)
{
    return (m->head + i) % SLOTS;
}

/* An arbitrary matcher within the invariant, every field stored (as host_matcher's harness). */
static void arbitrary_state(urb_matcher_t *m)
{
    m->head = (uint8_t)URB_HEAD;
    m->count = (uint8_t)URB_COUNT; /* a constant per item (>= 1: a response is matched only with a request
                                    * in flight): ESBMC then resolves every ring index */
    m->rx_start = URB_NONDET_U8();
    m->rx_len = URB_NONDET_U8();
    URB_ASSUME((uint32_t)m->rx_start + m->rx_len <= URB_MATCHER_RX);
    m->stray_bytes = URB_NONDET_U32();
    m->late_responses = URB_NONDET_U32();
    m->released_placeholders = URB_NONDET_U32();
    count0 = m->count;
    for (uint32_t i = 0u; i < SLOTS; i++) {
        uint32_t const x = ring(m, i);
        tr[i].state = URB_XFER_IDLE;
        tr[i].next = NULL;
        m->slot[x].t = NULL;
        m->slot[x].seq = URB_NONDET_U8();
        m->slot[x].length = URB_NONDET_U8();
        m->slot[x].read = URB_NONDET_BOOL();
        m->slot[x].garbage = URB_NONDET_BOOL();
        m->slot[x].long_answer = URB_NONDET_BOOL();
        m->slot[x].due_ns = (urb_ns_t)URB_NONDET_U8();
        m->slot[x].expires_ns = (urb_ns_t)URB_NONDET_U8();
        pos[i].live = false;
        if (i < count0) {
            bool const live = URB_NONDET_BOOL();
            URB_ASSUME(m->slot[x].seq < URB_SEQ_MOD && m->slot[x].length >= 1u && m->slot[x].length <= URB_LEN);
            for (uint32_t j = 0u; j < i; j++) {
                URB_ASSUME(pos[j].seq != m->slot[x].seq);
            }
            m->slot[x].t = live ? &tr[i] : NULL;
            pos[i].live = live;
            pos[i].seq = m->slot[x].seq;
            pos[i].length = m->slot[x].length;
            pos[i].read = m->slot[x].read;
            pos[i].garbage = m->slot[x].garbage;
            pos[i].due = m->slot[x].due_ns;
            pos[i].expires = m->slot[x].expires_ns;
            if (live) {
                tr[i].state = URB_XFER_IN_FLIGHT;
                tr[i].seq = (int8_t)m->slot[x].seq;
                tr[i].length = m->slot[x].length;
                tr[i].read = m->slot[x].read;
                tr[i].status = -1;
                tr[i].response_len = 0u;
            }
        }
    }
    waiting0 = URB_NONDET_U8();
    URB_ASSUME(waiting0 <= 2u);
    waiting[0].state = URB_XFER_COMPLETED;
    waiting[1].state = URB_XFER_COMPLETED;
    waiting[0].next = (waiting0 == 2u) ? &waiting[1] : NULL;
    waiting[1].next = NULL;
    m->done_head = (waiting0 == 0u) ? NULL : &waiting[0];
    m->done_tail = (waiting0 == 0u) ? NULL : &waiting[waiting0 - 1u];
}

static uint32_t index_of(const urb_transfer_t *t)
{
    for (uint32_t j = 0u; j < SLOTS; j++) {
        if (t == &tr[j]) {
            return j;
        }
    }
    return SLOTS;
}

/* The completion list: the waiting ones first, then transfers of live positions in ring order, each
 * once; every live position is in exactly one place. */
static void check_exactly_once(const urb_matcher_t *m)
{
    URB_ASSERT(m->count <= SLOTS && m->head < SLOTS, "invariant: the ring");
    URB_ASSERT((uint32_t)m->rx_start + m->rx_len <= URB_MATCHER_RX, "invariant: the held bytes lie within rx");
    uint32_t in_done[SLOTS] = {0u};
    const urb_transfer_t *p = m->done_head;
    const urb_transfer_t *last = NULL;
    uint32_t n = 0u;
    uint32_t next_index = 0u;
    while ((p != NULL) && (n < SLOTS + 2u)) {
        if (n < waiting0) {
            URB_ASSERT(p == &waiting[n], "completions: the waiting ones stay first, in order");
        } else {
            uint32_t const j = index_of(p);
            URB_ASSERT(j < SLOTS && pos[j].live && j >= next_index, "completions: live requests only, in request order");
            in_done[j % SLOTS]++;
            next_index = j + 1u;
        }
        last = p;
        p = p->next;
        n++;
    }
    URB_ASSERT(p == NULL, "completions: the list ends");
    URB_ASSERT(m->done_tail == last, "completions: done_tail is the last one");
    for (uint32_t j = 0u; j < SLOTS; j++) {
        if ((j < count0) && pos[j].live) {
            uint32_t in_slots = 0u;
            for (uint32_t q = 0u; q < SLOTS; q++) {
                in_slots += ((q < m->count) && (m->slot[ring(m, q)].t == &tr[j])) ? 1u : 0u;
            }
            URB_ASSERT((tr[j].state == URB_XFER_IN_FLIGHT && in_slots == 1u && in_done[j] == 0u) ||
                           (tr[j].state == URB_XFER_COMPLETED && in_slots == 0u && in_done[j] == 1u),
                       "exactly once: in flight in one slot, or completed once");
        }
    }
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

    /* The decoded response and its candidate, as urbh_frame_at_head hands them over. */
    urbh_candidate_t c;
    /* c is an uninitialised local (its data bytes arbitrary); its members are stored once each, k
     * last: ESBMC loses the known members of a struct written in a loop. */
    for (uint32_t j = 0u; j < SLOTS; j++) {
        URB_ASSUME(j >= URB_K || pos[j].seq != pos[URB_K].seq); /* K is the oldest with the number */
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

    check_exactly_once(&m);
    URB_ASSERT(m.rx_len == rx_len - n && (m.rx_len == 0u || m.rx_start == rx_start + n) &&
                   m.stray_bytes == stray,
               "matching: exactly the response's bytes are dropped, none counted stray");
    URB_ASSERT(m.count == count0 - (URB_K + 1u), "window: the answered request and the ones before it leave the ring");
    uint32_t placeholders_before = 0u;
    for (uint32_t i = 0u; i < SLOTS; i++) {
        if (i < URB_K) {
            if (pos[i].live) {
                URB_ASSERT(tr[i].state == URB_XFER_COMPLETED && tr[i].status == -1 && tr[i].response_len == 0u &&
                               tr[i].completed_ns == now &&
                               tr[i].flags == (pos[i].garbage ? URB_FLAG_UPLINK_CHECKSUM : URB_FLAG_UPLINK_TIMEOUT),
                           "matching: a live request passed over completes unanswered");
                URB_COVER("passed-over-live");
            } else {
                placeholders_before++;
                URB_COVER("passed-over-placeholder");
            }
        } else if (i == URB_K) {
            if (pos[i].live) {
                URB_ASSERT(tr[i].state == URB_XFER_COMPLETED && tr[i].seq == (int8_t)c.resp.seq &&
                               tr[i].status == (int8_t)c.resp.status && tr[i].completed_ns == now &&
                               tr[i].flags == urb_flags_from_status(c.resp.status) &&
                               tr[i].response_len == c.resp.data_len,
                           "no false match: the request with the response's number completes with it");
                for (uint32_t b = 0u; b < URB_LEN; b++) {
                    URB_ASSERT(b >= c.resp.data_len || tr[i].response[b] == c.resp.data[b],
                               "no false match: an OK read gets the response's data");
                }
                URB_COVER("matched-live");
                if (data) {
                    URB_COVER("matched-read-with-data");
                }
                if (c.resp.status != 0u) {
                    URB_COVER("matched-error-status");
                }
            } else {
                URB_COVER("late-response");
            }
        } else if (i < count0) {
            urb_slot_t const *const s = &m.slot[ring(&m, (i - URB_K - 1u) % SLOTS)];
            URB_ASSERT(s->t == (pos[i].live ? &tr[i] : NULL) && s->seq == pos[i].seq && s->due_ns == pos[i].due &&
                           s->expires_ns == pos[i].expires && s->length == pos[i].length && s->read == pos[i].read,
                       "window: the newer requests stay in order, unchanged");
            if (pos[i].live) {
                URB_ASSERT(tr[i].state == URB_XFER_IN_FLIGHT, "window: a newer request stays in flight");
            }
            URB_COVER("newer-request-stays");
        }
    }
    URB_ASSERT(m.released_placeholders == released + placeholders_before, "matching: placeholders passed over are released, counted");
    URB_ASSERT(m.late_responses == late + (pos[URB_K].live ? 0u : 1u), "matching: a placeholder's response counted late");
}
