/*
 * URB CAN downlink, bridge side: the master that runs one downlink transaction at a time on a CAN
 * bus, as a urb_downlink_t (urb_downlink.h), so the bridge core drives it exactly as the I2C one.
 *
 * The contract (spec/schema/README.md, "CAN downlink"; the node side is urb_can_slave.h):
 *  Write inbox m of node a:  the transfer data[length] on CanId(a, m, inbox, REQUEST) with the
 *      next transfer id of that (node, mailbox); the node answers on CanId(a, m, inbox, RESPONSE)
 *      with the same transfer id: empty = OK (stored), one CanWriteRefusal byte = NODE_BUSY,
 *      CHECKSUM, SIZE_MISMATCH or BAD_REQUEST (not stored).
 *  Read outbox m of node a:  an empty transfer on CanId(a, m, outbox, REQUEST); the answer on
 *      CanId(a, m, outbox, RESPONSE) is the outbox (OK when its length is `length`, else
 *      SIZE_MISMATCH), or empty when the node has no such outbox (BAD_REQUEST).
 *  Probe node a:  an empty transfer on CanId(a, 0, inbox, REQUEST) (an empty write, as I2C's probe
 *      is); any answer = OK. The node's mailboxes are not touched.
 *  SYNC:  one frame on CAN_SYNC_ID (the highest priority) carrying the counter; OK once sent.
 *  Clear:  the controller is re-initialised (bus-off recovery); OK when it is error-active again.
 * Outcomes that no answer gives: a transfer whose CRC fails -> CHECKSUM (a write's: TIMEOUT, since
 * the node may have stored it); no frame of the answer
 * within the timeout -> NO_NODE (nobody took the address, as an unacknowledged I2C address);
 * an answer begun and not finished, or a request not sent in time -> TIMEOUT; a controller that
 * is bus-off when a request begins -> BUS_STUCK (not executed) after the recovery; while the
 * controller stays bus-off after that, at once (the recovery is asked for again every recover_us). A request
 * during which the controller goes bus-off ends TIMEOUT: some of its frames may have arrived.
 *
 * Concurrency: urb_can_master_rx() and urb_can_master_tx_done() are the interrupt side (O(7) each);
 * the downlink's begin() and poll() the main loop, which masks the interrupt (hal->lock) around
 * the state they share. Nothing waits.
 */
#ifndef URB_CAN_MASTER_H
#define URB_CAN_MASTER_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_can.h"
#include "urb_downlink.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Microseconds a node may take to start its answer after the request's last frame (its receive
 *  interrupt and the first frame's queuing), part of every timeout. */
#define URB_CAN_NODE_LATENCY_US 500u
/** The shortest transaction timeout (the one at 1 Mb/s and faster). */
#define URB_CAN_MIN_TIMEOUT_US 2000u
/** Worst-case bit times of the longest transaction: a 32-byte write (5 frames) and a refusal, or
 *  an empty read request and a 32-byte answer, whichever is longer (urb_can_transfer_bits_max). */
#define URB_CAN_LONGEST_BITS 740u

/** Configuration; urb_can_master_default_config() fills in the defaults. */
typedef struct {
    uint16_t bitrate_kbps; /**< bus bit rate (1000, 500, 250, 125), reported in BridgeInfo; default 1000 */
    uint32_t timeout_us;   /**< longest transaction: urb_can_master_timeout_us(bitrate_kbps) */
    uint32_t recover_us;   /**< longest bus-off recovery: urb_can_master_recover_us(bitrate_kbps) */
} urb_can_master_config_t;

/** Counters for diagnostics (read with urb_can_master_stats). */
typedef struct {
    uint32_t timeouts;    /**< transactions that ran out of time (TIMEOUT or NO_NODE) */
    uint32_t bus_off;     /**< requests refused because the controller was bus-off (BUS_STUCK) */
    uint32_t recoveries;  /**< recoveries started (bus-off or clear) */
    uint32_t stale;       /**< frames of the expected identifier with another transfer id (late answers) */
    uint32_t foreign;     /**< frames of other identifiers while a transaction ran */
    uint32_t repeated;    /**< frames ignored by the toggle rule (repeats) or without a start */
    uint32_t crc_errors;  /**< answers whose transfer CRC failed (CHECKSUM) */
} urb_can_master_stats_t;

/** State of one master; caller-owned, one per bus; members are private. */
typedef struct {
    const urb_can_hal_t *hal;
    urb_can_master_config_t cfg;
    /* transaction (written by begin() before the phase) */
    uint8_t op, address, mailbox, length, tid;
    uint8_t *data;
    uint8_t sync_payload[1];
    uint8_t refusal[1];
    uint16_t expect_id;          /* identifier of the answer */
    uint8_t frames_total;        /* frames of the request */
    uint8_t frames_sent;         /* frames reported sent */
    uint8_t clear_result;        /* recovery: what to report when it ends (OK for CLEAR, BUS_STUCK) */
    bool frame_ready;            /* `frame` holds the next frame, not yet accepted by the HAL */
    bool answered;               /* a frame of the answer was accepted */
    uint32_t t0;                 /* begin() time */
    uint32_t recover_t0;         /* when the last recovery was asked for */
    bool recovering;             /* a recovery was asked for and the controller is not yet back */
    urb_can_tx_t tx;
    urb_can_rx_t rx;
    urb_can_frame_t frame;
    volatile uint8_t phase;      /* shared with the interrupt side */
    volatile uint8_t result;
    urb_can_master_stats_t stats;
    /* next transfer id per node address and session (urb_can_session) */
    uint8_t next_tid[URB_CAN_LAST_ADDRESS + 1u][16];
} urb_can_master_t;

/** Timeout for a bus at `bitrate_kbps`: twice the worst-case bit times of the longest transaction
 *  (the second half for arbitration lost to frames of others and error frames) plus
 *  URB_CAN_NODE_LATENCY_US, and never below URB_CAN_MIN_TIMEOUT_US. 0 gives the minimum.
 *  2000 us at 1 Mb/s, 3460 us at 500 kb/s, 6420 us at 250 kb/s. Divides: call it at set-up. */
uint32_t urb_can_master_timeout_us(uint32_t bitrate_kbps);

/** Longest wait for a recovery: twice URB_CAN_RECOVERY_BITS at `bitrate_kbps` (2816 us at 1 Mb/s),
 *  at least 1000 us. Divides: call it at set-up. */
uint32_t urb_can_master_recover_us(uint32_t bitrate_kbps);

/** Fills *cfg with the defaults (1 Mb/s and the timeouts above). */
void urb_can_master_default_config(urb_can_master_config_t *cfg);

/** Initialises *m on the controller *hal (kept by reference) with *cfg (copied); every transfer id
 *  starts at 0. */
void urb_can_master_init(urb_can_master_t *m, const urb_can_hal_t *hal, const urb_can_master_config_t *cfg);

/** Fills *dl so that the bridge drives this master (addresses 1..63, kind CAN). */
void urb_can_master_downlink(urb_can_master_t *m, urb_downlink_t *dl);

/** Interrupt side: the controller received `frame`. Frames other than the awaited answer are
 *  counted and ignored. CanTransfer.tla Receive. O(7). */
void urb_can_master_rx(urb_can_master_t *m, const urb_can_frame_t *frame);

/** Interrupt side: the oldest queued frame was sent (acknowledged on the bus). O(7). */
void urb_can_master_tx_done(urb_can_master_t *m);

/** The transfer id the next request to (address, session) will carry; for tests. */
uint8_t urb_can_master_next_tid(const urb_can_master_t *m, uint8_t address, uint8_t session);

/** True while a transaction or a recovery runs. */
bool urb_can_master_busy(const urb_can_master_t *m);

/** Copies the counters into *out. */
void urb_can_master_stats(const urb_can_master_t *m, urb_can_master_stats_t *out);

#ifdef __cplusplus
}
#endif

#endif /* URB_CAN_MASTER_H */
