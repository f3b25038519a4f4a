/*
 * URB node hardware abstraction: the few things the node library needs from a microcontroller.
 *
 * A port fills one `urb_node_hal_t` (function pointers + its own context pointer) and passes it to
 * urb_node_init(). The library calls these functions from the main loop AND from the two interrupt
 * entry points (urb_node_timer_event, urb_node_i2c_event), so every function here must be callable
 * from interrupt context and must not block.
 *
 * The port, in turn, calls the library:
 *   - urb_node_timer_event(node) from the heartbeat timer's compare interrupt (the compare set by
 *     set_compare() has been reached);
 *   - urb_node_i2c_event(node, event, byte) from the I2C slave interrupt, once per bus event.
 * Both must run at the SAME interrupt priority (they must not preempt each other): they share the
 * heartbeat state. The application (urb_node_poll and the URB_* mailbox calls) runs at thread
 * level and may be preempted by either at any point; the mailbox algorithms are built for that.
 *
 * Time is a free-running 32-bit tick counter. Wrap-around is fine: the library only ever uses
 * differences of ticks less than 2^31 apart. Nothing here assumes real time: the simulation's HAL
 * returns virtual time, the hosted HAL a counter the test advances.
 *
 * Ports: firmware/hal/hosted (deterministic, for unit tests), firmware/hal/cortex-m0plus
 * (register-level reference skeleton).
 */
#ifndef URB_NODE_HAL_H
#define URB_NODE_HAL_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** Timing marks the library emits through urb_node_hal_t.mark (for oscilloscope / simulation). */
typedef enum {
    URB_NODE_MARK_BEAT = 0,    /**< a heartbeat: the timer compare fired (timer interrupt) */
    URB_NODE_MARK_ACQ_END = 1, /**< the application finished this update's data acquisition */
    URB_NODE_MARK_SYNC = 2,    /**< a SYNC broadcast was time-stamped (I2C interrupt) */
    URB_NODE_MARK_COUNT = 3    /**< number of marks */
} urb_node_mark_t;

/** The port's side of the node library. Optional members may be NULL. */
typedef struct urb_node_hal {
    /** Port context, passed back as `ctx` to every function below. */
    void *ctx;
    /** Required. The free-running heartbeat timer, in ticks (tick rate: urb_node_config_t.ticks_per_us). */
    uint32_t (*now)(void *ctx);
    /** Required. Arm the heartbeat compare: call urb_node_timer_event() when the timer reaches `at`.
     *  Replaces any pending compare. The library always passes a tick at least 1 us in the future. */
    void (*set_compare)(void *ctx, uint32_t at);
    /** Optional. The tick latched by hardware at the last general-call address match (input capture);
     *  NULL: the library reads now() in the general-call event (adds the interrupt latency jitter). */
    uint32_t (*sync_capture)(void *ctx);
    /** Required. Set the 7-bit I2C slave address and enable general-call reception. */
    void (*set_address)(void *ctx, uint8_t address);
    /** Optional. Emit a timing mark (e.g. toggle a GPIO). Called from interrupts and the main loop. */
    void (*mark)(void *ctx, urb_node_mark_t mark);
    /** Optional. IDENTIFY command: blink the identification LED for `seconds` (0 = stop). */
    void (*identify)(void *ctx, uint8_t seconds);
} urb_node_hal_t;

#ifdef __cplusplus
}
#endif

#endif /* URB_NODE_HAL_H */
