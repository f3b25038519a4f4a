/* The CAN and RS485 ports of sim_downlink.h, shared by the bridges and the nodes. */
#include "sim_downlink.h"

#include <stddef.h>

static bool can_tx(void *ctx, const urb_can_frame_t *frame)
{
    sim_can_port_t *p = (sim_can_port_t *)ctx;
    if (p->len >= SIM_CAN_FIFO) {
        return false; /* the core retries after its next frame-sent report */
    }
    p->frames[(uint8_t)((p->head + p->len) % SIM_CAN_FIFO)] = *frame;
    p->len++;
    return true;
}

static void can_tx_abort(void *ctx)
{
    sim_can_port_t *p = (sim_can_port_t *)ctx;
    p->len = 0u;
    p->aborts++;
}

static uint8_t can_state(void *ctx)
{
    return ((const sim_can_port_t *)ctx)->state;
}

static void can_recover(void *ctx)
{
    ((sim_can_port_t *)ctx)->recoveries++;
}

void sim_can_port_init(sim_can_port_t *p)
{
    memset(p, 0, sizeof(*p));
    p->hal.ctx = p;
    p->hal.tx = can_tx;
    p->hal.tx_abort = can_tx_abort;
    p->hal.state = can_state;
    p->hal.recover = can_recover;
    p->hal.lock = NULL; /* the model calls every entry point from one context */
}

bool sim_can_port_take(sim_can_port_t *p, urb_can_frame_t *out)
{
    if (p->len == 0u) {
        return false;
    }
    *out = p->frames[p->head];
    p->head = (uint8_t)((p->head + 1u) % SIM_CAN_FIFO);
    p->len--;
    return true;
}

static void rs485_tx_start(void *ctx)
{
    ((sim_rs485_port_t *)ctx)->sending = true;
}

static void rs485_tx_abort(void *ctx)
{
    sim_rs485_port_t *p = (sim_rs485_port_t *)ctx;
    p->sending = false;
    p->aborts++;
}

static void rs485_wake_at(void *ctx, uint32_t at_us)
{
    ((sim_rs485_port_t *)ctx)->wake_us = at_us;
}

void sim_rs485_port_init(sim_rs485_port_t *p, bool wakes)
{
    memset(p, 0, sizeof(*p));
    p->hal.ctx = p;
    p->hal.tx_start = rs485_tx_start;
    p->hal.tx_abort = rs485_tx_abort;
    p->hal.wake_at = wakes ? rs485_wake_at : NULL;
    p->hal.lock = NULL;
}
