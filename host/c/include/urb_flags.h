/*
 * urb_flags.h: why a request failed. The same bits, names and hints as the Python library's
 * ErrorFlag (host/urb/errors.py), so a completion means the same in both.
 *
 * A completed request carries at most one flag (URB_FLAG_NONE, 0, when it succeeded). The low
 * eight bits mirror the bridge's Status codes one to one (bit 1 << (status - 1)); the high bits
 * are decided on the host. A failed request is never retransmitted (paper Sec. IV-C).
 */
#ifndef URB_FLAGS_H
#define URB_FLAGS_H

#include <stddef.h>
#include <stdint.h>

#include "urb_host_base.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A set of URB_FLAG_* bits. */
typedef uint32_t urb_flags_t;

#define URB_FLAG_NONE 0u
/* --- answered by the bridge (its Status) --- */
#define URB_FLAG_TIMEOUT (1u << 0)              /**< Bridge: the node did not complete the downlink transaction in time */
#define URB_FLAG_CHECKSUM (1u << 1)             /**< Bridge: a downlink frame failed its check */
#define URB_FLAG_BUSY (1u << 2)                 /**< Bridge: its request FIFO was full; not executed */
#define URB_FLAG_NO_NODE (1u << 3)              /**< Bridge: no node acknowledged the address */
#define URB_FLAG_SIZE_MISMATCH (1u << 4)        /**< Bridge: the length differs from the size the node reported */
#define URB_FLAG_BAD_REQUEST (1u << 5)          /**< Bridge: mailbox, length or address out of range */
#define URB_FLAG_BUS_STUCK (1u << 6)            /**< Bridge: the downlink was stuck and was cleared; not executed */
#define URB_FLAG_NODE_BUSY (1u << 7)            /**< Bridge: both buffers of the inbox were in use; write refused */
/* --- decided on the host --- */
#define URB_FLAG_UPLINK_CHECKSUM (1u << 8)      /**< Host: the response arrived corrupted and was discarded */
#define URB_FLAG_UPLINK_TIMEOUT (1u << 9)       /**< Host: no response arrived (request or response lost) */
#define URB_FLAG_BRIDGE_LOST (1u << 10)         /**< Host: the bridge went away or its manager was closed */
#define URB_FLAG_UNKNOWN_NODE (1u << 11)        /**< Host: the node is not in the discovery table; nothing sent */
#define URB_FLAG_HOST_SIZE_MISMATCH (1u << 12)  /**< Host: no such mailbox, or another size, in the schema; nothing sent */
#define URB_FLAG_FINGERPRINT_MISMATCH (1u << 13) /**< Host: the node was built from another schema; nothing sent */

/* Groups, for tests such as (flags & URB_FLAG_LINK); never the outcome of one request. */
#define URB_FLAG_BRIDGE 0xFFu                   /**< Any error the bridge reported */
#define URB_FLAG_LINK (URB_FLAG_UPLINK_CHECKSUM | URB_FLAG_UPLINK_TIMEOUT | URB_FLAG_BRIDGE_LOST)
#define URB_FLAG_REFUSED (URB_FLAG_UNKNOWN_NODE | URB_FLAG_HOST_SIZE_MISMATCH | URB_FLAG_FINGERPRINT_MISMATCH)
/** After these a write may or may not have been stored (Bridge.tla WriteStatusTruthful). */
#define URB_FLAG_WRITE_UNKNOWN (URB_FLAG_TIMEOUT | URB_FLAG_BUS_STUCK | URB_FLAG_LINK)
/** Every bit a completion can carry. */
#define URB_FLAG_ALL 0x3FFFu

/**
 * The flag for a bridge Status code: URB_FLAG_NONE for OK (0), 1 << (status - 1) for 1..8.
 * Invalid argument: a status above 8 gives URB_FLAG_ALL + 1 (0x4000), which no completion carries.
 * O(1), no memory.
 */
urb_flags_t urb_flags_from_status(uint8_t status);

/**
 * The names of the flags set in `flags`, e.g. "NO_NODE", "UPLINK_CHECKSUM|BRIDGE_LOST", or "OK"
 * for 0, written NUL-terminated into out[0 .. size - 1] in bit order (ErrorFlag.describe()).
 * Bits outside URB_FLAG_ALL are ignored. Returns the length written (without the NUL), or
 * URB_HOST_EINVAL for out == NULL or size == 0, URB_HOST_ENOSPC when the text was cut to fit.
 * O(14), no memory beyond `out`.
 */
int32_t urb_flags_describe(urb_flags_t flags, char *out, size_t size);

/** The name of a single flag bit ("NO_NODE"), "OK" for 0, NULL for anything else. O(14). */
const char *urb_flag_name(urb_flags_t flag);

/**
 * What a failure means and what to do (errors.hint()): the hint of the first flag set, in the
 * order TIMEOUT, CHECKSUM, ... FINGERPRINT_MISMATCH; "the request succeeded" for 0; "unknown
 * error" when no known bit is set. A static string, never NULL. O(14).
 */
const char *urb_flags_hint(urb_flags_t flags);

#ifdef __cplusplus
}
#endif

#endif /* URB_FLAGS_H */
