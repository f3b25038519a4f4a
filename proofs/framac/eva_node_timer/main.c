/* Eva entry: the heartbeat timer interrupt and the main loop's update step (urb_node_poll), any
 * timer readings, any interleaving of the two. */
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
        if (Frama_C_nondet(0, 1) != 0) {
            urb_node_timer_event(&node);
        } else {
            (void)urb_node_poll(&node);
        }
    }
    return 0;
}
