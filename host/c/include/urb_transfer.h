/*
 * urb_transfer.h: one uplink request (read or write of one mailbox at one downlink address) and,
 * once complete, its outcome. The Python library's Transfer (host/urb/managers/base.py).
 *
 * Ownership. A transfer is caller-owned memory (a struct on the stack, in a pool, in a C++
 * object). Build it with urb_transfer_read() or urb_transfer_write(), submit it to a core
 * (urb_core_submit); from then on the core owns it and the caller must neither change nor free
 * it until the core hands it back, exactly once, as a completion (urb_core_take_completed, or its
 * callback run by urb_loop). Then it is the caller's again and may be reused for a new request.
 * The core keeps no pointer to a completed transfer: a request that timed out but that the bridge
 * may still answer is remembered as a placeholder inside the core, not through the transfer.
 *
 *     urb_transfer_t t;
 *     urb_transfer_read(&t, 0x20, 1, 6);             // MotorFeedback of the node at 0x20
 *     urb_core_submit(&core, &t, now);
 *     ...
 *     urb_transfer_t *done = urb_core_take_completed(&core);   // == &t once answered
 *     if (urb_transfer_ok(done)) use(done->response, done->response_len);
 */
#ifndef URB_TRANSFER_H
#define URB_TRANSFER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_flags.h"
#include "urb_host_base.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct urb_transfer urb_transfer_t;

/** Completion callback: runs exactly once per submission, after the transfer completed, when a
 *  runtime dispatches it (urb_loop, urb_dispatch_completed). `t->callback_ns` holds the dispatch
 *  time; `user` is what urb_transfer_set_callback was given. The transfer is the caller's again
 *  inside the callback (it may be resubmitted from there). */
typedef void (*urb_done_fn)(urb_transfer_t *t, void *user);

/** Where a transfer is in its life (urb_transfer_t.state). */
typedef enum {
    URB_XFER_IDLE = 0,       /**< Built, never submitted (or reset by urb_transfer_read/_write) */
    URB_XFER_QUEUED = 1,     /**< Submitted, waiting on the host for the window (not sent) */
    URB_XFER_IN_FLIGHT = 2,  /**< Sent, waiting for its response */
    URB_XFER_COMPLETED = 3,  /**< Complete, waiting to be taken from the core's completion list */
    URB_XFER_DONE = 4        /**< Complete and handed back to the caller */
} urb_xfer_state_t;

struct urb_transfer {
    /* ---- the request: set by urb_transfer_read / urb_transfer_write ---- */
    uint8_t address;            /**< Downlink address 0..127 (0: the bridge itself) */
    uint8_t mailbox;            /**< Mailbox 0..7 (an outbox for reads, an inbox for writes) */
    bool read;                  /**< true: read the outbox; false: write the inbox */
    uint8_t length;             /**< Bytes to read, or bytes in data[] to write: 1..32 */
    uint8_t data[URB_HOST_MAILBOX_MAX]; /**< Write payload (data[0 .. length - 1]) */
    urb_ns_t answer_within_ns;  /**< How long the bridge may take to answer when that is longer than
                                     the core's timeout and lifetime (a bridge SCAN:
                                     URB_SCAN_ANSWER_NS); 0: the usual. Requests sent while it is
                                     in flight wait behind it, their clocks start after it. */
    urb_done_fn on_done;        /**< Callback for runtimes that dispatch (NULL: none) */
    void *user;                 /**< Passed to on_done; never touched by the library */

    /* ---- the outcome: written by the core, read-only for the caller ---- */
    int8_t seq;                 /**< 4-bit sequence number, set when sent; -1 before */
    int8_t status;              /**< The bridge's Status (0..8) when a response arrived; -1 otherwise */
    uint8_t response_len;       /**< Bytes in response[] (an OK read: == length; else 0) */
    uint8_t state;              /**< urb_xfer_state_t */
    urb_flags_t flags;          /**< URB_FLAG_NONE on success, else exactly one URB_FLAG_* */
    uint8_t response[URB_HOST_MAILBOX_MAX]; /**< Mailbox contents of a successful read */
    urb_ns_t submitted_ns;      /**< When it was submitted */
    urb_ns_t sent_ns;           /**< When it was put on the wire (URB_NO_TIME: never) */
    urb_ns_t completed_ns;      /**< When the core completed it (response matched, timeout, loss) */
    urb_ns_t callback_ns;       /**< When a runtime dispatched it (URB_NO_TIME: not dispatched) */
    char lost_reason[URB_REASON_MAX]; /**< For URB_FLAG_BRIDGE_LOST: why the bridge was considered
                                           lost ("closed by the application", ...); else "" */

    /* ---- private to the core ---- */
    urb_transfer_t *next;       /**< Queue and completion-list link */
};

/**
 * Makes `t` a read of outbox `mailbox` (0..7) of the node at downlink `address` (0..127),
 * `length` (1..32) bytes, and clears its outcome, callback and answer time. `t` may be fresh,
 * uninitialised memory; it must not be a transfer a core owns (urb_transfer_owned(): submitted and
 * not handed back), whose links the core still uses. Returns URB_HOST_OK, or URB_HOST_EINVAL for
 * t == NULL or an argument out of range (then nothing changes). O(1) (clears about 250 bytes), no
 * memory beyond *t.
 */
int32_t urb_transfer_read(urb_transfer_t *t, uint8_t address, uint8_t mailbox, uint8_t length);

/**
 * Makes `t` a write of `length` (1..32) bytes from `data` to inbox `mailbox` (0..7) of the node
 * at `address` (0..127); the bytes are copied. Errors as urb_transfer_read, and URB_HOST_EINVAL
 * for data == NULL. O(length).
 */
int32_t urb_transfer_write(urb_transfer_t *t, uint8_t address, uint8_t mailbox, const uint8_t *data,
                           uint8_t length);

/** Sets the completion callback (fn may be NULL) and its argument. URB_HOST_EINVAL for t == NULL,
 *  URB_HOST_EBUSY while a core owns t. O(1). */
int32_t urb_transfer_set_callback(urb_transfer_t *t, urb_done_fn fn, void *user);

/** Sets answer_within_ns (0..URB_NS_PER_S * 3600). URB_HOST_EINVAL for t == NULL or out of
 *  range, URB_HOST_EBUSY while a core owns t. O(1). */
int32_t urb_transfer_set_answer_within(urb_transfer_t *t, urb_ns_t answer_within_ns);

/** True when `t` completed without error (false for NULL). O(1). */
bool urb_transfer_ok(const urb_transfer_t *t);

/** True when a core owns `t` (queued, in flight, or completed and not yet taken). O(1). */
bool urb_transfer_owned(const urb_transfer_t *t);

/** Bytes of the response frame answering `t` with bridge status `status` (the wire rule: data only
 *  for an OK read; a 1-byte check up to 14 covered bytes, else 2). 0 for t == NULL. O(1). */
size_t urb_transfer_response_size(const urb_transfer_t *t, uint8_t status);

/** Bytes of the request frame of `t` (4 for a read, 4..37 for a write). 0 for t == NULL. O(1). */
size_t urb_transfer_request_size(const urb_transfer_t *t);

/** callback_ns - submitted_ns (the paper's latency, Figs. 15-16), or -1 when not yet dispatched
 *  or t == NULL. O(1). */
urb_ns_t urb_transfer_latency_ns(const urb_transfer_t *t);

#ifdef __cplusplus
}
#endif

#endif /* URB_TRANSFER_H */
