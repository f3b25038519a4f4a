/*
 * URB bridge uplinks: the RS232 byte stream and USB batches in, responses out.
 *
 * RS232 has no delimiter (spec/schema/README.md, "RS232 resynchronisation"): a frame's length
 * follows from its header; an idle gap longer than two byte times drops a partial frame; a frame
 * that fails its check loses its first byte and the assembler hunts again from the next one.
 * Hunting advances a start index (no bytes are shifted), and one poll makes at most
 * URB_BRIDGE_HUNT_CHECKS frame checks and takes at most URB_BRIDGE_RX_PER_POLL bytes from the ring:
 * a check costs up to ~2 800 cycles on a 48-MHz Cortex-M0+ and a line of garbage needs one per
 * byte, so without the caps one poll could check 36 failing candidates in a row (2.4 ms). What is
 * left waits in the assembler and the receive ring for the next poll: the frames found are the
 * same, in the same order, only later.
 *
 * USB delivers a transfer intact (its own CRC and retransmission): a batch header, then frames back
 * to back. They are admitted in order up to the first one that does not parse; the rest of that
 * transfer is dropped and counted, never hunted through (spec/schema/README.md, "USB batches").
 *
 * The UART interrupt only timestamps bytes into a ring (O(1)); parsing happens in poll().
 */
#include "bridge_internal.h"

#include "urb_core.h"
#include "urb_runtime.h"

#define NOT_A_FRAME 0xFFu /* candidate_len(): no frame can start with these bytes */

/* What urbb_uart_parse writes, for the assigns clauses of it and of urbb_uart_drain. */
#define URBB_PARSE_WRITES                                                                                  \
    b->rx_tail, b->rs232.buf[0 .. URB_BRIDGE_PARSE_BUF - 1], b->rs232.start, b->rs232.len, b->rs232.flushing, \
        b->stats.hunt_yields, b->stats.gap_drops, b->stats.hunt_discards, URBB_FRAME_WRITES

/* ACSL for Frama-C WP (proofs/framac/uplink_parsers/): the RS232 assembler holds at most one
 * candidate frame, inside its buffer. With it WP proves every index of the parsers in bounds and
 * urbb_frame's preconditions where they call it. */
/*@ predicate urbb_parser_ok(urb_bridge_parser_t *p) =
      p->len <= URB_BRIDGE_FRAME_MAX && p->start + p->len <= URB_BRIDGE_PARSE_BUF;

    predicate urbb_rs232_ok(urb_bridge_t *b) =
      \valid(b) && urbb_fifo_ok(b) && urbb_nodes_ok(b) && urbb_parser_ok(&b->rs232);
*/

/* The HAL's transmit kick (urbb_uplink_send). A function of its own for its contract, which states
 * the HAL rule of urb_bridge_hal.h: the kick may call urb_bridge_uart_tx_pop(), which writes the
 * transmit tail (and a byte of the HAL's own), and no other bridge function. A hypothesis for WP,
 * reviewed against every port (firmware/hal: each kick only enables the UART's transmit interrupt,
 * or counts), never proved: uart_kick is in no -wp-fct (proofs/framac/README.md). It speaks of the
 * bridge's memory only: the HAL's own state behind ctx is no part of it. GCC inlines it: the
 * machine code is that of the call in place. */
/*@ requires \valid_read(b) && \valid_read(b->hal);
    assigns b->tx_tail; */
static void uart_kick(urb_bridge_t *b)
{
    b->hal->uart_tx_kick(b->hal->ctx);
}

/*@ requires \valid(b) && b->cfg.baud != 0;
    ensures usb_ok: urbb_usb_ok(b);
    ensures usb_empty: !b->usb_prev_ready && b->usb_cur == 0 &&
      b->usb_len[0] == URB_USB_BATCH_HEADER_MAX_SIZE && b->usb_len[1] == URB_USB_BATCH_HEADER_MAX_SIZE &&
      b->usb_count[0] == 0 && b->usb_count[1] == 0; */
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
    b->rs232.start = 0u;
    b->rs232.len = 0u;
    b->rs232.flushing = false;
    b->usb_cur = 0u;
    b->usb_prev_ready = false;
    b->usb_last_frame = 0u;
    /* loop bound: 2 buffers */
    /*@ loop invariant 0 <= i <= 2;
        loop invariant \forall integer j; 0 <= j < i ==>
          b->usb_len[j] == URB_USB_BATCH_HEADER_MAX_SIZE && b->usb_count[j] == 0;
        loop assigns i, b->usb_len[0 .. 1], b->usb_count[0 .. 1], b->usb_frame[0 .. 1];
        loop variant 2 - i; */
    for (uint8_t i = 0u; i < 2u; i++) {
        b->usb_len[i] = (uint16_t)URB_USB_BATCH_HEADER_MAX_SIZE;
        b->usb_count[i] = 0u;
        b->usb_frame[i] = 0u;
    }
}

/* ===== Frame candidates ======================================================================= */

/* Length of the request frame that would start with `first` (its third byte `third` when n >= 3),
 * n bytes of it at hand: 0 when more bytes are needed to tell, NOT_A_FRAME when no request starts
 * like this (a write announcing > 32 bytes). The callers read the header bytes by array index: a
 * pointer at a variable offset into the bridge costs the bounded model checker the whole struct. */
/*@ assigns \nothing;
    ensures \result == 0 || \result == NOT_A_FRAME || 4 <= \result <= URB_BRIDGE_FRAME_MAX;
    ensures n == 0 ==> \result == 0; */
/* lobster-trace: urb.PKT_001 */
static uint8_t candidate_len(uint8_t first, uint8_t third, uint8_t n)
{
    if (n == 0u) {
        return 0u;
    }
    if ((first & 1u) != 0u) {
        return (uint8_t)URB_UPLINK_READ_REQUEST_MAX_SIZE; /* UplinkReadRequest: always 4 bytes */
    }
    if (n < 3u) {
        return 0u;
    }
    uint8_t const len = third;
    if (len > URB_MAX_MAILBOX_SIZE) {
        return NOT_A_FRAME;
    }
    return (uint8_t)(3u + len + urb_link_check_size(3u + (size_t)len));
}

/* ===== RS232 frame assembly and hunting ======================================================= */

/* The held bytes lose their first k (a frame, or one byte while hunting): the start moves on. */
/*@ requires \valid(p) && urbb_parser_ok(p) && k <= p->len;
    assigns p->start, p->len;
    ensures urbb_parser_ok(p) && p->len == \old(p->len) - k; */
static void consume(urb_bridge_parser_t *p, uint8_t k)
{
    p->start = (uint8_t)(p->start + k);
    p->len = (uint8_t)(p->len - k);
    if (p->len == 0u) {
        p->start = 0u; /* the next byte goes to the front: a stream of good frames never compacts */
    }
}

/* Appends one byte. Only an incomplete candidate (< 37 bytes) takes a byte, and the buffer has room
 * for 37 more behind it, so the held bytes move to the front at most once per 38 bytes received. */
/*@ requires urbb_rs232_ok(b) && p == &b->rs232;
    assigns p->buf[0 .. URB_BRIDGE_PARSE_BUF - 1], p->start, p->len, b->stats.hunt_discards;
    ensures urbb_parser_ok(p) && 1 <= p->len; */
static void push(urb_bridge_t *b, urb_bridge_parser_t *p, uint8_t byte)
{
    if (p->len >= URB_BRIDGE_FRAME_MAX) {
        /* cannot happen (hunt() leaves no complete candidate behind), but never overflow */
        b->stats.hunt_discards++;
        consume(p, 1u);
    }
    if ((uint8_t)(p->start + p->len) >= URB_BRIDGE_PARSE_BUF) {
        /* loop bound: URB_BRIDGE_FRAME_MAX bytes (the held candidate) */
        /*@ loop invariant 0 <= i <= p->len;
            loop assigns i, p->buf[0 .. URB_BRIDGE_FRAME_MAX - 1];
            loop variant p->len - i; */
        for (uint8_t i = 0u; i < p->len; i++) {
            p->buf[i] = p->buf[p->start + i];
        }
        p->start = 0u;
    }
    p->buf[p->start + p->len] = byte;
    p->len++;
}

/* Works through the held bytes. Every complete candidate is checked: a frame is admitted and
 * consumed; one that fails its check, or an impossible header, loses its first byte (hunting).
 * Hunting stops at an incomplete candidate, which waits for more bytes, unless the candidate has
 * `ended` (an idle gap follows it): then it is not a frame, and neither is any candidate that runs
 * past the held bytes, so the flush drops their first bytes one at a time and still finds the
 * complete frames behind them, until nothing is held. Returns false when a check is due and
 * *checks is spent: the caller ends the poll there and the next poll resumes at exactly this point
 * (p->flushing remembers a flush in progress). */
/*@ requires urbb_rs232_ok(b) && p == &b->rs232 && \valid(checks) && \separated(checks, b);
    assigns p->start, p->len, p->flushing, *checks, b->stats.gap_drops, b->stats.hunt_discards, URBB_FRAME_WRITES;
    ensures urbb_rs232_ok(b); */
/* lobster-trace: urb.CRC_005, urb.FLT_006 */
static bool hunt(urb_bridge_t *b, urb_bridge_parser_t *p, uint8_t *checks, bool ended)
{
    /* loop bound: URB_BRIDGE_FRAME_MAX + 1 rounds (each but a last one that returns removes a byte or more) */
    /*@ loop invariant 0 <= round <= URB_BRIDGE_FRAME_MAX + 1 && urbb_rs232_ok(b);
        loop assigns round, p->start, p->len, p->flushing, *checks, b->stats.gap_drops, b->stats.hunt_discards,
            URBB_FRAME_WRITES;
        loop variant URB_BRIDGE_FRAME_MAX + 1 - round; */
    for (uint8_t round = 0u; (round <= URB_BRIDGE_FRAME_MAX) && (p->len > 0u); round++) {
        uint8_t const at = p->start;
        uint8_t const need = candidate_len(p->buf[at], (p->len >= 3u) ? p->buf[at + 2u] : 0u, p->len);
        if ((need != 0u) && (need != NOT_A_FRAME) && (need <= p->len)) {
#ifndef URB_MUTANT_NO_BUDGET
            if (*checks == 0u) {
                return false;
            }
            (*checks)--;
#else
            (void)checks; /* mutant: every complete candidate is checked in the same poll */
#endif
            if (urbb_frame(b, URBB_UPLINK_RS232, &p->buf[at], need)) {
                consume(p, need);
                continue;
            }
        } else if (p->flushing || (ended && (need != NOT_A_FRAME))) {
            if (!p->flushing) {
                b->stats.gap_drops++; /* one partial frame per gap, however many bytes it loses */
                p->flushing = true;
            }
            consume(p, 1u);
            continue;
        } else if (need != NOT_A_FRAME) {
            return true; /* incomplete: wait for more bytes */
        } else {
            /* a write announcing more than 32 bytes: not a frame start */
        }
        /* Check failed (or impossible header): the frame did not start here. */
        b->stats.hunt_discards++;
#ifdef URB_MUTANT_NO_HUNT
        consume(p, p->len); /* mutant: drops the whole candidate, and any frame that started inside it */
#else
        consume(p, 1u);
#endif
    }
    p->flushing = false; /* the loop ends only when nothing is held (<= 37 bytes, one or more per round) */
    return true;
}

/* ===== RS232 ================================================================================== */

/*@ requires \valid(b);
    assigns b->rx_ring[0 .. URB_BRIDGE_RX_RING - 1], b->rx_head, b->rx_overrun, b->rx_started, b->rx_last_us,
            b->stats.rx_bytes, b->stats.rx_overruns; */
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
    uint8_t const tail = b->rx_tail; /* through a local: WP bounds a volatile read only so (proofs/framac/README.md) */
    if ((uint8_t)(head - tail) >= URB_BRIDGE_RX_RING) {
        b->rx_overrun = 1u; /* the frame in progress is broken: drop it at the next byte */
        b->stats.rx_overruns++;
        return;
    }
    if (b->rx_overrun != 0u) {
        flag = (uint16_t)URB_BRIDGE_RX_GAP;
        b->rx_overrun = 0u;
    }
    /* a remainder, not `& (URB_BRIDGE_RX_RING - 1u)`: the same machine code (a power of two, of an
     * unsigned value), and z3 and cvc4 bound a remainder, not a bitwise and (proofs/framac/README.md) */
    b->rx_ring[head % URB_BRIDGE_RX_RING] = (uint16_t)(byte | flag);
    b->rx_head = (uint8_t)(head + 1u); /* publish after the byte is stored */
}

/*@ requires urbb_rs232_ok(b);
    assigns URBB_PARSE_WRITES;
    ensures urbb_rs232_ok(b); */
/* lobster-trace: urb.WCET_005 */
void urbb_uart_parse(urb_bridge_t *b, uint32_t now, uint8_t checks)
{
    urb_bridge_parser_t *const p = &b->rs232;
    /* loop bound: URB_BRIDGE_RX_PER_POLL + 1 rounds (one ring byte each; later bytes wait for the next poll) */
    /*@ loop invariant 0 <= i <= URB_BRIDGE_RX_PER_POLL + 1 && urbb_rs232_ok(b);
        loop assigns i, checks, URBB_PARSE_WRITES;
        loop variant URB_BRIDGE_RX_PER_POLL + 1 - i; */
    for (uint8_t i = 0u; i <= URB_BRIDGE_RX_PER_POLL; i++) {
        uint8_t const tail = b->rx_tail;
        bool const more = (i < URB_BRIDGE_RX_PER_POLL) && (tail != b->rx_head);
        uint16_t v = 0u;
        bool ended;
        if (more) {
            URB_BARRIER(); /* read the head before the byte the interrupt stored */
            v = b->rx_ring[tail % URB_BRIDGE_RX_RING];
            ended = (v & URB_BRIDGE_RX_GAP) != 0u; /* an idle gap before this byte ends the candidate */
        } else {
#ifndef URB_MUTANT_NO_GAP
            /* The line has been idle long enough: a partial frame will not complete, do not wait for
             * the next byte to say so (frames behind it would wait too). rx_last_us is one aligned
             * word. A byte that arrives before a stopped flush is over carries the gap flag.
             * The UART interrupt may store a byte after the poll read `now` (on hardware it can run
             * between now_us() and this check): that byte's stamp is later than `now`, the
             * difference wraps to nearly 2^32, and it must count as "not idle", not as a gap.
             * So a difference of 2^31 us or more is read as negative: a byte newer than `now`. (While
             * bytes are held the main loop does not sleep, so a held candidate is flushed within a
             * poll of rx_gap_us, far below 2^31 us = 35 minutes.) */
            uint32_t const idle = now - b->rx_last_us;
#ifndef URB_MUTANT_RX_NEWER_THAN_NOW
            ended = (i < URB_BRIDGE_RX_PER_POLL) && (idle > b->rx_gap_us) && (idle < 0x80000000u);
#else
            ended = (i < URB_BRIDGE_RX_PER_POLL) && (idle > b->rx_gap_us); /* mutant: the wrapping comparison */
#endif
#else
            ended = false;
            (void)now;
#endif
        }
        if (!hunt(b, p, &checks, ended)) {
            b->stats.hunt_yields++;
            return; /* this poll's checks are spent: the held bytes and the ring wait, nothing is lost */
        }
        if (!more) {
            return;
        }
        b->rx_tail = (uint8_t)(tail + 1u); /* the byte joins only after the candidate before it is settled */
        push(b, p, (uint8_t)(v & 0xFFu));
    }
}

/*@ requires urbb_rs232_ok(b);
    assigns URBB_PARSE_WRITES;
    ensures urbb_rs232_ok(b); */
void urbb_uart_drain(urb_bridge_t *b, uint32_t now)
{
    urbb_uart_parse(b, now, (uint8_t)URB_BRIDGE_HUNT_CHECKS);
}

/*@ requires \valid(b) && \valid(byte) && \separated(byte, b);
    assigns *byte, b->tx_tail; */
bool urb_bridge_uart_tx_pop(urb_bridge_t *b, uint8_t *byte)
{
    uint8_t const tail = b->tx_tail;
    if (tail == b->tx_head) {
        return false;
    }
    *byte = b->tx_ring[tail % URB_BRIDGE_TX_RING];
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
/*@ requires \valid(b) && urbb_usb_ok(b);
    assigns b->stats.usb_late_reads, b->usb_prev_ready, b->usb_cur, b->usb_len[0 .. 1],
            b->usb_count[0 .. 1], b->usb_frame[0 .. 1];
    ensures usb_ok: urbb_usb_ok(b);
    behavior held:
      assumes b->usb_prev_ready && b->usb_count[1 - b->usb_cur] != 0;
      ensures b->usb_cur == \old(b->usb_cur) && b->usb_prev_ready &&
        b->usb_len[0] == \old(b->usb_len[0]) && b->usb_len[1] == \old(b->usb_len[1]) &&
        b->usb_count[0] == \old(b->usb_count[0]) && b->usb_count[1] == \old(b->usb_count[1]);
    behavior swap:
      assumes !b->usb_prev_ready || b->usb_count[1 - b->usb_cur] == 0;
      ensures swapped: b->usb_cur == 1 - \old(b->usb_cur) && b->usb_prev_ready;
      ensures fresh: b->usb_len[b->usb_cur] == URB_USB_BATCH_HEADER_MAX_SIZE && b->usb_count[b->usb_cur] == 0;
      ensures kept: b->usb_len[\old(b->usb_cur)] == \old(b->usb_len[b->usb_cur]) &&
        b->usb_count[\old(b->usb_cur)] == \old(b->usb_count[b->usb_cur]);
    complete behaviors;
    disjoint behaviors; */
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

/* UsbUplink.tla: UsbWrite (the batch arrives), then its requests are admitted in order (serving
 * them is Bridge.tla's business, shared with RS232). */
/*@ requires \valid(b) && urbb_fifo_ok(b) && urbb_nodes_ok(b) && urbb_usb_ok(b);
    requires data == \null || \valid_read(data + (0 .. len - 1));
    assigns b->stats.usb_bad_batches, b->stats.usb_batches, b->stats.usb_cut_batches, b->usb_last_frame,
            b->usb_frame[0 .. 1], URBB_FRAME_WRITES;
    ensures urbb_fifo_ok(b) && urbb_nodes_ok(b) && urbb_usb_ok(b); */
/* lobster-trace: urb.PKT_006, urb.WCET_006 */
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
    /* UsbUplink.tla: BridgeProcess. The frames lie back to back and USB delivered them intact, so
     * a frame that fails its check or runs past the end is not line noise to hunt through: the
     * host sent something that is not a batch. Hunting would cost a check per byte (34 ms for 512
     * bytes of garbage) and pass a false frame once in 256 positions. The rest of the transfer is
     * dropped and counted; its requests time out at the host, whose callbacks report it. */
    size_t at = URB_USB_BATCH_HEADER_MAX_SIZE;
    /* loop bound: URB_BRIDGE_USB_BUF / 4 frames (a request is at least 4 bytes) */
    /*@ loop invariant URB_USB_BATCH_HEADER_MAX_SIZE <= at <= len;
        loop invariant urbb_fifo_ok(b) && urbb_nodes_ok(b) && urbb_usb_ok(b);
        loop assigns at, b->stats.usb_cut_batches, URBB_FRAME_WRITES;
        loop variant len - at; */
    while (at < len) {
        size_t const rest = len - at;
        uint8_t const n = (rest < URB_BRIDGE_FRAME_MAX) ? (uint8_t)rest : (uint8_t)URB_BRIDGE_FRAME_MAX;
        uint8_t const need = candidate_len(data[at], (n >= 3u) ? data[at + 2u] : 0u, n);
        if ((need == 0u) || (need == NOT_A_FRAME) || (need > n) || !urbb_frame(b, URBB_UPLINK_USB, &data[at], need)) {
            b->stats.usb_cut_batches++;
#ifdef URB_MUTANT_USB_HUNT
            at++; /* mutant: the old behaviour, hunting on through the transfer one byte at a time */
            continue;
#else
            break;
#endif
        }
        at += need;
    }
    return true;
}

/* UsbUplink.tla: UsbRead. The previous frame's batch, once. */
/*@ requires \valid(b) && urbb_usb_ok(b);
    requires buf == \null || (\valid(buf + (0 .. cap - 1)) && \separated(buf + (0 .. cap - 1), b));
    ensures usb_ok: urbb_usb_ok(b);
    ensures copied: \result <= cap && \result <= URB_BRIDGE_USB_BUF;
    ensures whole: \result == 0 || \result == \old(b->usb_len[1 - b->usb_cur]); */
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
    /*@ loop invariant 0 <= i <= n;
        loop assigns i, buf[0 .. cap - 1];
        loop variant n - i; */
    for (uint16_t i = 0u; i < n; i++) {
        buf[i] = b->usb_buf[prev][i];
    }
    b->usb_prev_ready = false;
    return n;
}

/* ===== Responses out ========================================================================== */

/* Contract in bridge_internal.h (proofs/framac/usb_batch, emit_entry). */
bool urbb_uplink_send(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    if (uplink == URBB_UPLINK_USB) {
        uint8_t const c = b->usb_cur;
        if (((size_t)b->usb_len[c] + len > URB_BRIDGE_USB_BUF) || (b->usb_count[c] >= 128u)) {
            return false; /* batch full: the response waits for the next frame (UsbUplink NothingLost) */
        }
        /* loop bound: URB_UPLINK_RESPONSE_MAX_SIZE bytes */
        /*@ loop invariant 0 <= i <= len;
            loop invariant copied: \forall integer k; 0 <= k < i ==> b->usb_buf[c][b->usb_len[c] + k] == frame[k];
            loop assigns i, b->usb_buf[c][b->usb_len[c] .. b->usb_len[c] + len - 1];
            loop variant len - i; */
        for (uint8_t i = 0u; i < len; i++) {
            b->usb_buf[c][b->usb_len[c] + i] = frame[i];
        }
        b->usb_len[c] = (uint16_t)(b->usb_len[c] + len);
        b->usb_count[c]++;
        return true;
    }
    uint8_t const head = b->tx_head;
    uint8_t const tail = b->tx_tail; /* read once (the interrupt moves it); WP bounds a volatile
                                        read only through a local (proofs/framac/README.md) */
    if ((uint8_t)(URB_BRIDGE_TX_RING - (uint8_t)(head - tail)) < len) {
        return false; /* the UART is behind: keep the order, try at the next poll */
    }
    /* `% URB_BRIDGE_TX_RING` (a power of two, of an unsigned value) compiles to the mask `& (URB_BRIDGE_TX_RING
     * - 1u)`: the same machine code; z3 and cvc4 bound a remainder, not a bitwise and (proofs/framac/README.md) */
    /* loop bound: URB_UPLINK_RESPONSE_MAX_SIZE bytes */
    /*@ loop invariant 0 <= i <= len;
        loop assigns i, b->tx_ring[0 .. URB_BRIDGE_TX_RING - 1];
        loop variant len - i; */
    for (uint8_t i = 0u; i < len; i++) {
        b->tx_ring[(uint8_t)(head + i) % URB_BRIDGE_TX_RING] = frame[i];
    }
    URB_BARRIER(); /* the bytes are stored before the interrupt can see the new head */
    b->tx_head = (uint8_t)(head + len);
    /*@ assert uart_usb_ok: urbb_usb_ok(b); */
    uart_kick(b);
    return true;
}
