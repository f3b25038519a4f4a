/* What the simulation HALs of sim/downlink share: a FIFO of CAN frames between a core and the bus
 * model, and the transaction a bridge's downlink begins. Not firmware: a simulation harness. */
#ifndef SIM_DOWNLINK_H
#define SIM_DOWNLINK_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "urb_can.h"
#include "urb_downlink.h"

#define SIM_CAN_FIFO 8u /* a core queues at most a transfer's 5 frames */

/** Frames a core queued, oldest first, until the bus model takes them. */
typedef struct {
    urb_can_frame_t frames[SIM_CAN_FIFO];
    uint8_t head, len;
} sim_can_fifo_t;

/** Appends a frame; false when full (the core retries after its next frame-sent report). */
static inline bool sim_can_fifo_push(sim_can_fifo_t *q, const urb_can_frame_t *frame)
{
    if (q->len >= SIM_CAN_FIFO) {
        return false;
    }
    q->frames[(uint8_t)((q->head + q->len) % SIM_CAN_FIFO)] = *frame;
    q->len++;
    return true;
}

/** Takes the oldest frame into *out; false when empty. */
static inline bool sim_can_fifo_pop(sim_can_fifo_t *q, urb_can_frame_t *out)
{
    if (q->len == 0u) {
        return false;
    }
    *out = q->frames[q->head];
    q->head = (uint8_t)((q->head + 1u) % SIM_CAN_FIFO);
    q->len--;
    return true;
}

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
