/*
 * Hosted HAL (see urb_hal_hosted.h). Deterministic: no clock, no threads, no globals.
 */
#include "urb_hal_hosted.h"

#include <stddef.h>

static uint32_t hosted_now(void *ctx)
{
    urb_hal_hosted_t const *port = (urb_hal_hosted_t const *)ctx;
    return port->now + port->now_offset;
}

static void hosted_set_compare(void *ctx, uint32_t at)
{
    urb_hal_hosted_t *port = (urb_hal_hosted_t *)ctx;
    port->compare = at;
    port->armed = 1u;
    port->compare_calls++;
}

static uint32_t hosted_sync_capture(void *ctx)
{
    return ((urb_hal_hosted_t const *)ctx)->capture;
}

static void hosted_set_address(void *ctx, uint8_t address)
{
    ((urb_hal_hosted_t *)ctx)->address = address;
}

static void hosted_mark(void *ctx, urb_node_mark_t mark)
{
    urb_hal_hosted_t *port = (urb_hal_hosted_t *)ctx;
    if ((unsigned)mark < (unsigned)URB_NODE_MARK_COUNT) {
        port->mark_count[mark]++;
        port->mark_tick[mark] = hosted_now(ctx);
    }
}

static void hosted_identify(void *ctx, uint8_t seconds)
{
    urb_hal_hosted_t *port = (urb_hal_hosted_t *)ctx;
    port->identify_seconds = seconds;
    port->identify_calls++;
}

void urb_hal_hosted_init(urb_hal_hosted_t *port, uint32_t start, bool with_capture)
{
    if (port == NULL) {
        return;
    }
    *port = (urb_hal_hosted_t){0};
    port->now = start;
    port->hal.ctx = port;
    port->hal.now = hosted_now;
    port->hal.set_compare = hosted_set_compare;
    port->hal.sync_capture = with_capture ? hosted_sync_capture : NULL;
    port->hal.set_address = hosted_set_address;
    port->hal.mark = hosted_mark;
    port->hal.identify = hosted_identify;
}

uint32_t urb_hal_hosted_advance(urb_hal_hosted_t *port, urb_node_t *node, uint32_t ticks)
{
    uint32_t const end = port->now + ticks;
    uint32_t beats = 0u;
    /* bound: URB_HAL_HOSTED_MAX_BEATS heartbeats */
    while ((beats < URB_HAL_HOSTED_MAX_BEATS) && (port->armed != 0u) &&
           ((uint32_t)(port->compare - port->now) <= (uint32_t)(end - port->now))) {
        port->now = port->compare;
        port->armed = 0u;
        urb_node_timer_event(node);
        beats++;
    }
    port->now = end;
    return beats;
}
