/*
 * Single-node adapter: the paper's calling style (Fig. 4) for firmware that runs ONE node.
 *
 * The node library keeps all state in a caller-owned urb_node_t so that a process can run many
 * nodes (the simulation). Real firmware runs one; this optional adapter (urb_single.c, not part of
 * the library proper) holds that one instance and its mailbox storage as globals, maps the URB_*
 * calls onto the urb_node_* API, and calls the app_* functions the application defines.
 *
 * Mailbox storage: URB_SINGLE_STORAGE_BYTES (default 128: 64 bytes of mailboxes 1..7, double
 * buffered); build urb_single.c with -DURB_SINGLE_STORAGE_BYTES=N to change it, e.g.
 * URB_NODE_STORAGE_BYTES(sum of the sizes). URB_SetupInbox/Outbox return URB_NODE_ERR_NOMEM when
 * it is too small, and URB_Start then returns that error.
 *
 * Typical main (Cortex-M, see firmware/hal/cortex-m0plus):
 *     URB_Start(&hal, &cfg);            // app_bootup(), on the bus, app_init()
 *     for (;;) { URB_Poll(); sleep until an interrupt unless URB_HasWork(); }
 *     timer compare IRQ:  URB_TimerIsr();       I2C slave IRQ:  URB_I2cIsr(event, byte);
 */
#ifndef URB_SINGLE_H
#define URB_SINGLE_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_node.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ===== Defined by the application (paper Fig. 4, right column) ============================ */

void app_bootup(void);               /**< power-up: URB_SetClass, URB_SetIndex, URB_Setup* */
void app_init(void);                 /**< the node is on the bus */
void app_reset(void);                /**< inbox 0 RESET */
void app_idle(void);                 /**< every main-loop iteration */
void app_update(void);               /**< every heartbeat (divided by update_divider) */
void app_signal(uint8_t signal);     /**< inbox 0 SIGNAL */
void app_fault(urb_node_fault_t fault); /**< a fault occurred */

/* ===== Node API (paper Fig. 4, left column) =============================================== */

/** Sets the node class (call from app_bootup). */
int URB_SetClass(uint8_t class_id);
/** Sets the node index 0..63 (call from app_bootup). */
int URB_SetIndex(uint8_t index);
/** Sets the layout fingerprint, URB_NODE_<NAME>_FINGERPRINT (call from app_bootup). */
int URB_SetFingerprint(uint32_t fingerprint);
/** Sets up inbox n (1..7) with size bytes (call from app_bootup). */
int URB_SetupInbox(uint8_t n, uint8_t size);
/** Sets up outbox n (1..7) with size bytes (call from app_bootup). */
int URB_SetupOutbox(uint8_t n, uint8_t size);
/** Locks inbox n; *data points at the latest message. URB_NODE_NEW / _OK / _ERR_*. */
int URB_LockInbox(uint8_t n, const uint8_t **data);
/** Releases inbox n. */
int URB_ReleaseInbox(uint8_t n);
/** Locks outbox n; fill *data completely, then release. URB_NODE_OK / _ERR_BUSY / _ERR_*. */
int URB_LockOutbox(uint8_t n, uint8_t **data);
/** Publishes outbox n. */
int URB_ReleaseOutbox(uint8_t n);

/* ===== Plumbing for the port's main and interrupt handlers ================================ */

/** Initialises the one node with the port's HAL and configuration (calls app_bootup, app_init). */
int URB_Start(const urb_node_hal_t *hal, const urb_node_config_t *cfg);
/** One main-loop iteration (urb_node_poll). */
uint8_t URB_Poll(void);
/** True when URB_Poll has work now (urb_node_has_work). */
bool URB_HasWork(void);
/** Heartbeat timer compare interrupt (urb_node_timer_event). */
void URB_TimerIsr(void);
/** I2C slave interrupt, one call per event (urb_node_i2c_event). */
uint16_t URB_I2cIsr(urb_i2c_event_t event, uint8_t byte);
/** The node instance, for the urb_node_* calls the paper's API lacks. */
urb_node_t *URB_Node(void);

#ifdef __cplusplus
}
#endif

#endif /* URB_SINGLE_H */
