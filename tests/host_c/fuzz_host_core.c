/*
 * libFuzzer target of the host library's receive paths: the RS232 byte stream (built as
 * fuzz_host_rs232) or the USB batches (built with -DFUZZ_USB as fuzz_host_usb) of the protocol core
 * (host/c/core). The input is a script: submissions of reads and writes, time steps, sending,
 * responses to requests in flight (right or corrupted), raw garbage, deliveries in any chunking
 * (on USB: whole IN transfers with a good or a bad header), polls, and the rare link loss, reset,
 * drain, hand-over and window change.
 *
 * Oracle, checked as the script runs and at its end:
 *   - every submitted request completes exactly once (at the end the link is lost, which completes
 *     whatever is left), with at most one flag, and the core never hands back what it was not given;
 *   - matches are by sequence number: a completion carrying a bridge status is exactly a response
 *     frame that was received (its sequence number, status and data, check included, appear in the
 *     received bytes): the core never invents an answer nor gives one request another's;
 *   - requests go out in submission order with sequence numbers 1, 2, ... mod 16, never more than the
 *     window in flight; responses are matched in sending order (a timeout may complete a request
 *     before an earlier one whose clock started after a long answer, so only matches are ordered);
 *   - ASan and UBSan see no memory error and no undefined behaviour.
 * Any violation aborts (the fuzzer reports a crash).
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "urb_core.h"
#include "urb_host_core.h"

#ifdef FUZZ_USB
#define KIND URB_LINK_USB
#else
#define KIND URB_LINK_RS232
#endif

#define POOL 48u
#define HISTORY 65536u

#define REQUIRE(c, what)                                                                                              \
    do {                                                                                                              \
        if (!(c)) {                                                                                                   \
            (void)fprintf(stderr, "fuzz_host_core: %s (%s:%d)\n", what, __FILE__, __LINE__);                          \
            abort();                                                                                                  \
        }                                                                                                             \
    } while (0)

typedef struct {
    const uint8_t *p;
    size_t n;
} input_t;

static uint8_t next(input_t *in)
{
    if (in->n == 0u) {
        return 0u;
    }
    in->n--;
    return *in->p++;
}

static urb_core_t core;
static urb_transfer_t pool[POOL];
static unsigned completions[POOL];
static bool submitted[POOL];
static uint32_t send_index[POOL];     /* 1 + the order in which it was sent (0: never) */
static uint32_t submit_index[POOL];  /* the order in which it was submitted */
static uint32_t submit_count;
static uint32_t sent_count;
static uint32_t last_completed_send;
static uint8_t history[HISTORY];      /* every byte received (USB: the bodies), for the match oracle */
static size_t history_len;
static uint8_t stream[HISTORY];       /* bytes waiting to be delivered */
static size_t stream_len;
static urb_ns_t now;

static bool in_history(const uint8_t *frame, size_t n)
{
    for (size_t i = 0u; i + n <= history_len; i++) {
        if (memcmp(history + i, frame, n) == 0) {
            return true;
        }
    }
    return false;
}

static void take(void)
{
    urb_transfer_t *t;
    while ((t = urb_core_take_completed(&core)) != NULL) {
        REQUIRE((t >= pool) && (t < pool + POOL), "a completion that was never submitted");
        size_t const i = (size_t)(t - pool);
        REQUIRE(submitted[i], "a completion of a transfer not submitted");
        completions[i]++;
        REQUIRE(completions[i] == 1u, "a request completed twice");
        submitted[i] = false;
        REQUIRE((t->flags & (t->flags - 1u)) == 0u, "more than one flag");
        REQUIRE((t->flags & ~URB_FLAG_ALL) == 0u, "an unknown flag");
        if (t->status >= 0) { /* a matched response: it must be one that came, with this number */
            REQUIRE(send_index[i] > last_completed_send, "responses matched out of sending order");
            last_completed_send = send_index[i];
            REQUIRE(t->seq >= 0, "a response to a request never sent");
            urb_uplink_response_t r;
            memset(&r, 0, sizeof r);
            r.seq = (uint8_t)t->seq;
            r.status = (uint8_t)t->status;
            memcpy(r.data, t->response, t->response_len);
            r.data_len = t->response_len;
            uint8_t frame[URB_RESPONSE_MAX];
            int32_t const n = urb_uplink_response_encode(&r, frame, sizeof frame);
            REQUIRE(n > 0, "a completion no frame can carry");
            REQUIRE(in_history(frame, (size_t)n), "a response that was never received");
            REQUIRE(urb_flags_from_status((uint8_t)t->status) == t->flags, "flags differ from the status");
            REQUIRE((t->response_len == 0u) || (t->read && (t->status == 0) && (t->response_len == t->length)),
                    "data on a response that carries none");
        } else {
            REQUIRE((t->flags & URB_FLAG_BRIDGE) == 0u, "a bridge status without a response");
        }
    }
}

static void check_sent(const uint8_t *frame, size_t n)
{
    /* the request just put in flight carries the next number: 1, 2, ... mod 16 */
    uint8_t const expected = (uint8_t)((sent_count + 1u) % URB_SEQ_MOD);
    size_t found = POOL;
    for (size_t i = 0u; i < POOL; i++) {
        urb_transfer_t const *t = &pool[i];
        if (submitted[i] && (send_index[i] == 0u) && (t->state == URB_XFER_IN_FLIGHT) && (t->seq == (int8_t)expected)) {
            found = i;
        }
    }
    REQUIRE(found < POOL, "a frame for no request, or sequence numbers not 1, 2, ... mod 16");
    urb_transfer_t const *t = &pool[found];
    for (size_t i = 0u; i < POOL; i++) { /* sent in submission order: nothing submitted before it waits */
        REQUIRE(!(submitted[i] && (pool[i].state == URB_XFER_QUEUED) && (submit_index[i] < submit_index[found])),
                "a request overtook an earlier one");
    }
    sent_count++;
    send_index[found] = sent_count;
    REQUIRE(n == urb_transfer_request_size(t), "a frame of the wrong size");
    REQUIRE((frame[0] >> 1) == t->address, "a frame for another address");
    REQUIRE((frame[1] & 0x07u) == t->mailbox, "a frame for another mailbox");
    REQUIRE((frame[1] >> 4) == (uint8_t)t->seq, "a frame with another sequence number");
    REQUIRE(urb_core_in_flight(&core) <= core.cfg.window, "more in flight than the window");
}

static void submit(input_t *in, bool read)
{
    size_t i = 0u;
    while ((i < POOL) && (submitted[i] || (completions[i] > 0u && pool[i].state != URB_XFER_DONE))) {
        i++;
    }
    if (i == POOL) {
        return;
    }
    uint8_t const addr = (uint8_t)(next(in) & 0x7Fu);
    uint8_t const box = (uint8_t)(next(in) & 7u);
    uint8_t const len = (uint8_t)(1u + next(in) % URB_HOST_MAILBOX_MAX);
    uint8_t data[URB_HOST_MAILBOX_MAX];
    for (size_t k = 0u; k < len; k++) {
        data[k] = next(in);
    }
    urb_transfer_t *t = &pool[i];
    REQUIRE((read ? urb_transfer_read(t, addr, box, len) : urb_transfer_write(t, addr, box, data, len)) == URB_HOST_OK,
            "a valid request refused");
    if ((next(in) & 0x1Fu) == 0u) {
        (void)urb_transfer_set_answer_within(t, URB_SCAN_ANSWER_NS);
    }
    REQUIRE(urb_core_submit(&core, t, now) == URB_HOST_OK, "a submission refused");
    submitted[i] = true;
    submit_index[i] = ++submit_count;
    completions[i] = 0u;
    send_index[i] = 0u;
}

static void send_frames(void)
{
    uint8_t buf[URB_USB_BATCH_MAX];
#ifdef FUZZ_USB
    int32_t const n = urb_core_frame_out(&core, now, buf, sizeof buf);
    REQUIRE(n >= 0, "frame_out failed");
    if (n == 0) {
        return;
    }
    urb_usb_batch_header_t h;
    REQUIRE(urb_usb_batch_header_decode(&h, buf, URB_USB_HEADER_SIZE) == 4, "a bad batch header");
    REQUIRE(h.count <= core.cfg.max_batch, "more than max_batch in a batch");
    REQUIRE((size_t)n <= core.cfg.batch_bytes, "a batch over batch_bytes");
    size_t off = URB_USB_HEADER_SIZE;
    for (uint8_t k = 0u; k < h.count; k++) {
        size_t const len = ((buf[off] & 1u) != 0u) ? 4u
                                                   : 3u + buf[off + 2u] + ((3u + buf[off + 2u] <= 14u) ? 1u : 2u);
        check_sent(buf + off, len);
        off += len;
    }
    REQUIRE(off == (size_t)n, "a batch with bytes beyond its count");
#else
    int32_t n;
    while ((n = urb_core_next_frame(&core, now, buf, sizeof buf)) > 0) {
        check_sent(buf, (size_t)n);
    }
    REQUIRE(n == 0, "next_frame failed");
#endif
}

static void add_bytes(const uint8_t *b, size_t n)
{
    if (history_len + stream_len + n <= sizeof history) { /* every delivered byte stays in the history */
        memcpy(stream + stream_len, b, n);
        stream_len += n;
    }
}

static void respond(input_t *in)
{
    uint32_t const count = core.m.count;
    if (count == 0u) {
        return;
    }
    urb_slot_t const *s = &core.m.slot[(core.m.head + next(in) % count) % URB_MAX_WINDOW];
    urb_uplink_response_t r;
    memset(&r, 0, sizeof r);
    r.seq = s->seq;
    r.status = (uint8_t)(next(in) % 9u);
    if (s->read && (r.status == 0u)) {
        for (size_t k = 0u; k < s->length; k++) {
            r.data[k] = next(in);
        }
        r.data_len = s->length;
    }
    uint8_t frame[URB_RESPONSE_MAX];
    int32_t const n = urb_uplink_response_encode(&r, frame, sizeof frame);
    REQUIRE(n > 0, "cannot encode a response");
    uint8_t const flip = next(in);
    if (flip < 24u) { /* now and then a corrupted bit */
        frame[(size_t)flip % (size_t)n] ^= (uint8_t)(1u << (flip % 8u));
    }
    add_bytes(frame, (size_t)n);
}

static void deliver(input_t *in)
{
#ifdef FUZZ_USB
    uint8_t batch[HISTORY + URB_USB_HEADER_SIZE];
    uint8_t const how = next(in);
    urb_usb_batch_header_t h = {(uint16_t)(next(in) | (next(in) << 8)), (uint8_t)(how & 0x7Fu)};
    (void)urb_usb_batch_header_encode(&h, batch, URB_USB_HEADER_SIZE);
    if ((how & 0x80u) != 0u) {
        batch[3] ^= 0x5Au; /* a header that fails its check */
    }
    memcpy(batch + URB_USB_HEADER_SIZE, stream, stream_len);
    if (history_len + stream_len <= sizeof history) {
        memcpy(history + history_len, stream, stream_len);
        history_len += stream_len;
    }
    REQUIRE(urb_core_receive_batch(&core, batch, URB_USB_HEADER_SIZE + stream_len, now) == URB_HOST_OK,
            "receive_batch refused");
    stream_len = 0u;
#else
    size_t off = 0u;
    while (off < stream_len) {
        size_t chunk = 1u + next(in) % 12u;
        if (chunk > stream_len - off) {
            chunk = stream_len - off;
        }
        if (history_len + chunk <= sizeof history) {
            memcpy(history + history_len, stream + off, chunk);
            history_len += chunk;
        }
        REQUIRE(urb_core_receive(&core, stream + off, chunk, now) == URB_HOST_OK, "receive refused");
        off += chunk;
        take();
    }
    stream_len = 0u;
#endif
}

static const urb_ns_t steps[8] = {0, 1000, 100000, URB_NS_PER_MS, 20 * URB_NS_PER_MS, 60 * URB_NS_PER_MS,
                                  150 * URB_NS_PER_MS, 600 * URB_NS_PER_MS};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    input_t in = {data, size};
    urb_core_config_t cfg;
    urb_core_default_config(&cfg, KIND);
    cfg.window = (uint8_t)(1u + next(&in) % URB_MAX_WINDOW);
    cfg.max_batch = (uint8_t)(1u + next(&in) % URB_MAX_WINDOW);
    cfg.lost_after_timeouts = 1u + next(&in) % 9u;
    REQUIRE(urb_core_init(&core, KIND, &cfg) == URB_HOST_OK, "init refused the defaults");
    memset(pool, 0, sizeof pool);
    memset(completions, 0, sizeof completions);
    memset(submitted, 0, sizeof submitted);
    memset(send_index, 0, sizeof send_index);
    sent_count = 0u;
    submit_count = 0u;
    last_completed_send = 0u;
    history_len = 0u;
    stream_len = 0u;
    now = 0;
    while (in.n > 0u) {
        uint8_t const op = next(&in);
        switch (op % 10u) {
        case 0u: submit(&in, true); break;
        case 1u: submit(&in, false); break;
        case 2u: now += steps[next(&in) % 8u]; break;
        case 3u: send_frames(); break;
        case 4u: respond(&in); break;
        case 5u: {
            uint8_t garbage[16];
            size_t const n = next(&in) % 16u;
            for (size_t k = 0u; k < n; k++) {
                garbage[k] = next(&in);
            }
            add_bytes(garbage, n);
            break;
        }
        case 6u: deliver(&in); break;
        case 7u: REQUIRE(urb_core_poll(&core, now) == URB_HOST_OK, "poll refused"); break;
        case 8u: {
            uint8_t const what = next(&in);
            if (what % 5u == 0u) {
                urb_core_link_lost(&core, now, "fuzz: I/O error");
            } else if (what % 5u == 1u) {
                urb_core_reset(&core, now);
            } else if (what % 5u == 2u) {
                (void)urb_core_start_drain(&core, now);
            } else if (what % 5u == 3u) {
                urb_core_hand_over(&core, now + steps[what % 8u]);
            } else {
                REQUIRE(urb_core_set_window(&core, (uint8_t)(1u + (what >> 4) % URB_MAX_WINDOW)) == URB_HOST_OK,
                        "set_window refused");
            }
            break;
        }
        default: break;
        }
        take();
        REQUIRE(urb_core_in_flight(&core) <= URB_MAX_WINDOW, "more than 15 in flight");
        urb_ns_t const d = urb_core_next_deadline(&core);
        REQUIRE((d == URB_NEVER) || (d >= 0), "a deadline before time began");
    }
    urb_core_link_lost(&core, now, "fuzz: end of input"); /* whatever is left completes now */
    take();
    for (size_t i = 0u; i < POOL; i++) {
        REQUIRE(!submitted[i], "a request that never completed");
    }
    return 0;
}
