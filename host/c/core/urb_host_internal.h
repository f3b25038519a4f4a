/*
 * Functions the core's translation units share; not part of the public API.
 */
#ifndef URB_HOST_INTERNAL_H
#define URB_HOST_INTERNAL_H

#include "urb_host_core.h"

/** The index in m->slot of the i-th request in flight, oldest first (i < m->count). */
uint32_t urbh_at(const urb_matcher_t *m, uint32_t i);

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
