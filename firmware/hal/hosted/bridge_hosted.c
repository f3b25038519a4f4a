/*
 * Hosted bridge HAL and rig (see bridge_hosted.h).
 */
#include "bridge_hosted.h"

#include <string.h>

static urb_hosted_hal_t *hal_of(void *ctx)
{
    return (urb_hosted_hal_t *)ctx;
}

static uint32_t h_now(void *ctx)
{
    return hal_of(ctx)->now;
}

static void h_heartbeat_period(void *ctx, uint32_t period_us)
{
    urb_hosted_hal_t *h = hal_of(ctx);
    h->hb_period = period_us;
    h->hb_next = h->now + period_us;
}

static void h_uart_tx_kick(void *ctx)
{
    hal_of(ctx)->kicks++; /* the rig drains the ring at every iteration */
}

static void h_mark(void *ctx, uint8_t id, bool level)
{
    urb_hosted_hal_t *h = hal_of(ctx);
    if (id < 3u) {
        if (level && !h->mark_level[id]) {
            h->mark_rises[id]++;
        }
        h->mark_level[id] = level;
    }
}

void urb_hosted_hal_init(urb_hosted_hal_t *h)
{
    memset(h, 0, sizeof *h);
    h->hal.ctx = h;
    h->hal.now_us = h_now;
    h->hal.heartbeat_period = h_heartbeat_period;
    h->hal.uart_tx_kick = h_uart_tx_kick;
    h->hal.mark = h_mark;
}

int32_t urb_hosted_rig_init(urb_hosted_rig_t *r, const urb_bridge_config_t *cfg, const urb_i2c_master_config_t *mcfg)
{
    urb_i2c_master_config_t m;
    urb_bridge_config_t c;
    memset(r, 0, sizeof *r);
    urb_hosted_hal_init(&r->hal);
    if (mcfg == NULL) {
        urb_i2c_master_default_config(&m);
    } else {
        m = *mcfg;
    }
    if (cfg == NULL) {
        urb_bridge_default_config(&c);
    } else {
        c = *cfg;
    }
    urb_fake_i2c_init(&r->bus, &r->master, h_now, &r->hal);
    urb_i2c_master_init(&r->master, &r->bus.hal, &m);
    urb_i2c_master_downlink(&r->master, &r->dl);
    r->step_us = 1u;
    return urb_bridge_init(&r->bridge, &c, &r->hal.hal, &r->dl);
}

void urb_hosted_rig_iterate(urb_hosted_rig_t *r)
{
    urb_hosted_hal_t *h = &r->hal;
    if ((h->hb_period != 0u) && ((int32_t)(h->now - h->hb_next) >= 0)) {
        h->hb_next += h->hb_period;
        h->hb_ticks++;
        urb_bridge_heartbeat(&r->bridge);
    }
    /* Deliver every event due now (an immediate bus answers several per iteration). */
    for (uint32_t i = 0u; (i < 64u) && urb_fake_i2c_step(&r->bus); i++) {
    }
    urb_bridge_poll(&r->bridge);
    uint8_t byte;
    while (urb_bridge_uart_tx_pop(&r->bridge, &byte)) {
        if (h->tx_len >= sizeof h->tx) {
            memmove(h->tx, h->tx + 1, sizeof h->tx - 1u);
            h->tx_len--;
        }
        h->tx[h->tx_len++] = byte;
    }
}

void urb_hosted_rig_run(urb_hosted_rig_t *r, uint32_t us)
{
    uint32_t const step = (r->step_us == 0u) ? 1u : r->step_us;
    for (uint32_t t = 0u; t < us; t += step) {
        r->hal.now += step;
        urb_hosted_rig_iterate(r);
    }
}

bool urb_hosted_rig_settle(urb_hosted_rig_t *r, uint32_t max_us)
{
    uint32_t const step = (r->step_us == 0u) ? 1u : r->step_us;
    for (uint32_t t = 0u; t < max_us; t += step) {
        urb_hosted_rig_iterate(r);
        if (urb_bridge_idle(&r->bridge) && !r->bus.ev_pending && (r->master.phase == 0u)) {
            return true;
        }
        r->hal.now += step;
    }
    return false;
}

void urb_hosted_rig_uart_send(urb_hosted_rig_t *r, const uint8_t *bytes, size_t n, uint32_t spacing_us)
{
    for (size_t i = 0u; i < n; i++) {
        urb_hosted_rig_run(r, spacing_us);
        urb_bridge_uart_rx(&r->bridge, bytes[i], r->hal.now);
    }
}
