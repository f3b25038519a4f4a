/*
 * URB RS485 downlink, node side: answers the bridge's polls (urb_rs485_master.h has the contract)
 * from the node's UART interrupts, feeding the node library's mailboxes through urb_dl_slave.h.
 *
 *  - A frame is taken when it ends (t3.5 of silence, urb_rs485.h) and it is addressed to this
 *    node (byte 0: address, direction bit clear). Then, in this order: a failed check -> answer
 *    CHECKSUM (fault CHECKSUM), when the frame has a select byte; reserved select bits -> BAD_REQUEST;
 *    a read: data present -> BAD_REQUEST, no such outbox -> BAD_REQUEST, else OK and the outbox;
 *    a write without data is a probe -> OK, nothing touched; no such inbox -> BAD_REQUEST; a length
 *    other than the inbox size -> SIZE_MISMATCH; both buffers in use -> NODE_BUSY (fault OVERRUN);
 *    else the write is committed -> OK.
 *  - A write's data go straight into the inbox buffer as they arrive (IsrWriteBegin at the second
 *    data position, when the frame cannot be a probe any more); the end of the frame commits or
 *    aborts. Nothing is kept of a frame but its header, its CRCs and two bytes.
 *  - The answer starts at the end of the request (the t3.5 silence): the port enables the driver
 *    and pulls its bytes; the outbox is latched from the answer's start to its last byte. An
 *    answer not all sent when a frame ends (t3.5 of silence: the UART stalled, the driver lost the
 *    line) is dropped and its outbox released as not complete (read_end(.., false)).
 *  - A frame to address 0 with a good check, three bytes long, is SYNC: its counter is passed on
 *    with the time stamp of its first byte.
 *  - Broadcasts and frames to other nodes get no answer; nor does a frame without a select byte.
 * The port calls urb_rs485_slave_rx() per received byte, urb_rs485_slave_poll() when the silence
 * deadline (urb_rs485_rx_deadline, asked for with hal->wake_at) is reached, and
 * urb_rs485_slave_tx_next() per transmit slot, all at one interrupt priority. O(1) each, but the
 * frame's end, which is O(size) for the answer's check (computed there, before the first byte).
 */
#ifndef URB_RS485_SLAVE_H
#define URB_RS485_SLAVE_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_dl_slave.h"
#include "urb_rs485.h"

#ifdef __cplusplus
extern "C" {
#endif

#define URB_RS485_SLAVE_NONE 0xFFu /**< no mailbox */

/** Counters for diagnostics (urb_rs485_slave_stats). */
typedef struct {
    uint32_t answered;  /**< requests answered */
    uint32_t bad_check; /**< requests whose check failed */
    uint32_t syncs;     /**< SYNC frames passed on */
} urb_rs485_slave_stats_t;

/** State of the node side of one RS485 downlink; caller-owned; members are private. */
typedef struct {
    const urb_rs485_hal_t *hal;
    const urb_dl_mailbox_t *mb;
    urb_rs485_rx_t rx;
    uint8_t address;     /* own address 1..127 */
    uint8_t mine;        /* the frame in progress is addressed to this node */
    uint8_t *wbuf;       /* inbox buffer being filled, NULL when none */
    uint8_t wsize;
    uint8_t wbox;        /* inbox being written, URB_RS485_SLAVE_NONE when none */
    /* answer */
    uint8_t tx_head;     /* status | mailbox << 4 | 0x80 */
    const uint8_t *tx_data;
    uint8_t tx_len;      /* data bytes */
    uint8_t tx_pos;      /* bytes pulled so far */
    uint8_t tx_check[2];
    uint8_t tx_total;    /* header + data + check */
    uint8_t reading;     /* outbox latched, URB_RS485_SLAVE_NONE when none */
    urb_rs485_slave_stats_t stats;
} urb_rs485_slave_t;

/** Initialises *s at time `now` as node `address` (1..127) on *hal with the mailboxes *mb (both
 *  referenced), timing *t (copied). False (nothing set up) for a bad address or a missing
 *  required function (hal->tx_start, hal->wake_at and every urb_dl_mailbox_t member but fault). */
bool urb_rs485_slave_init(urb_rs485_slave_t *s, const urb_rs485_hal_t *hal, const urb_dl_mailbox_t *mb,
                          uint8_t address, const urb_rs485_timing_t *t, uint32_t now);

/** A byte was received at time `t`. */
void urb_rs485_slave_rx(urb_rs485_slave_t *s, uint8_t byte, uint32_t t);

/** Time `now` has come (the deadline asked for, or any later time): ends a frame whose silence
 *  has lasted t3.5, and answers it. */
void urb_rs485_slave_poll(urb_rs485_slave_t *s, uint32_t now);

/** The UART can take a byte of the answer: true and *byte, or false when it is all sent (the
 *  outbox is released then). */
bool urb_rs485_slave_tx_next(urb_rs485_slave_t *s, uint8_t *byte);

/** True while an answer is being sent. */
bool urb_rs485_slave_sending(const urb_rs485_slave_t *s);

/** Copies the counters into *out. */
void urb_rs485_slave_stats(const urb_rs485_slave_t *s, urb_rs485_slave_stats_t *out);

#ifdef __cplusplus
}
#endif

#endif /* URB_RS485_SLAVE_H */
