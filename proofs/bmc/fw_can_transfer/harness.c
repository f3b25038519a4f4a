/*
 * Proof of the CAN transfer layer (firmware/downlink/can/urb_can_transfer.c), in three parts:
 *   1 round trip   a payload of LEN bytes (a sweep item) with any transfer id and any bytes is cut
 *                  into urb_can_frames(LEN) frames, each at most 8 bytes, 8 but the last, with the
 *                  tail bits Cyphal/CAN gives (start, end, toggle 1, 0, ..., the transfer id), and
 *                  the reassembler takes them back: MORE, ..., DONE, the same LEN bytes and id
 *   2 one frame    any frame (length 0..8, any bytes) into a reassembler in any state within its
 *                  invariant, any room 0..32: only a documented result; an ignored frame changes
 *                  nothing; nothing is written past the room; the invariant holds after
 *   3 two in a row the largest transfer (32 bytes, 5 frames) and then one of LEN bytes with the next
 *                  transfer id through one reassembler: both delivered intact
 * Cost: each urb_can_tx_next and urb_can_rx_frame within FW_CAN_FRAME_BUDGET (half the shortest
 * frame at 1 Mb/s).
 * The CRC step runs as its bit-serial definition, or (items marked CRC0: 14 to 32 payload bytes,
 * part 3) as a constant: see crc_bitwise.c and crc_const.c.
 */
/* lobster-trace: urb.DLK_001, urb.DLK_002 (the requirements this proof verifies) */
#include "urb_verify.h"

#include "../stubs/fw_budgets.h"
#include "urb_can.h"

URB_PROOF_COST_STORAGE;

#ifndef URB_LEN
#define URB_LEN 8
#endif

static uint8_t frames[8][8];
static uint8_t flen[8];

/* Cuts `len` bytes of `payload` with transfer id `tid`; returns the number of frames. */
static uint8_t segment(const uint8_t *payload, uint8_t len, uint8_t tid)
{
    urb_can_tx_t tx;
    urb_can_tx_init(&tx, payload, len, tid);
    uint8_t n = 0u;
    for (uint8_t k = 0u; k < 6u; k++) {
        URB_COST_BEGIN();
        uint8_t const got = urb_can_tx_next(&tx, frames[n]);
        URB_COST_END(FW_CAN_FRAME_BUDGET);
        if (got == 0u) {
            break;
        }
        URB_ASSERT(got >= 1u && got <= 8u, "segment: a frame holds 1..8 bytes");
        flen[n] = got;
        n++;
    }
    URB_ASSERT(urb_can_tx_done(&tx), "segment: every frame taken");
    URB_ASSERT(n == urb_can_frames(len), "segment: urb_can_frames(len) frames");
    return n;
}

/* Feeds the frames to rx and checks the transfer comes back. */
static void reassemble(urb_can_rx_t *rx, uint8_t n, const uint8_t *payload, uint8_t len, uint8_t tid)
{
    uint8_t out[32];
    for (uint8_t k = 0u; k < n; k++) {
        uint8_t const tail = frames[k][flen[k] - 1u];
        URB_ASSERT(((tail & URB_CAN_TAIL_START) != 0u) == (k == 0u), "tail: start in the first frame only");
        URB_ASSERT(((tail & URB_CAN_TAIL_END) != 0u) == (k + 1u == n), "tail: end in the last frame only");
        URB_ASSERT(((tail & URB_CAN_TAIL_TOGGLE) != 0u) == ((k & 1u) == 0u), "tail: toggle 1, 0, 1, ...");
        URB_ASSERT((tail & URB_CAN_TAIL_TID) == (tid & 31u), "tail: the transfer id");
        URB_ASSERT((k + 1u == n) || (flen[k] == 8u), "segment: every frame but the last is full");
        URB_COST_BEGIN();
        urb_can_rx_result_t const r = urb_can_rx_frame(rx, frames[k], flen[k], out, 32u);
        URB_COST_END(FW_CAN_FRAME_BUDGET);
        URB_ASSERT(r == ((k + 1u == n) ? URB_CAN_RX_DONE : URB_CAN_RX_MORE), "reassembly: MORE, ..., DONE");
    }
    URB_ASSERT(urb_can_rx_len(rx) == len, "reassembly: the length sent");
    URB_ASSERT(urb_can_rx_tid(rx) == (tid & 31u), "reassembly: the transfer id sent");
    /* two nested loops of at most 8, so that one --unwind 9 bounds every loop of the proof */
    for (uint8_t w = 0u; w < 4u; w++) {
        for (uint8_t b = 0u; b < 8u; b++) {
            uint8_t const i = (uint8_t)(w * 8u + b);
            if (i < len) {
                URB_ASSERT(out[i] == payload[i], "reassembly: the bytes sent");
            }
        }
    }
}

#if URB_PART == 1
void harness(void)
{
    uint8_t payload[32];
    URB_NONDET_BYTES(payload, sizeof payload);
    uint8_t const tid = URB_NONDET_U8();
    URB_ASSUME(tid < 32u);
    uint8_t const n = segment(payload, (uint8_t)URB_LEN, tid);
    urb_can_rx_t rx;
    urb_can_rx_reset(&rx);
    reassemble(&rx, n, payload, (uint8_t)URB_LEN, tid);
    URB_COVER("part1-transfer-reassembled");
}
#elif URB_PART == 2
void harness(void)
{
    urb_can_rx_t rx;
    rx.crc = URB_NONDET_U16();
    rx.count = URB_NONDET_U8();
    rx.tid = URB_NONDET_U8();
    rx.toggle = URB_NONDET_U8();
    rx.active = URB_NONDET_U8();
    rx.single = URB_NONDET_U8();
    URB_ASSUME(rx.tid < 32u && rx.toggle <= 1u && rx.active <= 1u && rx.single <= 1u);
    urb_can_rx_t const before = rx;
    uint8_t data[8];
    URB_NONDET_BYTES(data, sizeof data);
    uint8_t const len = URB_NONDET_U8();
    URB_ASSUME(len <= 8u);
    uint8_t const cap = URB_NONDET_U8();
    URB_ASSUME(cap <= 32u);
    uint8_t out[32];
    URB_COST_BEGIN();
    urb_can_rx_result_t const r = urb_can_rx_frame(&rx, data, len, out, cap);
    URB_COST_END(FW_CAN_FRAME_BUDGET);
    URB_ASSERT(r <= URB_CAN_RX_BAD_START, "one frame: a documented result");
    if ((r != URB_CAN_RX_MORE) && (r != URB_CAN_RX_DONE) && (r != URB_CAN_RX_CRC)) {
        URB_ASSERT(rx.crc == before.crc && rx.count == before.count && rx.tid == before.tid &&
                       rx.toggle == before.toggle && rx.active == before.active && rx.single == before.single,
                   "one frame: an ignored frame changes nothing");
    } else {
        URB_ASSERT(len >= 1u, "one frame: only a frame with a tail byte is taken");
        URB_ASSERT(rx.tid == (data[len - 1u] & 31u), "one frame: taken under its transfer id");
        URB_ASSERT((rx.active != 0u) == (r == URB_CAN_RX_MORE), "one frame: active exactly while more is due");
    }
    if (len == 0u) {
        URB_ASSERT(r == URB_CAN_RX_EMPTY, "one frame: an empty frame is EMPTY");
    }
    URB_ASSERT(rx.tid < 32u && rx.toggle <= 1u && rx.active <= 1u && rx.single <= 1u, "one frame: invariant kept");
    if (r == URB_CAN_RX_DONE) {
        URB_COVER("part2-frame-completes-a-transfer");
    }
    if (r == URB_CAN_RX_MORE) {
        URB_COVER("part2-frame-taken-more-due");
    }
    if (len == 0u) {
        URB_COVER("part2-empty-frame");
    }
}
#elif URB_PART == 3
void harness(void)
{
    uint8_t big[32];
    uint8_t next[32];
    URB_NONDET_BYTES(big, sizeof big);
    URB_NONDET_BYTES(next, sizeof next);
    uint8_t const tid = URB_NONDET_U8();
    URB_ASSUME(tid < 32u);
    urb_can_rx_t rx;
    urb_can_rx_reset(&rx);
    uint8_t n = segment(big, 32u, tid);
    URB_ASSERT(n == 5u, "a 32-byte mailbox is 5 frames");
    reassemble(&rx, n, big, 32u, tid);
    uint8_t const tid2 = (uint8_t)((tid + 1u) & 31u);
    n = segment(next, (uint8_t)URB_LEN, tid2);
    reassemble(&rx, n, next, (uint8_t)URB_LEN, tid2);
    URB_COVER("part3-largest-transfer-then-another");
}
#else
#error "URB_PART must be 1, 2 or 3"
#endif
