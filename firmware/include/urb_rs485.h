/*
 * URB on RS485, the framing layer: line timing, the receiver that cuts the byte stream into frames
 * by silence (Modbus RTU's rules), and the transceiver HAL both ends use. spec/schema/README.md
 * ("RS485 downlink") gives the reasons; spec/schema/rs485.urbs the frames; spec/tla/Rs485Poll.tla
 * the poll cycle the master and the slave implement (urb_rs485_master.h, urb_rs485_slave.h).
 *
 * Characters are 8N1: 10 bit times. Time comes in explicit microsecond time stamps: a received
 * byte's is the moment its stop bit was sampled (the receive interrupt's time, or the UART's
 * time stamp). The silence before a byte is its time stamp minus the previous one's, less one
 * character. Rules:
 *  - a frame is the bytes between two silences of at least t3.5 (3.5 characters);
 *  - a silence of more than t1.5 (1.5 characters) inside a frame breaks it: the frame, and every
 *    byte until the next t3.5 silence, is discarded;
 *  - a frame longer than URB_RS485_MAX_FRAME (36) bytes is discarded (a babbling sender);
 *  - after start-up the receiver waits for a t3.5 silence before it takes a frame.
 * URB keeps 3.5 and 1.5 characters at every rate; Modbus fixes them at 1750 and 750 us above
 * 19200 Bd, which at 1 kHz would leave no room for a transaction (the README explains).
 * The frame check is link_check (CRC-8 up to 14 covered bytes, else CRC-16, little-endian): the
 * receiver runs both CRCs two bytes behind the line and picks the tier when the frame ends, so it
 * needs no frame buffer and does O(1) work per byte.
 */
#ifndef URB_RS485_H
#define URB_RS485_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_rs485_wire.h" /* the schema's constants: broadcast address, longest frame */

#ifdef __cplusplus
extern "C" {
#endif

/* ===== Timing ================================================================================ */

#define URB_RS485_CHAR_BITS 10u /**< 8N1: start, 8 data, stop */

/** Line timing of one bus; urb_rs485_timing() computes it from the baud rate. */
typedef struct {
    uint32_t baud;          /**< bits per second, 115200 .. 1000000 */
    uint16_t char_us;       /**< one character, rounded up */
    uint16_t t15_us;        /**< longest silence inside a frame: 1.5 characters, rounded up */
    uint16_t t35_us;        /**< silence that ends a frame: 3.5 characters, rounded up */
    uint16_t turnaround_us; /**< a node's answer starts at most this long after t3.5 of silence
                                 (its interrupt, its driver enable); the bridge allows it */
} urb_rs485_timing_t;

/** Fills *t for `baud` (0 is taken as 115200): 87/131/304 us at 115200 Bd, 10/15/35 us at 1 Mb/s;
 *  turnaround: 4 characters plus 50 us for the node's interrupt. Divides: call it at set-up. */
void urb_rs485_timing(urb_rs485_timing_t *t, uint32_t baud);

/* ===== Receiver (one per end: the bridge's sees its own echo too) ========================== */

/** Frame-level events of urb_rs485_rx_byte / urb_rs485_rx_poll (a bit mask). */
#define URB_RS485_EV_END 0x01u     /**< a frame ended (silence t3.5): its summary is in rx->last */
#define URB_RS485_EV_START 0x02u   /**< this byte starts a frame (it is byte 0) */
#define URB_RS485_EV_BYTE 0x04u    /**< this byte belongs to the frame in progress (byte rx->n - 1) */
#define URB_RS485_EV_BROKEN 0x08u  /**< the frame in progress broke (a silence over t1.5, too long) */

/** Summary of a frame that ended. */
typedef struct {
    uint8_t n;         /**< bytes */
    uint8_t head[2];   /**< its first two bytes (address, then select / counter / data) */
    bool check_ok;     /**< its last byte(s) are the link_check of the rest (tier by length) */
    uint32_t t_first;  /**< time stamp of its first byte */
    uint32_t t_last;   /**< time stamp of its last byte */
} urb_rs485_frame_t;

/** Receiver state; caller-owned; members are private. */
typedef struct {
    urb_rs485_timing_t tm;
    uint32_t t_last;   /* time stamp of the last byte (or of start-up) */
    uint32_t t_first;
    uint16_t crc16;    /* CRC-16 tier over the frame's bytes but the last two */
    uint8_t crc8;      /* CRC-8 tier over the same */
    uint8_t hold[2];   /* the last two bytes (hold[1] the latest) */
    uint8_t head[2];
    uint8_t n;         /* bytes of the frame in progress */
    uint8_t state;     /* SILENT (a byte starts a frame), FRAME, BROKEN (discarding until t3.5) */
    urb_rs485_frame_t last; /* the frame that ended last */
    uint32_t broken;   /* frames discarded: a silence over t1.5 inside */
    uint32_t too_long; /* frames discarded: longer than URB_RS485_MAX_FRAME */
} urb_rs485_rx_t;

/** Starts a receiver at time `now` with timing *t (copied): it takes no frame before a silence of
 *  t3.5 from `now`. */
void urb_rs485_rx_init(urb_rs485_rx_t *rx, const urb_rs485_timing_t *t, uint32_t now);

/** One received byte with its time stamp (stamps never decrease). Returns URB_RS485_EV_* bits: END
 *  first when the silence before it ended the previous frame (read rx->last before the next
 *  call), then START or BYTE, or BROKEN (also when the frame was already being discarded: then
 *  no other bit). O(1). */
uint8_t urb_rs485_rx_byte(urb_rs485_rx_t *rx, uint8_t byte, uint32_t t);

/** The line has been silent until `now`: returns URB_RS485_EV_END when that ends the frame in
 *  progress (summary in rx->last), else 0. Without a byte, the receiver knows the line was silent
 *  only up to one character before `now` (a character may be on its way), so a frame ends when
 *  now - (its last byte's time stamp) reaches t3.5 + one character. O(1). */
uint8_t urb_rs485_rx_poll(urb_rs485_rx_t *rx, uint32_t now);

/** True when the line has certainly been silent for t3.5 at `now` (a frame may start): t3.5 + one
 *  character since the last byte's time stamp. O(1). */
bool urb_rs485_rx_silent(const urb_rs485_rx_t *rx, uint32_t now);

/** The time at which a poll ends the frame in progress: the last byte's time stamp + one character
 *  + t3.5. */
uint32_t urb_rs485_rx_deadline(const urb_rs485_rx_t *rx);

/** Bytes of the frame in progress (0 when none). */
uint8_t urb_rs485_rx_count(const urb_rs485_rx_t *rx);

/** Check bytes of a frame of `n` bytes (1: CRC-8, 2: CRC-16), or 0 when no frame has n bytes
 *  (n < 2, n == 16: 15 covered bytes need CRC-16, 14 take CRC-8). O(1). */
uint8_t urb_rs485_check_len(uint8_t n);

/* ===== The transceiver, as both ends see it ================================================== */

/** A half-duplex RS485 transceiver on a UART, filled in by a port. The port reports back through
 *  its owner's entry points: each received byte with its time stamp, each transmit slot. */
typedef struct {
    void *ctx; /**< passed to every function */
    /** Enables the driver and starts sending: the UART's transmit interrupt then pulls bytes from
     *  the owner until it has none, and the driver is released after the last stop bit (the
     *  turnaround; hardware driver-enable does it without software). */
    void (*tx_start)(void *ctx);
    /** Stops sending at once and releases the driver (a collision). */
    void (*tx_abort)(void *ctx);
    /** Optional: asks for a call of the owner's poll at time `at_us` (the end of a silence);
     *  NULL when the owner is polled often enough anyway (the bridge's main loop). */
    void (*wake_at)(void *ctx, uint32_t at_us);
    /** Optional (NULL: one context): masks (true) / unmasks the UART interrupt. */
    void (*lock)(void *ctx, bool locked);
} urb_rs485_hal_t;

#ifdef __cplusplus
}
#endif

#endif /* URB_RS485_H */
