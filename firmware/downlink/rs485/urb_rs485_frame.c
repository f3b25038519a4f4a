/*
 * RS485 framing (urb_rs485.h): line timing and the receiver that delimits frames by silence.
 * Rs485Poll.tla's Receive is this receiver at the level of whole frames.
 *
 * Seeded bugs for the mutant checks: URB_MUTANT_RS485_NO_GAP_BREAK (a silence over t1.5 inside a
 * frame does not break it), URB_MUTANT_RS485_NO_LENGTH_LIMIT (a frame longer than 36 bytes is
 * taken), URB_MUTANT_RS485_EARLY_END (a silence of t1.5 already ends a frame).
 */
#include "urb_rs485.h"

#include "urb_runtime.h"

enum { ST_SILENT = 0u, ST_FRAME = 1u, ST_BROKEN = 2u };

static uint16_t chars_us(uint32_t baud, uint32_t tenths)
{
    /* tenths/10 characters of 10 bits at `baud`, in us, rounded up: tenths * 1e6 / baud */
    return (uint16_t)((tenths * 1000000u + baud - 1u) / baud);
}

void urb_rs485_timing(urb_rs485_timing_t *t, uint32_t baud)
{
    uint32_t const rate = (baud == 0u) ? 115200u : baud;
    t->baud = rate;
    t->char_us = chars_us(rate, 10u);
    t->t15_us = chars_us(rate, 15u);
    t->t35_us = chars_us(rate, 35u);
    t->turnaround_us = (uint16_t)(4u * t->char_us + 50u);
}

uint8_t urb_rs485_check_len(uint8_t n)
{
    /* link_check: CRC-8 for up to 14 covered bytes, CRC-16 from 15 */
    if ((n >= 2u) && (n <= 15u)) {
        return 1u;
    }
    if (n >= 17u) {
        return 2u;
    }
    return 0u;
}

void urb_rs485_rx_init(urb_rs485_rx_t *rx, const urb_rs485_timing_t *t, uint32_t now)
{
    rx->tm = *t;
    rx->t_last = now;
    rx->t_first = now;
    rx->crc16 = (uint16_t)URB_CRC16_LINK_CHECK_INIT;
    rx->crc8 = (uint8_t)URB_CRC8_LINK_CHECK_INIT;
    rx->hold[0] = 0u;
    rx->hold[1] = 0u;
    rx->head[0] = 0u;
    rx->head[1] = 0u;
    rx->n = 0u;
    rx->state = ST_BROKEN; /* wait for t3.5 of silence before the first frame */
    rx->last.n = 0u;
    rx->last.head[0] = 0u;
    rx->last.head[1] = 0u;
    rx->last.check_ok = false;
    rx->last.t_first = now;
    rx->last.t_last = now;
    rx->broken = 0u;
    rx->too_long = 0u;
}

/* Silence on the line between the end of the last byte and the end of a character at `t` (so the
 * start of that character): t - t_last - one character, or 0. */
static uint32_t silence_before(const urb_rs485_rx_t *rx, uint32_t t)
{
    uint32_t const d = (uint32_t)(t - rx->t_last);
    return (d > rx->tm.char_us) ? (d - rx->tm.char_us) : 0u;
}

/* Silence from the end of the last byte until `now` that is certain: a character whose stop bit
 * has not come yet may have started up to one character time ago, so that much is not counted. */
static uint32_t silence_until(const urb_rs485_rx_t *rx, uint32_t now)
{
    uint32_t const d = (uint32_t)(now - rx->t_last);
    return (d > rx->tm.char_us) ? (d - rx->tm.char_us) : 0u;
}

bool urb_rs485_rx_silent(const urb_rs485_rx_t *rx, uint32_t now)
{
    return silence_until(rx, now) >= rx->tm.t35_us;
}

uint32_t urb_rs485_rx_deadline(const urb_rs485_rx_t *rx)
{
    return rx->t_last + rx->tm.char_us + rx->tm.t35_us;
}

uint8_t urb_rs485_rx_count(const urb_rs485_rx_t *rx)
{
    return (rx->state == ST_FRAME) ? rx->n : 0u;
}

/* The frame in progress ended: its summary, the check taken at the tier its length gives. */
static void close_frame(urb_rs485_rx_t *rx)
{
    uint8_t const n = rx->n;
    uint8_t const cl = urb_rs485_check_len(n);
    bool ok = false;
    if (cl == 1u) {
        /* covered: every byte but the last; the CRC runs two behind, so add hold[0] */
        uint8_t const c = urb_crc8_link_check_byte(rx->crc8, rx->hold[0]);
        ok = urb_crc8_link_check_final(c) == rx->hold[1];
    } else if (cl == 2u) {
        uint16_t const want = urb_crc16_link_check_final(rx->crc16);
        ok = want == (uint16_t)((unsigned)rx->hold[0] | ((unsigned)rx->hold[1] << 8));
    } else {
        ok = false; /* no frame has this length */
    }
    rx->last.n = n;
    rx->last.head[0] = rx->head[0];
    rx->last.head[1] = rx->head[1];
    rx->last.check_ok = ok;
    rx->last.t_first = rx->t_first;
    rx->last.t_last = rx->t_last;
    rx->state = ST_SILENT;
    rx->n = 0u;
}

static void start_frame(urb_rs485_rx_t *rx, uint8_t byte, uint32_t t)
{
    rx->crc16 = (uint16_t)URB_CRC16_LINK_CHECK_INIT;
    rx->crc8 = (uint8_t)URB_CRC8_LINK_CHECK_INIT;
    rx->hold[0] = 0u;
    rx->hold[1] = byte;
    rx->head[0] = byte;
    rx->head[1] = 0u;
    rx->n = 1u;
    rx->t_first = t;
    rx->state = ST_FRAME;
}

uint8_t urb_rs485_rx_poll(urb_rs485_rx_t *rx, uint32_t now)
{
#if defined(URB_MUTANT_RS485_EARLY_END)
    uint32_t const end = rx->tm.t15_us;
#else
    uint32_t const end = rx->tm.t35_us;
#endif
    if (silence_until(rx, now) < end) {
        return 0u;
    }
    if (rx->state == ST_FRAME) {
        close_frame(rx);
        return URB_RS485_EV_END;
    }
    rx->state = ST_SILENT; /* a broken frame is over: the next byte starts one */
    return 0u;
}

uint8_t urb_rs485_rx_byte(urb_rs485_rx_t *rx, uint8_t byte, uint32_t t)
{
    uint32_t const gap = silence_before(rx, t);
    uint8_t ev = 0u;
#if defined(URB_MUTANT_RS485_EARLY_END)
    uint32_t const end = rx->tm.t15_us;
#else
    uint32_t const end = rx->tm.t35_us;
#endif
    if (gap >= end) {
        if (rx->state == ST_FRAME) {
            close_frame(rx);
            ev = URB_RS485_EV_END;
        }
        rx->state = ST_SILENT;
    }
    if (rx->state == ST_SILENT) {
        start_frame(rx, byte, t);
        rx->t_last = t;
        return (uint8_t)(ev | URB_RS485_EV_START);
    }
    rx->t_last = t;
    if (rx->state == ST_BROKEN) {
        return URB_RS485_EV_BROKEN; /* discarding until t3.5 of silence */
    }
#if !defined(URB_MUTANT_RS485_NO_GAP_BREAK)
    if (gap > rx->tm.t15_us) {
        rx->broken++;
        rx->state = ST_BROKEN; /* Modbus: a frame with a silence over t1.5 inside is discarded */
        return URB_RS485_EV_BROKEN;
    }
#endif
#if !defined(URB_MUTANT_RS485_NO_LENGTH_LIMIT)
    if (rx->n >= URB_RS485_MAX_FRAME) {
        rx->too_long++;
        rx->state = ST_BROKEN; /* longer than any frame: a babbling sender */
        return URB_RS485_EV_BROKEN;
    }
#endif
    /* the byte leaving the two-byte delay line joins both CRCs */
    if (rx->n >= 2u) {
        rx->crc8 = urb_crc8_link_check_byte(rx->crc8, rx->hold[0]);
        rx->crc16 = urb_crc16_link_check_byte(rx->crc16, rx->hold[0]);
    }
    rx->hold[0] = rx->hold[1];
    rx->hold[1] = byte;
    if (rx->n == 1u) {
        rx->head[1] = byte;
    }
    if (rx->n < 0xFFu) {
        rx->n++;
    }
    return URB_RS485_EV_BYTE;
}
