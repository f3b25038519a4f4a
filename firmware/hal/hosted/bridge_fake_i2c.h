/*
 * A simulated I2C bus with simple fake nodes, for hosted bridge tests and the hosted bridge
 * program. Each fake node implements the slave side of the downlink contract in urb_downlink.h
 * (select byte, inbox writes with check and NACK positions, outbox reads with the implicit-select
 * check, SYNC on the general call) with configurable mailboxes and fault knobs. The real node
 * library replaces it when the two sides are integrated.
 *
 * The bus implements urb_i2c_hal_t: each operation schedules its completion event `byte_us`
 * (or `start_us`) later on the bus's clock; urb_fake_i2c_step() delivers due events to the master.
 * Operations never call the master back directly (no nesting, no recursion). Deterministic.
 */
#ifndef URB_BRIDGE_FAKE_I2C_H
#define URB_BRIDGE_FAKE_I2C_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_bridge_hal.h"
#include "urb_downlink.h"

/** Fake nodes per bus: more than the bridge remembers (URB_BRIDGE_MAX_NODES, 32), so that a test
 *  can overfill its node table. */
#define URB_FAKE_MAX_NODES 40u
#define URB_FAKE_HOLD_FOREVER 255u /**< hold_sda: never released by a bus clear */
#define URB_FAKE_NO_NACK (-1)    /**< nack_at: no forced NACK */

/** One fake node: its mailboxes, what it observed, and faults to inject. */
typedef struct {
    bool used;                 /**< Slot in use */
    bool present;              /**< Acknowledges its address (false: vanished) */
    uint8_t address, class_id, index;
    uint32_t fingerprint;
    uint8_t in_size[8], out_size[8]; /**< Mailbox sizes (0 = unused); outbox 0 is the identification */
    uint8_t inbox[8][32], outbox[8][32];
    bool echo;                 /**< A write to inbox m >= 1 is copied to outbox m when the sizes match */
    uint8_t sel;               /**< Selected outbox (0 after a reset) */
    /* Faults. */
    int16_t nack_at;           /**< NACK the write byte at this position (0 address, 1 select, 2 first data...) */
    bool nack_once;            /**< Forget nack_at after it fired once */
    bool inbox_busy;           /**< Both buffers of every inbox in use: NACK the first data byte */
    bool corrupt_read;         /**< Flip bit 0 of the first byte of every read */
    bool mute;                 /**< After acknowledging its address, its events are lost (lines stay high) */
    uint32_t stretch_us;       /**< Stretch SCL this long before answering the byte after its address */
    uint8_t hold_sda;          /**< Holds SDA low; released after this many bus-clear pulses (255: never) */
    bool hold_scl;             /**< Holds SCL low (a bus clear cannot help) */
    bool reset_after_select;   /**< Resets (selection back to 0) right after the next read-select */
    /* Observations. */
    uint32_t writes[8];        /**< Committed inbox writes */
    uint32_t aborted_writes;   /**< Writes discarded (bad check, cut short) */
    uint32_t selects;          /**< Read-selects received */
    uint32_t reads;            /**< Read transfers */
    uint32_t syncs;            /**< SYNC broadcasts received */
    uint8_t last_sync;         /**< Counter of the last SYNC */
    uint32_t last_sync_us;     /**< Bus time of the last SYNC */
} urb_fake_node_t;

/** The bus. Fields other than the configuration ones are private. */
typedef struct {
    urb_fake_node_t nodes[URB_FAKE_MAX_NODES];
    urb_i2c_hal_t hal;          /**< The HAL table to give urb_i2c_master_init() */
    urb_i2c_master_t *master;   /**< Receives the events */
    uint32_t (*now)(void *ctx); /**< The bus clock */
    void *now_ctx;
    uint32_t byte_us;           /**< Duration of one byte with its ACK (default 23: 400 kb/s) */
    uint32_t start_us;          /**< Duration of a START (default 3) */
    /* Pending completion event. */
    bool ev_pending;
    uint8_t ev, ev_byte;
    uint32_t ev_due;
    bool stretching;            /* SCL is held low until the pending event */
    /* Transfer state. */
    int8_t target;              /* node index, -1 none, -2 general call */
    bool addressed, reading, lost;
    uint8_t wpos;               /* bytes written after the address */
    uint8_t wbuf[40];           /* select, data, check of the current write */
    uint8_t rpos;
    /* Bit-banging (bus clear). */
    bool bitbang;
    uint8_t driven;
    /* Counters. */
    uint32_t starts, stops, aborts, releases, general_calls;
    uint32_t scl_pulses;         /* bit-banged clock pulses (SCL rising with SDA released) */
    uint32_t bitbang_stops;      /* bit-banged STOPs (SDA rising while SCL is high) */
} urb_fake_i2c_t;

/** Initialises an empty bus on the clock now(now_ctx), delivering events to *master. */
void urb_fake_i2c_init(urb_fake_i2c_t *bus, urb_i2c_master_t *master, uint32_t (*now)(void *ctx), void *now_ctx);

/** Adds a present node with an identification (outbox 0, 25 bytes) and inbox 0 (6 bytes); NULL when full. */
urb_fake_node_t *urb_fake_i2c_add(urb_fake_i2c_t *bus, uint8_t address, uint8_t class_id, uint8_t index);

/** Rewrites node *n's outbox 0 from its class, index, fingerprint and sizes (call after changing them). */
void urb_fake_node_identify(urb_fake_node_t *n);

/** The node resets: its selection goes back to outbox 0. */
void urb_fake_node_reset(urb_fake_node_t *n);

/** Delivers the pending event if it is due; true when one was delivered. */
bool urb_fake_i2c_step(urb_fake_i2c_t *bus);

/** Current line levels (URB_I2C_SCL | URB_I2C_SDA bits when high). */
uint8_t urb_fake_i2c_lines(const urb_fake_i2c_t *bus);

#endif /* URB_BRIDGE_FAKE_I2C_H */
