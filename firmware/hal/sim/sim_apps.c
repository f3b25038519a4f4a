/* sim_apps.c: the probe node application. See sim_apps.h. */
#include "sim_apps.h"

static void probe_bootup(urb_node_t *node, void *user)
{
    sim_probe_app_t *app = user;
    (void)urb_node_set_class(node, app->class_id);
    (void)urb_node_set_index(node, app->index);
    (void)urb_node_set_fingerprint(node, app->fingerprint);
    (void)urb_node_setup_outbox(node, 1u, app->out_size);
    if (app->in_size) {
        (void)urb_node_setup_inbox(node, 1u, app->in_size);
    }
    app->counter = 0u;
}

static void probe_update(urb_node_t *node, void *user)
{
    sim_probe_app_t *app = user;
    app->counter++;
    if (app->in_size) {
        const uint8_t *in = NULL;
        int const rc = urb_node_lock_inbox(node, 1u, &in);
        if (rc == URB_NODE_NEW) {
            app->inbox_msgs++;
        }
        uint8_t const n = (rc >= 0 && app->in_size <= sizeof app->inbox) ? app->in_size : 0u;
        for (uint8_t i = 0u; i < n; i++) {
            app->inbox[i] = in[i];
        }
        if (app->on_inbox_locked != NULL) {
            app->on_inbox_locked(app->hook_ctx, rc, app->inbox, n);
        }
        if (urb_node_release_inbox(node, 1u) == URB_NODE_OK && app->on_inbox_released != NULL) {
            app->on_inbox_released(app->hook_ctx);
        }
    }
    uint8_t *out;
    if (urb_node_lock_outbox(node, 1u, &out) != URB_NODE_OK) {
        return; /* the bridge is still reading the buffer we need: skip this update */
    }
    for (uint8_t i = 0u; i < app->out_size; i++) {
        if (app->fill_counter) {
            out[i] = (uint8_t)app->counter;
        } else {
            out[i] = i < 4u ? (uint8_t)(app->counter >> (8u * i)) : (uint8_t)(0xA0u + i);
        }
    }
    (void)urb_node_release_outbox(node, 1u); /* marks the end of acquisition */
    if (app->on_release != NULL) {
        app->on_release(app->hook_ctx, app->counter);
    }
}

const urb_node_hooks_t sim_probe_hooks = {
    .bootup = probe_bootup,
    .init = NULL,
    .reset = NULL,
    .idle = NULL,
    .update = probe_update,
    .signal = NULL,
    .fault = NULL,
};

uint16_t sim_probe_storage(const sim_probe_app_t *app)
{
    return (uint16_t)(2u * ((unsigned)app->out_size + (unsigned)app->in_size));
}
