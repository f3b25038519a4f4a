/*
 * Read-only views of a node for telemetry, tests and the simulation's trace observers, so that
 * nothing outside the library reads urb_node_t's members. None of them is linked into an image
 * that does not call it (-ffunction-sections, --gc-sections).
 */
#include "urb_node_internal.h"

bool urb_node_update_due(const urb_node_t *node)
{
    return (node != NULL) && (node->update_due != node->update_done);
}

void urb_node_downlink(const urb_node_t *node, urb_node_downlink_t *out)
{
    if ((node == NULL) || (out == NULL)) {
        return;
    }
    out->phase = (urb_node_dl_phase_t)node->i2c.state;
    out->mailbox = node->i2c.mailbox;
    out->count = node->i2c.count;
}

bool urb_node_inbox_buffers(const urb_node_t *node, uint8_t n, urb_node_buffers_t *out)
{
    if ((node == NULL) || (out == NULL) || (n >= URB_NODE_MAILBOXES) || (node->inbox[n].size == 0u)) {
        return false;
    }
    urb_node_inbox_t const *ib = &node->inbox[n];
    out->front = ib->front;
    out->isr = ib->isr_idx;
    out->app = ib->app_idx;
    return true;
}
