/*
 * Hosted HAL for the node library: deterministic, for unit tests on the build machine (POSIX or
 * any hosted C99). There is no real timer and no real bus: time is a counter the test advances,
 * the heartbeat "interrupt" is urb_node_timer_event() called by urb_hal_hosted_advance() when the
 * counter reaches the armed compare, and I2C events are whatever the test feeds to
 * urb_node_i2c_event(). Everything the library asks of the port is recorded for assertions.
 */
#ifndef URB_HAL_HOSTED_H
#define URB_HAL_HOSTED_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_node.h"
#include "urb_node_hal.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Most heartbeats one urb_hal_hosted_advance() call fires (its loop bound). */
#define URB_HAL_HOSTED_MAX_BEATS 100000u

/** One hosted port instance; pass &port->hal to urb_node_init. */
typedef struct {
    urb_node_hal_t hal;            /**< filled by urb_hal_hosted_init (ctx = the port) */
    uint32_t now;                  /**< current tick: tests advance it */
    uint32_t compare;              /**< heartbeat compare armed by the library */
    uint32_t compare_calls;        /**< set_compare calls */
    uint32_t capture;              /**< tick returned by sync_capture (when enabled) */
    uint8_t armed;                 /**< a compare is armed */
    uint8_t address;               /**< address set by set_address (0: not yet) */
    uint8_t identify_seconds;      /**< last IDENTIFY argument */
    uint32_t identify_calls;       /**< identify calls */
    uint32_t mark_count[URB_NODE_MARK_COUNT]; /**< marks emitted, per mark */
    uint32_t mark_tick[URB_NODE_MARK_COUNT];  /**< tick of the latest mark, per mark */
    uint32_t now_offset;           /**< added to `now` by now() (tests use it to model elapsed work) */
} urb_hal_hosted_t;

/** Fills *port: time starts at `start`; with_capture selects a hardware SYNC capture (sync_capture set). */
void urb_hal_hosted_init(urb_hal_hosted_t *port, uint32_t start, bool with_capture);

/** Advances time by `ticks`, calling urb_node_timer_event(node) at every armed compare reached on the
 *  way (at most URB_HAL_HOSTED_MAX_BEATS). Returns the number of heartbeats fired. */
uint32_t urb_hal_hosted_advance(urb_hal_hosted_t *port, urb_node_t *node, uint32_t ticks);

#ifdef __cplusplus
}
#endif

#endif /* URB_HAL_HOSTED_H */
