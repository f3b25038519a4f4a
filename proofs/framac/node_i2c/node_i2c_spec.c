/*
 * Contracts of the two functions outside urb_i2c.c and urb_mailbox.c that the I2C slave path
 * calls, for the node_i2c unit.
 *
 * urb_isr_fault (firmware/node/urb_node.c): the unit lists urb_node.c and the function in
 * -wp-fct, so WP proves this contract on the body; it is not an assumption.
 *
 * urb_pll_sync (firmware/node/urb_pll.c, not a source of the unit): a reviewed HYPOTHESIS, not
 * proved: the SYNC's counter byte changes only the PLL state. Its body writes node->pll and
 * calls the HAL's now() and set_compare(), which by urb_node_hal.h do not touch the node. The
 * PLL's own run-time safety is Eva's (eva_node_timer, eva_node_all) and the PLL tests'.
 */
#include "urb_node_internal.h"

/*@ requires \valid(node) && URB_NODE_FAULT_CHECKSUM <= code <= URB_NODE_FAULT_STUCK_BUS;
    assigns node->isr_faults[code - 1]; */
void urb_isr_fault(urb_node_t *node, urb_node_fault_t code);

/*@ requires \valid(node);
    assigns node->pll; */
void urb_pll_sync(urb_node_t *node, uint32_t t_d, uint8_t counter);
