/* A node's mailboxes for the simulation HALs of sim/downlink: fixed sizes set by the bus model, one
 * buffer per inbox (so the slave never meets NODE_BUSY), committed writes counted, SYNCs recorded.
 * It stands in for the node library, which chooses its downlink only in issue #39 phase 2. Not
 * firmware: a simulation harness. */
#ifndef SIM_MAILBOX_H
#define SIM_MAILBOX_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_dl_slave.h"

#define SIM_MAILBOXES 8u
#define SIM_MAILBOX_BYTES 32u

/** The mailbox table; caller-owned. */
typedef struct {
    uint8_t in_size[SIM_MAILBOXES], out_size[SIM_MAILBOXES];
    uint8_t wbuf[SIM_MAILBOXES][SIM_MAILBOX_BYTES];
    uint8_t inbox[SIM_MAILBOXES][SIM_MAILBOX_BYTES];
    uint32_t writes[SIM_MAILBOXES];
    uint8_t outbox[SIM_MAILBOXES][SIM_MAILBOX_BYTES];
    uint32_t syncs, last_sync_t, faults;
} sim_mailbox_t;

/** Clears the table and fills *mb with its functions (ctx = the table). */
void sim_mailbox_init(sim_mailbox_t *t, urb_dl_mailbox_t *mb);

/** Sets up inbox `m` with `size` bytes (0: none). */
void sim_mailbox_set_inbox(sim_mailbox_t *t, uint8_t m, uint8_t size);

/** Sets up outbox `m` with `size` bytes of `data` (0: none). */
void sim_mailbox_set_outbox(sim_mailbox_t *t, uint8_t m, const uint8_t *data, uint8_t size);

#endif /* SIM_MAILBOX_H */
