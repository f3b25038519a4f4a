/*
 * CAN transfer layer (urb_can.h): identifiers, bus timing, CRC, segmentation, reassembly.
 * The segmenter and the reassembler are spec/tla/CanTransfer.tla's SendStart/SendFrame and
 * Receive; pycyphal's serializer is the independent oracle of the frames (tests/firmware/can).
 *
 * Seeded bugs for the mutant checks: URB_MUTANT_CAN_NO_TOGGLE_CHECK (a repeated frame is taken
 * again), URB_MUTANT_CAN_CRC_LITTLE_ENDIAN (the CRC is appended least significant byte first),
 * URB_MUTANT_CAN_START_TOGGLE_0 (the first frame carries toggle 0).
 */
#include "urb_can.h"

#include "urb_runtime.h"

#define TID_BITS 0x1Fu
#define CRC_BYTES 2u
#define CRC_INIT 0xFFFFu

uint16_t urb_can_id(uint8_t address, uint8_t mailbox, bool read, uint8_t direction)
{
    return (uint16_t)(((unsigned)mailbox & 7u) | (read ? 8u : 0u) | (((unsigned)address & 0x3Fu) << 4) |
                      (((unsigned)direction & 1u) << 10));
}

uint8_t urb_can_session(uint8_t mailbox, bool read)
{
    return (uint8_t)((mailbox & 7u) | (read ? 8u : 0u));
}

/* ===== Timing ================================================================================= */

uint16_t urb_can_frame_bits_max(uint8_t len, bool extended)
{
    unsigned const s = (len > URB_CAN_MTU) ? (unsigned)URB_CAN_MTU : (unsigned)len;
    unsigned const g = extended ? 54u : 34u; /* bits exposed to stuffing before the data field, less the data */
    /* g + 8s + 13 (CRC delimiter, ACK, EOF, IFS) + stuff bits: one per 4 bits after the first */
    return (uint16_t)(g + 8u * s + 13u + (g + 8u * s - 1u) / 4u);
}

uint16_t urb_can_frame_bits_min(uint8_t len, bool extended)
{
    unsigned const s = (len > URB_CAN_MTU) ? (unsigned)URB_CAN_MTU : (unsigned)len;
    return (uint16_t)((extended ? 67u : 47u) + 8u * s);
}

uint8_t urb_can_frames(uint8_t len)
{
    if (len <= URB_CAN_CHUNK) {
        return 1u;
    }
    unsigned const n = (len > URB_CAN_MAX_PAYLOAD) ? URB_CAN_MAX_PAYLOAD : (unsigned)len;
    return (uint8_t)((n + CRC_BYTES + URB_CAN_CHUNK - 1u) / URB_CAN_CHUNK);
}

uint16_t urb_can_transfer_bits_max(uint8_t len)
{
    unsigned const n = (len > URB_CAN_MAX_PAYLOAD) ? URB_CAN_MAX_PAYLOAD : (unsigned)len;
    unsigned left = (n <= URB_CAN_CHUNK) ? n : n + CRC_BYTES;
    unsigned bits = 0u;
    /* loop bound: URB_CAN_MAX_FRAMES frames */
    do {
        unsigned const chunk = (left > URB_CAN_CHUNK) ? URB_CAN_CHUNK : left;
        bits += urb_can_frame_bits_max((uint8_t)(chunk + 1u), false);
        left -= chunk;
    } while (left > 0u);
    return (uint16_t)bits;
}

/* ===== CRC ==================================================================================== */

uint16_t urb_can_crc(uint16_t crc, const uint8_t *data, uint8_t len)
{
    /* loop bound: len <= 255 bytes (at most 7 per frame in the callers) */
    for (uint8_t i = 0u; i < len; i++) {
        crc = urb_crc16_link_check_byte(crc, data[i]);
    }
    return crc;
}

/* ===== Segmentation =========================================================================== */

void urb_can_tx_init(urb_can_tx_t *tx, const uint8_t *payload, uint8_t len, uint8_t tid)
{
    uint8_t const n = (len > URB_CAN_MAX_PAYLOAD) ? (uint8_t)URB_CAN_MAX_PAYLOAD : len;
    tx->payload = payload;
    tx->crc = CRC_INIT;
    tx->len = n;
    tx->pos = 0u;
    tx->total = (n <= URB_CAN_CHUNK) ? n : (uint8_t)(n + CRC_BYTES);
    /* CanTransfer.tla: SendStart, the first frame carries start and toggle 1 */
#if defined(URB_MUTANT_CAN_START_TOGGLE_0)
    tx->tail = (uint8_t)(URB_CAN_TAIL_START | (tid & TID_BITS));
#else
    tx->tail = (uint8_t)(URB_CAN_TAIL_START | URB_CAN_TAIL_TOGGLE | (tid & TID_BITS));
#endif
}

bool urb_can_tx_done(const urb_can_tx_t *tx)
{
    /* the start bit stays set until the first frame is taken, so an empty payload has one frame */
    return (tx->pos >= tx->total) && ((tx->tail & URB_CAN_TAIL_START) == 0u);
}

/* CanTransfer.tla: SendFrame. Payload bytes feed the CRC; the CRC bytes follow the payload, most
 * significant first, and may straddle two frames. */
uint8_t urb_can_tx_next(urb_can_tx_t *tx, uint8_t *data)
{
    if (urb_can_tx_done(tx)) {
        return 0u;
    }
    uint8_t n = 0u;
    /* loop bound: URB_CAN_CHUNK bytes per frame */
    while ((n < URB_CAN_CHUNK) && (tx->pos < tx->total)) {
        uint8_t const k = tx->pos;
        uint8_t b;
        if (k < tx->len) {
            b = tx->payload[k];
            tx->crc = urb_crc16_link_check_byte(tx->crc, b);
        } else {
#if defined(URB_MUTANT_CAN_CRC_LITTLE_ENDIAN)
            b = (uint8_t)((k == tx->len) ? (tx->crc & 0xFFu) : (tx->crc >> 8));
#else
            b = (uint8_t)((k == tx->len) ? (tx->crc >> 8) : (tx->crc & 0xFFu));
#endif
        }
        data[n] = b;
        n++;
        tx->pos = (uint8_t)(k + 1u);
    }
    uint8_t tail = tx->tail;
    if (tx->pos >= tx->total) {
        tail = (uint8_t)(tail | URB_CAN_TAIL_END);
    }
    data[n] = tail;
    /* the next frame: no start, the other toggle */
    tx->tail = (uint8_t)((tx->tail & (uint8_t)~URB_CAN_TAIL_START) ^ URB_CAN_TAIL_TOGGLE);
    return (uint8_t)(n + 1u);
}

/* ===== Reassembly ============================================================================= */

void urb_can_rx_reset(urb_can_rx_t *rx)
{
    rx->crc = CRC_INIT;
    rx->count = 0u;
    rx->tid = 0u;
    rx->toggle = 0u;
    rx->active = 0u;
    rx->single = 0u;
}

uint8_t urb_can_rx_len(const urb_can_rx_t *rx)
{
    if ((rx->single != 0u) || (rx->count < CRC_BYTES)) {
        return rx->count;
    }
    return (uint8_t)(rx->count - CRC_BYTES);
}

uint8_t urb_can_rx_tid(const urb_can_rx_t *rx)
{
    return rx->tid;
}

bool urb_can_rx_active(const urb_can_rx_t *rx)
{
    return rx->active != 0u;
}

/* CanTransfer.tla: SendFrame, the receiving side (CanTransfer.tla Receive). The checks come in the order of the model's guards: a start frame
 * that is not a repeat opens a transfer; everything else must continue the one in progress with
 * its transfer id and the toggle bit it expects. */
urb_can_rx_result_t urb_can_rx_frame(urb_can_rx_t *rx, const uint8_t *data, uint8_t len, uint8_t *out, uint8_t cap)
{
    if (len == 0u) {
        return URB_CAN_RX_EMPTY;
    }
    uint8_t const size = (len > URB_CAN_MTU) ? (uint8_t)URB_CAN_MTU : len;
    uint8_t const tail = data[size - 1u];
    uint8_t const tid = (uint8_t)(tail & TID_BITS);
    uint8_t const toggle = ((tail & URB_CAN_TAIL_TOGGLE) != 0u) ? 1u : 0u;
    bool const start = (tail & URB_CAN_TAIL_START) != 0u;
    bool const end = (tail & URB_CAN_TAIL_END) != 0u;
    if (start && (toggle == 0u)) {
        return URB_CAN_RX_BAD_START;
    }
    if (start && ((rx->active == 0u) || (tid != rx->tid))) {
        /* CanTransfer.tla Receive, a new transfer (one in progress is dropped) */
        rx->crc = CRC_INIT;
        rx->count = 0u;
        rx->tid = tid;
        rx->toggle = 1u;
        rx->active = 1u;
        rx->single = end ? 1u : 0u;
    } else {
        if (rx->active == 0u) {
            return URB_CAN_RX_NO_START;
        }
        if (tid != rx->tid) {
            return URB_CAN_RX_OTHER_TID;
        }
#if !defined(URB_MUTANT_CAN_NO_TOGGLE_CHECK)
        if (toggle != rx->toggle) {
            return URB_CAN_RX_TOGGLE; /* a repeated frame (or one lost between): not taken */
        }
#endif
    }
    uint8_t const n = (uint8_t)(size - 1u);
    /* loop bound: URB_CAN_CHUNK payload bytes per frame */
    for (uint8_t i = 0u; i < n; i++) {
        uint8_t const k = rx->count;
        if (k < cap) {
            out[k] = data[i];
        }
        rx->crc = urb_crc16_link_check_byte(rx->crc, data[i]);
        if (k < 0xFFu) {
            rx->count = (uint8_t)(k + 1u); /* saturates: any length past the largest is wrong anyway */
        }
    }
    rx->toggle = (uint8_t)(rx->toggle ^ 1u);
    if (!end) {
        return URB_CAN_RX_MORE;
    }
    rx->active = 0u;
    if (start) {
        return URB_CAN_RX_DONE; /* a single frame: CAN's own CRC-15 covers it */
    }
    return (rx->crc == 0u) ? URB_CAN_RX_DONE : URB_CAN_RX_CRC;
}
