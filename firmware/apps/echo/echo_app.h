/*
 * The echo node application: what every URB node application is (hooks on urb_node.h, nothing of
 * the downlink), doing the least that shows the mailboxes work: every update, outbox m gets a copy
 * of inbox m for each m in 1..7 where both are set up with the same size. The hosted nodes
 * (urb-node-hosted) run it on any downlink; the hosted bridge's fake I2C nodes (echo=1) behave
 * the same, so a host program sees one behaviour on every downlink. (An outbox is republished
 * every update while its inbox holds a message.)
 */
#ifndef URB_ECHO_APP_H
#define URB_ECHO_APP_H

#include <stdint.h>

#include "urb_node.h"

/** The node's identity and layout; caller-owned, referenced by the hooks' `user` pointer. */
typedef struct {
    uint8_t class_id;
    uint8_t index;         /**< 0..63 */
    uint32_t fingerprint;
    uint8_t in_size[8];    /**< inbox sizes 1..7 (index 0 unused: mailbox 0 is the library's) */
    uint8_t out_size[8];   /**< outbox sizes 1..7 */
    uint32_t echoes;       /**< outboxes published */
} echo_app_t;

/** The hooks to give urb_node_init, with `user` an echo_app_t. */
extern const urb_node_hooks_t echo_app_hooks;

#endif /* URB_ECHO_APP_H */
