/*
 * URB CAN downlink, node side: the slave that answers the bridge's requests (urb_can_master.h has
 * the contract) from the node's CAN interrupt, feeding the node library's mailboxes through
 * urb_dl_slave.h.
 *
 *  - A write's frames go straight into the inbox buffer the mailbox algorithm hands out at the
 *    start frame (IsrWriteBegin); the end frame commits it when the transfer's CRC holds and its
 *    length is the inbox size, and the node answers: empty (OK), or CanWriteRefusal NODE_BUSY
 *    (both buffers in use, fault OVERRUN), BAD_REQUEST (no such inbox), SIZE_MISMATCH, CHECKSUM
 *    (CRC failed, fault CHECKSUM). An empty write is a probe: answered empty, no mailbox touched.
 *  - A read request latches the outbox (IsrReadBegin) and the answer's frames are cut from it as
 *    the controller takes them; the last frame sent ends the read (IsrReadEnd, complete). A node
 *    without that outbox answers empty.
 *  - A repeated transfer is not taken twice: CAN may deliver a frame twice (a receiver that saw an
 *    error in the last bit of the end of frame takes the frame, the sender sends it again), so a
 *    start frame with the session and transfer id of the request completed last, within
 *    `dup_window_us` of it, is ignored (CanTransfer.tla Receive, the duplicate filter); frames repeated inside
 *    a transfer are the toggle bit's business.
 *  - A new request drops the one in progress: an unfinished write is aborted, an answer still being
 *    sent is abandoned (read ended, incomplete).
 *  - SYNC (CAN_SYNC_ID, one frame with the counter) is passed on with the frame's time stamp.
 *  - Bus-off: the answer and the write in progress are abandoned, a STUCK_BUS fault is counted and
 *    the recovery started.
 * Every entry point is called from the node's CAN interrupt(s), at one priority. O(7) each.
 */
#ifndef URB_CAN_SLAVE_H
#define URB_CAN_SLAVE_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_can.h"
#include "urb_dl_slave.h"

#ifdef __cplusplus
extern "C" {
#endif

#define URB_CAN_SLAVE_NO_SESSION 0xFFu /**< no request in progress / none completed */

/** Counters for diagnostics (urb_can_slave_stats). */
typedef struct {
    uint32_t requests;   /**< requests answered */
    uint32_t duplicates; /**< repeated requests ignored */
    uint32_t crc_errors; /**< writes whose transfer CRC failed */
    uint32_t dropped;    /**< requests or answers abandoned for a newer request or bus-off */
    uint32_t bus_off;    /**< bus-off events */
    uint32_t syncs;      /**< SYNC frames passed on */
} urb_can_slave_stats_t;

/** State of the node side of one CAN downlink; caller-owned; members are private. */
typedef struct {
    const urb_can_hal_t *hal;
    const urb_dl_mailbox_t *mb;
    uint8_t address;       /* own address 1..63 */
    uint32_t dup_window_us;
    /* request in progress */
    urb_can_rx_t rx;
    uint8_t session;       /* session of the transfer in progress, URB_CAN_SLAVE_NO_SESSION when none */
    uint8_t *wbuf;         /* inbox buffer being filled, NULL when none */
    uint8_t wsize;         /* its size */
    uint8_t refusal;       /* status decided at the start frame (NODE_BUSY, BAD_REQUEST) or OK */
    /* the request completed last (duplicate filter) */
    uint8_t last_session;
    uint8_t last_tid;
    uint32_t last_t;
    /* answer being sent */
    urb_can_tx_t tx;
    urb_can_frame_t frame;
    uint8_t answer[1];     /* a write's refusal byte */
    uint8_t reading;       /* outbox latched for the answer, URB_CAN_SLAVE_NO_SESSION when none */
    uint8_t frames_total;
    uint8_t frames_sent;
    bool frame_ready;
    bool sending;
    urb_can_slave_stats_t stats;
} urb_can_slave_t;

/** Initialises *s as node `address` (1..63) on the controller *hal with the mailboxes *mb (both
 *  kept by reference); `dup_window_us` is how long a repeat of the last request is recognised
 *  (urb_can_slave_dup_window_us). Returns false (nothing set up) for an address out of range or a
 *  missing required function. */
bool urb_can_slave_init(urb_can_slave_t *s, const urb_can_hal_t *hal, const urb_dl_mailbox_t *mb, uint8_t address,
                        uint32_t dup_window_us);

/** The duplicate window for a bus at `bitrate_kbps`: 8 worst-case frames (8 x 135 bit times), enough
 *  for an error frame, the sender's suspend time and a frame of higher priority before the repeat:
 *  1080 us at 1 Mb/s, 4320 us at 250 kb/s. 0 gives the 125 kb/s value. */
uint32_t urb_can_slave_dup_window_us(uint32_t bitrate_kbps);

/** The controller received `frame` at tick `t` (its start of frame, as the port captured it). */
void urb_can_slave_rx(urb_can_slave_t *s, const urb_can_frame_t *frame, uint32_t t);

/** The oldest queued frame was sent. */
void urb_can_slave_tx_done(urb_can_slave_t *s);

/** The controller's state changed to `state` (urb_can_state_t); bus-off is acted on. */
void urb_can_slave_state(urb_can_slave_t *s, uint8_t state);

/** True while an answer is being sent. */
bool urb_can_slave_sending(const urb_can_slave_t *s);

/** Copies the counters into *out. */
void urb_can_slave_stats(const urb_can_slave_t *s, urb_can_slave_stats_t *out);

#ifdef __cplusplus
}
#endif

#endif /* URB_CAN_SLAVE_H */
