/*
 * A node on the RS485 downlink (urb_node_downlink.h explains the build-time choice): the node's
 * mailbox table, the line timing and its RS485 slave in one caller-owned struct. The port's UART
 * interrupts call urb_rs485_slave_rx / urb_rs485_slave_poll / urb_rs485_slave_tx_next on `slave`.
 */
#ifndef URB_NODE_RS485_H
#define URB_NODE_RS485_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_node_downlink.h"
#include "urb_rs485_slave.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The node side of an RS485 downlink; caller-owned, lives as long as the node. */
typedef struct {
    urb_dl_mailbox_t mb;     /**< the node's mailbox steps (urb_node_dl_mailbox) */
    urb_rs485_timing_t tm;   /**< the line's timing at the configured baud rate */
    urb_rs485_slave_t slave; /**< the slave the port's UART interrupts drive */
} urb_node_rs485_t;

/** Attaches *node (initialised by urb_node_init with *cfg) to the transceiver *hal at `baud`, as
 *  node cfg->i2c_address, at line time `now_us`. False (nothing attached) for an address outside
 *  1..127 or a HAL without tx_start or wake_at. */
bool urb_node_rs485_attach(urb_node_rs485_t *r, urb_node_t *node, const urb_node_config_t *cfg,
                           const urb_rs485_hal_t *hal, uint32_t baud, uint32_t now_us);

#ifdef __cplusplus
}
#endif

#endif /* URB_NODE_RS485_H */
