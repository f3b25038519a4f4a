/*
 * urb_host_core.h: the host side of the URB uplink protocol for one bridge, as a pure state
 * machine (sans-IO): fed received bytes and timestamps, asked for frames to send, it returns
 * completions and the next instant it needs to be polled. No I/O, no clock, no threads, no heap.
 * It is the Python library's Rs232Core and UsbCore (host/urb/managers/rs232_core.py,
 * usb_core.py) transcribed rule for rule; tests/host_c/test_differential.py drives both with the
 * same byte and time traces and requires the same completions (flags, data, order, times).
 *
 * What it implements (spec: spec/tla/Bridge.tla, UsbUplink.tla; spec/schema/README.md):
 *   - the pending-request FIFO matched by order AND 4-bit sequence number: the n-th request of a
 *     core carries n mod 16 (Bridge.tla SeqOf); a response is matched to the oldest request in
 *     flight whose number it echoes, and the requests before it complete as lost
 *     (Bridge.tla HostMatch; UsbUplink.tla Callback);
 *   - the window: at most `window` (<= 15) requests in flight, placeholders included; the others
 *     wait on the host, never dropped (Bridge.tla SubmitAndAdmit's guard);
 *   - RS232 hunting: a candidate starts with a byte whose sequence number is in flight and whose
 *     status is valid; its length follows from the matched request and the status; a candidate
 *     that fails its check loses its first byte; a partial candidate with no byte for
 *     resync_gap_ns loses its first byte too;
 *   - USB batches: one OUT transfer per frame (a header and up to max_batch requests, within
 *     batch_bytes both ways), an OUT every frame while responses are outstanding; each IN
 *     transfer is matched as one response stream and what is left of it is discarded;
 *   - timeouts (URB_FLAG_UPLINK_TIMEOUT, or URB_FLAG_UPLINK_CHECKSUM when corrupt bytes stood in
 *     the request's place) that keep the request's sequence number and window slot as a
 *     PLACEHOLDER until its late response (discarded), a later response, or placeholder_ns after
 *     its sending (Bridge.tla HostTimeout, HostExpire);
 *   - the lost-bridge rules (host/urb/README.md "When a bridge is declared lost"): an I/O error
 *     (urb_core_link_lost), lost_after_ns of silence with requests outstanding, or the
 *     lost_after_timeouts-th timeout in a row after lost_after_ns of silence; then every pending
 *     and later request completes URB_FLAG_BRIDGE_LOST until urb_core_reset (Bridge.tla
 *     HostLinkLost, HostReopen);
 *   - a draining close (urb_core_start_drain) and the hand-over wait of a new process
 *     (urb_core_hand_over; Bridge.tla HostRestart).
 *
 * The contract: every submitted transfer completes exactly once (urb_core_take_completed hands
 * it back), whatever arrives, including bytes that are garbage, a bridge that goes silent or a
 * caller that resets or drains the core.
 *
 * Using it (the real-time port urb_loop.h does exactly this):
 *
 *     urb_core_t core;  urb_core_config_t cfg;
 *     urb_core_default_config(&cfg, URB_LINK_RS232);
 *     urb_core_init(&core, URB_LINK_RS232, &cfg);
 *     urb_core_submit(&core, &t, now);
 *     for (;;) {                                   // on every wake-up, in any order:
 *         while ((n = urb_core_next_frame(&core, now, frame, sizeof frame)) > 0) write(fd, frame, n);
 *         urb_core_receive(&core, bytes, got, now); // whatever the port delivered
 *         urb_core_poll(&core, now);                // at or after urb_core_next_deadline()
 *         while ((done = urb_core_take_completed(&core)) != NULL) handle(done);
 *     }
 *
 * Threads: a core is not thread-safe; callers serialise access (urb_loop holds a mutex).
 */
#ifndef URB_HOST_CORE_H
#define URB_HOST_CORE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_flags.h"
#include "urb_host_base.h"
#include "urb_transfer.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ===== The response matcher (rs232_core.ResponseMatcher), shared by both uplinks ============ */

/** Bytes the matcher holds between calls: a partial response candidate (at most 34 bytes) plus
 *  room to take received bytes in chunks (at least URB_RESPONSE_MAX; a build may change it). */
#ifndef URB_MATCHER_RX
#define URB_MATCHER_RX 64u
#endif

/** Slots of the in-flight ring: the window's maximum. Only a bounded proof sets it lower (keeping
 *  every window it uses within it): ESBMC copies the whole matcher at each store into it. */
#ifndef URB_MATCHER_SLOTS
#define URB_MATCHER_SLOTS URB_MAX_WINDOW
#endif

/** One request in flight: live (t != NULL) or a placeholder (t == NULL: it completed, timed out or
 *  failed BRIDGE_LOST, and the bridge may still answer it). */
typedef struct {
    urb_transfer_t *t;   /**< The live transfer, NULL for a placeholder */
    urb_ns_t due_ns;     /**< When a live request completes UPLINK_TIMEOUT */
    urb_ns_t expires_ns; /**< When the bridge no longer holds it: the placeholder's end */
    uint8_t seq;         /**< Its sequence number */
    uint8_t length;      /**< Its length (a placeholder's response still has to be sized) */
    bool read;           /**< A read (an OK response then carries `length` data bytes) */
    bool garbage;        /**< Corrupt bytes were seen while it was the oldest live request */
    bool long_answer;    /**< Sent with answer_within_ns > 0 */
} urb_slot_t;

/** The requests in flight (oldest first, a ring), the bytes held, the completions not yet taken. */
typedef struct {
    urb_slot_t slot[URB_MATCHER_SLOTS];
    uint8_t head;            /**< Ring index of the oldest request in flight */
    uint8_t count;           /**< Requests in flight, placeholders included */
    uint8_t rx_start;        /**< Where the bytes held start in rx: dropping bytes moves it, not them */
    uint8_t rx_len;          /**< Bytes held: rx[rx_start .. rx_start + rx_len) */
    uint8_t rx[URB_MATCHER_RX];
    uint64_t stray_bytes;    /**< Bytes that answered no request (corrupt, or nothing in flight) */
    uint64_t late_responses; /**< Responses to placeholders, discarded */
    uint64_t released_placeholders; /**< Placeholders released without their late response */
    urb_transfer_t *done_head; /**< Completed transfers not yet taken, in completion order */
    urb_transfer_t *done_tail;
} urb_matcher_t;

/** Empties `m`. Nothing happens for m == NULL. O(1). */
void urb_matcher_init(urb_matcher_t *m);

/**
 * Puts a live request in flight behind the others, with sequence number seq (0..15) and its
 * timeout and lifetime. Returns URB_HOST_OK; URB_HOST_EINVAL for NULL arguments or seq > 15;
 * URB_HOST_ENOSPC when URB_MATCHER_SLOTS requests are in flight (the caller's window prevents it).
 * t->seq is set; t->state becomes URB_XFER_IN_FLIGHT. O(1).
 */
int32_t urb_matcher_push(urb_matcher_t *m, urb_transfer_t *t, uint8_t seq, urb_ns_t due_ns,
                         urb_ns_t expires_ns);

/**
 * Takes n received bytes (any chunking) and matches every complete response among the bytes
 * held (hunting past corrupt ones). Returns true when a partial candidate is left waiting for more
 * bytes. data may be NULL only when n == 0 (then it just parses what is held). O(n * w) with w the
 * requests in flight (<= 15), no memory beyond *m.
 */
bool urb_matcher_feed(urb_matcher_t *m, const uint8_t *data, size_t n, urb_ns_t now);

/** Drops the first n held bytes (counted as stray; the oldest live request is marked as having
 *  had corrupt bytes in its place). n is cut to the bytes held. O(held bytes). */
void urb_matcher_discard(urb_matcher_t *m, size_t n);

/** Completes UPLINK_TIMEOUT (or UPLINK_CHECKSUM) every live request due by `now`, which stays in
 *  flight as a placeholder, then releases the expired placeholders. Returns how many timed out.
 *  O(w). */
uint32_t urb_matcher_time_out(urb_matcher_t *m, urb_ns_t now);

/** Releases the placeholders whose lifetime is over by `now` (wherever they are). O(w). */
void urb_matcher_expire(urb_matcher_t *m, urb_ns_t now);

/** When the first live request times out or the first placeholder expires; URB_NEVER when nothing
 *  is in flight. O(w). */
urb_ns_t urb_matcher_next_event(const urb_matcher_t *m);

/** The latest lifetime of a request in flight sent with a long answer time; 0 when none. O(w). */
urb_ns_t urb_matcher_long_until(const urb_matcher_t *m);

/** The oldest completed transfer not yet taken (handed back: state URB_XFER_DONE), or NULL. O(1). */
urb_transfer_t *urb_matcher_take(urb_matcher_t *m);

/* ===== The protocol core of one bridge (MatchingCore, Rs232Core, UsbCore) ===================== */

typedef enum {
    URB_LINK_RS232 = 1, /**< A byte stream (a serial port): urb_core_receive, urb_core_next_frame */
    URB_LINK_USB = 2    /**< Per-frame transfers: urb_core_receive_batch, urb_core_frame_out */
} urb_link_kind_t;

/** Settings of a core (urb_core_default_config gives the Python library's defaults). */
typedef struct {
    uint8_t window;               /**< Requests in flight, placeholders included: 1..15 (RS232 4, USB 15);
                                       lowered or raised after discovery from BridgeInfo.fifo_depth */
    urb_ns_t timeout_ns;          /**< No response this long after sending: UPLINK_TIMEOUT (RS232 100 ms,
                                       USB 50 ms); 1 ns .. 1 h */
    urb_ns_t lost_after_ns;       /**< Silence that declares the bridge lost (500 ms); 1 ns .. 1 h */
    uint32_t lost_after_timeouts; /**< Timeouts in a row that, after lost_after_ns of silence, declare it
                                       lost (8); >= 1 */
    urb_ns_t placeholder_ns;      /**< A timed-out request's lifetime from its sending (300 ms); keep it
                                       below lost_after_ns; 0 .. 1 h */
    urb_ns_t resync_gap_ns;       /**< RS232: idle time after which a partial candidate loses its first
                                       byte (20 ms); 1 ns .. 1 h */
    uint8_t max_batch;            /**< USB: requests per OUT transfer, 1..15 (14) */
    uint16_t batch_bytes;         /**< USB: largest transfer either way, 41..512 (512) */
} urb_core_config_t;

/** One bridge's protocol state. Size: about 1.2 KiB; no other memory. */
typedef struct {
    uint8_t kind;                 /**< urb_link_kind_t */
    urb_core_config_t cfg;
    urb_matcher_t m;
    urb_transfer_t *q_head;       /**< Submitted, not sent (intrusive FIFO through t->next) */
    urb_transfer_t *q_tail;
    uint32_t queued;
    bool lost;                    /**< The bridge is lost (or the core closed): requests fail at once */
    bool closing;                 /**< urb_core_start_drain was called: nothing more is sent */
    bool partial;                 /**< RS232: a partial candidate is held */
    bool flushing;                /**< USB hand-over: IN transfers are fetched and discarded */
    uint8_t next_seq;
    uint16_t frame;               /**< USB: the next OUT transfer's frame counter, 1..65535 */
    uint32_t silent_timeouts;     /**< Timeouts since the bridge last sent something */
    urb_ns_t last_heard_ns;       /**< When the bridge last sent something */
    urb_ns_t active_since_ns;     /**< When the host last went from nothing outstanding to something */
    urb_ns_t handover_until_ns;   /**< Nothing is sent before this (URB_NO_TIME: no hand-over) */
    urb_ns_t quiet_until_ns;      /**< Silence is excused until then (a long answer in flight) */
    urb_ns_t flush_empty_from_ns; /**< USB hand-over: an empty IN from this instant ends the flush */
    uint64_t frames_written;      /**< USB OUT transfers built */
    uint64_t transfers_in;        /**< USB IN transfers received */
    uint64_t bad_headers;         /**< USB IN transfers whose header did not decode */
    char lost_reason[URB_REASON_MAX]; /**< Why it is lost ("" while usable) */
} urb_core_t;

/** Fills *cfg with the defaults for `kind` (the Python managers' defaults). Nothing happens for
 *  cfg == NULL or an unknown kind. O(1). */
void urb_core_default_config(urb_core_config_t *cfg, urb_link_kind_t kind);

/**
 * Initialises `core` for one bridge on an uplink of `kind` (cfg NULL: the defaults). The first
 * request sent carries sequence number 1. Returns URB_HOST_OK, or URB_HOST_EINVAL for core ==
 * NULL, an unknown kind or a setting out of its range (listed in urb_core_config_t), in which
 * case *core is not initialised. O(1), no memory beyond *core.
 */
int32_t urb_core_init(urb_core_t *core, urb_link_kind_t kind, const urb_core_config_t *cfg);

/**
 * Queues `t` (it goes out when the window allows). A lost or closing core completes it at once
 * with URB_FLAG_BRIDGE_LOST (its lost_reason says why), still through urb_core_take_completed.
 * Sets t->submitted_ns = now. Returns URB_HOST_OK; URB_HOST_EINVAL for NULL arguments or a
 * transfer whose fields are out of range (address > 127, mailbox > 7, length not 1..32,
 * answer_within_ns < 0); URB_HOST_EBUSY when a core already owns t (submitted and not handed
 * back). On error nothing changes and no completion will come. O(w).
 */
int32_t urb_core_submit(urb_core_t *core, urb_transfer_t *t, urb_ns_t now);

/**
 * RS232: bytes received from the uplink, in arrival order (any chunking). Returns URB_HOST_OK, or
 * URB_HOST_EINVAL for core == NULL, a USB core, or data == NULL with n > 0. O(n * w).
 */
int32_t urb_core_receive(urb_core_t *core, const uint8_t *data, size_t n, urb_ns_t now);

/**
 * USB: one bulk-IN transfer, whole (a batch header, then responses back to back; a response
 * never spans two transfers). n may be 0 (an empty transfer still shows the bridge alive).
 * Returns URB_HOST_OK, or URB_HOST_EINVAL for core == NULL, an RS232 core, or data == NULL with
 * n > 0. Transfers longer than the window's responses are fine: what answers nothing is stray.
 * O(n * w).
 */
int32_t urb_core_receive_batch(urb_core_t *core, const uint8_t *data, size_t n, urb_ns_t now);

/** Applies timeouts, the RS232 idle-gap rule and the lost-bridge rules at `now`. Call it at or
 *  after urb_core_next_deadline() (earlier or more often is harmless). URB_HOST_EINVAL for
 *  core == NULL. O(w). */
int32_t urb_core_poll(urb_core_t *core, urb_ns_t now);

/**
 * RS232: the next request frame that may go on the wire now, written to buf (write it with ONE
 * write(): the bridge's idle-gap rule needs its bytes back to back). Returns its size (4..37), 0
 * when nothing may be sent (window full, nothing queued, hand-over wait, lost), URB_HOST_EINVAL
 * for NULL arguments or a USB core, URB_HOST_ENOSPC when cap < URB_REQUEST_MAX (nothing
 * changes). Call it until it returns 0. O(w).
 */
int32_t urb_core_next_frame(urb_core_t *core, urb_ns_t now, uint8_t *buf, size_t cap);

/**
 * USB: the bulk-OUT transfer for this frame (call once per 1-ms frame): a batch header and the
 * queued requests that fit, written to buf. Returns its size (>= 4; an empty batch of 4 bytes
 * while responses are outstanding or a hand-over flushes), 0 when there is nothing to send or
 * fetch, URB_HOST_EINVAL for NULL arguments or an RS232 core, URB_HOST_ENOSPC when cap <
 * cfg.batch_bytes (nothing changes). O(max_batch + w).
 */
int32_t urb_core_frame_out(urb_core_t *core, urb_ns_t now, uint8_t *buf, size_t cap);

/** USB: true when urb_core_frame_out would return a transfer (requests queued or in flight, or a
 *  hand-over flushing): the runtime needs a frame tick. False for NULL or an RS232 core. O(1). */
bool urb_core_wants_frame(const urb_core_t *core);

/** The oldest completed transfer not yet handed back, or NULL; completions come in completion
 *  order (= request order for responses). The transfer is the caller's again. O(1). */
urb_transfer_t *urb_core_take_completed(urb_core_t *core);

/** When urb_core_poll next has something to do; URB_NEVER when nothing is pending (or core is
 *  NULL). O(w). */
urb_ns_t urb_core_next_deadline(const urb_core_t *core);

/**
 * The uplink is gone (an I/O error, the port closed): every request in flight and queued
 * completes URB_FLAG_BRIDGE_LOST with `reason` (cut to URB_REASON_MAX - 1 bytes; NULL: "the uplink
 * was lost"), and so does every later submission until urb_core_reset. Requests in flight stay
 * as placeholders (a reopened uplink does not reset the bridge). Nothing happens when already
 * lost or core == NULL. O(w + queued).
 */
void urb_core_link_lost(urb_core_t *core, urb_ns_t now, const char *reason);

/** After the uplink was reopened: what is pending completes BRIDGE_LOST ("the uplink was reset
 *  (reconnect)"), the lost state is forgotten, the placeholders stay. O(w + queued). */
void urb_core_reset(urb_core_t *core, urb_ns_t now);

/**
 * The start of a draining close: queued requests complete BRIDGE_LOST ("closed by the
 * application"), and so does every later submission; requests in flight go on being matched and
 * timed out. Returns when the drain ends at the latest (the newest lifetime in flight), or
 * URB_NO_TIME when there is nothing to wait for (nothing in flight, or lost). O(w + queued).
 */
urb_ns_t urb_core_start_drain(urb_core_t *core, urb_ns_t now);

/** Nothing left to wait for after urb_core_start_drain: nothing in flight, or lost. O(1). */
bool urb_core_drained(const urb_core_t *core);

/**
 * This core is a new user of the port: send nothing before `until_ns`, when the late responses
 * to the previous process's requests are over (urb_handover_predecessor_until). What arrives
 * meanwhile answers nothing and is stray. On USB it also fetches and discards IN transfers until
 * one received two frames after until_ns or later is empty. No effect for core == NULL. O(1).
 */
void urb_core_hand_over(urb_core_t *core, urb_ns_t until_ns);

/** The latest lifetime in flight (when the last response to this core's requests may come), or
 *  URB_NO_TIME when nothing is in flight. O(w). */
urb_ns_t urb_core_busy_until(const urb_core_t *core);

/** Sets the window (1..15; learnt from BridgeInfo.fifo_depth). URB_HOST_EINVAL otherwise. O(1). */
int32_t urb_core_set_window(urb_core_t *core, uint8_t window);

/** Requests queued or in flight (placeholders included). O(1). */
bool urb_core_busy(const urb_core_t *core);
/** Queued requests the window lets go out now (once a hand-over is over). O(1). */
bool urb_core_has_queued(const urb_core_t *core);
/** Requests in flight, placeholders included (what the window counts). O(1). */
uint32_t urb_core_in_flight(const urb_core_t *core);
/** Placeholders in flight. O(w). */
uint32_t urb_core_placeholders(const urb_core_t *core);
/** Why the bridge is lost, or NULL while it is usable. O(1). */
const char *urb_core_lost_reason(const urb_core_t *core);

#ifdef __cplusplus
}
#endif

#endif /* URB_HOST_CORE_H */
