/* A node on the RS485 downlink: urb_node_rs485.h. */
#include "urb_node_rs485.h"

bool urb_node_rs485_attach(urb_node_rs485_t *r, urb_node_t *node, const urb_node_config_t *cfg,
                           const urb_rs485_hal_t *hal, uint32_t baud, uint32_t now_us)
{
    urb_node_dl_mailbox(node, &r->mb);
    urb_rs485_timing(&r->tm, baud);
    return urb_rs485_slave_init(&r->slave, hal, &r->mb, cfg->i2c_address, &r->tm, now_us);
}
