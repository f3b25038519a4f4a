/* A node on the CAN downlink: urb_node_can.h. */
#include "urb_node_can.h"

bool urb_node_can_attach(urb_node_can_t *c, urb_node_t *node, const urb_node_config_t *cfg,
                         const urb_can_hal_t *hal, uint32_t bitrate_kbps)
{
    urb_node_dl_mailbox(node, &c->mb);
    return urb_can_slave_init(&c->slave, hal, &c->mb, cfg->i2c_address, urb_can_slave_dup_window_us(bitrate_kbps));
}
