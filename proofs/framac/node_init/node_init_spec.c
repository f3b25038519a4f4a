/*
 * node_init unit: the base case of the I2C slave invariant urb_i2c_ok (firmware/node/urb_i2c.c).
 *
 * One translation unit holds urb_i2c.c (for the predicate urb_i2c_ok, which only that file
 * defines), urb_node.c and urb_mailbox.c, so that the contracts below can name urb_i2c_ok on
 * functions of the other two files without a copy of the predicate and without touching
 * urb_node_internal.h. Frama-C merges each contract below with the one on the function's
 * definition; WP proves the merged contracts of start_slave and of the two setup wrappers on their
 * bodies (the unit's -wp-fct), with urb_mailbox_reset's own contract (reset_i2c_*: mailbox unit).
 *
 * start_slave (urb_node.c): the steps of urb_node_init after the zeroing. Its own contract
 * requires what the zeroing gives and ensures the conjuncts of urb_i2c_ok; here, that they are
 * urb_i2c_ok itself.
 *
 * start_node (urb_node.c): urb_node_init's steps before the bootup hook, the zeroing included, up
 * to start_slave, whose requires WP proves at that call (with the ghost function zero_fields, also
 * in the unit's -wp-fct); here, that it ensures urb_i2c_ok.
 *
 * urb_node_setup_inbox / urb_node_setup_outbox (urb_mailbox.c, the calls the bootup hook may make):
 * keep urb_i2c_ok, through setup_box's default postconditions setup_layout, setup_i2c and
 * setup_sizes, which the mailbox unit proves.
 */
#include "urb_i2c.c"

/*@ ensures start_ok: urb_i2c_ok(node); */
static void start_slave(urb_node_t *node);

/*@ ensures fresh_ok: urb_i2c_ok(node); */
static void start_node(urb_node_t *node, const urb_node_hal_t *hal, const urb_node_hooks_t *hooks, void *user,
                       const urb_node_config_t *cfg, uint8_t *storage, uint16_t storage_len);

#include "urb_node.c"

/*@ requires node == \null || urb_i2c_ok(node);
    ensures setup_keeps: node == \null || urb_i2c_ok(node); */
int urb_node_setup_inbox(urb_node_t *node, uint8_t n, uint8_t size);

/*@ requires node == \null || urb_i2c_ok(node);
    ensures setup_keeps: node == \null || urb_i2c_ok(node); */
int urb_node_setup_outbox(urb_node_t *node, uint8_t n, uint8_t size);

#include "urb_mailbox.c"

