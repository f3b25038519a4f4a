/* The bridge side of the CAN downlink, the firmware's urb_can_master, behind a CAN HAL that the
 * Python bus model (sim/urb_sim/fieldbus/cycle.py) drives through ctypes: frames the master queues
 * wait in a FIFO here until the model takes them onto its bus; the model reports each one sent, each
 * frame received and the controller's state. Compiled into build/sim/liburbdl.so only (issue #39:
 * the bridge firmware itself gets its CAN HAL in phase 2). Not firmware: a simulation harness. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "urb_can.h"
#include "urb_can_master.h"
#include "sim_downlink.h"

typedef struct {
    urb_can_hal_t hal;
    urb_can_master_t master;
    urb_downlink_t dl;
    sim_can_fifo_t txq;
    uint8_t state;           /* urb_can_state_t, set by the model */
    uint32_t recover_calls;  /* recover() requests */
    uint32_t abort_calls;    /* tx_abort() requests */
    uint8_t data[URB_CAN_MAX_PAYLOAD];
} sim_can_bridge_t;

static bool hal_tx(void *ctx, const urb_can_frame_t *frame)
{
    return sim_can_fifo_push(&((sim_can_bridge_t *)ctx)->txq, frame);
}

static void hal_tx_abort(void *ctx)
{
    sim_can_bridge_t *b = (sim_can_bridge_t *)ctx;
    b->txq.len = 0u;
    b->abort_calls++;
}

static uint8_t hal_state(void *ctx)
{
    return ((const sim_can_bridge_t *)ctx)->state;
}

static void hal_recover(void *ctx)
{
    ((sim_can_bridge_t *)ctx)->recover_calls++;
}

/** Bytes to allocate for one bridge (the caller owns the memory). */
size_t sim_can_bridge_size(void)
{
    return sizeof(sim_can_bridge_t);
}

/** Initialises a bridge at `kbps` (1000, 500, 250, 125). */
void sim_can_bridge_init(sim_can_bridge_t *b, uint16_t kbps)
{
    memset(b, 0, sizeof(*b));
    b->hal.ctx = b;
    b->hal.tx = hal_tx;
    b->hal.tx_abort = hal_tx_abort;
    b->hal.state = hal_state;
    b->hal.recover = hal_recover;
    b->hal.lock = NULL;
    urb_can_master_config_t cfg;
    urb_can_master_default_config(&cfg);
    cfg.bitrate_kbps = kbps;
    cfg.timeout_us = urb_can_master_timeout_us(kbps);
    cfg.recover_us = urb_can_master_recover_us(kbps);
    urb_can_master_init(&b->master, &b->hal, &cfg);
    urb_can_master_downlink(&b->master, &b->dl);
}

/** Begins a transaction (urb_dl_op_t); a write's `data` is copied. False while one runs. */
bool sim_can_bridge_begin(sim_can_bridge_t *b, uint8_t op, uint8_t address, uint8_t mailbox, uint8_t length,
                          uint8_t counter, const uint8_t *data, uint32_t now_us)
{
    return sim_downlink_begin(&b->dl, b->data, op, address, mailbox, length, counter, data, now_us);
}

/** The master's poll: URB_DOWNLINK_BUSY, _IDLE or the final urb_status_t. */
int8_t sim_can_bridge_poll(sim_can_bridge_t *b, uint32_t now_us)
{
    return b->dl.poll(b->dl.ctx, now_us);
}

/** Takes the oldest frame the master queued into *out; false when none waits. */
bool sim_can_bridge_take(sim_can_bridge_t *b, urb_can_frame_t *out)
{
    return sim_can_fifo_pop(&b->txq, out);
}

/** A frame the bridge queued went through (in queue order). */
void sim_can_bridge_tx_done(sim_can_bridge_t *b)
{
    urb_can_master_tx_done(&b->master);
}

/** A frame received from the bus. */
void sim_can_bridge_rx(sim_can_bridge_t *b, const urb_can_frame_t *frame)
{
    urb_can_master_rx(&b->master, frame);
}

/** The controller's urb_can_state_t, as the bus model's fault confinement has it. */
void sim_can_bridge_set_state(sim_can_bridge_t *b, uint8_t state)
{
    b->state = state;
}

/** The data a read returned (the bridge's buffer). */
const uint8_t *sim_can_bridge_data(const sim_can_bridge_t *b)
{
    return b->data;
}

/** recover() calls so far. */
uint32_t sim_can_bridge_recoveries(const sim_can_bridge_t *b)
{
    return b->recover_calls;
}

/** tx_abort() calls so far (the model then drops what the controller still holds). */
uint32_t sim_can_bridge_aborts(const sim_can_bridge_t *b)
{
    return b->abort_calls;
}
