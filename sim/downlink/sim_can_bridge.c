/* The bridge side of the CAN downlink, the firmware's urb_can_master, behind a CAN HAL that the
 * Python bus model (sim/urb_sim/fieldbus/cycle.py) drives through ctypes: frames the master queues
 * wait in a FIFO here until the model takes them onto its bus; the model reports each one sent, each
 * frame received and the controller's state (sim_port.c). Compiled into build/sim/liburbsim.so. Not
 * firmware: a simulation harness. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "urb_can.h"
#include "urb_can_master.h"
#include "sim_downlink.h"

typedef struct {
    sim_can_port_t port;
    urb_can_master_t master;
    urb_downlink_t dl;
    uint8_t data[URB_CAN_MAX_PAYLOAD];
} sim_can_bridge_t;

/** Bytes to allocate for one bridge (the caller owns the memory). */
size_t sim_can_bridge_size(void)
{
    return sizeof(sim_can_bridge_t);
}

/** Initialises a bridge at `kbps` (1000, 500, 250, 125). */
void sim_can_bridge_init(sim_can_bridge_t *b, uint16_t kbps)
{
    memset(b, 0, sizeof(*b));
    sim_can_port_init(&b->port);
    urb_can_master_config_t cfg;
    urb_can_master_default_config(&cfg);
    cfg.bitrate_kbps = kbps;
    cfg.timeout_us = urb_can_master_timeout_us(kbps);
    cfg.recover_us = urb_can_master_recover_us(kbps);
    urb_can_master_init(&b->master, &b->port.hal, &cfg);
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
    return sim_can_port_take(&b->port, out);
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
    b->port.state = state;
}

/** The data a read returned (the bridge's buffer). */
const uint8_t *sim_can_bridge_data(const sim_can_bridge_t *b)
{
    return b->data;
}

/** recover() calls so far. */
uint32_t sim_can_bridge_recoveries(const sim_can_bridge_t *b)
{
    return b->port.recoveries;
}

/** tx_abort() calls so far (the model then drops what the controller still holds). */
uint32_t sim_can_bridge_aborts(const sim_can_bridge_t *b)
{
    return b->port.aborts;
}
