/* Eva entry: the node's I2C slave interrupt handler, any sequence of bus events and bytes. */
#include "eva_node_env.h"

int eva_main(void)
{
    static urb_node_t node;
    static uint8_t storage[EVA_NODE_STORAGE];
    urb_node_hal_t hal;
    urb_node_hooks_t hooks;
    urb_node_config_t cfg;
    if (eva_node_start(&node, &hal, &hooks, &cfg, storage) != URB_NODE_OK) {
        return 1;
    }
    while (Frama_C_nondet(0, 1) != 0) {
        urb_i2c_event_t const event = (urb_i2c_event_t)Frama_C_interval(URB_I2C_ADDR_WRITE, URB_I2C_STUCK);
        (void)urb_node_i2c_event(&node, event, Frama_C_unsigned_char_interval(0u, 255u));
    }
    return 0;
}
