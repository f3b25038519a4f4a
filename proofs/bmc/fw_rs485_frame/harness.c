/*
 * Proof of the RS485 receiver (firmware/downlink/rs485/urb_rs485_frame.c) at 1 Mb/s, two parts:
 *   1 a frame  after start-up and t3.5 + a character of silence, N bytes (a sweep item) of any value
 *              arrive with any silences up to t1.5 between them; the first starts a frame, the others
 *              join it; the line then stays silent: a poll before t3.5 + a character after the last
 *              byte ends nothing, one at that time ends the frame with n = N, its first two bytes,
 *              and check_ok exactly when its last byte(s) are the link_check of the rest at the tier
 *              its length gives (urb_link_check, proved by its own proofs); none for N = 16
 *   2 a byte   any byte at any time into a receiver in any state within its invariant (state one of
 *              three, at most 36 bytes held): only documented event bits, at most 36 bytes held
 *              after, and a silence of more than t1.5 inside a frame breaks it
 * Cost: each urb_rs485_rx_byte and urb_rs485_rx_poll within FW_RS485_BYTE_BUDGET: one character at
 * 1 Mb/s (stubs/fw_budgets.h says why not half).
 */
/* lobster-trace: urb.DLK_006 (the requirements this proof verifies) */
#include "urb_verify.h"

#include "../stubs/fw_budgets.h"
#include "urb_rs485.h"
#include "urb_runtime.h"

URB_PROOF_COST_STORAGE;

#ifndef URB_N
#define URB_N 3
#endif

static urb_rs485_rx_t rx;

#if URB_PART == 1
void harness(void)
{
    urb_rs485_timing_t tm;
    urb_rs485_timing(&tm, 1000000u);
    urb_rs485_rx_init(&rx, &tm, 0u);
    uint32_t t = URB_NONDET_U32();
    URB_ASSUME(t >= 45u && t <= 100000u);
    URB_COST_BEGIN();
    (void)urb_rs485_rx_poll(&rx, t);
    URB_COST_END(FW_RS485_BYTE_BUDGET);
    uint8_t b[URB_N];
    URB_NONDET_BYTES(b, sizeof b);
    for (uint8_t k = 0u; k < (uint8_t)URB_N; k++) {
        uint32_t const gap = URB_NONDET_U32();
        URB_ASSUME(gap <= 15u && (k > 0u || gap == 0u));
        t += 10u + gap;
        URB_COST_BEGIN();
        uint8_t const ev = urb_rs485_rx_byte(&rx, b[k], t);
        URB_COST_END(FW_RS485_BYTE_BUDGET);
        URB_ASSERT(ev == ((k == 0u) ? URB_RS485_EV_START : URB_RS485_EV_BYTE), "a frame: START, then BYTE");
    }
    URB_ASSERT(urb_rs485_rx_deadline(&rx) == t + 45u, "a frame: it ends t3.5 + a character after its last byte");
    URB_ASSERT(urb_rs485_rx_poll(&rx, t + 44u) == 0u, "a frame: not before");
    URB_COST_BEGIN();
    uint8_t const ev = urb_rs485_rx_poll(&rx, t + 45u);
    URB_COST_END(FW_RS485_BYTE_BUDGET);
    URB_ASSERT(ev == URB_RS485_EV_END, "a frame: ended by the silence");
    URB_ASSERT(rx.last.n == (uint8_t)URB_N, "a frame: all its bytes");
    URB_ASSERT(rx.last.head[0] == b[0] && (URB_N < 2 || rx.last.head[1] == b[URB_N >= 2 ? 1 : 0]), "a frame: its head");
    uint8_t const cl = urb_rs485_check_len((uint8_t)URB_N);
    bool want = false;
    if (cl != 0u) {
        uint32_t const c = urb_link_check(NULL, 0u, b, (size_t)(URB_N - cl));
        uint32_t got = b[URB_N - cl];
        if (cl == 2u) {
            got |= (uint32_t)b[URB_N - 1] << 8;
        }
        want = (got == c);
    }
    URB_ASSERT(rx.last.check_ok == want, "a frame: check_ok exactly when the link_check matches");
    URB_COVER("part1-frame-ended");
    if (want) {
        URB_COVER("part1-frame-check-passes");
    }
}
#elif URB_PART == 2
void harness(void)
{
    urb_rs485_timing(&rx.tm, 1000000u);
    rx.t_last = URB_NONDET_U32();
    rx.t_first = URB_NONDET_U32();
    rx.crc16 = URB_NONDET_U16();
    rx.crc8 = URB_NONDET_U8();
    rx.hold[0] = URB_NONDET_U8();
    rx.hold[1] = URB_NONDET_U8();
    rx.head[0] = URB_NONDET_U8();
    rx.head[1] = URB_NONDET_U8();
    rx.n = URB_NONDET_U8();
    rx.state = URB_NONDET_U8();
    rx.broken = URB_NONDET_U32();
    rx.too_long = URB_NONDET_U32();
    URB_ASSUME(rx.state <= 2u && rx.n <= URB_RS485_MAX_FRAME && (rx.state != 1u || rx.n >= 1u));
    URB_ASSUME(rx.broken < 0xFFFFFFFFu && rx.too_long < 0xFFFFFFFFu);
    uint8_t const state = rx.state;
    uint32_t const t_last = rx.t_last;
    uint8_t const byte = URB_NONDET_U8();
    uint32_t const t = URB_NONDET_U32();
    URB_COST_BEGIN();
    uint8_t const ev = urb_rs485_rx_byte(&rx, byte, t);
    URB_COST_END(FW_RS485_BYTE_BUDGET);
    URB_ASSERT((ev & (uint8_t)~0x0Fu) == 0u, "a byte: documented event bits only");
    URB_ASSERT(rx.n <= URB_RS485_MAX_FRAME && rx.state <= 2u, "a byte: invariant kept");
    uint32_t const d = t - t_last;
    if ((state == 1u) && (d > 10u) && (d - 10u > 15u) && (d - 10u < 35u)) {
        URB_ASSERT(ev == URB_RS485_EV_BROKEN && rx.state == 2u, "a byte: a silence over t1.5 inside a frame breaks it");
    }
    if ((ev & URB_RS485_EV_START) != 0u) {
        URB_ASSERT(rx.n == 1u && rx.head[0] == byte, "a byte: START makes it byte 0");
        URB_COVER("part2-byte-starts-a-frame");
    }
    if (ev == URB_RS485_EV_BROKEN) {
        URB_COVER("part2-silence-breaks-a-frame");
    }
}
#else
#error "URB_PART must be 1 or 2"
#endif
