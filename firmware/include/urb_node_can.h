/*
 * A node on the CAN downlink (urb_node_downlink.h explains the build-time choice): the node's
 * mailbox table and its CAN slave in one caller-owned struct. The port's CAN interrupt calls
 * urb_can_slave_rx / urb_can_slave_tx_done / urb_can_slave_state on `slave`.
 */
#ifndef URB_NODE_CAN_H
#define URB_NODE_CAN_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_can_slave.h"
#include "urb_node_downlink.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The node side of a CAN downlink; caller-owned, lives as long as the node. */
typedef struct {
    urb_dl_mailbox_t mb;   /**< the node's mailbox steps (urb_node_dl_mailbox) */
    urb_can_slave_t slave; /**< the slave the port's CAN interrupt drives */
} urb_node_can_t;

/** Attaches *node (initialised by urb_node_init with *cfg) to the CAN
 *  controller *hal at `bitrate_kbps` (the duplicate window follows it), as node cfg->i2c_address.
 *  False (nothing attached) when the address is outside CAN's 1..63 or *hal lacks tx, tx_abort or
 *  recover. */
bool urb_node_can_attach(urb_node_can_t *c, urb_node_t *node, const urb_node_config_t *cfg,
                         const urb_can_hal_t *hal, uint32_t bitrate_kbps);

#ifdef __cplusplus
}
#endif

#endif /* URB_NODE_CAN_H */
