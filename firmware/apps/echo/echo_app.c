/* The echo node application: echo_app.h. */
#include "echo_app.h"

#include <string.h>

static void echo_bootup(urb_node_t *node, void *user)
{
    echo_app_t const *a = (echo_app_t const *)user;
    (void)urb_node_set_class(node, a->class_id);
    (void)urb_node_set_index(node, a->index);
    (void)urb_node_set_fingerprint(node, a->fingerprint);
    for (uint8_t m = 1u; m < URB_NODE_MAILBOXES; m++) {
        if (a->in_size[m] != 0u) {
            (void)urb_node_setup_inbox(node, m, a->in_size[m]);
        }
        if (a->out_size[m] != 0u) {
            (void)urb_node_setup_outbox(node, m, a->out_size[m]);
        }
    }
}

static void echo_update(urb_node_t *node, void *user)
{
    echo_app_t *a = (echo_app_t *)user;
    for (uint8_t m = 1u; m < URB_NODE_MAILBOXES; m++) {
        uint8_t const size = a->in_size[m];
        if ((size == 0u) || (size != a->out_size[m])) {
            continue;
        }
        const uint8_t *in;
        int const rc = urb_node_lock_inbox(node, m, &in);
        if ((rc != URB_NODE_NEW) && (rc != URB_NODE_OK)) {
            continue;
        }
        uint8_t *out;
        if (urb_node_lock_outbox(node, m, &out) == URB_NODE_OK) { /* busy: the next update copies it */
            memcpy(out, in, size);
            (void)urb_node_release_outbox(node, m);
            a->echoes++;
        }
        (void)urb_node_release_inbox(node, m);
    }
}

const urb_node_hooks_t echo_app_hooks = {echo_bootup, NULL, NULL, NULL, echo_update, NULL, NULL};
