/*
 * URB on CAN, the transfer layer: identifiers, the tail byte, segmentation of a payload into
 * classic CAN frames, reassembly, and the bus timing every CAN budget is derived from.
 * spec/schema/README.md ("CAN downlink") gives the layout and the reasons; spec/schema/can.urbs
 * declares the identifier and the tail byte; spec/tla/CanTransfer.tla is the protocol these
 * functions implement (each cites the action it follows).
 *
 * Pure functions over caller-owned state: no heap, no globals, no bus access. Both ends use them:
 * the bridge's master (urb_can_master.h) and the node's slave (urb_can_slave.h).
 *
 * Segmentation is Cyphal/CAN's (libcanard v4): a payload of at most 7 bytes is one frame (payload,
 * tail); a longer one gets CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no final
 * xor: link_check's CRC-16 tier) appended most significant byte first, and the whole is cut into
 * 7-byte chunks, each followed by its tail byte. A 32-byte mailbox is 34 bytes in 5 frames.
 * Tail byte (CanTail): bit 7 start, bit 6 end, bit 5 toggle (1 in the first frame, then
 * alternating), bits 0..4 the transfer id.
 */
#ifndef URB_CAN_H
#define URB_CAN_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_can_wire.h" /* the schema's constants: addresses, SYNC identifier, frame and transfer limits */

#ifdef __cplusplus
extern "C" {
#endif

/* ===== Constants ============================================================================= */

#define URB_CAN_MTU URB_CAN_FRAME_BYTES /**< data bytes of a classic CAN frame */
#define URB_CAN_CHUNK 7u            /**< payload bytes per frame (the eighth is the tail byte) */
#define URB_CAN_MAX_PAYLOAD 32u     /**< largest transfer payload: a 32-byte mailbox */

#define URB_CAN_TAIL_START 0x80u    /**< tail byte: first frame of a transfer */
#define URB_CAN_TAIL_END 0x40u      /**< tail byte: last frame of a transfer */
#define URB_CAN_TAIL_TOGGLE 0x20u   /**< tail byte: toggle bit */
#define URB_CAN_TAIL_TID 0x1Fu      /**< tail byte: transfer id */

#define URB_CAN_REQUEST 0u          /**< direction: bridge to node */
#define URB_CAN_RESPONSE 1u         /**< direction: node to bridge */

/** One classic CAN data frame with an 11-bit identifier (what a CAN HAL sends and receives). */
typedef struct {
    uint16_t id;                    /**< standard identifier, 0..0x7FF */
    uint8_t len;                    /**< data length 0..8 */
    uint8_t data[URB_CAN_MTU];      /**< data bytes; the last one is the tail byte */
} urb_can_frame_t;

/* ===== Identifiers (CanId in spec/schema/can.urbs) ========================================== */

/** The identifier of a frame to or from node `address` about mailbox `mailbox` (0..7) of the inbox
 *  (`read` false) or outbox (`read` true) set, in `direction` (URB_CAN_REQUEST / _RESPONSE): bits
 *  0..2 mailbox, bit 3 read, bits 4..9 address, bit 10 the response bit. Arguments are masked to their
 *  widths. O(1). */
uint16_t urb_can_id(uint8_t address, uint8_t mailbox, bool read, uint8_t direction);

/** The session index 0..15 of a mailbox: inboxes 0..7, outboxes 8..15 (the bridge keeps one
 *  transfer id per node and session, the node its duplicate filter per session). O(1). */
uint8_t urb_can_session(uint8_t mailbox, bool read);

/* ===== Bus timing ============================================================================ */
/* Worst-case frame length with bit stuffing (Davis, Burns, Bril, Lukkien, Real-Time Systems 35,
 * 2007, eq. 1; Linux can_frame_bits() agrees): g + 8s + 13 + floor((g + 8s - 1) / 4) bit times for
 * s data bytes, g = 34 (11-bit identifier) or 54 (29-bit), i.e. 55 + 10s and 80 + 10s. Without
 * stuffing 47 + 8s (11-bit). Both include the 3-bit interframe space. */

/** Bit times of bus-off recovery: 128 occurrences of 11 recessive bits (ISO 11898-1). */
#define URB_CAN_RECOVERY_BITS (128u * 11u)

/** Worst-case bit times of a frame with `len` data bytes (0..8), 11-bit (`extended` false) or
 *  29-bit identifier, stuffing included. O(1). */
uint16_t urb_can_frame_bits_max(uint8_t len, bool extended);

/** Bit times of a frame with `len` data bytes (0..8) and no stuff bit at all. O(1). */
uint16_t urb_can_frame_bits_min(uint8_t len, bool extended);

/** Frames of a transfer with a `len`-byte payload (0..32): 1 up to 7 bytes, else (len + 2) / 7
 *  rounded up. O(1). */
uint8_t urb_can_frames(uint8_t len);

/** Worst-case bit times of the whole transfer of a `len`-byte payload on 11-bit identifiers:
 *  the sum of its frames' urb_can_frame_bits_max. O(frames). */
uint16_t urb_can_transfer_bits_max(uint8_t len);

/* ===== CRC ==================================================================================== */

/** CRC-16/CCITT-FALSE over `len` bytes, starting from `crc` (0xFFFF for a new transfer). Running
 *  it over a payload followed by its appended CRC (most significant byte first) gives 0. O(len). */
uint16_t urb_can_crc(uint16_t crc, const uint8_t *data, uint8_t len);

/* ===== Segmentation (one outgoing transfer) ================================================== */

/** Segmenter of one transfer; caller-owned; fields private. */
typedef struct {
    const uint8_t *payload; /* the caller's payload, valid until the last frame is taken */
    uint16_t crc;           /* running CRC of the payload bytes emitted so far */
    uint8_t len;            /* payload length */
    uint8_t pos;            /* bytes of payload + CRC emitted */
    uint8_t total;          /* len, or len + 2 for a multi-frame transfer */
    uint8_t tail;           /* tail byte of the next frame, start bit included while pos == 0 */
} urb_can_tx_t;

/** Prepares the transfer of `len` (0..32; larger is cut to 32) bytes at `payload` (NULL allowed
 *  when len is 0) with transfer id `tid` (masked to 5 bits). CanTransfer.tla SendStart. O(1). */
void urb_can_tx_init(urb_can_tx_t *tx, const uint8_t *payload, uint8_t len, uint8_t tid);

/** Writes the next frame's data into `data` (8 bytes of room) and returns its length 1..8, or 0
 *  when every frame was taken. Reads at most 7 payload bytes. CanTransfer.tla SendFrame. O(7). */
uint8_t urb_can_tx_next(urb_can_tx_t *tx, uint8_t *data);

/** True when every frame of the transfer was taken. O(1). */
bool urb_can_tx_done(const urb_can_tx_t *tx);

/* ===== Reassembly (one incoming session) ===================================================== */

/** Results of urb_can_rx_frame. */
typedef enum {
    URB_CAN_RX_MORE = 0,          /**< accepted: a frame of the transfer, more to come */
    URB_CAN_RX_DONE = 1,          /**< accepted: the transfer is complete and its CRC (if any) holds */
    URB_CAN_RX_CRC = 2,           /**< the last frame came, but the transfer's CRC does not hold */
    URB_CAN_RX_EMPTY = 3,         /**< ignored: a frame without a tail byte (length 0) */
    URB_CAN_RX_OTHER_TID = 4,     /**< ignored: another transfer id than the one expected */
    URB_CAN_RX_TOGGLE = 5,        /**< ignored: wrong toggle bit (a repeated frame) */
    URB_CAN_RX_NO_START = 6,      /**< ignored: a frame of a transfer whose start was not seen */
    URB_CAN_RX_BAD_START = 7      /**< ignored: a start frame with toggle 0 (no segmenter sends it) */
} urb_can_rx_result_t;

/** Reassembler of one session (one identifier); caller-owned; fields private. */
typedef struct {
    uint16_t crc;    /* running CRC over every byte of the transfer so far */
    uint8_t count;   /* bytes received (payload and CRC) */
    uint8_t tid;     /* transfer id of the transfer in progress */
    uint8_t toggle;  /* toggle bit the next frame must carry */
    uint8_t active;  /* 1 while a transfer is in progress */
    uint8_t single;  /* the transfer was a single frame */
} urb_can_rx_t;

/** Forgets any transfer in progress. O(1). */
void urb_can_rx_reset(urb_can_rx_t *rx);

/** One received frame of this session (CanTransfer.tla Receive). A start frame whose transfer id
 *  differs from the transfer in progress (or with none in progress) begins a transfer, dropping
 *  the one in progress; any other frame must carry the transfer id in progress and the expected
 *  toggle bit, so a repeated frame is ignored. Payload bytes go to out[0 .. cap-1]; bytes beyond
 *  `cap` are covered by the CRC and counted but not stored (the caller compares the length). On
 *  DONE, urb_can_rx_len() is the payload length (CRC bytes removed) and urb_can_rx_tid() its id.
 *  Which transfer ids are wanted at all is the caller's rule (the bridge: its request's; a node:
 *  any but a repeat of the last one, urb_can_slave.h). O(7). */
urb_can_rx_result_t urb_can_rx_frame(urb_can_rx_t *rx, const uint8_t *data, uint8_t len, uint8_t *out,
                                     uint8_t cap);

/** Transfer id of the transfer in progress or last completed. O(1). */
uint8_t urb_can_rx_tid(const urb_can_rx_t *rx);

/** Payload bytes of the transfer completed by the last DONE (or received so far). O(1). */
uint8_t urb_can_rx_len(const urb_can_rx_t *rx);

/** True while a transfer is in progress (its start was accepted, its end not yet). O(1). */
bool urb_can_rx_active(const urb_can_rx_t *rx);

/* ===== The CAN controller, as both ends see it ============================================== */

/** Fault-confinement state of a CAN controller (ISO 11898-1): error-active while both error
 *  counters are at most 127, error-passive above, bus-off when the transmit counter passes 255. */
typedef enum {
    URB_CAN_ERROR_ACTIVE = 0,  /**< normal operation */
    URB_CAN_ERROR_PASSIVE = 1, /**< TEC or REC > 127: sends passive error flags, waits 8 bits more between frames */
    URB_CAN_BUS_OFF = 2        /**< TEC > 255: off the bus until recovered (128 x 11 recessive bits) */
} urb_can_state_t;

/** A CAN controller, filled in by a port (function pointers with a context; no bus access in the
 *  cores). The port reports back through the owner's entry points: a received frame, a frame
 *  sent (each queued frame once, in queue order), and the state. Frames queued with one
 *  identifier must leave in the order queued (a FIFO transmit queue, or one mailbox at a time). */
typedef struct {
    void *ctx; /**< passed to every function */
    /** Queues one frame for sending; false when no transmit slot is free (try again after the
     *  next frame-sent report). Calls no core function. */
    bool (*tx)(void *ctx, const urb_can_frame_t *frame);
    /** Drops every queued frame not yet on the bus; no frame-sent report comes for them. */
    void (*tx_abort)(void *ctx);
    /** The controller's urb_can_state_t now. */
    uint8_t (*state)(void *ctx);
    /** Starts the way back from bus-off (or re-initialises the controller): error-active again,
     *  both counters zero, after 128 occurrences of 11 recessive bits. */
    void (*recover)(void *ctx);
    /** Optional (NULL: the port calls every entry point from one context): masks (true) or unmasks
     *  (false) the controller's interrupt, around the owner's main-loop steps. */
    void (*lock)(void *ctx, bool locked);
} urb_can_hal_t;

#ifdef __cplusplus
}
#endif

#endif /* URB_CAN_H */
