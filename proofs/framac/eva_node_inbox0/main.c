/* Eva entry: an inbox-0 command of arbitrary bytes written over the downlink (select, six data
 * bytes, check, STOP), then the main loop that executes it. */
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
        (void)urb_node_i2c_event(&node, URB_I2C_ADDR_WRITE, 0u);
        (void)urb_node_i2c_event(&node, URB_I2C_RX_BYTE, 0u); /* MailboxSelect: write inbox 0 */
        for (uint8_t k = 0u; k < URB_NODE_INBOX0_SIZE + 1u; k++) {
            (void)urb_node_i2c_event(&node, URB_I2C_RX_BYTE, Frama_C_unsigned_char_interval(0u, 255u));
        }
        (void)urb_node_i2c_event(&node, URB_I2C_STOP, 0u);
        (void)urb_node_poll(&node);
    }
    return 0;
}
