/*
 * A bridge on a scripted downlink: the test decides when each transaction ends and with which
 * outcome, refuses begins, or loses a transaction (poll then says IDLE); HAL stubs with a clock
 * that moves only when told, and a UART whose transmitted bytes are captured or left in the
 * bridge's ring (a stalled line). Downlink addresses SRIG_FIRST..SRIG_LAST, each with a node
 * layout of its own; the initial scan finds the nodes srig_present_at_start() names.
 */
#ifndef URB_BRIDGE_TEST_SCRIPTED_RIG_H
#define URB_BRIDGE_TEST_SCRIPTED_RIG_H

#include "support.h"

#define SRIG_FIRST 8u /* the scripted downlink's address range: 7 and 16 are reserved */
#define SRIG_LAST 15u

/** A bridge, its HAL stubs and its scripted downlink. */
typedef struct {
    urb_bridge_t b;
    urb_bridge_hal_t hal;
    urb_downlink_t dl;
    uint32_t now;
    uint32_t period;          /* the heartbeat period last set through the HAL */
    /* downlink */
    bool refuse;              /* begin() refuses every transaction */
    bool busy, done, lose;    /* a transaction runs; its outcome is set; it was lost (poll says IDLE) */
    uint8_t outcome;
    urb_downlink_txn_t txn;   /* the last transaction begun */
    unsigned begins;          /* transactions begun */
    /* UART */
    bool tx_stall;            /* the kick leaves the bytes in the bridge's ring */
    uint8_t tx[8192];
    size_t tx_len;
} srig_t;

/** Node `a`'s mailbox sizes (inbox 0 and outbox 0 as on every node, the others differ per node). */
void srig_node_sizes(uint8_t a, uint8_t in[8], uint8_t out[8]);

/** Node `a`'s identification (outbox 0) into buf[0 .. URB_IDENTIFICATION_SIZE - 1]. */
void srig_node_identification(uint8_t a, uint8_t *buf);

/** True for the nodes the initial scan finds (8, 10, 11, 15); the others answer it NO_NODE. */
bool srig_present_at_start(uint8_t a);

/** Moves the bytes the bridge queued on the UART into r->tx. */
void srig_drain_uart(srig_t *r);

/** Ends the running transaction with `status`; a read gets `data` (its length) when OK, other bytes
 *  when it failed (the bridge must not send them). */
void srig_finish(srig_t *r, uint8_t status, const uint8_t *data);

/** Initialises *r with `depth` data slots and heartbeat `heartbeat_us`, and runs the initial scan. */
void srig_init(srig_t *r, uint8_t depth, uint16_t heartbeat_us);

#endif
