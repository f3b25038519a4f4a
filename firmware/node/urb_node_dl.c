/*
 * The node library as a downlink slave sees it (urb_dl_slave.h): the table of the mailbox
 * algorithms' interrupt-side steps that the CAN and RS485 slaves drive. Built into a node image
 * only when its downlink is CAN or RS485 (urb_node_downlink.h); the I2C slave (urb_i2c.c) calls
 * the same urb_isr_* steps itself.
 *
 * What I2C's byte state machine does around the steps is done here the same way: an outbox-0
 * read begun counts in id_reads and a complete one sets id_done (Identification.fault may clear),
 * a SYNC emits the mark and goes to the PLL, and nothing is on the bus before urb_node_init() is done.
 *
 * Seeded bugs for the three-downlink test (tests/firmware/node_dl/): URB_MUTANT_NODE_DL_FRONT_BUFFER
 * (a write is filled into the buffer the application may hold: the front, not IsrWriteBegin's),
 * URB_MUTANT_NODE_DL_NO_SYNC (SYNC is not passed to the PLL), URB_MUTANT_NODE_DL_NO_ID_DONE (a
 * complete identification read is not recorded: the fault flag never clears).
 */
#include "urb_node_downlink.h"

#include <stddef.h>

#include "urb_node_internal.h"

static uint8_t dl_inbox_size(void *ctx, uint8_t m)
{
    urb_node_t const *node = (urb_node_t const *)ctx;
    return ((node->started != 0u) && (m < URB_NODE_MAILBOXES)) ? node->inbox[m].size : 0u;
}

static uint8_t dl_outbox_size(void *ctx, uint8_t m)
{
    urb_node_t const *node = (urb_node_t const *)ctx;
    return ((node->started != 0u) && (m < URB_NODE_MAILBOXES)) ? node->outbox[m].size : 0u;
}

static uint8_t *dl_write_begin(void *ctx, uint8_t m)
{
    urb_node_t *node = (urb_node_t *)ctx;
    if (!urb_isr_write_begin(node, m)) { /* MailboxInbox.tla IsrWriteBegin refused */
        return NULL;
    }
#if defined(URB_MUTANT_NODE_DL_FRONT_BUFFER)
    return urb_inbox_buf(node, m, node->inbox[m].front);
#else
    return urb_inbox_buf(node, m, node->inbox[m].isr_idx);
#endif
}

static void dl_write_commit(void *ctx, uint8_t m)
{
    urb_isr_write_commit((urb_node_t *)ctx, m); /* MailboxInbox.tla IsrWriteCommit */
}

static void dl_write_abort(void *ctx, uint8_t m)
{
    urb_isr_write_abort((urb_node_t *)ctx, m); /* MailboxInbox.tla IsrWriteAbort */
}

static const uint8_t *dl_read_begin(void *ctx, uint8_t m)
{
    urb_node_t *node = (urb_node_t *)ctx;
    urb_isr_read_begin(node, m); /* MailboxOutbox.tla IsrReadBegin */
    if (m == 0u) {
        node->id_reads = (uint8_t)(node->id_reads + 1u);
    }
    return urb_outbox_buf(node, m, node->outbox[m].isr_idx);
}

static void dl_read_end(void *ctx, uint8_t m, bool complete)
{
    urb_node_t *node = (urb_node_t *)ctx;
    urb_isr_read_end(node, m); /* MailboxOutbox.tla IsrReadEnd */
#if !defined(URB_MUTANT_NODE_DL_NO_ID_DONE)
    if ((m == 0u) && complete) {
        node->id_done = node->id_reads; /* a complete identification read (clears the fault flag) */
    }
#else
    (void)complete;
#endif
}

static void dl_sync(void *ctx, uint32_t t, uint8_t counter)
{
    urb_node_t *node = (urb_node_t *)ctx;
    if (node->started == 0u) {
        return;
    }
    if (node->hal->mark != NULL) {
        node->hal->mark(node->hal->ctx, URB_NODE_MARK_SYNC);
    }
#if !defined(URB_MUTANT_NODE_DL_NO_SYNC)
    urb_pll_sync(node, t, counter);
#else
    (void)t;
    (void)counter;
#endif
}

static void dl_fault(void *ctx, uint8_t code)
{
    if ((code >= 1u) && (code <= URB_NODE_FAULT_CODES)) {
        urb_isr_fault((urb_node_t *)ctx, (urb_node_fault_t)code);
    }
}

void urb_node_dl_mailbox(urb_node_t *node, urb_dl_mailbox_t *mb)
{
    mb->ctx = node;
    mb->inbox_size = dl_inbox_size;
    mb->outbox_size = dl_outbox_size;
    mb->write_begin = dl_write_begin;
    mb->write_commit = dl_write_commit;
    mb->write_abort = dl_write_abort;
    mb->read_begin = dl_read_begin;
    mb->read_end = dl_read_end;
    mb->sync = dl_sync;
    mb->fault = dl_fault;
}
