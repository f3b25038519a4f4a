/*
 * Contract of urb_setup_error (firmware/node/urb_node.c) for the mailbox unit: setup_box calls it
 * on every refused setup, so its frame is part of setup_box's proof. The unit lists urb_node.c and
 * the function in -wp-fct: WP proves this contract on the body, it is not an assumption.
 */
#include "urb_node_internal.h"

/*@ requires node == \null || \valid(node);
    assigns node->setup_err; */
void urb_setup_error(urb_node_t *node, int rc);
