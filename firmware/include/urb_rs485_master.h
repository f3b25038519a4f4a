/*
 * URB RS485 downlink, bridge side: the master that polls one node at a time on a half-duplex bus,
 * as a urb_downlink_t (urb_downlink.h), so the bridge core drives it exactly as the I2C one.
 *
 * The poll cycle (spec/schema/README.md, "RS485 downlink"; Rs485Poll.tla; node side:
 * urb_rs485_slave.h). The line must have been silent for t3.5 before the bridge sends; then:
 *  Write inbox m of node a:  Rs485Request(a, select m, data[length]); answer Rs485Response with the
 *      node's status (OK: stored; NODE_BUSY, CHECKSUM, SIZE_MISMATCH, BAD_REQUEST: not stored).
 *  Read outbox m of node a:  Rs485Request(a, select m | read); answer status OK and the outbox
 *      (OK when it holds `length` bytes, else SIZE_MISMATCH), or a refusal without data.
 *  Probe node a:  Rs485Request(a, select 0, no data); any well-formed answer = OK.
 *  SYNC:  Rs485Sync(counter) to address 0; nobody answers; OK once sent.
 *  Clear:  wait for t3.5 of silence: OK when it comes within the timeout, else BUS_STUCK.
 * The bridge hears its own frame (the receiver stays on while the driver sends). An echo byte
 * that differs from the byte sent is a collision: the bridge stops driving at once; when the
 * collision hit a byte before the last, the frame was cut and no node can take it: BUS_STUCK (not
 * executed) once the line is silent again, except when what the line carried is itself a
 * well-formed shorter frame (its check passes: about one cut in 256 on a CRC-8 frame), alone or
 * with the bytes the other talker added to it, which a node may have taken: TIMEOUT; the same
 * when the UART stalls for t3.5 inside the request (the line carried a shorter frame: the bridge
 * stops); a collision on the last byte leaves it to the node's check (the answer, or its
 * absence, decides). A request whose frame breaks on or after its last byte (a byte after a
 * silence over t1.5 before its t3.5 end, or a frame grown past 36 bytes by another talker's bytes)
 * reached no node (every receiver discards a broken frame): BUS_STUCK (not executed) once the
 * line is silent again (TIMEOUT if another talker's frame that passes its check ends first),
 * never the node's silence or answer. No answer started within t3.5 + the turnaround +
 * one character of the request's end -> NO_NODE (silence). An answer broken by a silence over
 * t1.5 -> TIMEOUT; one that fails its check, is too long or is not a well-formed Rs485Response
 * for this mailbox -> CHECKSUM. A line never silent for t3.5 before sending (a babbler) ->
 * BUS_STUCK after the timeout. Bytes heard while no answer is awaited are counted as babble.
 *
 * Concurrency: urb_rs485_master_rx() and urb_rs485_master_tx_next() are the UART interrupt; the
 * downlink's begin() and poll() the main loop, which masks the interrupt (hal->lock) around them.
 */
#ifndef URB_RS485_MASTER_H
#define URB_RS485_MASTER_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_downlink.h"
#include "urb_rs485.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Counters for diagnostics (urb_rs485_master_stats). */
typedef struct {
    uint32_t collisions; /**< echoes that differed from the byte sent, and bytes that joined or broke
                              the request's frame after its last byte */
    uint32_t silences;   /**< requests no node answered (NO_NODE) */
    uint32_t babble;     /**< bytes heard while no answer was awaited */
    uint32_t bad;        /**< answers that failed their check or were malformed (CHECKSUM) */
    uint32_t broken;     /**< answers broken by a silence inside (TIMEOUT) */
    uint32_t busy_line;  /**< requests not sent: the line was never silent (BUS_STUCK) */
} urb_rs485_master_stats_t;

/** State of one master; caller-owned; members are private. */
typedef struct {
    const urb_rs485_hal_t *hal;
    urb_rs485_rx_t rx;
    uint32_t timeout_us;
    uint8_t op, address, mailbox, length;
    uint8_t *data;
    uint8_t buf[URB_RS485_MAX_FRAME];   /* the request being sent */
    uint8_t ans[URB_RS485_MAX_FRAME];   /* the answer being received */
    uint8_t n_tx;        /* bytes of the request */
    volatile uint8_t pos;         /* bytes handed to the UART */
    volatile uint8_t echo;        /* echo bytes that matched */
    volatile uint8_t phase;
    volatile uint8_t result;
    bool cut;            /* no node can take the request's frame: a collision cut it before its last
                            byte (and its bytes pass no check), or it broke on or after its last byte */
    uint32_t t0;         /* begin() time */
    uint32_t t_sent;     /* time stamp of the request's last echo byte */
    urb_rs485_master_stats_t stats;
} urb_rs485_master_t;

/** The transaction timeout at `baud`: a 36-byte request, the turnaround, a 35-byte answer and two
 *  t3.5 silences, doubled, and never below 2000 us (2000 us at 1 Mb/s, 14 000 us at 115200 Bd).
 *  Divides: call it at set-up. */
uint32_t urb_rs485_master_timeout_us(uint32_t baud);

/** Initialises *m at time `now` on the transceiver *hal (kept by reference) at `baud`, with
 *  urb_rs485_master_timeout_us(baud). */
void urb_rs485_master_init(urb_rs485_master_t *m, const urb_rs485_hal_t *hal, uint32_t baud, uint32_t now);

/** Fills *dl so that the bridge drives this master (addresses 1..127, kind RS485; the bit rate is
 *  reported in kb/s, rounded down). */
void urb_rs485_master_downlink(urb_rs485_master_t *m, urb_downlink_t *dl);

/** Interrupt side: a byte was received (the echo of our own, or anyone else's) at time `t`.
 *  Rs485Poll.tla SendEnd, Rs485Poll.tla AnswerEnd. O(1). */
void urb_rs485_master_rx(urb_rs485_master_t *m, uint8_t byte, uint32_t t);

/** Interrupt side: the UART can take a byte; true and *byte set, or false when the frame is all
 *  sent (the port then releases the driver after the stop bit). O(1). */
bool urb_rs485_master_tx_next(urb_rs485_master_t *m, uint8_t *byte);

/** True while a transaction runs. */
bool urb_rs485_master_busy(const urb_rs485_master_t *m);

/** Copies the counters into *out. */
void urb_rs485_master_stats(const urb_rs485_master_t *m, urb_rs485_master_stats_t *out);

#ifdef __cplusplus
}
#endif

#endif /* URB_RS485_MASTER_H */
