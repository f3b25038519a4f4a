/*
 * dl_can_layout unit: what dl_can_transfer leaves open in firmware/downlink/can/urb_can_transfer.c.
 *
 * 1. The identifier layout, functionally (spec/schema/README.md, "CAN downlink"; urb_can.h): each
 *    argument of urb_can_id lands in its own field (mailbox bits 0..2, read bit 3, address bits
 *    4..9, response bit 10, nothing above bit 10), and the slave's decoding of a received
 *    identifier (urb_can_slave_rx: id >> 10, (id >> 4) & 0x3F, id & 15) gives back the direction,
 *    the address and the session: decode(encode(x)) == x for every x within the field widths (the
 *    arguments are masked to them). urb_can_session likewise. WP's bitwise strategies
 *    (-wp-auto wp:bitwised,...) prove these bit by bit; stated by division and remainder, or as a
 *    sum of the fields, they do not prove (z3 "unknown error", cvc4 unknown: see the README).
 *
 * 2. The four functions with a loop (urb_can_crc, urb_can_transfer_bits_max, urb_can_tx_next,
 *    urb_can_rx_frame): no run-time error, loop invariants, variants and loop assigns, and their
 *    key properties. The loop annotations cannot be written here (ACSL attaches them to the loop
 *    itself), and written into the firmware file they would change the bytes the BMC proofs read;
 *    so unit.json's "annotations" puts them, as comments only, into a copy of the firmware file
 *    that this file includes (tools/proofs_framac.py checks that the copy's code is the original's).
 *
 * As in dl_can_transfer, the contracts are declared before the firmware file is included; Frama-C
 * merges them with the definitions and WP proves them on the bodies. The callees keep the contracts
 * proved elsewhere: urb_crc16_link_check_byte's generated one (gen_runtime), and
 * urb_can_tx_done's and urb_can_frame_bits_max's restated here (proved here too).
 */
#include "urb_can.h"

/* The session of a mailbox (urb_can.h: inboxes 0..7, outboxes 8..15). */
/*@ logic integer urb_can_session_of(integer mailbox, integer read) = (mailbox & 7) | (read != 0 ? 8 : 0); */

/*@ predicate urb_can_tx_ok(urb_can_tx_t *tx) =
      \valid(tx) && tx->len <= URB_CAN_MAX_PAYLOAD &&
      tx->total == (tx->len <= URB_CAN_CHUNK ? tx->len : tx->len + 2) &&
      tx->pos <= tx->total &&
      \valid_read(tx->payload + (0 .. tx->len - 1));
*/

/* ===== Identifier and session ============================================================== */

/*@ assigns \nothing;
    ensures id_mailbox: (\result & 7) == (mailbox & 7);
    ensures id_read: (\result & 8) == (read ? 8 : 0);
    ensures id_address: ((\result >> 4) & 0x3F) == (address & 0x3F);
    ensures id_direction: (\result >> 10) == (direction & 1);
    ensures id_session: (\result & 15) == ((mailbox & 7) | (read ? 8 : 0));
    ensures id_high_clear: (\result & 0xF800) == 0;
    ensures id_high_shift: (\result >> 11) == 0;
*/
uint16_t urb_can_id(uint8_t address, uint8_t mailbox, bool read, uint8_t direction);

/*@ assigns \nothing;
    ensures session_value: \result == urb_can_session_of(mailbox, read);
    ensures session_mailbox: (\result & 7) == (mailbox & 7);
    ensures session_read: (\result & 8) == (read ? 8 : 0);
    ensures session_range: \result <= 15;
*/
uint8_t urb_can_session(uint8_t mailbox, bool read);

/* ===== Callees of the loops (the same contracts as in dl_can_transfer) ====================== */

/*@ assigns \nothing;
    ensures stuffed: \let s = (len > 8 ? 8 : len); \let g = (extended ? 54 : 34);
              \result == g + 8 * s + 13 + (g + 8 * s - 1) / 4; */
uint16_t urb_can_frame_bits_max(uint8_t len, bool extended);

/*@ requires \valid_read(tx);
    assigns \nothing;
    ensures \result <==> tx->pos >= tx->total && (tx->tail & URB_CAN_TAIL_START) == 0; */
bool urb_can_tx_done(const urb_can_tx_t *tx);

/* ===== The functions with a loop =========================================================== */

/*@ requires \valid_read(data + (0 .. len - 1));
    assigns \nothing; */
uint16_t urb_can_crc(uint16_t crc, const uint8_t *data, uint8_t len);

/* 11-bit identifiers: a frame of 8 bytes takes at most 55 + 80 = 135 bit times, of 1 byte 65. */
/*@ assigns \nothing;
    ensures at_least_one_frame: \result >= 65;
    ensures at_most_five_full_frames: \result <= 5 * 135; */
uint16_t urb_can_transfer_bits_max(uint8_t len);

/* The segmenter's step (CanTransfer.tla SendFrame). */
/*@ requires urb_can_tx_ok(tx);
    requires \valid(data + (0 .. 7));
    requires \separated(data + (0 .. 7), tx);
    assigns tx->crc, tx->pos, tx->tail, data[0 .. 7];
    ensures keeps_ok: urb_can_tx_ok(tx);
    ensures kept: tx->payload == \old(tx->payload) && tx->len == \old(tx->len) && tx->total == \old(tx->total);
    behavior done:
      assumes tx->pos >= tx->total && (tx->tail & URB_CAN_TAIL_START) == 0;
      ensures nothing_more: \result == 0 && tx->pos == \old(tx->pos) && tx->tail == \old(tx->tail);
    behavior frame:
      assumes tx->pos < tx->total || (tx->tail & URB_CAN_TAIL_START) != 0;
      ensures frame_length: 1 <= \result <= 8;
      ensures chunk: \result - 1 == (\old(tx->total) - \old(tx->pos) < 7 ? \old(tx->total) - \old(tx->pos) : 7);
      ensures advances: tx->pos == \old(tx->pos) + \result - 1;
      ensures tail_byte: data[\result - 1] ==
                (\old(tx->tail) | (tx->pos >= tx->total ? URB_CAN_TAIL_END : 0));
      ensures next_no_start: (tx->tail & URB_CAN_TAIL_START) == 0;
      ensures next_toggle: (tx->tail & URB_CAN_TAIL_TOGGLE) != (\old(tx->tail) & URB_CAN_TAIL_TOGGLE);
      ensures next_toggle_set: (\old(tx->tail) & URB_CAN_TAIL_TOGGLE) == 0 ==> (tx->tail & URB_CAN_TAIL_TOGGLE) == URB_CAN_TAIL_TOGGLE;
      ensures next_toggle_clear: (\old(tx->tail) & URB_CAN_TAIL_TOGGLE) != 0 ==> (tx->tail & URB_CAN_TAIL_TOGGLE) == 0;
      ensures next_tid: (tx->tail & URB_CAN_TAIL_TID) == (\old(tx->tail) & URB_CAN_TAIL_TID);
    complete behaviors;
    disjoint behaviors;
*/
uint8_t urb_can_tx_next(urb_can_tx_t *tx, uint8_t *data);

/* The reassembler's step (CanTransfer.tla Receive). */
/*@ requires \valid(rx);
    requires len <= 8 ==> \valid_read(data + (0 .. len - 1));
    requires len > 8 ==> \valid_read(data + (0 .. 7));
    requires \valid(out + (0 .. cap - 1));
    requires \separated(rx, out + (0 .. cap - 1));
    requires \separated(rx, data + (0 .. 7));
    assigns *rx, out[0 .. cap - 1];
    ensures result: URB_CAN_RX_MORE <= \result <= URB_CAN_RX_BAD_START;
    ensures empty: len == 0 <==> \result == URB_CAN_RX_EMPTY;
    ensures ignored_changes_nothing: \result >= URB_CAN_RX_EMPTY ==>
              rx->crc == \old(rx->crc) && rx->count == \old(rx->count) && rx->tid == \old(rx->tid) &&
              rx->toggle == \old(rx->toggle) && rx->active == \old(rx->active) && rx->single == \old(rx->single);
    ensures toggle_alternates: \result <= URB_CAN_RX_CRC ==>
              rx->toggle == ((\old(data[(len > 8 ? 8 : len) - 1]) & URB_CAN_TAIL_TOGGLE) != 0 ? 0 : 1);
    ensures accepted_tid: \result <= URB_CAN_RX_CRC ==>
              rx->tid == (\old(data[(len > 8 ? 8 : len) - 1]) & URB_CAN_TAIL_TID);
    ensures more_keeps_active: \result == URB_CAN_RX_MORE ==> rx->active != 0;
    ensures end_closes: (\result == URB_CAN_RX_DONE || \result == URB_CAN_RX_CRC) ==> rx->active == 0;
    ensures counted: \result <= URB_CAN_RX_CRC ==>
              \let size = (len > 8 ? 8 : len); \let tail = \old(data[size - 1]);
              \let fresh = (tail & URB_CAN_TAIL_START) != 0 &&
                           (\old(rx->active) == 0 || (tail & URB_CAN_TAIL_TID) != \old(rx->tid));
              \let base = (fresh ? 0 : \old(rx->count));
              rx->count == (base + size - 1 <= 255 ? base + size - 1 : 255);
*/
urb_can_rx_result_t urb_can_rx_frame(urb_can_rx_t *rx, const uint8_t *data, uint8_t len, uint8_t *out,
                                     uint8_t cap);

#include "urb_can_transfer.c"
