/*
 * URB bridge HAL: the little the bridge firmware needs from its board.
 *
 * Two tables of function pointers, each with a context pointer, filled in by a port
 * (firmware/hal/hosted: POSIX and deterministic for tests; firmware/hal/cortex-m0plus: reference
 * skeleton; the simulation brings its own). Nothing here assumes real time or static state: every
 * call gets its context, and time is whatever now_us() says.
 *
 * Direction of calls. The bridge calls the HAL through these tables. The port calls the bridge
 * back through the entry points of urb_bridge.h / urb_downlink.h:
 *   timer ISR, every heartbeat period  -> urb_bridge_heartbeat()
 *   UART byte received (ISR)           -> urb_bridge_uart_rx(byte, now_us)
 *   UART ready for a byte (ISR)        -> urb_bridge_uart_tx_pop()
 *   USB start of frame, OUT done, IN   -> urb_bridge_usb_sof(), _usb_out(), _usb_in() (main loop)
 *   I2C operation completed (ISR)      -> urb_i2c_master_event()
 *   main loop                          -> urb_bridge_poll()
 */
#ifndef URB_BRIDGE_HAL_H
#define URB_BRIDGE_HAL_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_i2c_event.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ===== Board services ========================================================================= */

/** Timing marks the bridge sets on the GPIO mark pin(s), for oscilloscope / trace timing. */
typedef enum {
    URB_MARK_SERVE = 0, /**< High while a request's downlink transaction runs */
    URB_MARK_SYNC = 1,  /**< High while a SYNC broadcast runs */
    URB_MARK_EMIT = 2,  /**< Pulsed when a response leaves on an uplink */
} urb_mark_t;

/** Board services of one bridge. Every pointer except `mark` is required. */
typedef struct {
    void *ctx; /**< Passed to every function */
    /** Free-running microsecond counter; wraps at 2^32 (the bridge only subtracts times). */
    uint32_t (*now_us)(void *ctx);
    /** (Re)starts the periodic heartbeat tick with this period; 0 stops it. */
    void (*heartbeat_period)(void *ctx, uint32_t period_us);
    /** Bytes are waiting in the UART TX ring: start draining it with urb_bridge_uart_tx_pop().
     *  Called from poll(): it may call urb_bridge_uart_tx_pop() and no other bridge function. */
    void (*uart_tx_kick)(void *ctx);
    /** Sets timing mark `id` (urb_mark_t) to `level`; NULL when the board has no mark pin. Calls no
     *  bridge function. */
    void (*mark)(void *ctx, uint8_t id, bool level);
} urb_bridge_hal_t;

/* ===== I2C master byte level ================================================================== */

/* Completion events of I2C operations (URB_I2C_EV_START .. URB_I2C_EV_ERROR), reported by the
 * HAL with urb_i2c_master_event(), are urb_i2c_event_t values (urb_i2c_event.h). */

#define URB_I2C_SCL 0x01u /**< lines()/drive() bit for SCL (1 = high / released) */
#define URB_I2C_SDA 0x02u /**< lines()/drive() bit for SDA (1 = high / released) */

/** Byte-level I2C master operations. start/write/read complete later with exactly one event,
 *  delivered from the HAL's interrupt (never from inside the call: that would nest the state
 *  machine); the master issues at most one operation at a time. */
typedef struct {
    void *ctx; /**< Passed to every function */
    /** Generates a START (or a repeated START after a read-select); completes with EV_START. */
    void (*start)(void *ctx);
    /** Sends one byte; completes with EV_ACK or EV_NACK. */
    void (*write)(void *ctx, uint8_t byte);
    /** Receives one byte and answers ACK (`ack`) or NACK (last byte); completes with EV_BYTE. */
    void (*read)(void *ctx, bool ack);
    /** Generates a STOP; no event (the next start() waits for the bus to be free). */
    void (*stop)(void *ctx);
    /** Abandons the current operation; after it returns no event of it is delivered. */
    void (*abort)(void *ctx);
    /** Current levels of the lines: URB_I2C_SCL | URB_I2C_SDA bits set when high. */
    uint8_t (*lines)(void *ctx);
    /** Bit-bangs the lines as open-drain GPIO: a set bit releases the line, a clear bit pulls it low. */
    void (*drive)(void *ctx, uint8_t lines);
    /** Ends bit-banging: gives the pins back to the controller and re-initialises it. */
    void (*release)(void *ctx);
} urb_i2c_hal_t;

#ifdef __cplusplus
}
#endif

#endif /* URB_BRIDGE_HAL_H */
