/*
 * Private declarations shared by the bridge sources (not part of the public API).
 */
#ifndef URB_BRIDGE_INTERNAL_H
#define URB_BRIDGE_INTERNAL_H

#include "urb_bridge.h"

/* Keeps the compiler from moving plain loads/stores across this point. The interrupt side
 * publishes a result by writing data then a volatile phase; the main loop reads the phase and then
 * the data, and without the barrier the compiler may hoist those data loads above the phase load. */
#if defined(__GNUC__) || defined(__clang__)
#define URB_BARRIER() __asm__ __volatile__("" ::: "memory")
#else
#define URB_BARRIER() ((void)0)
#endif

#define URB_BRIDGE_PENDING 0xFFu  /* ring status: waiting for the downlink */
#define URB_BRIDGE_NO_SLOT 0xFFu  /* ring slot: admission error, no payload buffer */
#define URB_BRIDGE_RX_GAP 0x100u  /* rx ring flag: an idle gap (or an overrun) precedes this byte */

enum { URBB_UPLINK_RS232 = 0u, URBB_UPLINK_USB = 1u };
enum {
    URBB_ACT_NONE = 0u, URBB_ACT_REQUEST = 1u, URBB_ACT_SCAN = 2u, URBB_ACT_SYNC = 3u, URBB_ACT_PROBE = 4u,
    URBB_ACT_LEARN = 5u
};

/* ACSL for Frama-C: the response ring and the data-slot FIFO stay within their arrays and the
 * configured depth; the node table's indexes stay within it. The first says \valid_read:
 * slot_index and first_pending take a const bridge, and \valid is false on a const-qualified
 * location (Eva then finds their precondition invalid and stops the analysis of every caller);
 * the functions that write the bridge require \valid(b) next to it. */
/*@ predicate urbb_fifo_ok(urb_bridge_t *b) =
      \valid_read(b) && 1 <= b->cfg.fifo_depth <= URB_BRIDGE_FIFO_MAX &&
      b->ring_head < URB_BRIDGE_RING_MAX && b->ring_count <= URB_BRIDGE_RING_MAX &&
      b->slot_head < b->cfg.fifo_depth && b->slot_served <= b->slot_count <= b->cfg.fifo_depth;

    predicate urbb_nodes_ok(urb_bridge_t *b) =
      \forall integer a; 0 <= a < 128 ==> b->node_of[a] <= URB_BRIDGE_MAX_NODES;
*/

/* What urbb_frame writes, for the ACSL assigns clauses of it and of the parsers that call it
 * (Frama-C preprocesses annotations). */
#define URBB_FRAME_WRITES                                                                                     \
    b->ring[0 .. URB_BRIDGE_RING_MAX - 1], b->ring_count, b->slots[0 .. URB_BRIDGE_FIFO_MAX - 1], b->slot_count, \
        b->stats.frames, b->stats.window_overflow, b->stats.busy

/* bridge.c: a complete candidate frame of `len` bytes from `uplink`. Returns false when it fails
 * its check (the caller then discards one byte and hunts on), true when it was admitted (as a
 * request, or answered BAD_REQUEST when it passed its check but breaks a schema rule). The frame
 * may lie inside the bridge (the RS232 assembler's buffer): it is read before anything is written,
 * and only the response ring, the data slots and three counters are. */
/*@ requires \valid(b) && urbb_fifo_ok(b) && urbb_nodes_ok(b);
    requires 2 <= len && \valid_read(frame + (0 .. len - 1));
    assigns URBB_FRAME_WRITES;
    ensures urbb_fifo_ok(b) && urbb_nodes_ok(b); */
bool urbb_frame(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len);

/* bridge_uplink.c: the uplink side of poll(): parse the bytes the UART interrupt queued, with at
 * most URB_BRIDGE_HUNT_CHECKS frame checks and URB_BRIDGE_RX_PER_POLL bytes (the rest waits for the
 * next call). */
void urbb_uart_drain(urb_bridge_t *b, uint32_t now);

/* bridge_uplink.c: urbb_uart_drain with a budget of `checks` frame checks. It stops only where a
 * check is due and none is left, in a state the next call resumes from, so any split of the work
 * into calls admits the same frames in the same order (proofs/bmc/fw_bridge_rs232_parser). */
void urbb_uart_parse(urb_bridge_t *b, uint32_t now, uint8_t checks);

/* ACSL for Frama-C WP (proofs/framac/usb_batch/): each USB batch holds its header and at most
 * URB_BRIDGE_USB_BUF bytes and at most 128 responses, and usb_cur names one of the two batches.
 * usb_len, usb_count and usb_cur are written only by urbb_uplink_init (which establishes the
 * invariant), urb_bridge_usb_sof and urbb_uplink_send (which keep it); urb_bridge_usb_in reads a
 * batch under it. WP proves all four (urbb_uplink_send: its USB behavior, and on the UART path up
 * through the HAL's transmit kick, by the contract of uart_kick). */
/*@ predicate urbb_usb_ok(urb_bridge_t *b) =
      b->usb_cur <= 1 &&
      (\forall integer c; 0 <= c <= 1 ==>
         URB_USB_BATCH_HEADER_MAX_SIZE <= b->usb_len[c] <= URB_BRIDGE_USB_BUF && b->usb_count[c] <= 128);
*/

/* What urbb_uplink_send writes (and emit_entry), for their assigns clauses: a USB batch, or the
 * UART transmit ring, its head, and its tail (the HAL's kick may drain the ring: see uart_kick in
 * bridge_uplink.c). The two batches are named one by one: WP turns each into one contiguous range. */
#define URBB_SEND_WRITES                                                                                        \
    b->usb_buf[0][0 .. URB_BRIDGE_USB_BUF - 1], b->usb_buf[1][0 .. URB_BRIDGE_USB_BUF - 1], b->usb_len[0 .. 1], \
        b->usb_count[0 .. 1], b->tx_ring[0 .. URB_BRIDGE_TX_RING - 1], b->tx_head, b->tx_tail

/* bridge_uplink.c: queue one encoded response on `uplink`; false when it has no room now. The only
 * writer of a batch's length and count besides init and sof. The UART path ends in the HAL's
 * transmit kick, called through uart_kick (bridge_uplink.c), whose contract states the HAL rule of
 * urb_bridge_hal.h (the kick may drain the transmit ring and changes nothing else of the bridge):
 * a reviewed hypothesis, not proved (proofs/framac/README.md). With it WP proves what both paths
 * write and that both keep urbb_usb_ok. */
/*@ requires \valid(b) && urbb_usb_ok(b) && \valid_read(b->hal);
    requires \valid_read(frame + (0 .. len - 1)) && \separated(frame + (0 .. len - 1), b);
    assigns URBB_SEND_WRITES;
    ensures usb_ok: urbb_usb_ok(b);
    behavior usb:
      assumes uplink == URBB_UPLINK_USB;
      assigns b->usb_buf[b->usb_cur][0 .. URB_BRIDGE_USB_BUF - 1], b->usb_len[b->usb_cur], b->usb_count[b->usb_cur];
      ensures same_batch: b->usb_cur == \old(b->usb_cur);
      ensures queued: \result <==> (\old(b->usb_len[b->usb_cur]) + len <= URB_BRIDGE_USB_BUF &&
                                    \old(b->usb_count[b->usb_cur]) < 128);
      ensures appended: \result ==> b->usb_len[b->usb_cur] == \old(b->usb_len[b->usb_cur]) + len &&
        b->usb_count[b->usb_cur] == \old(b->usb_count[b->usb_cur]) + 1 &&
        (\forall integer k; 0 <= k < len ==> b->usb_buf[b->usb_cur][\old(b->usb_len[b->usb_cur]) + k] == frame[k]);
      ensures refused: !\result ==> b->usb_len[b->usb_cur] == \old(b->usb_len[b->usb_cur]) &&
        b->usb_count[b->usb_cur] == \old(b->usb_count[b->usb_cur]);
    behavior uart:
      assumes uplink != URBB_UPLINK_USB;
      assigns b->tx_ring[0 .. URB_BRIDGE_TX_RING - 1], b->tx_head, b->tx_tail;
      ensures same_batch_uart: b->usb_cur == \old(b->usb_cur);
    complete behaviors;
    disjoint behaviors; */
bool urbb_uplink_send(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len);

/* bridge_uplink.c: reset the uplink state at init. */
void urbb_uplink_init(urb_bridge_t *b);

#endif /* URB_BRIDGE_INTERNAL_H */
