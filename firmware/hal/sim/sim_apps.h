/*
 * sim_apps.h: node applications that exist only for the simulation's experiments.
 *
 * The probe node (paper Sec. VI-B: "a test node with configurable message box sizes"): outbox 1
 * of a configurable size refreshed on every app_update (a 32-bit update counter, then a byte
 * pattern), optionally inbox 1, which it reads whole on every app_update. Its class and
 * fingerprint are parameters so the host can be given
 * a matching schema entry (urb_sim.probe.probe_info).
 */
#ifndef URBSIM_SIM_APPS_H
#define URBSIM_SIM_APPS_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_node.h"

typedef struct {
    uint8_t class_id;
    uint8_t index;
    uint32_t fingerprint;
    uint8_t out_size;   /**< outbox 1 size, 1..32 */
    uint8_t in_size;    /**< inbox 1 size, 0 = none */
    uint32_t counter;   /**< updates run */
    uint32_t inbox_msgs;
    bool fill_counter;  /**< every byte = the counter's low byte (trace validation: each byte read
                             names the write it came from) */
    uint8_t inbox[32];  /**< the last message read from inbox 1 */
    void (*on_release)(void *ctx, uint32_t counter); /**< after each outbox-1 release (or NULL) */
    /** After each inbox-1 lock (or NULL): its result and the `len` bytes the probe read (0 when
     *  the lock failed), before the release. */
    void (*on_inbox_locked)(void *ctx, int rc, const uint8_t *data, uint8_t len);
    void (*on_inbox_released)(void *ctx); /**< after each successful inbox-1 release (or NULL) */
    void *hook_ctx;
} sim_probe_app_t;

/** The probe's hooks (bootup, update). */
extern const urb_node_hooks_t sim_probe_hooks;

/** Storage the probe needs for its mailboxes. */
uint16_t sim_probe_storage(const sim_probe_app_t *app);

#endif /* URBSIM_SIM_APPS_H */
