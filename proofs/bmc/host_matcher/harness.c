/*
 * Proof of the host library's response matcher (host/c/core/matcher.c), by induction: every part
 * starts from an arbitrary matcher within its invariant, does ONE operation and checks the
 * invariant and the operation's contract after it (an inductive step instead of operation
 * sequences, which ran ESBMC out of its 4 GB, host/c/README.md).
 *
 * The invariant and the arbitrary state: proofs/bmc/include/host_matcher_state.h (shared with
 * host_matching); here the held bytes are also fewer than the longest response (a parse leaves at
 * most a partial candidate). Position i of the ring (the i-th oldest) holds transfer transfer_at(i)
 * when it is live: the names are arbitrary, the harness fixes them to tell the transfers apart.
 *
 * Parts (URB_PART):
 *   1 time_out  urb_matcher_time_out(now) (and urb_matcher_expire in it), any due times, lifetimes
 *               and now: exactly the live requests due by now complete at now, without a response,
 *               UPLINK_CHECKSUM when corrupt bytes stood in their place and UPLINK_TIMEOUT otherwise,
 *               once each, in ring order, and stay as placeholders; exactly the placeholders expired by
 *               now (the ones just made included) are released and counted; the others keep their
 *               place, order, number and times; the held bytes are untouched; it returns how many timed
 *               out; afterwards no event is due (urb_matcher_next_event > now)
 *   2 push+take urb_matcher_push of a new request: appended at the back with its number, times, size
 *               and long-answer mark, or ENOSPC (ring full) / EINVAL (number >= 16) with nothing
 *               changed; then urb_matcher_take hands back the oldest completion (DONE), the others stay
 * Every part checks "exactly once" after the step: each request live before it is either still in
 * exactly one slot (IN_FLIGHT) or in the completion list exactly once (COMPLETED), completions in
 * request order behind the ones already waiting, nothing else in the slots or the list.
 *
 * Bounds (the Makefile): a ring of URB_MATCHER_SLOTS = 1 (one request in flight, live or a
 * placeholder), requests of 1..URB_LEN bytes, up to 2 completions already waiting, times 0..255 ns
 * (only their order matters to the matcher). urb_matcher_feed (matching, hunting, framing) is not
 * proved here: host/c/README.md says what was measured.
 */
/* lobster-trace: urb.HOST_001 (the requirements this proof verifies: exactly once; the matching by number, HOST_002, needs urb_matcher_feed, not proved here) */
#include "urb_verify.h"

#include "host_matcher_state.h"
#include "urb_host_core.h"

URB_PROOF_COST_STORAGE;

/* The longest response to a request of at most URB_LEN bytes (an OK read): what can be held is shorter. */
#define RESPONSE_MAX ((1u + URB_LEN) + (((1u + URB_LEN) <= 14u) ? 1u : 2u))

static uint32_t ring(const urb_matcher_t *m, uint32_t i)
{
    return (m->head + i) % SLOTS;
}

static urb_ns_t small_time(void)
{
    return (urb_ns_t)URB_NONDET_U8();
}

/* The matcher between operations: the shared invariant, and fewer bytes held than a response. */
static void arbitrary_between_operations(urb_matcher_t *m)
{
    arbitrary_state(m);
    URB_ASSUME(m->rx_len < RESPONSE_MAX);
}

/* The position whose live transfer t is, or SLOTS when t is none of them. */
static uint32_t index_of(const urb_transfer_t *t)
{
    for (uint32_t j = 0u; j < SLOTS; j++) {
        if (t == transfer_at(j)) {
            return j;
        }
    }
    return SLOTS;
}

/* The completion list after the step: the waiting ones first, then transfers of live positions in
 * ring order, each once; every live position is in exactly one place; the slots hold only those
 * and `pushed` (PART=3's new request). */
static void check_exactly_once(const urb_matcher_t *m, const urb_transfer_t *pushed)
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
            URB_ASSERT(p == ((n == 0u) ? &wait0 : &wait1), "completions: the waiting ones stay first, in order");
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
    for (uint32_t k = 0u; k < SLOTS; k++) { /* constant bounds, guards inside: ESBMC unrolls a loop
                                              * over a symbolic count to the full --unwind */
        urb_transfer_t const *const t = m->slot[ring(m, k)].t;
        if ((k < m->count) && (t != NULL) && (t != pushed)) {
            uint32_t const j = index_of(t);
            URB_ASSERT(j < SLOTS && pos[j].live, "slots: only live requests");
        }
    }
    for (uint32_t j = 0u; j < SLOTS; j++) {
        if ((j < count0) && pos[j].live) {
            uint32_t in_slots = 0u;
            for (uint32_t k = 0u; k < SLOTS; k++) {
                in_slots += ((k < m->count) && (m->slot[ring(m, k)].t == transfer_at(j))) ? 1u : 0u;
            }
            URB_ASSERT((transfer_at(j)->state == URB_XFER_IN_FLIGHT && in_slots == 1u && in_done[j] == 0u) ||
                           (transfer_at(j)->state == URB_XFER_COMPLETED && in_slots == 0u && in_done[j] == 1u),
                       "exactly once: in flight in one slot, or completed once");
        }
    }
}

#if URB_PART == 1
void harness(void)
{
    static urb_matcher_t m;
    arbitrary_between_operations(&m);
    uint8_t const rx_start = m.rx_start;
    uint8_t const rx_len = m.rx_len;
    uint64_t const released = m.released_placeholders;
    urb_ns_t const now = small_time();
    uint32_t const n = urb_matcher_time_out(&m, now);
    check_exactly_once(&m, NULL);
    uint32_t timed = 0u;
    uint32_t kept = 0u;
    uint32_t gone = 0u;
    for (uint32_t i = 0u; i < SLOTS; i++) {
        if (i >= count0) {
            break;
        }
        bool const times_out = pos[i].live && (pos[i].due <= now);
        bool const stays_live = pos[i].live && !times_out;
        if (times_out) {
            timed++;
            URB_ASSERT(transfer_at(i)->state == URB_XFER_COMPLETED && transfer_at(i)->status == -1 && transfer_at(i)->response_len == 0u &&
                           transfer_at(i)->completed_ns == now,
                       "time_out: a request due by now completes now, without a response");
            URB_ASSERT(transfer_at(i)->flags == (pos[i].garbage ? URB_FLAG_UPLINK_CHECKSUM : URB_FLAG_UPLINK_TIMEOUT),
                       "time_out: UPLINK_CHECKSUM exactly when corrupt bytes stood in its place");
            URB_COVER("timeout");
            if (pos[i].garbage) {
                URB_COVER("timeout-after-corrupt-bytes");
            }
        }
        if (stays_live) {
            URB_ASSERT(transfer_at(i)->state == URB_XFER_IN_FLIGHT, "time_out: a request not due stays live");
        }
        if (!stays_live && (pos[i].expires <= now)) {
            gone++;
            if (times_out) {
                URB_COVER("timed-out-and-expired-at-once");
            } else {
                URB_COVER("placeholder-released");
            }
        } else {
            /* kept: the kept-th slot after the step, same number, times and size */
            URB_ASSERT(kept < m.count, "time_out: a placeholder within its lifetime keeps its place");
            urb_slot_t const *const s = &m.slot[ring(&m, kept % SLOTS)];
            URB_ASSERT(s->seq == pos[i].seq && s->due_ns == pos[i].due && s->expires_ns == pos[i].expires &&
                           s->length == pos[i].length && s->read == pos[i].read,
                       "time_out: the kept slots in their order, unchanged");
            URB_ASSERT(s->t == (stays_live ? transfer_at(i) : NULL), "time_out: a timed-out request stays as a placeholder");
            kept++;
        }
    }
    URB_ASSERT(n == timed, "time_out: returns how many timed out");
    URB_ASSERT(m.count == kept, "time_out: only the expired placeholders leave");
    URB_ASSERT(m.released_placeholders == released + gone, "time_out: every released placeholder counted");
    URB_ASSERT(m.rx_start == rx_start && m.rx_len == rx_len, "time_out: the held bytes untouched");
    URB_ASSERT(urb_matcher_next_event(&m) > now, "time_out: afterwards nothing is due by now");
}
#elif URB_PART == 2
static urb_transfer_t fresh;

void harness(void)
{
    static urb_matcher_t m;
    arbitrary_between_operations(&m);
    fresh.state = URB_XFER_QUEUED;
    fresh.read = URB_NONDET_BOOL();
    fresh.length = URB_NONDET_U8();
    fresh.answer_within_ns = small_time();
    URB_ASSUME(fresh.length >= 1u && fresh.length <= URB_LEN);
    uint8_t const seq = URB_NONDET_U8();
    urb_ns_t const due = small_time();
    urb_ns_t const expires = small_time();
    int32_t const rc = urb_matcher_push(&m, &fresh, seq, due, expires);
    if (seq >= URB_SEQ_MOD || count0 == SLOTS) {
        URB_ASSERT(rc == ((seq >= URB_SEQ_MOD) ? URB_HOST_EINVAL : URB_HOST_ENOSPC) &&
                       fresh.state == URB_XFER_QUEUED && m.count == count0,
                   "push: refused (number >= 16, ring full), nothing changes");
        URB_COVER("push-refused");
    } else {
        URB_ASSERT(rc == URB_HOST_OK && m.count == count0 + 1u && m.head == URB_HEAD, "push: accepted at the back");
        urb_slot_t const *const s = &m.slot[ring(&m, count0 % SLOTS)];
        URB_ASSERT(s->t == &fresh && s->seq == seq && s->due_ns == due && s->expires_ns == expires &&
                       s->length == fresh.length && s->read == fresh.read && !s->garbage &&
                       s->long_answer == (fresh.answer_within_ns > 0),
                   "push: the new slot holds the request, its number, times and size");
        URB_ASSERT(fresh.state == URB_XFER_IN_FLIGHT && fresh.seq == (int8_t)seq, "push: the request is in flight");
        URB_COVER("pushed");
    }
    for (uint32_t i = 0u; i < SLOTS; i++) {
        urb_slot_t const *const s = &m.slot[ring(&m, i)];
        URB_ASSERT(i >= count0 || (s->t == (pos[i].live ? transfer_at(i) : NULL) && s->seq == pos[i].seq), "push: the others unchanged");
    }
    check_exactly_once(&m, &fresh);
    urb_transfer_t *const got = urb_matcher_take(&m);
    if (waiting0 == 0u) {
        URB_ASSERT(got == NULL && m.done_head == NULL && m.done_tail == NULL, "take: nothing to take");
    } else {
        URB_ASSERT(got == &wait0 && got->state == URB_XFER_DONE && got->next == NULL, "take: the oldest completion, handed back");
        URB_ASSERT(m.done_head == ((waiting0 == 2u) ? &wait1 : NULL) &&
                       m.done_tail == ((waiting0 == 2u) ? &wait1 : NULL),
                   "take: the others stay");
        URB_COVER("taken");
        if (waiting0 == 2u) {
            URB_COVER("taken-with-another-waiting");
        }
    }
}
#else
#error "URB_PART must be 1 or 2"
#endif
