/*
 * Proof of the USB batch parser (firmware/bridge/bridge_uplink.c urb_bridge_usb_out, UsbUplink.tla
 * UsbWrite/BridgeProcess): one OUT transfer (a UsbBatchHeader and request frames) of any bytes.
 *
 * As in fw_bridge_rs232_parser, admission (urbb_frame) is a recorder deciding like bridge.c with
 * an arbitrary frame check (the parser must be right for every check function; the RS232 proof's
 * part 3 proves the decoders' cost it charges), and the frame check of the header is arbitrary too.
 *
 * Part 1: the refused transfers (impossible lengths, no data). Part 2: one transfer of a possible
 * length (header + 0..FW_BODY bytes) and any bytes. Part 3, the full-size frames: a body of
 * FW_BODY = 42 bytes (run with a USB buffer of 46) whose first request is the longest (a write of
 * 32 bytes, 37 bytes on the wire: its first and third bytes are fixed, every other byte and the
 * body's length from 37 up are arbitrary), so the longest frame and the frame behind it (a read of
 * 4 or a write of 5 bytes) are inside the bound; part 2's bodies (8 fast, 16 full) hold neither, and
 * a cap one byte too short for the longest frame (seeded bug frame-max-one-short) passed them.
 * Properties (besides bounds, pointers, overflow and shifts on every access; parts 2 and 3):
 *   refused       a transfer shorter than a header, longer than URB_BRIDGE_USB_BUF, or whose header
 *                 fails its check is dropped whole: false, no frame admitted, counted
 *   in order      an accepted transfer's frames handed to admission are exactly, in order, those
 *                 of the reference over its body: frames back to back from the first body byte,
 *                 up to the first that fails its check, announces an impossible length or runs past
 *                 the end; only bytes of this transfer are read; the response batch echoes the
 *                 header's frame counter
 *   cut           the transfer is counted as cut (usb_cut_batches) exactly when the reference stops
 *                 before its end: nothing after a bad frame is hunted for, and nothing is silent
 *   cost          the transfer's cycles are at most FW_USB_HEADER_CYCLES + FW_USB_ROUND_CYCLES per
 *                 frame admitted + the admitted frames' decoding + one more round and one failing
 *                 check if it was cut. Beyond the decoding of the requests it carries (admission
 *                 work, FW_ADMIT_BUDGET each), a 512-byte transfer (at most 127 frames) thus costs
 *                 at most FW_USB_PARSE_WORST, which the static check below keeps within
 *                 FW_BRIDGE_USB_TRANSFER_BUDGET (half the 1-ms frame); that part of the cost is
 *                 the value recorded in COST. (Before, one 512-byte transfer of garbage cost a
 *                 failing check per byte: ~34 ms.)
 * Cover points (URB_COVER, checked by the reach run) per part: both refusals; a header refused, a
 * frame admitted, two frames, a cut transfer; the longest frame admitted, the longest frame then
 * another admitted, the longest frame failing its check. The reference walk and check_transfer,
 * which hold part 2's points, are compiled into parts 2 and 3 only: part 1 never calls them, so
 * their points were listed for part 1 too and reported NOT REACHED there (they belong to parts 2
 * and 3, which reach them).
 */
/* lobster-trace: urb.PKT_006, urb.WCET_006 (the requirements this proof verifies) */
#include "urb_verify.h"

#include "bridge_internal.h"
#include "urb_core.h"
#include "urb_runtime.h"

#include "../stubs/fw_budgets.h"
#include "fw_bridge_check.h"

#define FW_COST_BUDGET FW_BRIDGE_USB_TRANSFER_BUDGET

#ifndef FW_BODY
#define FW_BODY 12u /* body bytes of the transfer */
#endif
/* The longest request, from the schema (not the firmware's own URB_BRIDGE_FRAME_MAX, which a bug
 * may get wrong): a write of URB_MAX_MAILBOX_SIZE bytes. */
#define FW_REQUEST_MAX URB_UPLINK_WRITE_REQUEST_MAX_SIZE
#define FW_MAX_FRAMES (FW_BODY / 4u + 1u)
#ifndef FW_DECODE_CYCLES
#define FW_DECODE_CYCLES(n) (800u + 52u * (uint32_t)(n)) /* proved by fw_bridge_rs232_parser part 3 */
#endif
/* Cost terms, as prepare.py instruments the sources (cost_model.json): urb_bridge_usb_out's entry
 * (48) and the header's decoding with its CRC (bounded by 1452: the decoder of a 4-byte frame is
 * FW_DECODE_CYCLES(4) = 1008, and the frame check stub 132 + 46 x 3 cycles, with room to spare);
 * per frame, the loop round (10) and candidate_len (42 + urb_link_check_size 30). */
#define FW_USB_HEADER_CYCLES 1500u
#define FW_USB_ROUND_CYCLES 82u
#define FW_USB_FRAMES_MAX (URB_BRIDGE_USB_BUF / 4u) /* a request is at least 4 bytes */
#define FW_USB_PARSE_WORST                                                                         \
    (FW_USB_HEADER_CYCLES + FW_USB_ROUND_CYCLES * (FW_USB_FRAMES_MAX + 1u) + FW_DECODE_CYCLES(FW_REQUEST_MAX))
/* Static check with the real transfer size (512 bytes; the proof's own URB_BRIDGE_USB_BUF is small). */
typedef char fw_transfer_fits_its_budget[(FW_USB_HEADER_CYCLES + FW_USB_ROUND_CYCLES * (512u / 4u + 1u) +
                                          FW_DECODE_CYCLES(FW_REQUEST_MAX) <= FW_BRIDGE_USB_TRANSFER_BUDGET) ? 1 : -1];

URB_PROOF_COST_STORAGE;

static urb_bridge_t bridge;
static const uint8_t *xfer; /* the transfer: the harness's uninitialised local, so arbitrary bytes */
static size_t xfer_len;
#define stream (xfer + URB_USB_BATCH_HEADER_MAX_SIZE)

static uint8_t got_len[FW_MAX_FRAMES];
static uint8_t got_first[FW_MAX_FRAMES];
static uint8_t got_last[FW_MAX_FRAMES];
static uint8_t got_at[FW_MAX_FRAMES];
static uint8_t got_count;
static uint32_t got_decode; /* decoding cycles of the frames admitted */
static const uint8_t *key;  /* one arbitrary key per length (the harness's uninitialised local) */

/* a candidate copy: the body, or the longest request when the body is longer (part 3) */
#define FW_FRAME_WIDTH ((FW_BODY < FW_REQUEST_MAX) ? FW_BODY : FW_REQUEST_MAX)
#include "../stubs/fw_uplink_model.h"

bool urbb_frame(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    URB_ASSERT(b == &bridge, "admission: the bridge under proof");
    URB_ASSERT(uplink == URBB_UPLINK_USB, "admission: USB frames come from the USB uplink");
    URB_ASSERT((len >= 4u) && (len <= FW_REQUEST_MAX), "admission: a candidate of a request's length");
    URB_ASSERT((frame >= stream) && (frame + len <= xfer + xfer_len), "admission: only bytes of this transfer");
    URB_COST(FW_DECODE_CYCLES(len));
    /* read through the transfer array at an index: constant objects keep ESBMC's dereference simple */
    uint8_t const at = (uint8_t)(frame - stream);
    uint8_t copy[FW_FRAME_WIDTH];
    for (uint8_t k = 0u; k < FW_FRAME_WIDTH; k++) {
        copy[k] = (k < len) ? stream[at + k] : 0u;
    }
    bool const ok = fw_is_frame(copy, len);
    if (ok) {
        URB_ASSERT(got_count < FW_MAX_FRAMES, "at most one frame per 4 bytes");
        got_len[got_count] = len;
        got_first[got_count] = copy[0];
        got_last[got_count] = copy[len - 1u];
        got_at[got_count] = at;
        got_count++;
        got_decode += FW_DECODE_CYCLES(len);
    }
    return ok;
}

/* Parts 2 and 3 only: part 1 (refused transfers) never walks a body, see the header. */
#if defined(URB_PART) && ((URB_PART == 2) || (URB_PART == 3))
static uint8_t ref_len[FW_MAX_FRAMES];
static uint8_t ref_start[FW_MAX_FRAMES];
static uint8_t ref_count;

/* The reference over a body of e bytes: frames back to back from its first byte, until one is not
 * a frame. Returns where it stopped (e: the whole body was frames). */
static uint8_t ref_walk(uint8_t e)
{
    uint8_t buf[FW_FRAME_WIDTH];
    uint8_t s = 0u;
    for (uint8_t round = 0u; (round < FW_MAX_FRAMES) && (s < e); round++) {
        uint8_t const need = fw_request_need(&stream[s], (uint8_t)(e - s));
        if ((need == 0u) || (need == FW_NOT_A_REQUEST) || (need > (uint8_t)(e - s))) {
            break;
        }
        for (uint8_t k = 0u; k < FW_FRAME_WIDTH; k++) {
            buf[k] = ((uint8_t)(s + k) < FW_BODY) ? stream[s + k] : 0u;
        }
        if (!fw_is_frame(buf, need)) {
            break;
        }
        URB_ASSERT(ref_count < FW_MAX_FRAMES, "reference: at most one frame per 4 bytes");
        ref_len[ref_count] = need;
        ref_start[ref_count] = s;
        ref_count++;
        s = (uint8_t)(s + need);
    }
    return s;
}

/* Parts 2 and 3: one accepted-or-refused transfer of body_len body bytes, against the reference. */
static void check_transfer(uint8_t body_len)
{
    size_t const len = xfer_len;
    uint32_t const bad_before = bridge.stats.usb_bad_batches;
    uint32_t const cut_before = bridge.stats.usb_cut_batches;
    URB_COST_BEGIN();
    bool const ok = urb_bridge_usb_out(&bridge, xfer, len);
    uint32_t const cost = urb_proof_cost;
    if (!ok) {
        URB_ASSERT(got_count == 0u, "a transfer whose header fails its check is dropped whole");
        URB_ASSERT(bridge.stats.usb_bad_batches == bad_before + 1u, "and counted");
        URB_ASSERT(bridge.stats.usb_cut_batches == cut_before, "and not as cut");
        URB_COVER("header-refused");
        return;
    }
    URB_ASSERT(bridge.usb_frame[bridge.usb_cur] == bridge.usb_last_frame, "the response batch echoes the request batch");

    uint8_t const s = ref_walk(body_len);
    bool const cut = s < body_len;
    URB_ASSERT(got_count == ref_count, "as many frames as the reference finds");
    for (uint8_t i = 0u; i < FW_MAX_FRAMES; i++) {
        if (i < ref_count) {
            URB_ASSERT(got_at[i] == ref_start[i], "frame i starts where the reference's does");
            URB_ASSERT(got_len[i] == ref_len[i], "frame i has the reference's length");
            URB_ASSERT(got_first[i] == stream[ref_start[i]], "frame i's first byte is the reference's");
            URB_ASSERT(got_last[i] == stream[ref_start[i] + ref_len[i] - 1u], "frame i's last byte is the reference's");
        }
    }
    URB_ASSERT(bridge.stats.usb_cut_batches == cut_before + (cut ? 1u : 0u),
               "a transfer is counted as cut exactly when a bad frame ends it early");
    if (got_count >= 1u) {
        URB_COVER("a-frame-admitted");
    }
    if (got_count >= 2u) {
        URB_COVER("two-frames-admitted");
    }
    if (cut) {
        URB_COVER("transfer-cut");
    }

    /* cost: the linear form, then the part beyond the admitted requests' decoding (COST) */
    URB_ASSERT(cost <= FW_USB_HEADER_CYCLES + FW_USB_ROUND_CYCLES * ((uint32_t)got_count + (cut ? 1u : 0u)) + got_decode +
                           (cut ? FW_DECODE_CYCLES(FW_REQUEST_MAX) : 0u),
               "cost: one transfer within its linear form (so within FW_USB_PARSE_WORST beyond its requests)");
    urb_proof_cost = cost - got_decode;
    URB_COST_END(FW_COST_BUDGET);
}
#endif

void harness(void)
{
    uint8_t keys[FW_REQUEST_MAX + 1u];
    URB_NONDET_BYTES(keys, sizeof keys);
    key = keys;
    uint8_t data[URB_USB_BATCH_HEADER_MAX_SIZE + FW_BODY];
    URB_NONDET_BYTES(data, sizeof data);
    xfer = data;
    bridge.usb_cur = 0u;
    uint8_t const body_len = URB_NONDET_U8();
    URB_ASSUME(body_len <= FW_BODY);
    size_t const len = URB_USB_BATCH_HEADER_MAX_SIZE + (size_t)body_len;
    xfer_len = len;

#if !defined(URB_PART)
#error "give URB_PART (the Makefile's SWEEP does)"
#elif URB_PART == 1
    /* Part 1. Too short or too long: refused before a byte is read. */
    size_t const bad_len = URB_NONDET_SIZE();
    URB_ASSUME((bad_len < URB_USB_BATCH_HEADER_MAX_SIZE) || (bad_len > URB_BRIDGE_USB_BUF));
    /* a header's worth of bytes: a parser that reads past them is reported at its first body byte */
    uint8_t header_only[URB_USB_BATCH_HEADER_MAX_SIZE];
    URB_NONDET_BYTES(header_only, sizeof header_only);
    xfer = header_only;
    xfer_len = URB_USB_BATCH_HEADER_MAX_SIZE;
    URB_ASSERT(!urb_bridge_usb_out(&bridge, header_only, bad_len), "refused: a transfer of impossible length");
    URB_ASSERT(got_count == 0u, "refused: nothing admitted");
    URB_ASSERT(!urb_bridge_usb_out(&bridge, NULL, len), "refused: no data");
    URB_ASSERT(bridge.stats.usb_bad_batches == 2u, "refused transfers are counted");
    URB_ASSERT(bridge.stats.usb_batches == 0u, "refused transfers are not accepted");
    URB_COVER("part1-both-refusals-checked");
#elif URB_PART == 2
    /* Part 2: a transfer of a possible length, any bytes. */
    check_transfer(body_len);
#elif URB_PART == 3
    /* Part 3: the longest request first (a write of 32 bytes), then any bytes. Its payload bytes are
     * zero: the parser never reads a payload (it measures a frame by its first and third byte and
     * hands it to admission whole), and the abstract check still passes or fails it through the
     * arbitrary key and check bytes; part 2 has arbitrary payloads. */
    URB_ASSUME(body_len >= FW_REQUEST_MAX);
    /* the bytes that shape the frame are assigned (not assumed): its length is then a constant */
    data[URB_USB_BATCH_HEADER_MAX_SIZE] = (uint8_t)(data[URB_USB_BATCH_HEADER_MAX_SIZE] & 0xFEu); /* a write */
    data[URB_USB_BATCH_HEADER_MAX_SIZE + 2u] = URB_MAX_MAILBOX_SIZE;
    for (uint8_t k = 3u; k < (uint8_t)(FW_REQUEST_MAX - 2u); k++) {
        data[URB_USB_BATCH_HEADER_MAX_SIZE + k] = 0u;
    }
    check_transfer(body_len);
    if ((got_count >= 1u) && (got_len[0] == FW_REQUEST_MAX)) {
        URB_COVER("part3-longest-frame-admitted");
    }
    if ((got_count >= 2u) && (got_len[0] == FW_REQUEST_MAX)) {
        URB_COVER("part3-longest-frame-then-another-admitted");
    }
    if (ref_count == 0u) {
        URB_COVER("part3-longest-frame-fails-its-check");
    }
#else
#error "URB_PART is 1, 2 or 3"
#endif
}
