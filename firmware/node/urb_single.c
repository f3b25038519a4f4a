/*
 * Single-node adapter (see urb_single.h). The only file of the node firmware with globals: the
 * one node instance and its mailbox storage. Not part of the library proper; link it only into
 * firmware written in the paper's style.
 */
#include "urb_single.h"

#include <stddef.h>

#ifndef URB_SINGLE_STORAGE_BYTES
#define URB_SINGLE_STORAGE_BYTES 128u
#endif

static urb_node_t urb_single_node;
static uint8_t urb_single_storage[URB_SINGLE_STORAGE_BYTES];

/* Trampolines from the context-passing hooks to the application's app_* functions. */
static void single_bootup(urb_node_t *node, void *user)
{
    (void)node;
    (void)user;
    app_bootup();
}

static void single_init(urb_node_t *node, void *user)
{
    (void)node;
    (void)user;
    app_init();
}

static void single_reset(urb_node_t *node, void *user)
{
    (void)node;
    (void)user;
    app_reset();
}

static void single_idle(urb_node_t *node, void *user)
{
    (void)node;
    (void)user;
    app_idle();
}

static void single_update(urb_node_t *node, void *user)
{
    (void)node;
    (void)user;
    app_update();
}

static void single_signal(urb_node_t *node, void *user, uint8_t signal)
{
    (void)node;
    (void)user;
    app_signal(signal);
}

static void single_fault(urb_node_t *node, void *user, urb_node_fault_t fault)
{
    (void)node;
    (void)user;
    app_fault(fault);
}

static const urb_node_hooks_t single_hooks = {single_bootup, single_init,   single_reset, single_idle,
                                              single_update, single_signal, single_fault};

int URB_SetClass(uint8_t class_id)
{
    return urb_node_set_class(&urb_single_node, class_id);
}

int URB_SetIndex(uint8_t index)
{
    return urb_node_set_index(&urb_single_node, index);
}

int URB_SetFingerprint(uint32_t fingerprint)
{
    return urb_node_set_fingerprint(&urb_single_node, fingerprint);
}

int URB_SetupInbox(uint8_t n, uint8_t size)
{
    return urb_node_setup_inbox(&urb_single_node, n, size);
}

int URB_SetupOutbox(uint8_t n, uint8_t size)
{
    return urb_node_setup_outbox(&urb_single_node, n, size);
}

int URB_LockInbox(uint8_t n, const uint8_t **data)
{
    return urb_node_lock_inbox(&urb_single_node, n, data);
}

int URB_ReleaseInbox(uint8_t n)
{
    return urb_node_release_inbox(&urb_single_node, n);
}

int URB_LockOutbox(uint8_t n, uint8_t **data)
{
    return urb_node_lock_outbox(&urb_single_node, n, data);
}

int URB_ReleaseOutbox(uint8_t n)
{
    return urb_node_release_outbox(&urb_single_node, n);
}

int URB_Start(const urb_node_hal_t *hal, const urb_node_config_t *cfg)
{
    return urb_node_init(&urb_single_node, hal, &single_hooks, NULL, cfg, urb_single_storage,
                         (uint16_t)sizeof urb_single_storage);
}

uint8_t URB_Poll(void)
{
    return urb_node_poll(&urb_single_node);
}

bool URB_HasWork(void)
{
    return urb_node_has_work(&urb_single_node);
}

void URB_TimerIsr(void)
{
    urb_node_timer_event(&urb_single_node);
}

uint16_t URB_I2cIsr(urb_i2c_event_t event, uint8_t byte)
{
    return urb_node_i2c_event(&urb_single_node, event, byte);
}

urb_node_t *URB_Node(void)
{
    return &urb_single_node;
}
