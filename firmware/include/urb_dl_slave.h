/*
 * What a downlink's node side (the CAN slave, urb_can_slave.h; the RS485 slave, urb_rs485_slave.h)
 * needs from the node library: the mailbox algorithms' interrupt-side steps, the SYNC time stamp
 * and the fault counters. A table of function pointers with a context, so a downlink module knows
 * nothing of urb_node_t: the node library fills it (from firmware/node/urb_node_internal.h's
 * urb_isr_* functions), a test fills it with a fake.
 *
 * Every function is called from the downlink's interrupt, at the priority of the node's other
 * interrupt entry points (urb_node.h), never from the main loop. Each names the step of
 * spec/tla/MailboxInbox.tla / MailboxOutbox.tla it stands for; the calling rules are those
 * models': a write is begun, filled, and then committed or aborted exactly once; a read is begun
 * and ended exactly once, and the buffer it returned is read only in between.
 */
#ifndef URB_DL_SLAVE_H
#define URB_DL_SLAVE_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** The node library as a downlink slave sees it. Every member is required except `fault`. */
typedef struct {
    void *ctx; /**< passed to every function */
    /** Size in bytes of inbox `m` (0..7); 0 when it is not set up. */
    uint8_t (*inbox_size)(void *ctx, uint8_t m);
    /** Size in bytes of outbox `m` (0..7); 0 when it is not set up. */
    uint8_t (*outbox_size)(void *ctx, uint8_t m);
    /** MailboxInbox.tla IsrWriteBegin: the buffer to fill with inbox_size(m) bytes, or NULL when the
     *  algorithm refuses (both buffers in use: the write is answered NODE_BUSY). */
    uint8_t *(*write_begin)(void *ctx, uint8_t m);
    /** MailboxInbox.tla IsrWriteCommit: the buffer holds a complete, checked message: publish it. */
    void (*write_commit)(void *ctx, uint8_t m);
    /** MailboxInbox.tla IsrWriteAbort: forget the buffer's contents. */
    void (*write_abort)(void *ctx, uint8_t m);
    /** MailboxOutbox.tla IsrReadBegin: latch and return the buffer holding the latest release
     *  (outbox_size(m) bytes, set up outboxes only). */
    const uint8_t *(*read_begin)(void *ctx, uint8_t m);
    /** MailboxOutbox.tla IsrReadEnd: the latched buffer is free again; `complete` when every byte
     *  of it reached the bus (an identification read that completes may clear the fault flag). */
    void (*read_end)(void *ctx, uint8_t m, bool complete);
    /** A SYNC broadcast with this counter, time-stamped at `t` (the node's tick at the frame's
     *  start, as the port captured it). */
    void (*sync)(void *ctx, uint32_t t, uint8_t counter);
    /** Counts a fault (urb_node_fault_t code: 1 CHECKSUM, 2 OVERRUN, 4 STUCK_BUS), delivered
     *  later by the main loop; NULL: not counted. */
    void (*fault)(void *ctx, uint8_t code);
} urb_dl_mailbox_t;

#define URB_DL_FAULT_CHECKSUM 1u  /**< urb_node_fault_t URB_NODE_FAULT_CHECKSUM */
#define URB_DL_FAULT_OVERRUN 2u   /**< urb_node_fault_t URB_NODE_FAULT_OVERRUN */
#define URB_DL_FAULT_STUCK_BUS 4u /**< urb_node_fault_t URB_NODE_FAULT_STUCK_BUS */

#ifdef __cplusplus
}
#endif

#endif /* URB_DL_SLAVE_H */
