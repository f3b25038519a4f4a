/*
 * The USB batch parser, the response batches and the UART transmit ring (firmware/bridge/
 * bridge_uplink.c) against reference models written from their documented behaviour (urb_bridge.h,
 * bridge_internal.h; spec/schema/README.md "USB batches"; spec/tla/UsbUplink.tla), driven with
 * seeded random inputs and compared call by call: return values, the requests each transfer admits,
 * the batches read back byte for byte (nothing written past them), the transmitted bytes and the
 * kicks, every counter. Each bridge starts over random memory. Written for the mutation review of
 * the "uplink parsers" component (tests/mutation/README.md).
 */
#include <stdlib.h>
#include <string.h>

#include "bridge_internal.h"
#include "support.h"
#include "uplink_model.h"
#include "urb_runtime.h"

/* ===== The USB model =============================================================================== */

typedef struct {
    uint8_t data[URB_BRIDGE_USB_BUF]; /* responses after the 4 header bytes */
    size_t len;                       /* header included */
    unsigned count;
    uint16_t frame;
} model_batch_t;

typedef struct {
    model_batch_t batch[2];
    unsigned cur;
    bool prev_ready;
    uint16_t last_frame;
    urb_bridge_stats_t st;
    admitted_t admitted;
} usb_model_t;

static void model_usb_init(usb_model_t *m)
{
    memset(m, 0, sizeof *m);
    m->batch[0].len = URB_USB_BATCH_HEADER_MAX_SIZE;
    m->batch[1].len = URB_USB_BATCH_HEADER_MAX_SIZE;
}

/* urb_bridge_usb_out: a transfer with a good header is accepted; its frames are admitted in order up
 * to the first that is cut short or fails its check, which drops the rest. */
static bool model_usb_out(usb_model_t *m, const uint8_t *data, size_t len)
{
    urb_usb_batch_header_t h;
    if ((data == NULL) || (len < 4u) || (len > URB_BRIDGE_USB_BUF) || (urb_usb_batch_header_decode(&h, data, 4u) < 0)) {
        m->st.usb_bad_batches++;
        return false;
    }
    m->st.usb_batches++;
    m->last_frame = h.frame;
    m->batch[m->cur].frame = h.frame;
    for (size_t at = 4u; at < len;) {
        int const need = request_len(data + at, len - at);
        if ((need <= 0) || ((size_t)need > len - at) || !passes_check(data + at, (size_t)need)) {
            m->st.usb_cut_batches++;
            break;
        }
        admit_frame(&m->admitted, data + at, (size_t)need);
        m->st.frames++;
        at += (size_t)need;
    }
    return true;
}

/* urb_bridge_usb_sof: the current batch becomes the one to read, unless the previous one still holds
 * unread responses (then both stay, and the frame counts as a late read). */
static void model_usb_sof(usb_model_t *m)
{
    unsigned const next = m->cur ^ 1u;
    if (m->prev_ready && (m->batch[next].count != 0u)) {
        m->st.usb_late_reads++;
        return;
    }
    m->prev_ready = true;
    m->cur = next;
    m->batch[next].len = URB_USB_BATCH_HEADER_MAX_SIZE;
    m->batch[next].count = 0u;
    m->batch[next].frame = m->last_frame;
}

static size_t model_usb_in(usb_model_t *m, uint8_t *buf, size_t cap)
{
    model_batch_t const *p = &m->batch[m->cur ^ 1u];
    if (!m->prev_ready || (buf == NULL) || (cap < p->len)) {
        return 0u;
    }
    urb_usb_batch_header_t const h = {p->frame, (uint8_t)p->count};
    assert_int_equal(urb_usb_batch_header_encode(&h, buf, 4u), 4);
    memcpy(buf + 4, p->data, p->len - 4u);
    m->prev_ready = false;
    return p->len;
}

static bool model_usb_send(usb_model_t *m, const uint8_t *f, size_t len)
{
    model_batch_t *c = &m->batch[m->cur];
    if ((c->len + len > URB_BRIDGE_USB_BUF) || (c->count >= 128u)) {
        return false;
    }
    memcpy(c->data + (c->len - 4u), f, len);
    c->len += len;
    c->count++;
    return true;
}

/* A USB OUT transfer: a header (its check or count sometimes wrong), then pieces back to back, the
 * last sometimes cut by the transfer's end; now and then exactly or one byte over the largest
 * transfer, or shorter than a header. Returns its length. */
static size_t usb_transfer(uint32_t *s, uint8_t *out, size_t cap)
{
    urb_usb_batch_header_t h = {(uint16_t)rnd(s), (uint8_t)below(s, 129u)};
    assert_int_equal(urb_usb_batch_header_encode(&h, out, 4u), 4);
    uint32_t const shape = below(s, 16u);
    if (shape == 0u) {
        out[below(s, 4u)] ^= (uint8_t)(1u << below(s, 8u)); /* a header failing its check */
    } else if (shape == 1u) {
        out[2] = (uint8_t)(129u + below(s, 127u)); /* a count over 128 under a good check */
        uint32_t const c = urb_link_check(NULL, 0u, out, 3u);
        out[3] = (uint8_t)c;
    }
    size_t n = 4u;
    size_t const want = (shape == 2u) ? cap : (shape == 3u) ? below(s, 4u) : 4u + below(s, (uint32_t)cap - 4u);
    /* at most 28 requests, so that the response ring (32) never overflows: then the longest ones */
    for (unsigned pieces = 0u; n < want; pieces++) {
        uint8_t f[40];
        size_t const k = (pieces >= 28u) ? good_frame(s, f, true)
                         : (below(s, 6u) == 0u) ? stream_piece(s, f) : good_frame(s, f, false);
        size_t const take = (n + k <= want) ? k : want - n;
        memcpy(out + n, f, take);
        n += take;
    }
    return (shape == 3u) ? want : n;
}

/* The transfer in a buffer of exactly its length (ASan sees any read past it). */
static bool usb_out_exact(urb_bridge_t *b, const uint8_t *data, size_t len)
{
    uint8_t *copy = malloc((len == 0u) ? 1u : len);
    assert_non_null(copy);
    memcpy(copy, data, len);
    bool const ok = urb_bridge_usb_out(b, copy, len);
    free(copy);
    return ok;
}

/* USB: random OUT transfers, start-of-frame ticks, IN transfers into buffers of random capacity and
 * responses queued on USB, compared with the model after every call: return values, the requests
 * admitted, the batch bytes read back (header with frame and count, then the responses), nothing
 * written past the length returned, every counter. */
static void usb_matches_its_model(void **state)
{
    (void)state;
    uint32_t s = 0xB0B5EEDu;
    urb_hosted_rig_t *rig = rig_new(16u, 0u);
    unsigned frames = 0u;
    unsigned reads = 0u;
    unsigned full = 0u;
    unsigned counted_full = 0u; /* refused for their number, not their bytes */
    for (unsigned round = 0u; round < 24u; round++) {
        usb_model_t m;
        model_usb_init(&m);
        urb_bridge_t *b = bridge_over_garbage(&s, rig, &rig->hal.hal, 115200u, 0u);
        uint32_t const sends = 2u + round % 5u;
        bool const shortest = (round % 3u) == 0u; /* status-only responses, few ticks: 128 fill a batch */
        for (unsigned op = 0u; op < 150u; op++) {
            uint32_t what = below(&s, 10u);
            if (shortest && (what >= 2u) && (what < 4u) && (below(&s, 4u) != 0u)) {
                what = 9u;
            }
            if (what < 2u) {
                uint8_t t[URB_BRIDGE_USB_BUF + 1u];
                size_t const cap = (below(&s, 8u) == 0u) ? sizeof t : URB_BRIDGE_USB_BUF;
                size_t const n = usb_transfer(&s, t, cap);
                bool const null_data = below(&s, 40u) == 0u;
                bool const want = model_usb_out(&m, null_data ? NULL : t, n);
                assert_int_equal(null_data ? urb_bridge_usb_out(b, NULL, n) : usb_out_exact(b, t, n), want);
                expect_admitted(b, &m.admitted, URBB_UPLINK_USB);
            } else if (what < 4u) {
                urb_bridge_usb_sof(b);
                model_usb_sof(&m);
            } else if (what < 6u) {
                size_t const len = m.batch[m.cur ^ 1u].len;
                uint32_t const pick = below(&s, 6u);
                size_t const cap = (pick == 0u) ? len - 1u : (pick == 1u) ? len : (pick == 2u) ? len + 1u
                                 : (pick == 3u) ? 0u : URB_BRIDGE_USB_BUF;
                uint8_t *buf = (below(&s, 30u) == 0u) ? NULL : malloc(cap + 1u);
                uint8_t want[URB_BRIDGE_USB_BUF];
                if (buf != NULL) {
                    memset(buf, 0xEE, cap + 1u);
                }
                size_t const got = urb_bridge_usb_in(b, buf, cap);
                size_t const expect = model_usb_in(&m, (buf == NULL) ? NULL : want, cap);
                assert_int_equal(got, expect);
                if (buf != NULL) {
                    assert_memory_equal(buf, want, got);
                    for (size_t i = got; i <= cap; i++) {
                        assert_int_equal(buf[i], 0xEE);
                    }
                    free(buf);
                }
                reads += (got > 4u) ? 1u : 0u;
            } else {
                for (uint32_t k = below(&s, sends * 6u); k > 0u; k--) {
                    uint8_t f[URB_UPLINK_RESPONSE_MAX_SIZE];
                    size_t const len = shortest ? 2u : (below(&s, 4u) == 0u) ? sizeof f : 2u + below(&s, sizeof f - 1u);
                    for (size_t i = 0u; i < len; i++) {
                        f[i] = (uint8_t)rnd(&s);
                    }
                    bool const want = model_usb_send(&m, f, len);
                    assert_int_equal(urbb_uplink_send(b, URBB_UPLINK_USB, f, (uint8_t)len), want);
                    full += want ? 0u : 1u;
                    counted_full += (!want && (m.batch[m.cur].count == 128u)) ? 1u : 0u;
                }
            }
            expect_stats(b, &m.st);
        }
        frames += m.st.frames;
        free(b);
    }
    print_message("usb model: %u frames, %u batches read, %u responses refused (%u at 128)\n", frames, reads, full,
                  counted_full);
    assert_true(frames > 500u);
    assert_true(reads > 100u);
    assert_true(full > 20u);
    assert_true(counted_full > 0u);
    rig_free(rig);
}

/* USB: transfers of requests ending in a longest write (37 bytes) and in every other kind of frame,
 * cut at every length from the bare header to the whole, each in a buffer of exactly its length. */
static void usb_transfers_cut_at_every_length(void **state)
{
    (void)state;
    uint32_t s = 0xC0705EEDu;
    urb_hosted_rig_t *rig = rig_new(16u, 0u);
    for (unsigned shape = 0u; shape < 6u; shape++) {
        usb_model_t m;
        model_usb_init(&m);
        urb_bridge_t *b = bridge_over_garbage(&s, rig, &rig->hal.hal, 115200u, 0u);
        uint8_t t[URB_BRIDGE_USB_BUF];
        urb_usb_batch_header_t const h = {(uint16_t)rnd(&s), 3u};
        assert_int_equal(urb_usb_batch_header_encode(&h, t, 4u), 4);
        size_t n = 4u;
        for (unsigned k = 0u; k < 3u; k++) {
            uint8_t f[40];
            size_t const len = (shape < 2u) ? good_frame(&s, f, (k == 2u) || (shape == 0u)) : sealed_frame(&s, f);
            memcpy(t + n, f, len);
            n += len;
        }
        for (size_t len = 0u; len <= n; len++) {
            bool const want = model_usb_out(&m, t, len);
            assert_int_equal(usb_out_exact(b, t, len), want);
            expect_admitted(b, &m.admitted, URBB_UPLINK_USB);
            expect_stats(b, &m.st);
        }
        free(b);
    }
    rig_free(rig);
}

/* ===== The UART transmit ring ====================================================================== */

/* A HAL whose transmit kick takes a random number of the queued bytes at once (as an interrupt
 * would), recording them. */
typedef struct {
    urb_bridge_hal_t hal;
    urb_bridge_t *bridge;
    uint32_t seed;
    uint32_t kicks;
    uint32_t kick_most; /* bytes a kick takes at most */
    uint8_t sent[8192];
    size_t sent_len;
} tx_hal_t;

static uint32_t tx_now(void *ctx)
{
    (void)ctx;
    return 0u;
}

static void tx_heartbeat(void *ctx, uint32_t period_us)
{
    (void)ctx;
    (void)period_us;
}

static void drain(tx_hal_t *h, uint32_t most)
{
    uint8_t byte;
    for (uint32_t i = 0u; (i < most) && urb_bridge_uart_tx_pop(h->bridge, &byte); i++) {
        assert_true(h->sent_len < sizeof h->sent);
        h->sent[h->sent_len++] = byte;
    }
}

static void tx_kick(void *ctx)
{
    tx_hal_t *h = ctx;
    h->kicks++;
    drain(h, (h->kick_most == 1000u) ? 1000u : below(&h->seed, h->kick_most + 1u));
}

/* RS232 responses: random lengths queued while the kick and the test take random numbers of bytes;
 * a response is queued whole exactly when the ring has room for it, each queued response kicks the
 * HAL once with its bytes visible, and the bytes come out in order, each once. */
static void uart_tx_matches_its_model(void **state)
{
    (void)state;
    uint32_t s = 0x7AC0FFEEu;
    urb_hosted_rig_t *rig = rig_new(16u, 0u);
    tx_hal_t *h = calloc(1u, sizeof *h);
    assert_non_null(h);
    h->hal.ctx = h;
    h->hal.now_us = tx_now;
    h->hal.heartbeat_period = tx_heartbeat;
    h->hal.uart_tx_kick = tx_kick;
    h->seed = 0x1234567u;
    unsigned refused = 0u;
    for (unsigned round = 0u; round < 8u; round++) {
        h->bridge = bridge_over_garbage(&s, rig, &h->hal, 115200u, 0u);
        h->sent_len = 0u;
        h->kicks = 0u;
        h->kick_most = (round % 3u == 0u) ? 0u : (round % 3u == 1u) ? 40u : 1000u; /* 1000: all there is */
        uint8_t want[8192];
        size_t want_len = 0u;
        size_t queued = 0u; /* bytes in the ring: queued, not yet taken */
        uint32_t kicks = 0u;
        uint8_t none;
        assert_false(urb_bridge_uart_tx_pop(h->bridge, &none));
        for (unsigned op = 0u; op < 160u; op++) {
            uint8_t f[URB_UPLINK_RESPONSE_MAX_SIZE];
            size_t const len = 1u + below(&s, sizeof f);
            for (size_t i = 0u; i < len; i++) {
                f[i] = (uint8_t)rnd(&s);
            }
            queued = want_len - h->sent_len;
            bool const fits = queued + len <= URB_BRIDGE_TX_RING;
            size_t const before = h->sent_len;
            assert_int_equal(urbb_uplink_send(h->bridge, URBB_UPLINK_RS232, f, (uint8_t)len), fits);
            if (fits) {
                memcpy(want + want_len, f, len);
                want_len += len;
                kicks++;
                assert_true(want_len <= sizeof want);
                if (h->kick_most == 1000u) {
                    assert_int_equal(h->sent_len, want_len); /* the kick saw the whole response */
                }
            } else {
                refused++;
                assert_int_equal(h->sent_len, before);
            }
            assert_int_equal(h->kicks, kicks);
            if (below(&s, 3u) == 0u) {
                drain(h, below(&s, 80u));
            }
            assert_true(h->sent_len <= want_len);
            assert_memory_equal(h->sent, want, h->sent_len);
            if (want_len > 6000u) {
                break;
            }
        }
        drain(h, 10000u);
        assert_int_equal(h->sent_len, want_len);
        assert_memory_equal(h->sent, want, want_len);
        assert_false(urb_bridge_uart_tx_pop(h->bridge, &none));
        free(h->bridge);
    }
    assert_true(refused > 20u);
    free(h);
    rig_free(rig);
}

int run_usb_model_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(usb_matches_its_model),
        cmocka_unit_test(usb_transfers_cut_at_every_length),
        cmocka_unit_test(uart_tx_matches_its_model),
    };
    return cmocka_run_group_tests_name("bridge_usb_model", tests, NULL, NULL);
}
