/* The node side of the CAN downlink, the firmware's urb_can_slave, behind a CAN HAL that the Python
 * bus model drives through ctypes, with a mailbox table of fixed sizes standing in for the node
 * library (one inbox buffer per mailbox, committed writes counted; outboxes set by the model).
 * Compiled into build/sim/liburbdl.so only. Not firmware: a simulation harness (issue #39). */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "urb_can.h"
#include "urb_can_slave.h"
#include "urb_dl_slave.h"
#include "sim_downlink.h"
#include "sim_mailbox.h"


typedef struct {
    urb_can_hal_t hal;
    urb_dl_mailbox_t mb;
    urb_can_slave_t slave;
    sim_can_fifo_t txq;
    uint8_t state;
    sim_mailbox_t boxes;
    uint32_t aborts;
} sim_can_node_t;

static bool hal_tx(void *ctx, const urb_can_frame_t *frame)
{
    return sim_can_fifo_push(&((sim_can_node_t *)ctx)->txq, frame);
}

static void hal_tx_abort(void *ctx)
{
    sim_can_node_t *n = (sim_can_node_t *)ctx;
    n->txq.len = 0u;
    n->aborts++;
}

static uint8_t hal_state(void *ctx)
{
    return ((const sim_can_node_t *)ctx)->state;
}

static void hal_recover(void *ctx)
{
    (void)ctx; /* the bus model recovers a bus-off controller after 128 x 11 recessive bits */
}

/** Bytes to allocate for one node (the caller owns the memory). */
size_t sim_can_node_size(void)
{
    return sizeof(sim_can_node_t);
}

/** Initialises node `address` on a bus at `kbps`; false when the slave refuses the set-up. */
bool sim_can_node_init(sim_can_node_t *n, uint8_t address, uint16_t kbps)
{
    memset(n, 0, sizeof(*n));
    n->hal.ctx = n;
    n->hal.tx = hal_tx;
    n->hal.tx_abort = hal_tx_abort;
    n->hal.state = hal_state;
    n->hal.recover = hal_recover;
    n->hal.lock = NULL;
    sim_mailbox_init(&n->boxes, &n->mb);
    return urb_can_slave_init(&n->slave, &n->hal, &n->mb, address, urb_can_slave_dup_window_us(kbps));
}

/** Sets up inbox `m` with `size` bytes (0: none). */
void sim_can_node_set_inbox(sim_can_node_t *n, uint8_t m, uint8_t size)
{
    sim_mailbox_set_inbox(&n->boxes, m, size);
}

/** Sets up outbox `m` with its contents (`size` bytes; 0: none). */
void sim_can_node_set_outbox(sim_can_node_t *n, uint8_t m, const uint8_t *data, uint8_t size)
{
    sim_mailbox_set_outbox(&n->boxes, m, data, size);
}

/** A frame on the bus, received at tick `t_us` (its start of frame). */
void sim_can_node_rx(sim_can_node_t *n, const urb_can_frame_t *frame, uint32_t t_us)
{
    urb_can_slave_rx(&n->slave, frame, t_us);
}

/** Takes the oldest frame the slave queued; false when none waits. */
bool sim_can_node_take(sim_can_node_t *n, urb_can_frame_t *out)
{
    return sim_can_fifo_pop(&n->txq, out);
}

/** A frame the node queued went through. */
void sim_can_node_tx_done(sim_can_node_t *n)
{
    urb_can_slave_tx_done(&n->slave);
}

/** The controller's state (urb_can_state_t) as the bus model has it; bus-off is reported to the slave. */
void sim_can_node_set_state(sim_can_node_t *n, uint8_t state)
{
    if (state != n->state) {
        n->state = state;
        urb_can_slave_state(&n->slave, state);
    }
}

/** Inbox `m`'s latest committed contents, and how many writes were committed. */
const uint8_t *sim_can_node_inbox(const sim_can_node_t *n, uint8_t m, uint32_t *writes)
{
    *writes = n->boxes.writes[m & 7u];
    return n->boxes.inbox[m & 7u];
}

/** SYNCs passed on to the mailboxes, and the time stamp of the last. */
uint32_t sim_can_node_syncs(const sim_can_node_t *n, uint32_t *last_t)
{
    *last_t = n->boxes.last_sync_t;
    return n->boxes.syncs;
}

/** tx_abort() calls so far (an answer dropped for bus-off or a newer request). */
uint32_t sim_can_node_aborts(const sim_can_node_t *n)
{
    return n->aborts;
}
