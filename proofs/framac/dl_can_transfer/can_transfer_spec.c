/*
 * dl_can_transfer unit: the CAN transfer layer of firmware/downlink/can/urb_can_transfer.c, its
 * loop-free functions: identifiers and sessions (no run-time error), frame bit times and frames per transfer, the segmenter's start
 * (urb_can_tx_init: the first frame's start bit, toggle 1 and transfer id) and end test, and the
 * reassembler's reset and accessors.
 *
 * As in dl_rs485_frame, the contracts are declared here and the firmware file is included after
 * them; Frama-C merges them with the definitions and WP proves them on the bodies (nothing is an
 * assumption; the firmware file carries no annotation, so its bytes, which the BMC proofs
 * fw_can_transfer, fw_can_master and fw_can_slave also read, stay the same).
 *
 * Not in this unit: the functions with a loop (urb_can_tx_next, urb_can_rx_frame, urb_can_crc,
 * urb_can_transfer_bits_max). WP needs a loop invariant and loop assigns written on the loop
 * itself, inside urb_can_transfer.c, and ACSL offers no way to attach one from another file
 * (-ulevel leaves the loop after the unrolled copies, so it does not help): see the README,
 * "Downlink WP units". Their bounds and the toggle/transfer-id rules are proved by the BMC proof
 * proofs/bmc/fw_can_transfer meanwhile.
 *
 * urb_can_tx_ok is the segmenter's invariant that urb_can_tx_next would need: at most 32 payload
 * bytes readable at the payload pointer, the total of payload and CRC bytes by the transfer's
 * size (the CRC only on a multi-frame transfer), and the position within it.
 */
#include "urb_can.h"

/*@ predicate urb_can_tx_ok(urb_can_tx_t *tx) =
      \valid(tx) && tx->len <= URB_CAN_MAX_PAYLOAD &&
      tx->total == (tx->len <= URB_CAN_CHUNK ? tx->len : tx->len + 2) &&
      tx->pos <= tx->total &&
      \valid_read(tx->payload + (0 .. tx->len - 1));
*/

/* urb_can_id and urb_can_session: no run-time error and no write (assigns); their field layout by
   division and remainder (id_range, id_mailbox, ..., session_read) did not prove: z3 fails and cvc4
   answers unknown on every bitwise goal (| and << of masked fields), as in gen_runtime's note on
   urb_get_bits. tests/firmware/can/test_can.c checks the layout for every argument against the
   generated codec urb_can_id_encode (which gen_downlinks proves). */
/*@ assigns \nothing; */
uint16_t urb_can_id(uint8_t address, uint8_t mailbox, bool read, uint8_t direction);

/*@ assigns \nothing; */
uint8_t urb_can_session(uint8_t mailbox, bool read);

/*@ assigns \nothing;
    ensures stuffed: \let s = (len > 8 ? 8 : len); \let g = (extended ? 54 : 34);
              \result == g + 8 * s + 13 + (g + 8 * s - 1) / 4; */
uint16_t urb_can_frame_bits_max(uint8_t len, bool extended);

/*@ assigns \nothing;
    ensures unstuffed: \let s = (len > 8 ? 8 : len); \result == (extended ? 67 : 47) + 8 * s; */
uint16_t urb_can_frame_bits_min(uint8_t len, bool extended);

/*@ assigns \nothing;
    ensures single: len <= URB_CAN_CHUNK ==> \result == 1;
    ensures multi: URB_CAN_CHUNK < len <= URB_CAN_MAX_PAYLOAD ==> \result == (len + 2 + 6) / 7;
    ensures at_most: 1 <= \result <= URB_CAN_MAX_FRAMES; */
uint8_t urb_can_frames(uint8_t len);

/*@ requires \valid(tx);
    requires \valid_read(payload + (0 .. (len > URB_CAN_MAX_PAYLOAD ? URB_CAN_MAX_PAYLOAD : len) - 1));
    assigns *tx;
    ensures init_ok: urb_can_tx_ok(tx);
    ensures cut: tx->len == (len > URB_CAN_MAX_PAYLOAD ? URB_CAN_MAX_PAYLOAD : len) && tx->pos == 0;
    ensures first_tail: tx->tail == (URB_CAN_TAIL_START | URB_CAN_TAIL_TOGGLE | (tid & URB_CAN_TAIL_TID));
    ensures crc_init: tx->crc == 0xFFFF; */
void urb_can_tx_init(urb_can_tx_t *tx, const uint8_t *payload, uint8_t len, uint8_t tid);

/*@ requires \valid_read(tx);
    assigns \nothing;
    ensures \result <==> tx->pos >= tx->total && (tx->tail & URB_CAN_TAIL_START) == 0; */
bool urb_can_tx_done(const urb_can_tx_t *tx);

/*@ requires \valid(rx);
    assigns *rx;
    ensures idle: rx->active == 0 && rx->count == 0 && rx->toggle == 0 && rx->crc == 0xFFFF; */
void urb_can_rx_reset(urb_can_rx_t *rx);

/*@ requires \valid_read(rx);
    assigns \nothing;
    ensures single_len: rx->single != 0 ==> \result == rx->count;
    ensures crc_removed: rx->single == 0 && rx->count >= 2 ==> \result == rx->count - 2;
    ensures within: \result <= rx->count; */
uint8_t urb_can_rx_len(const urb_can_rx_t *rx);

/*@ requires \valid_read(rx);
    assigns \nothing;
    ensures \result == rx->tid; */
uint8_t urb_can_rx_tid(const urb_can_rx_t *rx);

/*@ requires \valid_read(rx);
    assigns \nothing;
    ensures \result <==> rx->active != 0; */
bool urb_can_rx_active(const urb_can_rx_t *rx);

#include "urb_can_transfer.c"
