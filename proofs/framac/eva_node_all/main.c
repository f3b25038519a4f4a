/* Eva entry: every node entry point interleaved, as on the target: the I2C slave interrupt (any
 * event, any byte), the heartbeat timer interrupt and the main loop (urb_node_poll, which runs the
 * application's update on mailboxes 1 and 2: lock, fill or read, release), in any order. The other
 * node units drive one entry point each; only here does the interrupt read an outbox buffer the
 * application has published, or write an inbox while the main loop has run commands. */
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
        switch (Frama_C_interval(0, 2)) {
        case 0: {
            urb_i2c_event_t const event = (urb_i2c_event_t)Frama_C_interval(URB_I2C_ADDR_WRITE, URB_I2C_STUCK);
            (void)urb_node_i2c_event(&node, event, Frama_C_unsigned_char_interval(0u, 255u));
            break;
        }
        case 1:
            urb_node_timer_event(&node);
            break;
        default:
            (void)urb_node_poll(&node);
            break;
        }
    }
    return 0;
}
