/* The node side of the RS485 downlink, the firmware's urb_rs485_slave, behind a transceiver HAL that
 * the Python line model drives through ctypes, with the mailbox table of sim_mailbox.h. Compiled
 * into build/sim/liburbdl.so only. Not firmware: a simulation harness (issue #39). */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "urb_rs485.h"
#include "urb_rs485_slave.h"
#include "sim_mailbox.h"

typedef struct {
    urb_rs485_hal_t hal;
    urb_dl_mailbox_t mb;
    urb_rs485_slave_t slave;
    sim_mailbox_t boxes;
    bool sending;     /* the driver is enabled: the UART pulls the answer */
    uint32_t wake_us; /* the poll the slave asked for */
} sim_rs485_node_t;

static void hal_tx_start(void *ctx)
{
    ((sim_rs485_node_t *)ctx)->sending = true;
}

static void hal_tx_abort(void *ctx)
{
    ((sim_rs485_node_t *)ctx)->sending = false;
}

static void hal_wake_at(void *ctx, uint32_t at_us)
{
    ((sim_rs485_node_t *)ctx)->wake_us = at_us;
}

/** Bytes to allocate for one node (the caller owns the memory). */
size_t sim_rs485_node_size(void)
{
    return sizeof(sim_rs485_node_t);
}

/** Initialises node `address` on a line at `baud` (with silences t15_us / t35_us), its receiver
 *  starting at `now_us`; false when the slave refuses the set-up. */
bool sim_rs485_node_init(sim_rs485_node_t *n, uint8_t address, uint32_t baud, uint16_t t15_us, uint16_t t35_us,
                         uint32_t now_us)
{
    memset(n, 0, sizeof(*n));
    n->hal.ctx = n;
    n->hal.tx_start = hal_tx_start;
    n->hal.tx_abort = hal_tx_abort;
    n->hal.wake_at = hal_wake_at;
    n->hal.lock = NULL;
    sim_mailbox_init(&n->boxes, &n->mb);
    urb_rs485_timing_t t;
    urb_rs485_timing(&t, baud);
    t.t15_us = t15_us;
    t.t35_us = t35_us;
    return urb_rs485_slave_init(&n->slave, &n->hal, &n->mb, address, &t, now_us);
}

/** Sets up inbox `m` with `size` bytes (0: none). */
void sim_rs485_node_set_inbox(sim_rs485_node_t *n, uint8_t m, uint8_t size)
{
    sim_mailbox_set_inbox(&n->boxes, m, size);
}

/** Sets up outbox `m` with its contents. */
void sim_rs485_node_set_outbox(sim_rs485_node_t *n, uint8_t m, const uint8_t *data, uint8_t size)
{
    sim_mailbox_set_outbox(&n->boxes, m, data, size);
}

/** A byte heard on the line (stop bit at `t_us`). */
void sim_rs485_node_rx(sim_rs485_node_t *n, uint8_t byte, uint32_t t_us)
{
    urb_rs485_slave_rx(&n->slave, byte, t_us);
}

/** The poll the slave asked for (its receiver's deadline). */
uint32_t sim_rs485_node_wake_us(const sim_rs485_node_t *n)
{
    return n->wake_us;
}

/** Time `now_us` has come: the slave ends a frame and may answer. */
void sim_rs485_node_poll(sim_rs485_node_t *n, uint32_t now_us)
{
    urb_rs485_slave_poll(&n->slave, now_us);
}

/** The next byte of the answer while the driver is enabled: true and *byte, else false. */
bool sim_rs485_node_tx_next(sim_rs485_node_t *n, uint8_t *byte)
{
    if (!n->sending) {
        return false;
    }
    if (!urb_rs485_slave_tx_next(&n->slave, byte)) {
        n->sending = false;
        return false;
    }
    return true;
}

/** Inbox `m`'s latest committed contents, and how many writes were committed. */
const uint8_t *sim_rs485_node_inbox(const sim_rs485_node_t *n, uint8_t m, uint32_t *writes)
{
    *writes = n->boxes.writes[m & 7u];
    return n->boxes.inbox[m & 7u];
}

/** SYNCs passed on to the mailboxes, and the time stamp of the last. */
uint32_t sim_rs485_node_syncs(const sim_rs485_node_t *n, uint32_t *last_t)
{
    *last_t = n->boxes.last_sync_t;
    return n->boxes.syncs;
}
