/* What the simulation HALs of sim/downlink share: the CAN and RS485 ports (the HAL a core's
 * urb_can_hal_t / urb_rs485_hal_t calls, and what the Python bus models read back from it), and the
 * transaction a bridge's downlink begins. The bridges (sim_can_bridge.c, sim_rs485_bridge.c) and the
 * nodes (sim_dl_node.c) all set their controller up through sim_port.c. Not firmware: a simulation
 * harness. */
#ifndef SIM_DOWNLINK_H
#define SIM_DOWNLINK_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "urb_can.h"
#include "urb_downlink.h"
#include "urb_rs485.h"

#define SIM_CAN_FIFO 8u /* a core queues at most a transfer's 5 frames */

/** A CAN controller as the bus model drives it: frames the core queued, oldest first, until the
 *  model takes them; the fault-confinement state the model sets; the core's requests counted. */
typedef struct {
    urb_can_hal_t hal;
    urb_can_frame_t frames[SIM_CAN_FIFO];
    uint8_t head, len;
    uint8_t state;          /* urb_can_state_t, set by the model */
    uint32_t aborts;        /* tx_abort() requests (the model then drops what the controller holds) */
    uint32_t recoveries;    /* recover() requests (the model recovers after 128 x 11 recessive bits) */
} sim_can_port_t;

/** Clears *p and points its HAL at it. */
void sim_can_port_init(sim_can_port_t *p);

/** Takes the oldest frame into *out; false when none waits. */
bool sim_can_port_take(sim_can_port_t *p, urb_can_frame_t *out);

/** An RS485 transceiver and UART as the line model drives them: whether the driver is enabled (the
 *  UART pulls bytes), the poll the owner asked for, the aborts counted. */
typedef struct {
    urb_rs485_hal_t hal;
    bool sending;
    uint32_t wake_us;   /* the poll the owner asked for (wake_at), when `wakes` */
    uint32_t aborts;    /* tx_abort() requests (collisions, timeouts while sending) */
} sim_rs485_port_t;

/** Clears *p and points its HAL at it; `wakes`: the owner may ask for polls (a node's slave), else
 *  wake_at is NULL (a bridge's main loop polls often enough). */
void sim_rs485_port_init(sim_rs485_port_t *p, bool wakes);

/** Begins a transaction on `dl`: a write's `data` (length bytes, at most 32) is copied into `buf`
 *  (32 bytes), where a read's answer lands. */
static inline bool sim_downlink_begin(const urb_downlink_t *dl, uint8_t *buf, uint8_t op, uint8_t address,
                                      uint8_t mailbox, uint8_t length, uint8_t counter, const uint8_t *data,
                                      uint32_t now_us)
{
    if (length > 32u) {
        length = 32u;
    }
    if ((data != NULL) && (length > 0u)) {
        memcpy(buf, data, length);
    }
    urb_downlink_txn_t t;
    t.op = op;
    t.address = address;
    t.mailbox = mailbox;
    t.length = length;
    t.counter = counter;
    t.reselect = false;
    t.data = buf;
    return dl->begin(dl->ctx, &t, now_us);
}

#endif /* SIM_DOWNLINK_H */
