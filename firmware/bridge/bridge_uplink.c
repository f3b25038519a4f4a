/*
 * URB bridge uplinks: the RS232 byte stream and USB batches in, responses out.
 *
 * Both uplinks feed the same admission (bridge.c) through one frame assembler each. RS232 has no
 * delimiter (spec/schema/README.md, "RS232 resynchronisation"): a frame's length follows from its
 * header; an idle gap longer than two byte times drops a partial frame; a frame that fails its
 * check loses its first byte and the assembler hunts again from the next one. A USB transfer is
 * parsed the same way, its end acting as the idle gap.
 *
 * The UART interrupt only timestamps bytes into a ring (O(1)); parsing happens in poll().
 */
#include "bridge_internal.h"

#include "urb_core.h"
#include "urb_runtime.h"

#define NOT_A_FRAME 0xFFu /* candidate_len(): no frame can start with these bytes */

void urbb_uplink_init(urb_bridge_t *b)
{
    b->rx_head = 0u;
    b->rx_tail = 0u;
    b->rx_overrun = 0u;
    b->rx_last_us = 0u;
    b->rx_started = false;
    /* computed once: the interrupt must not divide (no divide instruction on Cortex-M0+) */
    b->rx_gap_us = (10000000u + b->cfg.baud - 1u) / b->cfg.baud + b->cfg.idle_gap_us;
    b->tx_head = 0u;
    b->tx_tail = 0u;
    b->rs232.len = 0u;
    b->usb.len = 0u;
    b->usb_cur = 0u;
    b->usb_prev_ready = false;
    b->usb_last_frame = 0u;
    /* loop bound: 2 buffers */
    for (uint8_t i = 0u; i < 2u; i++) {
        b->usb_len[i] = (uint16_t)URB_USB_BATCH_HEADER_MAX_SIZE;
        b->usb_count[i] = 0u;
        b->usb_frame[i] = 0u;
    }
}

/* ===== Frame assembly and hunting ============================================================= */

/* Length of the request frame that would start at buf[0], from its header: 0 when more bytes are
 * needed to tell, NOT_A_FRAME when no request starts like this (a write announcing > 32 bytes). */
static uint8_t candidate_len(const uint8_t *buf, uint8_t n)
{
    if (n == 0u) {
        return 0u;
    }
    if ((buf[0] & 1u) != 0u) {
        return (uint8_t)URB_UPLINK_READ_REQUEST_MAX_SIZE; /* UplinkReadRequest: always 4 bytes */
    }
    if (n < 3u) {
        return 0u;
    }
    uint8_t const len = buf[2];
    if (len > URB_MAX_MAILBOX_SIZE) {
        return NOT_A_FRAME;
    }
    return (uint8_t)(3u + len + urb_link_check_size(3u + (size_t)len));
}

static void discard(urb_bridge_parser_t *p, uint8_t k)
{
    if (k >= p->len) {
        p->len = 0u;
        return;
    }
    uint8_t const rest = (uint8_t)(p->len - k);
    /* loop bound: URB_BRIDGE_FRAME_MAX bytes */
    for (uint8_t i = 0u; i < rest; i++) {
        p->buf[i] = p->buf[i + k];
    }
    p->len = rest;
}

/* Examine every complete candidate in the buffer. Each round removes at least one byte (a frame,
 * or one byte while hunting) or stops, so at most URB_BRIDGE_FRAME_MAX rounds. */
static void hunt(urb_bridge_t *b, urb_bridge_parser_t *p, uint8_t uplink)
{
    /* loop bound: URB_BRIDGE_FRAME_MAX rounds (one byte or more removed per round) */
    for (uint8_t round = 0u; (round < URB_BRIDGE_FRAME_MAX) && (p->len > 0u); round++) {
        uint8_t const need = candidate_len(p->buf, p->len);
        if ((need == 0u) || ((need != NOT_A_FRAME) && (need > p->len))) {
            return; /* wait for more bytes */
        }
        if ((need != NOT_A_FRAME) && urbb_frame(b, uplink, p->buf, need)) {
            discard(p, need);
            continue;
        }
        /* Check failed (or impossible header): the frame did not start here. */
        b->stats.hunt_discards++;
#ifdef URB_MUTANT_NO_HUNT
        p->len = 0u; /* mutant: drops the whole candidate, and any frame that started inside it */
#else
        discard(p, 1u);
#endif
    }
}

static void parser_push(urb_bridge_t *b, urb_bridge_parser_t *p, uint8_t byte, uint8_t uplink)
{
    if (p->len >= URB_BRIDGE_FRAME_MAX) {
        /* cannot happen (hunt() consumes every complete candidate), but never overflow */
        b->stats.hunt_discards++;
        discard(p, 1u);
    }
    p->buf[p->len] = byte;
    p->len++;
    hunt(b, p, uplink);
}

/* An idle gap (or the end of a USB transfer): no byte will complete the candidate in progress, so
 * it is not a frame. Frames that arrived intact behind it must not be lost with it: drop the
 * candidate's first byte and hunt on through the rest, complete candidates first. */
static void parser_flush(urb_bridge_t *b, urb_bridge_parser_t *p, uint8_t uplink)
{
    bool dropped = false;
    /* loop bound: URB_BRIDGE_FRAME_MAX rounds (one byte or more removed per round) */
    for (uint8_t round = 0u; (round < URB_BRIDGE_FRAME_MAX) && (p->len > 0u); round++) {
        uint8_t const need = candidate_len(p->buf, p->len);
        if ((need == 0u) || (need == NOT_A_FRAME) || (need > p->len)) {
            dropped = true; /* incomplete: can never complete now */
            discard(p, 1u);
        } else if (urbb_frame(b, uplink, p->buf, need)) {
            discard(p, need);
        } else {
            b->stats.hunt_discards++;
            discard(p, 1u);
        }
    }
    if (dropped) {
        b->stats.gap_drops++;
    }
}

/* ===== RS232 ================================================================================== */

void urb_bridge_uart_rx(urb_bridge_t *b, uint8_t byte, uint32_t t_us)
{
    uint8_t const head = b->rx_head;
    uint16_t flag = 0u;
    /* Timestamps mark each byte's end, so back-to-back bytes are one byte time apart: the line
     * was idle for (delta - one byte time). More than idle_gap_us of idle ends a partial frame. */
#ifndef URB_MUTANT_NO_GAP
    if (b->rx_started && ((uint32_t)(t_us - b->rx_last_us) > b->rx_gap_us)) {
        flag = (uint16_t)URB_BRIDGE_RX_GAP;
    }
#endif
    b->rx_started = true;
    b->rx_last_us = t_us;
    b->stats.rx_bytes++;
    if ((uint8_t)(head - b->rx_tail) >= URB_BRIDGE_RX_RING) {
        b->rx_overrun = 1u; /* the frame in progress is broken: drop it at the next byte */
        b->stats.rx_overruns++;
        return;
    }
    if (b->rx_overrun != 0u) {
        flag = (uint16_t)URB_BRIDGE_RX_GAP;
        b->rx_overrun = 0u;
    }
    b->rx_ring[head & (URB_BRIDGE_RX_RING - 1u)] = (uint16_t)(byte | flag);
    b->rx_head = (uint8_t)(head + 1u); /* publish after the byte is stored */
}

void urbb_uart_drain(urb_bridge_t *b, uint32_t now)
{
    /* loop bound: URB_BRIDGE_RX_RING bytes (the ring holds no more; later ones wait for the next poll) */
    for (uint8_t i = 0u; i < URB_BRIDGE_RX_RING; i++) {
        uint8_t const tail = b->rx_tail;
        if (tail == b->rx_head) {
            break;
        }
        URB_BARRIER(); /* read the head before the byte the interrupt stored */
        uint16_t const v = b->rx_ring[tail & (URB_BRIDGE_RX_RING - 1u)];
        b->rx_tail = (uint8_t)(tail + 1u);
        if ((v & URB_BRIDGE_RX_GAP) != 0u) {
            parser_flush(b, &b->rs232, URBB_UPLINK_RS232);
        }
        parser_push(b, &b->rs232, (uint8_t)(v & 0xFFu), URBB_UPLINK_RS232);
    }
#ifndef URB_MUTANT_NO_GAP
    /* The line has been idle long enough: a partial frame will not complete, do not wait for the
     * next byte to say so (frames behind it would wait too). rx_last_us is one aligned word. */
    if ((b->rs232.len > 0u) && (b->rx_head == b->rx_tail) && ((uint32_t)(now - b->rx_last_us) > b->rx_gap_us)) {
        parser_flush(b, &b->rs232, URBB_UPLINK_RS232);
    }
#else
    (void)now;
#endif
}

bool urb_bridge_uart_tx_pop(urb_bridge_t *b, uint8_t *byte)
{
    uint8_t const tail = b->tx_tail;
    if (tail == b->tx_head) {
        return false;
    }
    *byte = b->tx_ring[tail & (URB_BRIDGE_TX_RING - 1u)];
    b->tx_tail = (uint8_t)(tail + 1u);
    return true;
}

/* ===== USB ==================================================================================== */

/* UsbUplink.tla: Tick. The batch filled during the frame that ends becomes the one the next IN
 * transfer reads (write n and read n-1 share a frame: two buffers). If the host has not read the
 * previous batch yet, keep filling the current one instead of overwriting it: nothing is lost. An
 * unread previous batch without responses holds nothing to lose (the model's txPrev is empty):
 * it is replaced, so a host that skips the IN of an idle frame (the paper's Fig. 9 driver reads
 * only after a write) does not get its next responses a frame late. */
void urb_bridge_usb_sof(urb_bridge_t *b)
{
    uint8_t const next = (uint8_t)(b->usb_cur ^ 1u);
#ifdef URB_MUTANT_USB_KEEP_EMPTY
    bool const keep = b->usb_prev_ready; /* mutant: an unread empty batch holds the swap back */
#else
    bool const keep = b->usb_prev_ready && (b->usb_count[next] != 0u);
#endif
    if (keep) {
        b->stats.usb_late_reads++;
#ifndef URB_MUTANT_USB_OVERWRITE
        return;
#endif
    }
    b->usb_prev_ready = true;
    b->usb_cur = next;
    b->usb_len[next] = (uint16_t)URB_USB_BATCH_HEADER_MAX_SIZE;
    b->usb_count[next] = 0u;
    b->usb_frame[next] = b->usb_last_frame;
}

/* UsbUplink.tla: UsbWrite (the batch arrives) and BridgeProcess (its requests are admitted in
 * order; serving them is Bridge.tla's business, shared with RS232). */
bool urb_bridge_usb_out(urb_bridge_t *b, const uint8_t *data, size_t len)
{
    urb_usb_batch_header_t h;
    if ((data == NULL) || (len < URB_USB_BATCH_HEADER_MAX_SIZE) || (len > URB_BRIDGE_USB_BUF) ||
        (urb_usb_batch_header_decode(&h, data, URB_USB_BATCH_HEADER_MAX_SIZE) < 0)) {
        b->stats.usb_bad_batches++;
        return false;
    }
    b->stats.usb_batches++;
    b->usb_last_frame = h.frame;
    b->usb_frame[b->usb_cur] = h.frame; /* the response batch echoes its request batch */
    parser_flush(b, &b->usb, URBB_UPLINK_USB);
    /* loop bound: URB_BRIDGE_USB_BUF bytes */
    for (size_t i = URB_USB_BATCH_HEADER_MAX_SIZE; i < len; i++) {
        parser_push(b, &b->usb, data[i], URBB_UPLINK_USB);
    }
    parser_flush(b, &b->usb, URBB_UPLINK_USB); /* a frame never spans two transfers */
    return true;
}

/* UsbUplink.tla: UsbRead. The previous frame's batch, once. */
size_t urb_bridge_usb_in(urb_bridge_t *b, uint8_t *buf, size_t cap)
{
    if (!b->usb_prev_ready) {
        return 0u;
    }
    uint8_t const prev = (uint8_t)(b->usb_cur ^ 1u);
    uint16_t const n = b->usb_len[prev];
    if ((buf == NULL) || (cap < n)) {
        return 0u;
    }
    urb_usb_batch_header_t h;
    h.frame = b->usb_frame[prev];
    h.count = b->usb_count[prev];
    (void)urb_usb_batch_header_encode(&h, b->usb_buf[prev], URB_USB_BATCH_HEADER_MAX_SIZE);
    /* loop bound: URB_BRIDGE_USB_BUF bytes */
    for (uint16_t i = 0u; i < n; i++) {
        buf[i] = b->usb_buf[prev][i];
    }
    b->usb_prev_ready = false;
    return n;
}

/* ===== Responses out ========================================================================== */

bool urbb_uplink_send(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    if (uplink == URBB_UPLINK_USB) {
        uint8_t const c = b->usb_cur;
        if (((size_t)b->usb_len[c] + len > URB_BRIDGE_USB_BUF) || (b->usb_count[c] >= 128u)) {
            return false; /* batch full: the response waits for the next frame (UsbUplink NothingLost) */
        }
        /* loop bound: URB_UPLINK_RESPONSE_MAX_SIZE bytes */
        for (uint8_t i = 0u; i < len; i++) {
            b->usb_buf[c][b->usb_len[c] + i] = frame[i];
        }
        b->usb_len[c] = (uint16_t)(b->usb_len[c] + len);
        b->usb_count[c]++;
        return true;
    }
    uint8_t const head = b->tx_head;
    if ((uint8_t)(URB_BRIDGE_TX_RING - (uint8_t)(head - b->tx_tail)) < len) {
        return false; /* the UART is behind: keep the order, try at the next poll */
    }
    /* loop bound: URB_UPLINK_RESPONSE_MAX_SIZE bytes */
    for (uint8_t i = 0u; i < len; i++) {
        b->tx_ring[(uint8_t)(head + i) & (URB_BRIDGE_TX_RING - 1u)] = frame[i];
    }
    URB_BARRIER(); /* the bytes are stored before the interrupt can see the new head */
    b->tx_head = (uint8_t)(head + len);
    b->hal->uart_tx_kick(b->hal->ctx);
    return true;
}
