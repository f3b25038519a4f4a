/*
 * urb_host_base.h: time, return codes and protocol constants shared by the URB host library.
 *
 * The host library (host/c/README.md) is the CPU side of URB in C99: sans-IO protocol cores
 * (urb_host_core.h, urb_discovery.h) that are fed bytes and timestamps and return bytes, deadlines
 * and completions, and a Linux port (urb_port.h, urb_loop.h) that moves the bytes. It is the same
 * protocol as the Python library host/urb (host/urb/README.md), constant for constant.
 *
 * Conventions of every header of the library:
 *   - Times are nanoseconds of the caller's monotonic clock in an int64_t (urb_ns_t). The cores
 *     never read a clock: every function that needs the time takes `now`. Calls on one object
 *     must pass non-decreasing `now` values (what a monotonic clock gives).
 *   - No heap, no globals (beyond const tables), no threads in the cores: every object is a
 *     caller-owned struct, initialised by its *_init function, whose size is fixed at compile time.
 *   - Functions that can fail return an int32_t: >= 0 on success (a count or a size), or one of
 *     the URB_HOST_E* codes below. Invalid arguments never crash a core: they give URB_HOST_EINVAL
 *     and change nothing.
 *   - The fields of the structs are visible (so they can live on the stack or in a static) but
 *     private unless their comment says otherwise: read them through the accessor functions.
 */
#ifndef URB_HOST_BASE_H
#define URB_HOST_BASE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** A time or a duration in nanoseconds of the caller's monotonic clock. */
typedef int64_t urb_ns_t;

/** "No such time": a deadline that never comes, a request not sent yet (Python's None). */
#define URB_NO_TIME INT64_MIN
/** The latest time: what urb_*_next_deadline returns when nothing is due (Python's None). */
#define URB_NEVER INT64_MAX

#define URB_NS_PER_US 1000LL
#define URB_NS_PER_MS 1000000LL
#define URB_NS_PER_S 1000000000LL

/* ===== Return codes ======================================================================== */

#define URB_HOST_OK 0              /**< Success */
#define URB_HOST_EINVAL (-1)       /**< An argument is NULL or out of its documented range; nothing changed */
#define URB_HOST_EBUSY (-2)        /**< The transfer is still owned by a core (submitted and not completed) */
#define URB_HOST_ENOSPC (-3)       /**< A fixed capacity is full (output buffer, table); nothing changed */
#define URB_HOST_EIO (-4)          /**< An operating-system call failed; the object's error text says which */
#define URB_HOST_ESTATE (-5)       /**< Not allowed in the object's current state (e.g. discovery running) */
#define URB_HOST_ENOTFOUND (-6)    /**< No such node, manager or record */

/** The name of a URB_HOST_E* code ("EINVAL", ...), "OK" for 0 and "?" for anything else. */
const char *urb_host_error_name(int32_t code);

/* ===== Protocol constants (the Python library's, host/urb/managers/rs232_core.py) ============= */

/** Sequence numbers are 4 bits: the n-th request of a process carries n mod 16 (Bridge.tla SeqOf). */
#define URB_SEQ_MOD 16u
/** At most this many requests in flight per bridge, so the sequence number cannot alias
 *  (Bridge.tla HostWindow < SeqMod). */
#define URB_MAX_WINDOW 15u
/** How long a timed-out request keeps its sequence number and window slot after it was sent: the
 *  bridge firmware's worst-case answer time at 100 kb/s, rounded up (rs232_core.PLACEHOLDER_NS). */
#define URB_PLACEHOLDER_NS (300LL * URB_NS_PER_MS)
/** How long a bridge may take to answer a SCAN command (rs232_core.SCAN_ANSWER_NS). */
#define URB_SCAN_ANSWER_NS (1500LL * URB_NS_PER_MS)
/** One USB frame (usb_core.FRAME_NS). */
#define URB_USB_FRAME_NS URB_NS_PER_MS
/** Largest mailbox payload in bytes. */
#define URB_HOST_MAILBOX_MAX 32u
/** Longest uplink response frame (a 32-byte read: 1 + 32 + 2). */
#define URB_RESPONSE_MAX 35u
/** Longest uplink request frame (a 32-byte write: 3 + 32 + 2). */
#define URB_REQUEST_MAX 37u
/** Bytes of a USB batch header. */
#define URB_USB_HEADER_SIZE 4u
/** Largest USB transfer the host builds or accepts as one batch (core.urbs USB_BATCH_MAX_BYTES). */
#define URB_USB_BATCH_MAX 512u
/** Room for one lost reason, terminating NUL included (longer texts are cut). A build may change it
 *  (a bounded proof shrinks it: ESBMC copies a whole transfer at each store into one). */
#ifndef URB_REASON_MAX
#define URB_REASON_MAX 112u
#endif

#ifdef __cplusplus
}
#endif

#endif /* URB_HOST_BASE_H */
