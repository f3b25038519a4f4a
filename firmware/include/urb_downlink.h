/*
 * URB downlink interface: what the bridge needs from a downlink (I2C now, CAN and RS485 later),
 * and the I2C master that implements it.
 *
 * The bridge (urb_bridge.h) never touches a bus: it hands one transaction at a time to a
 * urb_downlink_t (a context pointer and function pointers) and polls it until it reports an
 * outcome. A downlink runs its bus from interrupts or from its poll function; it never blocks.
 *
 * ---- The I2C downlink contract (the node library implements the slave side of exactly this) ----
 *
 *  Write inbox m of node a:  START, a<<1|0, select, data[size], check, STOP
 *      select = m (bits 0..2), bit 7 = 0; check = link_check over select+data: CRC-8 when
 *      1+size <= 14, else CRC-16 sent little-endian. NACK of the address -> NO_NODE, of the select
 *      -> BAD_REQUEST, of the first data byte -> NODE_BUSY, of a later data byte -> SIZE_MISMATCH,
 *      of a check byte -> CHECKSUM; all ACKed -> OK. A write does not change the read selection.
 *  Read outbox m of node a:  [START, a<<1|0, m|0x80 (NACK -> BAD_REQUEST), repeated] START,
 *      a<<1|1, size data bytes and the check (the master ACKs all but the last byte), STOP.
 *      The select part is sent only when the master's cached selection for a is not m; the
 *      node keeps its selection until the next select. The check covers the implicit select
 *      byte (m | 0x80) then the data, so a node that lost its selection (reset) fails it: the
 *      master then reports CHECKSUM and forgets its cached selection.
 *  SYNC:  START, 0x00 (general call, write), 0xA5, counter, STOP, once per heartbeat period.
 *  Probe: START, a<<1|0, STOP: is node a there (the node sees an empty write and keeps its state).
 *  Any transaction: no completion within the timeout -> TIMEOUT; SDA or SCL held low (before a
 *      transaction or after a fault) -> nine SCL pulses, a STOP, and BUS_STUCK (not executed).
 */
#ifndef URB_DOWNLINK_H
#define URB_DOWNLINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_bridge_hal.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ===== The interface ======================================================================== */

/** Transaction kinds a downlink executes. */
typedef enum {
    URB_DL_READ = 0,  /**< Read `length` bytes of outbox `mailbox` of node `address` into `data` */
    URB_DL_WRITE = 1, /**< Write `length` bytes from `data` into inbox `mailbox` of node `address` */
    URB_DL_SYNC = 2,  /**< Broadcast the heartbeat SYNC carrying `counter` */
    URB_DL_CLEAR = 3, /**< Clear the bus (I2C: nine clocks and a STOP); OK when the bus is free after */
    URB_DL_PROBE = 4, /**< Address node `address` alone (I2C: START, address + W, STOP): OK when it
                           acknowledges, NO_NODE when not; the node's mailboxes are not touched */
} urb_dl_op_t;

/** One downlink transaction. `data` must stay valid until the downlink reports the outcome. */
typedef struct {
    uint8_t op;       /**< urb_dl_op_t */
    uint8_t address;  /**< Node address (READ, WRITE) */
    uint8_t mailbox;  /**< Mailbox 0..7 (READ, WRITE) */
    uint8_t length;   /**< Payload bytes 1..32 (READ, WRITE) */
    uint8_t counter;  /**< SYNC counter (SYNC) */
    bool reselect;    /**< READ: send the select even when the cached selection matches (discovery) */
    uint8_t *data;    /**< READ: destination of `length` bytes; WRITE: source */
} urb_downlink_txn_t;

#define URB_DOWNLINK_BUSY (-1) /**< poll(): the transaction is still running */
#define URB_DOWNLINK_IDLE (-2) /**< poll(): no transaction (its outcome was already reported) */

/** A downlink as the bridge sees it: identification for BridgeInfo plus three operations. */
typedef struct {
    void *ctx;                 /**< Passed to every operation */
    uint8_t kind;              /**< urb_downlink_kind_t, reported in BridgeInfo */
    uint16_t bitrate_kbps;     /**< Reported in BridgeInfo */
    uint8_t first_address;     /**< Lowest node address (scan start; lower non-zero ones are BAD_REQUEST) */
    uint8_t last_address;      /**< Highest node address (scan end; higher ones are BAD_REQUEST) */
    /** Starts `txn` (copied except for `data`); false when a transaction is still running. O(length). */
    bool (*begin)(void *ctx, const urb_downlink_txn_t *txn, uint32_t now_us);
    /** Advances timeouts and bus clears; returns BUSY, IDLE, or once the final urb_status_t. O(length). */
    int8_t (*poll)(void *ctx, uint32_t now_us);
} urb_downlink_t;

/* ===== The I2C master ======================================================================== */
/* A non-blocking state machine driven by byte-level HAL events (urb_i2c_hal_t): the HAL reports
 * each completed bus operation by calling urb_i2c_master_event() from its interrupt; the handler
 * issues the next operation and returns, O(1). Timeouts, bus clears and check verification run in
 * the downlink poll (main loop). */

#define URB_I2C_FIRST_ADDRESS 0x08u /**< 0x00..0x07 are reserved by the I2C specification */
#define URB_I2C_LAST_ADDRESS 0x77u  /**< 0x78..0x7F are reserved (10-bit addressing and future use) */
#define URB_I2C_NO_SELECTION 0xFFu  /**< Selection cache: the node's selected outbox is unknown */

/** Configuration of the I2C master; urb_i2c_master_default_config() fills in the defaults. */
typedef struct {
    uint16_t bitrate_kbps;   /**< Bus bit rate, reported in BridgeInfo (default 400) */
    uint32_t timeout_us;     /**< Longest transaction, clock stretching included: urb_i2c_master_timeout_us(bitrate_kbps) (default 2000) */
    uint16_t clear_half_us;  /**< Half period of the bus-clear clock pulses (default 5: 100 kHz) */
} urb_i2c_master_config_t;

/** State of one I2C master; caller-owned, one per bus. Fields are private. */
typedef struct {
    const urb_i2c_hal_t *hal;
    urb_i2c_master_config_t cfg;
    /* Transaction in progress (written by begin() before the first bus operation). */
    uint8_t op, address, mailbox, length;
    uint8_t *data;
    uint8_t hdr[3];           /* address, select (or SYNC bytes) */
    uint8_t tail[2];          /* write check, little-endian */
    uint8_t rx_check[2];      /* read check as received */
    uint8_t n_hdr, n_data, n_tail, n_rx;
    bool read_after;          /* a repeated START and a read follow the header */
    uint32_t t0;              /* begin() time, for the timeout */
    /* Shared with the event handler (interrupt). */
    volatile uint8_t phase;
    volatile uint8_t pos;
    volatile uint8_t result;
    /* Bus clear (poll only). */
    uint8_t clear_step;
    uint8_t clear_for;        /* result to report: BUS_STUCK, or by the lines for URB_DL_CLEAR */
    uint32_t t_step;
    /* Selected outbox of every address, or URB_I2C_NO_SELECTION (poll/begin only). */
    uint8_t sel[128];
    /* Counters for diagnostics. */
    uint32_t bus_clears, timeouts;
} urb_i2c_master_t;

/** Bit times of the longest transaction, a 32-byte read with its select: address, select, repeated
 *  START, address, 32 data bytes, 2 check bytes (37 bytes of 9 bits: 8 and the ACK), plus START,
 *  repeated START and STOP. (A 32-byte write is one byte shorter: no second address.) */
#define URB_I2C_LONGEST_BITS (37u * 9u + 3u)
/** The shortest transaction timeout: the one of 400 kb/s and every faster rate (2 ms). */
#define URB_I2C_MIN_TIMEOUT_US 2000u

/** The timeout_us to configure for a bus at `bitrate_kbps`: twice the bus time of the longest
 *  transaction (the second half for the nodes' clock stretching), rounded up, and never below
 *  URB_I2C_MIN_TIMEOUT_US. 2000 us from 336 kb/s up (so at 400 kb/s), 6720 us at 100 kb/s,
 *  67 200 us at 10 kb/s. 0 (no rate known) gives URB_I2C_MIN_TIMEOUT_US. Divides: call it at set-up,
 *  not from an interrupt. A port that changes bitrate_kbps must set timeout_us from it too. */
uint32_t urb_i2c_master_timeout_us(uint32_t bitrate_kbps);

/** Fills *cfg with the defaults (400 kb/s, 2 ms timeout = urb_i2c_master_timeout_us(400), 100 kHz
 *  bus-clear clock). */
void urb_i2c_master_default_config(urb_i2c_master_config_t *cfg);

/** Initialises *m on the bus driven by *hal (kept by reference) with *cfg (copied); forgets all selections. */
void urb_i2c_master_init(urb_i2c_master_t *m, const urb_i2c_hal_t *hal, const urb_i2c_master_config_t *cfg);

/** Fills *dl so that the bridge drives this master (addresses 0x08..0x77). */
void urb_i2c_master_downlink(urb_i2c_master_t *m, urb_downlink_t *dl);

/** Interrupt side: the HAL reports that its last operation completed. Never waits; O(1). */
void urb_i2c_master_event(urb_i2c_master_t *m, urb_i2c_event_t ev, uint8_t byte);

/** The cached selected outbox of `address` (URB_I2C_NO_SELECTION when unknown); for tests. */
uint8_t urb_i2c_master_selection(const urb_i2c_master_t *m, uint8_t address);

/** True while a transaction waits for bus events (START .. last byte; not during a bus clear). */
bool urb_i2c_master_busy(const urb_i2c_master_t *m);

/** While busy: true, and *deadline_us = the now_us from which poll() reports TIMEOUT (begin time +
 *  timeout_us + 1, modulo 2^32); a port that sleeps between events must poll by then. */
bool urb_i2c_master_deadline(const urb_i2c_master_t *m, uint32_t *deadline_us);

/** Transactions that timed out since init. */
uint32_t urb_i2c_master_timeouts(const urb_i2c_master_t *m);

/** Bus clears performed since init. */
uint32_t urb_i2c_master_bus_clears(const urb_i2c_master_t *m);

#ifdef __cplusplus
}
#endif

#endif /* URB_DOWNLINK_H */
