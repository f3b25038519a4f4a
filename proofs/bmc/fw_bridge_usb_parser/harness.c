/*
 * Proof of the USB batch parser (firmware/bridge/bridge_uplink.c urb_bridge_usb_out, UsbUplink.tla
 * UsbWrite/BridgeProcess): one OUT transfer (a UsbBatchHeader and request frames) of any bytes.
 *
 * As in fw_bridge_rs232_parser, admission (urbb_frame) is a recorder deciding like bridge.c with
 * an arbitrary frame check (the parser must be right for every check function; the RS232 proof's
 * part 3 proves the decoders' cost it charges), and the frame check of the header is arbitrary too.
 *
 * Part 1: the refused transfers (impossible lengths, no data). Part 2: one transfer of a possible
 * length and any bytes. Properties (besides bounds, pointers, overflow and shifts on every access):
 *   no overrun    every access in bounds, the assembler holds at most URB_BRIDGE_FRAME_MAX bytes
 *   refused       a transfer shorter than a header, longer than URB_BRIDGE_USB_BUF, or whose header
 *                 fails its check is dropped whole: false, no frame admitted, counted
 *   in order      an accepted transfer's frames handed to admission are exactly, in order, those
 *                 of the reference parser over its body (complete candidates that pass their
 *                 check; a failing one loses its first byte; the transfer's end drops the
 *                 incomplete rest, complete frames behind it still count); nothing is carried into
 *                 the next transfer; the response batch echoes the header's frame counter
 *   cost          the transfer's cycles, amortised like the RS232 parser's: at most
 *                 FW_USB_HEADER_CYCLES + FW_COST_BUDGET per body byte
 */
#include "urb_verify.h"

#include "bridge_internal.h"
#include "urb_core.h"
#include "urb_runtime.h"

#include "../stubs/fw_budgets.h"
#include "fw_bridge_check.h"

#define FW_COST_BUDGET FW_BRIDGE_RS232_BYTE_BUDGET

#ifndef FW_BODY
#define FW_BODY 5u /* body bytes of the transfer */
#endif
#define FW_FRAME_BOUND FW_BODY
#define FW_MAX_FRAMES (FW_BODY / 4u + 1u)
/* Header decode, the transfer's set-up and the two flushes' loop exits (cost model). */
#define FW_USB_HEADER_CYCLES 1500u
#ifndef FW_DECODE_CYCLES
#define FW_DECODE_CYCLES(n) (800u + 52u * (uint32_t)(n)) /* proved by fw_bridge_rs232_parser part 3 */
#endif

URB_PROOF_COST_STORAGE;

static urb_bridge_t bridge;
static const uint8_t *xfer; /* the transfer: the harness's uninitialised local, so arbitrary bytes */
static uint8_t body_len;
#define stream (xfer + URB_USB_BATCH_HEADER_MAX_SIZE)

static uint8_t got_len[FW_MAX_FRAMES];
static uint8_t got_first[FW_MAX_FRAMES];
static uint8_t got_last[FW_MAX_FRAMES];
static uint8_t got_count;
static bool record = true;
static const uint8_t *key; /* one arbitrary key per length (the harness's uninitialised local) */

/* The frame check, abstracted (see fw_bridge_rs232_parser): a key per length folded with the
 * covered bytes, and the strict decoders' length rules. */
static bool fw_is_frame(const uint8_t *frame, uint8_t len)
{
    uint8_t want;
    if ((frame[0] & 1u) != 0u) {
        want = 4u;
    } else if ((len < 3u) || (frame[2] > 32u)) {
        return false;
    } else {
        want = (uint8_t)(3u + frame[2] + ((3u + frame[2] <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u));
    }
    if (len != want) {
        return false;
    }
    uint8_t fold = key[len];
    for (uint8_t k = 0u; k < FW_FRAME_BOUND; k++) {
        if ((uint8_t)(k + 1u) < len) {
            fold = (uint8_t)(fold ^ frame[k]);
        }
    }
    return frame[len - 1u] == fold;
}

bool urbb_frame(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    URB_ASSERT(b == &bridge, "admission: the bridge under proof");
    URB_ASSERT(uplink == URBB_UPLINK_USB, "admission: USB frames come from the USB uplink");
    URB_ASSERT((len >= 4u) && (len <= URB_BRIDGE_FRAME_MAX), "admission: a candidate of a request's length");
    URB_ASSERT(frame == b->usb.buf, "admission: the candidate starts the assembler's buffer");
    URB_ASSERT(len <= b->usb.len, "admission: only complete candidates");
    URB_COST(FW_DECODE_CYCLES(len));
    uint8_t copy[FW_BODY]; /* len <= usb.len <= FW_BODY: constant offsets keep ESBMC's dereference simple */
    for (uint8_t k = 0u; k < FW_BODY; k++) {
        copy[k] = frame[k];
    }
    bool const ok = fw_is_frame(copy, len);
    if (ok && record) {
        URB_ASSERT(got_count < FW_MAX_FRAMES, "at most one frame per 4 bytes");
        got_len[got_count] = len;
        got_first[got_count] = copy[0];
        got_last[got_count] = copy[len - 1u];
        got_count++;
    }
    return ok;
}

/* Reference: the request starting at stream[s] with bytes s..end-1 available (see the RS232 proof). */
static uint8_t ref_need(uint8_t s, uint8_t end)
{
    if ((stream[s] & 1u) != 0u) {
        return 4u;
    }
    if ((uint8_t)(end - s) < 3u) {
        return 0u;
    }
    uint8_t const n = stream[s + 2u];
    if (n > 32u) {
        return 0xFFu;
    }
    return (uint8_t)(3u + n + ((3u + n <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u));
}

static uint8_t ref_len[FW_MAX_FRAMES];
static uint8_t ref_start[FW_MAX_FRAMES];
static uint8_t ref_count;

static uint8_t ref_scan(uint8_t s, uint8_t e, bool flush)
{
    uint8_t buf[URB_BRIDGE_FRAME_MAX];
    for (uint8_t round = 0u; round < FW_BODY; round++) {
        if (s >= e) {
            break;
        }
        uint8_t const need = ref_need(s, e);
        bool const complete = (need != 0u) && (need != 0xFFu) && (need <= (uint8_t)(e - s));
        if (!complete && !flush && (need != 0xFFu)) {
            break;
        }
        if (complete) {
            for (uint8_t k = 0u; k < FW_BODY; k++) {
                if (k < need) {
                    buf[k] = stream[s + k];
                }
            }
            if (fw_is_frame(buf, need)) {
                URB_ASSERT(ref_count < FW_MAX_FRAMES, "reference: at most one frame per 4 bytes");
                ref_len[ref_count] = need;
                ref_start[ref_count] = s;
                ref_count++;
                s = (uint8_t)(s + need);
                continue;
            }
        }
        s++;
    }
    return s;
}

void harness(void)
{
    uint8_t keys[URB_BRIDGE_FRAME_MAX + 1u];
    URB_NONDET_BYTES(keys, sizeof keys);
    key = keys;
    uint8_t data[URB_USB_BATCH_HEADER_MAX_SIZE + FW_BODY];
    URB_NONDET_BYTES(data, sizeof data);
    xfer = data;
    bridge.usb.len = 0u;
    bridge.usb_cur = 0u;
    body_len = URB_NONDET_U8();
    URB_ASSUME(body_len <= FW_BODY);
    size_t const len = URB_USB_BATCH_HEADER_MAX_SIZE + (size_t)body_len;

#if !defined(URB_PART)
#error "give URB_PART (the Makefile's SWEEP does)"
#elif URB_PART == 1
    /* Part 1. Too short or too long: refused before a byte is read. */
    size_t const bad_len = URB_NONDET_SIZE();
    URB_ASSUME((bad_len < URB_USB_BATCH_HEADER_MAX_SIZE) || (bad_len > URB_BRIDGE_USB_BUF));
    /* a header's worth of bytes: a parser that reads past them is reported at its first body byte */
    uint8_t header_only[URB_USB_BATCH_HEADER_MAX_SIZE];
    URB_NONDET_BYTES(header_only, sizeof header_only);
    URB_ASSERT(!urb_bridge_usb_out(&bridge, header_only, bad_len), "refused: a transfer of impossible length");
    URB_ASSERT(got_count == 0u, "refused: nothing admitted");
    URB_ASSERT(!urb_bridge_usb_out(&bridge, NULL, len), "refused: no data");
    URB_ASSERT(bridge.stats.usb_bad_batches == 2u, "refused transfers are counted");
#else
    /* Part 2: a transfer of a possible length, any bytes. */

    uint32_t const bad_before = bridge.stats.usb_bad_batches;
    URB_COST_BEGIN();
    bool const ok = urb_bridge_usb_out(&bridge, xfer, len);
    uint32_t const cost = urb_proof_cost;
    URB_ASSERT(bridge.usb.len == 0u, "nothing is carried into the next transfer");
    if (!ok) {
        URB_ASSERT(got_count == 0u, "a transfer whose header fails its check is dropped whole");
        URB_ASSERT(bridge.stats.usb_bad_batches == bad_before + 1u, "and counted");
        return;
    }
    URB_ASSERT(bridge.usb_frame[bridge.usb_cur] == bridge.usb_last_frame, "the response batch echoes the request batch");
    /* amortised cost: the header, then at most the RS232 parser's per-byte bound per body byte */
    urb_proof_cost = (cost > FW_USB_HEADER_CYCLES) ? ((cost - FW_USB_HEADER_CYCLES) / ((body_len > 0u) ? body_len : 1u)) : 0u;
    URB_COST_END(FW_COST_BUDGET);

    record = false;
    uint8_t s = 0u;
    for (uint8_t k = 0u; k < FW_BODY; k++) {
        if (k < body_len) {
            s = ref_scan(s, (uint8_t)(k + 1u), false);
        }
    }
    s = ref_scan(s, body_len, true);
    URB_ASSERT(s == body_len, "reference: the transfer's end ends every candidate");
    URB_ASSERT(got_count == ref_count, "as many frames as the reference finds");
    for (uint8_t i = 0u; i < FW_MAX_FRAMES; i++) {
        if (i < ref_count) {
            URB_ASSERT(got_len[i] == ref_len[i], "frame i has the reference's length");
            URB_ASSERT(got_first[i] == stream[ref_start[i]], "frame i starts where the reference's does");
            URB_ASSERT(got_last[i] == stream[ref_start[i] + ref_len[i] - 1u], "frame i ends where the reference's does");
        }
    }
#endif
}
