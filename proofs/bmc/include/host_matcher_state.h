/*
 * host_matcher_state.h: the arbitrary matcher within its invariant that the host matcher proofs
 * start from (proofs/bmc/host_matcher, one operation; proofs/bmc/host_matching, one matching step).
 *
 * The invariant (what urb_matcher_init establishes and every operation keeps):
 *   - at most URB_MATCHER_SLOTS requests in flight in the ring (head, count), oldest first, their
 *     sequence numbers below 16 and distinct (the window < 16 guarantees it: Bridge.tla HostWindow),
 *     lengths URB_LEN_MIN..URB_LEN;
 *   - a live slot points to its own transfer (IN_FLIGHT, its number, length and direction), a
 *     placeholder's is NULL; no transfer is in two places;
 *   - the bytes held lie within rx (a harness may bound rx_len further);
 *   - the completion list is a NULL-terminated list of 0..2 COMPLETED transfers ending at done_tail.
 * Every field is stored: an uninitialised matcher's arbitrary pointers cost ESBMC minutes.
 *
 * The item fixes the ring's head (URB_HEAD) and may fix the requests in flight (URB_COUNT; else any
 * count up to the ring's size). The ring is indexed with that constant head, never through m->head:
 * ESBMC propagates no constant out of a struct that holds arbitrary values, and a store at an index
 * computed from m->head becomes a byte-level update of the whole matcher (what ran the first
 * matching harness out of memory, proofs/bmc/host_matching/Makefile).
 *
 * The live request at position i is the object transfer_at(i) (tr0, tr1, tr2: distinct objects, not
 * an array, so a pointer to one carries no index through the list and the slots); the completions
 * waiting before the step are wait0 and wait1.
 */
#ifndef HOST_MATCHER_STATE_H
#define HOST_MATCHER_STATE_H

#include "urb_verify.h"

#include "urb_host_core.h"

#define SLOTS URB_MATCHER_SLOTS

#ifndef URB_LEN
#define URB_LEN 2
#endif
#ifndef URB_LEN_MIN
#define URB_LEN_MIN 1
#endif
#if !defined(URB_HEAD) || (URB_HEAD >= URB_MATCHER_SLOTS)
#error "an item sets URB_HEAD < URB_MATCHER_SLOTS"
#endif
#if (URB_MATCHER_SLOTS > 3) && (!defined(URB_COUNT) || (URB_COUNT > 3))
#error "at most 3 requests in flight: transfer_at has 3 objects"
#endif

/* The ring index of position i from a constant head. */
#define RING(head, i) (((uint32_t)(head) + (uint32_t)(i)) % SLOTS)

/* What position i of the ring held before the step. */
typedef struct {
    bool live;
    uint8_t seq;
    uint8_t length;
    bool read;
    bool garbage;
    urb_ns_t due;
    urb_ns_t expires;
} position_t;

static urb_transfer_t tr0, tr1, tr2; /* the live request at position 0, 1, 2 */
static urb_transfer_t wait0, wait1;  /* completions waiting before the step */
static position_t pos[SLOTS];
static uint32_t count0;   /* requests in flight before the step */
static uint32_t waiting0; /* completions waiting before the step */

static urb_transfer_t *transfer_at(uint32_t i)
{
    return (i == 0u) ? &tr0 : ((i == 1u) ? &tr1 : &tr2);
}

static void arbitrary_state(urb_matcher_t *m)
{
    m->head = (uint8_t)URB_HEAD;
#ifdef URB_COUNT
    m->count = (uint8_t)URB_COUNT; /* a constant per item: every ring position is then known */
#else
    m->count = URB_NONDET_U8();
    URB_ASSUME(m->count <= SLOTS);
#endif
    m->rx_start = URB_NONDET_U8();
    m->rx_len = URB_NONDET_U8();
    URB_ASSUME((uint32_t)m->rx_start + m->rx_len <= URB_MATCHER_RX);
    m->stray_bytes = URB_NONDET_U32();
    m->late_responses = URB_NONDET_U32();
    m->released_placeholders = URB_NONDET_U32();
    count0 = m->count;
    for (uint32_t i = 0u; i < SLOTS; i++) {
        uint32_t const x = RING(URB_HEAD, i);
        m->slot[x].t = NULL;
        m->slot[x].seq = URB_NONDET_U8();
        m->slot[x].length = URB_NONDET_U8();
        m->slot[x].read = URB_NONDET_BOOL();
        m->slot[x].garbage = URB_NONDET_BOOL();
        m->slot[x].long_answer = URB_NONDET_BOOL();
        m->slot[x].due_ns = (urb_ns_t)URB_NONDET_U8(); /* times 0..255 ns: only their order matters */
        m->slot[x].expires_ns = (urb_ns_t)URB_NONDET_U8();
        pos[i].live = false;
        if (i < 3u) {
            urb_transfer_t *const t = transfer_at(i);
            t->state = URB_XFER_IDLE;
            t->next = NULL;
        }
        if (i < count0) {
            urb_transfer_t *const t = transfer_at(i);
            bool const live = URB_NONDET_BOOL();
            URB_ASSUME(m->slot[x].seq < URB_SEQ_MOD && m->slot[x].length >= URB_LEN_MIN && m->slot[x].length <= URB_LEN);
            for (uint32_t j = 0u; j < i; j++) {
                URB_ASSUME(pos[j].seq != m->slot[x].seq);
            }
            m->slot[x].t = live ? t : NULL;
            pos[i].live = live;
            pos[i].seq = m->slot[x].seq;
            pos[i].length = m->slot[x].length;
            pos[i].read = m->slot[x].read;
            pos[i].garbage = m->slot[x].garbage;
            pos[i].due = m->slot[x].due_ns;
            pos[i].expires = m->slot[x].expires_ns;
            if (live) {
                t->state = URB_XFER_IN_FLIGHT;
                t->seq = (int8_t)m->slot[x].seq;
                t->length = m->slot[x].length;
                t->read = m->slot[x].read;
                t->status = -1;
                t->response_len = 0u;
            }
        }
    }
    waiting0 = URB_NONDET_U8();
    URB_ASSUME(waiting0 <= 2u);
    wait0.state = URB_XFER_COMPLETED;
    wait1.state = URB_XFER_COMPLETED;
    wait0.next = (waiting0 == 2u) ? &wait1 : NULL;
    wait1.next = NULL;
    m->done_head = (waiting0 == 0u) ? NULL : &wait0;
    m->done_tail = (waiting0 == 0u) ? NULL : ((waiting0 == 1u) ? &wait0 : &wait1);
}

#endif /* HOST_MATCHER_STATE_H */
