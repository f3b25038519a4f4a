/*
 * fw_node_stubs.c: what urb_mailbox.c needs from urb_node.c, for proofs that compile the mailbox
 * alone. Included by the harnesses that want it (#include "../stubs/fw_node_stubs.c"), so it is
 * never cost-instrumented: it stands for code outside the function under proof.
 *
 *   urb_setup_error         records the first setup error, as urb_node.c does (same rule)
 *   urb_node_mark_acquired  the acquisition mark: outside app_update it is a no-op in the real
 *                           code too (the mailbox proofs never run inside app_update)
 */
#include "urb_node_internal.h"

void urb_setup_error(urb_node_t *node, int rc)
{
    if ((node != NULL) && (node->started == 0u) && (node->setup_err == 0)) {
        node->setup_err = (int8_t)rc;
    }
}

void urb_node_mark_acquired(urb_node_t *node)
{
    (void)node;
}

/*
 * What urb_mailbox_reset does, written with member accesses the checker keeps field-level.
 * ESBMC 8.4 turns a store through `node->outbox[n].field` with a variable n into a byte-level
 * update of the whole 336-byte urb_node_t, and every later access then goes through it: the
 * mailbox proofs ran out of memory that way. The harnesses that are not about urb_node_init
 * start from this state instead (urb_node_init zeroes the node, then calls urb_mailbox_reset).
 */
static void fw_node_mailbox_reset(urb_node_t *node)
{
    for (uint8_t n = 0u; n < URB_NODE_MAILBOXES; n++) {
        urb_node_outbox_t *ob = &node->outbox[n];
        urb_node_inbox_t *ib = &node->inbox[n];
        ob->isr_idx = URB_NONE;
        ob->held = URB_NONE;
        ib->isr_idx = URB_NONE;
        ib->app_idx = URB_NONE;
    }
    node->outbox[0].size = URB_NODE_OUTBOX0_SIZE;
    node->inbox[0].offset = 2u * URB_NODE_OUTBOX0_SIZE;
    node->inbox[0].size = URB_NODE_INBOX0_SIZE;
}
