/*
 * Hosted (POSIX) bridge HAL for tests and the hosted bridge program: a virtual microsecond clock
 * that only moves when told, a heartbeat derived from it, a UART whose transmitted bytes are
 * captured, and a "rig" that wires a bridge, an I2C master and a fake I2C bus together.
 * Deterministic: no threads, no wall clock (the hosted program sets the clock from the wall clock
 * itself). Any number of rigs can live in one process.
 */
#ifndef URB_BRIDGE_HOSTED_H
#define URB_BRIDGE_HOSTED_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bridge_fake_i2c.h"
#include "urb_bridge.h"
#include "urb_bridge_hal.h"
#include "urb_downlink.h"

#define URB_HOSTED_TX_CAPTURE 16384u /**< UART bytes captured before the oldest are discarded */

/** The board services of one hosted bridge. */
typedef struct {
    urb_bridge_hal_t hal;           /**< The table given to urb_bridge_init() */
    uint32_t now;                   /**< Virtual time in microseconds */
    uint32_t hb_period, hb_next;    /**< Heartbeat period (0 = off) and next tick time */
    uint32_t hb_ticks;              /**< Heartbeat ticks delivered */
    uint8_t tx[URB_HOSTED_TX_CAPTURE]; /**< UART bytes the bridge sent, in order */
    size_t tx_len;
    uint32_t kicks;                 /**< uart_tx_kick() calls */
    uint32_t mark_rises[3];         /**< Rising edges of each timing mark */
    bool mark_level[3];
} urb_hosted_hal_t;

/** A complete hosted bridge: HAL, fake bus with its nodes, I2C master and the bridge. */
typedef struct {
    urb_hosted_hal_t hal;
    urb_fake_i2c_t bus;
    urb_i2c_master_t master;
    urb_downlink_t dl;
    urb_bridge_t bridge;
    uint32_t step_us;               /**< Virtual time per iteration of urb_hosted_rig_run() (default 1) */
} urb_hosted_rig_t;

/** Initialises the HAL table of *h at virtual time 0. */
void urb_hosted_hal_init(urb_hosted_hal_t *h);

/** Initialises a rig with bridge configuration *cfg and master configuration *mcfg (NULL: defaults).
 *  Add nodes to r->bus before the first urb_hosted_rig_run(): the initial scan starts there. */
int32_t urb_hosted_rig_init(urb_hosted_rig_t *r, const urb_bridge_config_t *cfg, const urb_i2c_master_config_t *mcfg);

/** One iteration at the current time: heartbeat tick if due, due bus events, bridge poll, UART drain. */
void urb_hosted_rig_iterate(urb_hosted_rig_t *r);

/** Advances virtual time by `us`, iterating every step_us. */
void urb_hosted_rig_run(urb_hosted_rig_t *r, uint32_t us);

/** Runs until the bridge is idle and no bus event is pending, at most `max_us`; true when idle. */
bool urb_hosted_rig_settle(urb_hosted_rig_t *r, uint32_t max_us);

/** Sends bytes on the RS232 uplink, `spacing_us` apart (87 = back to back at 115200 Bd), running the rig in between. */
void urb_hosted_rig_uart_send(urb_hosted_rig_t *r, const uint8_t *bytes, size_t n, uint32_t spacing_us);

#endif /* URB_BRIDGE_HOSTED_H */
