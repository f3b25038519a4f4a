/*
 * Functions the core's translation units share; not part of the public API.
 */
#ifndef URB_HOST_INTERNAL_H
#define URB_HOST_INTERNAL_H

#include "urb_host_core.h"
#include "urb_core.h"

/** The index in m->slot of the i-th request in flight, oldest first (i < m->count). */
uint32_t urbh_at(const urb_matcher_t *m, uint32_t i);

/** The oldest request in flight whose number is seq: its position k (0 = oldest), m->count if none. */
uint32_t urbh_find(const urb_matcher_t *m, uint8_t seq);

/** What the bytes held start with (urbh_frame_at_head). */
typedef enum {
    URBH_FRAME_NOTHING, /**< No bytes held */
    URBH_FRAME_STRAY,   /**< The first byte starts no response: no request in flight has its number,
                             its status is out of range, or the whole candidate fails its check */
    URBH_FRAME_WAIT,    /**< The first byte starts a candidate of c->n bytes, not all held yet */
    URBH_FRAME_WHOLE    /**< A response of c->n bytes with a valid check, to position c->k */
} urbh_frame_t;

/** A response candidate at the start of the bytes held. */
typedef struct {
    uint32_t k;                  /**< Position in the ring (0 = oldest) of the request it answers */
    size_t n;                    /**< Its size, from that request's length, direction and the status */
    urb_uplink_response_t resp;  /**< The decoded response (URBH_FRAME_WHOLE only) */
} urbh_candidate_t;

/** The framing step of urb_matcher_feed: classifies the bytes held (m->count > 0) and fills *c.
 *  Changes nothing in *m. O(w + n). */
urbh_frame_t urbh_frame_at_head(const urb_matcher_t *m, urbh_candidate_t *c);

/** The matching step of urb_matcher_feed for a URBH_FRAME_WHOLE candidate: drops its n bytes,
 *  completes the requests before position k as unanswered (placeholders released), and the one at
 *  k with the response (a placeholder: counted as a late response). O(w). */
void urbh_deliver(urb_matcher_t *m, const urbh_candidate_t *c, urb_ns_t now);

/** Completes `t` (exactly once: it is no longer in the queue or a live slot) and appends it to the
 *  completion list. status -1: no response; data/len: an OK read's mailbox bytes. */
void urbh_complete(urb_matcher_t *m, urb_transfer_t *t, urb_ns_t now, urb_flags_t flags, int8_t status,
                   const uint8_t *data, uint8_t len);

/** Completes `t` URB_FLAG_BRIDGE_LOST, saying why. */
void urbh_lose(urb_matcher_t *m, urb_transfer_t *t, urb_ns_t now, const char *reason);

/** Copies `reason` (NULL: "") into a URB_REASON_MAX buffer, cut and NUL-terminated. */
void urbh_copy_reason(char *dst, const char *reason);

/** The reason of requests failed by a close (base.CLOSED_REASON). */
#define URBH_CLOSED_REASON "closed by the application"

#endif /* URB_HOST_INTERNAL_H */
