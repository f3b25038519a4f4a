/*
 * The node library on a CAN or RS485 downlink (issue #39): what a port includes instead of wiring
 * urb_node_i2c_event() when the node's downlink is not I2C. urb_node.h (the application's API) and
 * the mailbox semantics are the same on every downlink; only the port's interrupt path differs.
 *
 * The downlink is chosen when the node image is built (mk/node_downlinks.mk: URB_DOWNLINK=i2c|can|
 * rs485): the I2C build links firmware/node/urb_i2c.c and the port calls urb_node_i2c_event(); a
 * CAN build links urb_node_dl.c, urb_node_can.c and firmware/downlink/can/ and the port calls the
 * urb_can_slave_* entry points of urb_node_can_t.slave from its CAN interrupt; an RS485 build the
 * same with urb_node_rs485.c, firmware/downlink/rs485/ and urb_rs485_slave_*. The node's address
 * is urb_node_config_t.i2c_address on every downlink (CAN: 1..63, RS485: 1..127); the HAL's
 * set_address is still called with it (a CAN port sets its acceptance filter there, or ignores it).
 *
 * Every slave entry point must be called at the priority of urb_node_timer_event() (urb_node_hal.h):
 * the SYNC it passes on shares the heartbeat state with the timer interrupt. Until urb_node_init()
 * has put the node on the bus it has no mailboxes there: requests are answered as for a node without them and SYNC
 * is ignored, as the I2C slave NACKs everything then.
 */
#ifndef URB_NODE_DOWNLINK_H
#define URB_NODE_DOWNLINK_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_dl_slave.h"
#include "urb_node.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Fills *mb with the node library's interrupt-side mailbox steps for *node (kept by reference):
 *  the table a downlink slave (urb_can_slave_init, urb_rs485_slave_init) takes. A complete read
 *  of outbox 0 counts as an identification read (it may clear Identification.fault), SYNC goes to
 *  the heartbeat PLL with the port's time stamp and emits URB_NODE_MARK_SYNC, and faults are
 *  counted for urb_node_poll to deliver, exactly as on I2C. */
void urb_node_dl_mailbox(urb_node_t *node, urb_dl_mailbox_t *mb);

#ifdef __cplusplus
}
#endif

#endif /* URB_NODE_DOWNLINK_H */
