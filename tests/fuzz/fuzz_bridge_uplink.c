/*
 * libFuzzer target: the bridge firmware's uplink side (RS232 byte stream and USB transfers) on the
 * hosted rig with two fake nodes (tests/fuzz/README.md).
 *
 * The input is a script. Byte 0 configures the rig (FIFO depth, heartbeat on/off, faults of node
 * 0x10); then each operation byte selects one of: send the next byte on RS232 back to back, let
 * the line idle, deliver a USB OUT transfer of the next n bytes, a USB start of frame with its IN
 * read, run the rig a while, or send a well-formed read/write request built from the next bytes
 * (so the fuzzer reaches the FIFO and downlink paths, not only the hunting parser).
 * Sanitizers catch memory errors; the script then asserts what Bridge.tla promises: the bridge
 * settles, every request frame it accepted is answered (or counted as beyond the host's window),
 * and every USB IN batch fits the host's buffer and starts with a valid header. And every valid
 * request is accepted, not only answered when accepted: a well-formed request in a USB transfer of
 * its own is admitted by that transfer, and one sent on a quiet RS232 line (seq bit 6: the line
 * idles first, so nothing held can join it) is admitted once its last byte is in. A request sent
 * back to back after garbage may be lost to a false frame that the hunt finds first (one in 256
 * candidates passes a CRC-8), so those only count for the answers. Requests are up to the longest
 * (a write of 32 bytes, 37 on the wire): a cap one byte short of it fails here.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "bridge_hosted.h"
#include "fuzz_require.h"
#include "urb_core.h"
#include "urb_runtime.h"

#define BYTE_US 87u          /* one UART byte at 115200 Bd */
#define SETTLE_US 2000000u
/* A USB OUT operation sends (op >> 3) * OUT_STEP bytes, up to OUT_MAX: over the bridge's largest
 * transfer (URB_BRIDGE_USB_BUF), which it must drop. The buffer once held only URB_BRIDGE_USB_BUF + 1
 * bytes, and a long fuzzing run found the script writing past it. */
#define OUT_STEP 17u
#define OUT_MAX (31u * OUT_STEP)
/* Iteration step of the rig: bus events carry their own times, so coarser steps only delay when
 * the bridge sees them (as a slower main loop would); they cut the cost of one input tenfold. */
#define STEP_US 10u   /* longer than any queue of 16 requests with timeouts and bus clears */
/* A quiet RS232 line: longer than the idle gap (a byte time + 2 byte times), and enough polls to
 * parse a full receive ring (64 bytes, 16 a poll) and flush what is held. */
#define QUIET_US 2000u
/* After a request's last byte: a few polls admit it. */
#define PARSE_US 200u

typedef struct {
    const uint8_t *data;
    size_t size, pos;
} script_t;

static bool next(script_t *s, uint8_t *out)
{
    if (s->pos >= s->size) {
        return false;
    }
    *out = s->data[s->pos++];
    return true;
}

static urb_fake_node_t *add_node(urb_hosted_rig_t *r, uint8_t address, uint8_t in1, uint8_t out1)
{
    urb_fake_node_t *n = urb_fake_i2c_add(&r->bus, address, 0x20u, (uint8_t)(address & 0x3Fu));
    REQUIRE(n != NULL);
    n->in_size[1] = in1;
    n->out_size[1] = out1;
    n->echo = true;
    urb_fake_node_identify(n);
    return n;
}

/* A start of frame and the host's IN read into a buffer of exactly `cap` bytes (a host may offer
 * less than a full batch; the bridge must then keep the batch for a later read). */
static void usb_frame(urb_hosted_rig_t *r, size_t cap)
{
    uint8_t *const in = malloc(cap);
    REQUIRE(in != NULL);
    urb_bridge_usb_sof(&r->bridge);
    size_t const got = urb_bridge_usb_in(&r->bridge, in, cap);
    REQUIRE(got <= cap);
    if (got > 0u) {
        urb_usb_batch_header_t h;
        REQUIRE(got >= URB_USB_BATCH_HEADER_MAX_SIZE);
        REQUIRE(urb_usb_batch_header_decode(&h, in, URB_USB_BATCH_HEADER_MAX_SIZE) == (int32_t)URB_USB_BATCH_HEADER_MAX_SIZE);
    }
    free(in);
    urb_hosted_rig_run(r, 1000u);
}

static void send_request(urb_hosted_rig_t *r, script_t *s, bool write)
{
    uint8_t a = 0u, m = 0u, len = 0u, seq = 0u;
    (void)(next(s, &a) && next(s, &m) && next(s, &len) && next(s, &seq));
    uint8_t frame[URB_UPLINK_WRITE_REQUEST_MAX_SIZE];
    int32_t n;
    if (write) {
        urb_uplink_write_request_t q;
        memset(&q, 0, sizeof q);
        q.address = (uint8_t)(a & 0x7Fu);
        q.mailbox = (uint8_t)(m & 7u);
        q.seq = (uint8_t)(seq & 15u);
        q.length = (uint8_t)(len % 33u);
        for (uint8_t i = 0u; i < q.length; i++) {
            q.data[i] = (uint8_t)(seq + i);
        }
        n = urb_uplink_write_request_encode(&q, frame, sizeof frame);
    } else {
        urb_uplink_read_request_t q = {(uint8_t)(a & 0x7Fu), (uint8_t)(m & 7u), (uint8_t)(seq & 15u), (uint8_t)(len % 33u)};
        n = urb_uplink_read_request_encode(&q, frame, sizeof frame);
    }
    if (n <= 0) {
        return; /* a field the schema rejects: nothing to send */
    }
    uint32_t const before = urb_bridge_stats(&r->bridge)->frames;
    if ((seq & 0x80u) != 0u) {
        uint8_t batch[URB_USB_BATCH_HEADER_MAX_SIZE + sizeof frame];
        urb_usb_batch_header_t h;
        memset(&h, 0, sizeof h);
        h.frame = (uint16_t)(seq & 0x7Fu);
        h.count = 1u;
        REQUIRE(urb_usb_batch_header_encode(&h, batch, URB_USB_BATCH_HEADER_MAX_SIZE) == (int32_t)URB_USB_BATCH_HEADER_MAX_SIZE);
        memcpy(batch + URB_USB_BATCH_HEADER_MAX_SIZE, frame, (size_t)n);
        /* a valid batch is accepted, and its one valid request admitted */
        REQUIRE(urb_bridge_usb_out(&r->bridge, batch, URB_USB_BATCH_HEADER_MAX_SIZE + (size_t)n));
        REQUIRE(urb_bridge_stats(&r->bridge)->frames == before + 1u);
    } else if ((seq & 0x40u) != 0u) {
        /* on a quiet line the request is admitted, whatever came before */
        urb_hosted_rig_run(r, QUIET_US);
        uint32_t const quiet = urb_bridge_stats(&r->bridge)->frames;
        urb_hosted_rig_uart_send(r, frame, (size_t)n, BYTE_US);
        urb_hosted_rig_run(r, PARSE_US);
        REQUIRE(urb_bridge_stats(&r->bridge)->frames == quiet + 1u);
    } else {
        urb_hosted_rig_uart_send(r, frame, (size_t)n, BYTE_US);
    }
}

static void apply_faults(urb_fake_node_t *n, uint8_t f)
{
    n->corrupt_read = (f & 0x01u) != 0u;
    n->nack_at = (f & 0x02u) != 0u ? (int16_t)((f >> 4) & 3u) : (int16_t)URB_FAKE_NO_NACK;
    n->nack_once = (f & 0x04u) != 0u;
    n->stretch_us = (f & 0x08u) != 0u ? 300u : 0u;
    n->present = (f & 0x40u) == 0u;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    script_t s = {data, size, 0u};
    uint8_t conf = 0u;
    if (!next(&s, &conf)) {
        return 0;
    }
    urb_hosted_rig_t *const r = calloc(1u, sizeof *r);
    REQUIRE(r != NULL);
    urb_bridge_config_t cfg;
    urb_bridge_default_config(&cfg);
    cfg.fifo_depth = (uint8_t)(1u + (conf & 15u));
    cfg.heartbeat_us = (conf & 0x10u) != 0u ? 1000u : 0u;
    REQUIRE(urb_hosted_rig_init(r, &cfg, NULL) == URB_OK);
    r->step_us = STEP_US;
    urb_fake_node_t *const n1 = add_node(r, 0x10u, 4u, 6u);
    (void)add_node(r, 0x11u, 32u, 32u);
    REQUIRE(urb_hosted_rig_settle(r, SETTLE_US));

    uint8_t op = 0u;
    for (unsigned steps = 0u; steps < 512u && next(&s, &op); steps++) {
        uint8_t arg = 0u;
        switch (op & 7u) {
        case 0u: /* one byte on RS232, back to back with the previous */
            if (next(&s, &arg)) {
                urb_hosted_rig_uart_send(r, &arg, 1u, BYTE_US);
            }
            break;
        case 1u: /* the line idles */
            urb_hosted_rig_run(r, 100u * (uint32_t)(op >> 3));
            break;
        case 2u: { /* a USB OUT transfer of arbitrary bytes */
            uint8_t out[OUT_MAX];
            size_t const want = (size_t)(op >> 3) * OUT_STEP;
            size_t got = 0u;
            while (got < want && next(&s, &out[got])) {
                got++;
            }
            (void)urb_bridge_usb_out(&r->bridge, out, got);
            break;
        }
        case 3u:
            usb_frame(r, (op >> 3) == 0u ? URB_BRIDGE_USB_BUF : 4u + 8u * (size_t)(op >> 3));
            break;
        case 4u:
            urb_hosted_rig_run(r, 50u * (uint32_t)(op >> 3));
            break;
        case 5u:
            if (next(&s, &arg)) {
                apply_faults(n1, arg);
            }
            break;
        case 6u:
            send_request(r, &s, false);
            break;
        default:
            send_request(r, &s, true);
            break;
        }
    }

    apply_faults(n1, 0u);
    urb_hosted_rig_run(r, 1000u); /* past the idle gap: a partial RS232 frame is dropped */
    for (unsigned i = 0u; i < 64u && urb_bridge_outstanding(&r->bridge) > 0u; i++) {
        usb_frame(r, URB_BRIDGE_USB_BUF); /* USB answers leave only when the host reads them */
    }
    REQUIRE(urb_hosted_rig_settle(r, SETTLE_US));
    REQUIRE(urb_bridge_outstanding(&r->bridge) == 0u);
    const urb_bridge_stats_t *const st = urb_bridge_stats(&r->bridge);
    REQUIRE(st->responses + st->window_overflow == st->frames);
    free(r);
    return 0;
}
