/*
 * The uplink parsers (firmware/bridge/bridge_uplink.c) against reference models written from their
 * documented behaviour (urb_bridge.h, bridge_internal.h; spec/schema/README.md, "RS232
 * resynchronisation" and "USB batches"), driven with seeded random inputs and compared call by
 * call: the requests each call admits (in order, with their fields), every counter, the receive
 * ring, the bytes the RS232 assembler holds, the USB batches read back byte for byte and the
 * transmit ring's bytes and kicks. Each bridge starts over random memory (a restart without
 * zeroing), so every state the initialisation must set is checked too. Written for the mutation
 * review of the "uplink parsers" component (tests/mutation/README.md): each test kills many of its
 * generated mutants. The models are deliberately plain (the held bytes shift to the front, the
 * rings count without wrapping) so that they share no index arithmetic with the firmware.
 */
#include <stdlib.h>
#include <string.h>

#include "bridge_internal.h"
#include "support.h"
#include "urb_runtime.h"

#define MODEL_RX_RING 64u
#define MODEL_FRAMES 64u
#define IMPOSSIBLE (-1) /* request_len(): no request starts with these bytes */

/* ===== Seeded random numbers (xorshift32: the same seed gives the same inputs) =================== */

static uint32_t rnd(uint32_t *s)
{
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *s = x;
    return x;
}

static uint32_t below(uint32_t *s, uint32_t n)
{
    return rnd(s) % n;
}

/* ===== Requests: lengths, checks and the admitted requests ======================================= */

/* The length of the request whose first n bytes are f[0..n): 0 while more bytes are needed to tell,
 * IMPOSSIBLE for a write announcing more than 32 bytes (urb_core.h: a read is 4 bytes; a write is 3
 * header bytes, its payload and the link check over them). */
static int request_len(const uint8_t *f, size_t n)
{
    if (n == 0u) {
        return 0;
    }
    if ((f[0] & 1u) != 0u) {
        return (int)URB_UPLINK_READ_REQUEST_MAX_SIZE;
    }
    if (n < 3u) {
        return 0;
    }
    if (f[2] > URB_MAX_MAILBOX_SIZE) {
        return IMPOSSIBLE;
    }
    return 3 + (int)f[2] + (int)urb_link_check_size(3u + (size_t)f[2]);
}

/* True when the frame passes its check (it is then admitted, as a request or as BAD_REQUEST). */
static bool passes_check(const uint8_t *f, size_t n)
{
    int32_t r;
    if ((f[0] & 1u) != 0u) {
        urb_uplink_read_request_t q;
        r = urb_uplink_read_request_decode(&q, f, n);
    } else {
        urb_uplink_write_request_t w;
        r = urb_uplink_write_request_decode(&w, f, n);
    }
    return (r != URB_ERR_CHECKSUM) && (r != URB_ERR_SHORT) && (r != URB_ERR_LONG);
}

/* Requests a model admitted since the last comparison. */
typedef struct {
    uint8_t bytes[MODEL_FRAMES][URB_BRIDGE_FRAME_MAX];
    uint8_t len[MODEL_FRAMES];
    unsigned n;
} admitted_t;

static void admit_frame(admitted_t *a, const uint8_t *f, size_t n)
{
    assert_true(a->n < MODEL_FRAMES);
    memcpy(a->bytes[a->n], f, n);
    a->len[a->n] = (uint8_t)n;
    a->n++;
}

/* The bridge admitted exactly the model's requests, in order, from `uplink`: each ring entry's seq,
 * and for a queued request its slot's direction, address, mailbox, length and write data; a frame
 * that breaks a schema rule is answered BAD_REQUEST. Then both forget them (the test plays the
 * serving side: the bridge's queue is emptied so that it never answers BUSY). */
static void expect_admitted(urb_bridge_t *b, admitted_t *a, uint8_t uplink)
{
    if (b->ring_count != a->n) {
        print_error("the bridge admitted %u requests, the model %u\n", b->ring_count, a->n);
    }
    assert_int_equal(b->ring_count, a->n);
    for (unsigned i = 0u; i < a->n; i++) {
        urb_bridge_resp_t const e = b->ring[(b->ring_head + i) % URB_BRIDGE_RING_MAX];
        const uint8_t *f = a->bytes[i];
        bool const read = (f[0] & 1u) != 0u;
        urb_uplink_read_request_t q;
        urb_uplink_write_request_t w;
        int32_t const r = read ? urb_uplink_read_request_decode(&q, f, a->len[i])
                               : urb_uplink_write_request_decode(&w, f, a->len[i]);
        assert_int_equal(e.uplink, uplink);
        if (r < 0) {
            assert_int_equal(e.seq, f[1] >> 4);
            assert_int_equal(e.status, URB_STATUS_BAD_REQUEST);
            assert_int_equal(e.slot, URB_BRIDGE_NO_SLOT);
            continue;
        }
        assert_int_equal(e.seq, read ? q.seq : w.seq);
        if (e.slot == URB_BRIDGE_NO_SLOT) {
            assert_int_not_equal(e.status, URB_BRIDGE_PENDING);
            continue;
        }
        assert_int_equal(e.status, URB_BRIDGE_PENDING);
        urb_bridge_slot_t const *d = &b->slots[e.slot];
        assert_int_equal(d->read, read);
        assert_int_equal(d->address, read ? q.address : w.address);
        assert_int_equal(d->mailbox, read ? q.mailbox : w.mailbox);
        assert_int_equal(d->length, read ? q.length : w.length);
        if (!read) {
            assert_memory_equal(d->data, w.data, w.length);
        }
    }
    a->n = 0u;
    b->ring_head = 0u;
    b->ring_count = 0u;
    b->slot_head = 0u;
    b->slot_count = 0u;
    b->slot_served = 0u;
}

/* A well-formed read or write to a node at 8..119, a 32-byte write one time in three (always when
 * `longest`). */
static size_t good_frame(uint32_t *s, uint8_t *f, bool longest)
{
    uint8_t const address = (uint8_t)(8u + below(s, 112u));
    uint8_t const mailbox = (uint8_t)below(s, 8u);
    uint8_t const seq = (uint8_t)below(s, 16u);
    if (!longest && (below(s, 3u) == 0u)) {
        return enc_read(f, address, mailbox, seq, (uint8_t)(1u + below(s, 32u)));
    }
    uint8_t data[32];
    for (unsigned i = 0u; i < 32u; i++) {
        data[i] = (uint8_t)rnd(s);
    }
    uint8_t const len = (longest || (below(s, 3u) == 0u)) ? 32u : (uint8_t)(1u + below(s, 32u));
    return enc_write(f, address, mailbox, seq, len, data);
}

/* A frame with a valid check over random header bytes (a write's payload as long as its third byte
 * says, up to 32): a request, or one breaking a schema rule (length 0, a read of 33..255 bytes). */
static size_t sealed_frame(uint32_t *s, uint8_t *f)
{
    f[0] = (uint8_t)rnd(s);
    f[1] = (uint8_t)rnd(s);
    f[2] = (uint8_t)((below(s, 2u) == 0u) ? below(s, 33u) : rnd(s));
    size_t n = 3u;
    if ((f[0] & 1u) == 0u) {
        f[2] = (uint8_t)(f[2] % 33u);
        for (unsigned i = 0u; i < f[2]; i++) {
            f[n++] = (uint8_t)rnd(s);
        }
    }
    size_t const k = urb_link_check_size(n);
    uint32_t const c = urb_link_check(NULL, 0u, f, n);
    for (size_t i = 0u; i < k; i++) {
        f[n + i] = (uint8_t)(c >> (8u * i));
    }
    return n + k;
}

/* One piece of a stream: a request, a sealed frame, a damaged or cut request, garbage, or the
 * header of a write announcing more than 32 bytes. */
static size_t stream_piece(uint32_t *s, uint8_t *f)
{
    uint32_t const kind = below(s, 16u);
    if (kind < 7u) {
        return good_frame(s, f, false);
    }
    if (kind < 9u) {
        return sealed_frame(s, f);
    }
    if (kind < 11u) { /* a bit error */
        size_t const n = good_frame(s, f, false);
        f[below(s, (uint32_t)n)] ^= (uint8_t)(1u << below(s, 8u));
        return n;
    }
    if (kind < 13u) { /* cut short */
        size_t const n = good_frame(s, f, false);
        return 1u + below(s, (uint32_t)n - 1u);
    }
    if (kind < 15u) { /* garbage */
        size_t const n = 1u + below(s, 12u);
        for (size_t i = 0u; i < n; i++) {
            f[i] = (uint8_t)rnd(s);
        }
        return n;
    }
    f[0] = (uint8_t)(rnd(s) & 0xFEu);
    f[1] = (uint8_t)rnd(s);
    f[2] = (uint8_t)(33u + below(s, 223u));
    return 3u;
}

/* ===== The RS232 model ============================================================================ */

typedef struct {
    uint32_t gap_us; /* one byte time and the idle gap: bytes further apart are separated by a gap */
    uint16_t ring[MODEL_RX_RING];
    uint32_t ring_in, ring_out; /* bytes ever stored in and taken from the ring */
    bool overrun, started;
    uint32_t last_us;
    uint8_t held[URB_BRIDGE_FRAME_MAX + URB_BRIDGE_RX_PER_POLL];
    size_t held_len;
    bool flushing;
    urb_bridge_stats_t st;
    admitted_t admitted;
} rs232_model_t;

static void model_drop(rs232_model_t *m, size_t k)
{
    memmove(m->held, m->held + k, m->held_len - k);
    m->held_len -= k;
}

/* urb_bridge_uart_rx: the byte and whether an idle gap (or a lost byte) precedes it. */
static void model_rx(rs232_model_t *m, uint8_t byte, uint32_t t)
{
    uint16_t flag = 0u;
    if (m->started && ((uint32_t)(t - m->last_us) > m->gap_us)) {
        flag = URB_BRIDGE_RX_GAP;
    }
    m->started = true;
    m->last_us = t;
    m->st.rx_bytes++;
    if ((m->ring_in - m->ring_out) >= MODEL_RX_RING) {
        m->overrun = true;
        m->st.rx_overruns++;
        return;
    }
    if (m->overrun) {
        flag = URB_BRIDGE_RX_GAP;
        m->overrun = false;
    }
    m->ring[m->ring_in % MODEL_RX_RING] = (uint16_t)(byte | flag);
    m->ring_in++;
}

/* The held bytes, as far as they can be settled: every complete candidate costs a check (false when
 * none is left); a frame is admitted whole, anything else loses its first byte; an incomplete one
 * waits, unless `ended`: then the bytes are flushed one by one (one gap drop) until none is held. */
static bool model_settle(rs232_model_t *m, unsigned *checks, bool ended)
{
    while (m->held_len > 0u) {
        int const need = request_len(m->held, m->held_len);
        if ((need > 0) && ((size_t)need <= m->held_len)) {
            if (*checks == 0u) {
                return false;
            }
            (*checks)--;
            if (passes_check(m->held, (size_t)need)) {
                admit_frame(&m->admitted, m->held, (size_t)need);
                m->st.frames++;
                model_drop(m, (size_t)need);
                continue;
            }
            m->st.hunt_discards++;
        } else if (m->flushing || (ended && (need != IMPOSSIBLE))) {
            if (!m->flushing) {
                m->st.gap_drops++;
                m->flushing = true;
            }
        } else if (need != IMPOSSIBLE) {
            return true; /* incomplete: wait for more bytes */
        } else {
            m->st.hunt_discards++;
        }
        model_drop(m, 1u);
    }
    m->flushing = false;
    return true;
}

/* urbb_uart_parse: at most URB_BRIDGE_RX_PER_POLL ring bytes and `checks` checks. */
static void model_parse(rs232_model_t *m, uint32_t now, unsigned checks)
{
    for (unsigned taken = 0u;; taken++) {
        bool const more = (taken < URB_BRIDGE_RX_PER_POLL) && (m->ring_out != m->ring_in);
        bool ended;
        if (more) {
            ended = (m->ring[m->ring_out % MODEL_RX_RING] & URB_BRIDGE_RX_GAP) != 0u;
        } else {
            uint32_t const idle = now - m->last_us;
            ended = (taken < URB_BRIDGE_RX_PER_POLL) && (idle > m->gap_us) && (idle < 0x80000000u);
        }
        if (!model_settle(m, &checks, ended)) {
            m->st.hunt_yields++;
            return;
        }
        if (!more) {
            return;
        }
        m->held[m->held_len++] = (uint8_t)(m->ring[m->ring_out % MODEL_RX_RING] & 0xFFu);
        m->ring_out++;
    }
}

static void expect_stats(const urb_bridge_t *b, const urb_bridge_stats_t *want)
{
    const urb_bridge_stats_t *got = urb_bridge_stats(b);
    assert_int_equal(got->rx_bytes, want->rx_bytes);
    assert_int_equal(got->rx_overruns, want->rx_overruns);
    assert_int_equal(got->frames, want->frames);
    assert_int_equal(got->hunt_discards, want->hunt_discards);
    assert_int_equal(got->gap_drops, want->gap_drops);
    assert_int_equal(got->hunt_yields, want->hunt_yields);
    assert_int_equal(got->usb_batches, want->usb_batches);
    assert_int_equal(got->usb_bad_batches, want->usb_bad_batches);
    assert_int_equal(got->usb_cut_batches, want->usb_cut_batches);
    assert_int_equal(got->usb_late_reads, want->usb_late_reads);
    assert_int_equal(got->window_overflow, 0u);
}

/* The bridge's receive ring, assembler and counters are the model's. */
static void expect_rs232(urb_bridge_t *b, rs232_model_t *m)
{
    expect_stats(b, &m->st);
    uint8_t const queued = (uint8_t)(b->rx_head - b->rx_tail);
    assert_int_equal(queued, m->ring_in - m->ring_out);
    for (uint8_t k = 0u; k < queued; k++) {
        assert_int_equal(b->rx_ring[(uint8_t)(b->rx_tail + k) % URB_BRIDGE_RX_RING],
                         m->ring[(m->ring_out + k) % MODEL_RX_RING]);
    }
    assert_int_equal(b->rx_overrun != 0u, m->overrun);
    assert_int_equal(b->rs232.len, m->held_len);
    assert_true((size_t)b->rs232.start + b->rs232.len <= URB_BRIDGE_PARSE_BUF);
    assert_memory_equal(&b->rs232.buf[b->rs232.start], m->held, m->held_len);
    assert_int_equal(b->rs232.flushing, m->flushing);
    expect_admitted(b, &m->admitted, URBB_UPLINK_RS232);
}

/* A bridge of the rig's downlink over random memory, with `hal`; the rest of its configuration
 * default but `baud` and `idle_gap_us`. */
static urb_bridge_t *bridge_over_garbage(uint32_t *s, urb_hosted_rig_t *r, const urb_bridge_hal_t *hal,
                                         uint32_t baud, uint32_t idle_gap_us)
{
    urb_bridge_t *b = malloc(sizeof *b);
    assert_non_null(b);
    uint8_t *raw = (uint8_t *)b;
    for (size_t i = 0u; i < sizeof *b; i++) {
        raw[i] = (uint8_t)rnd(s);
    }
    urb_bridge_config_t cfg;
    urb_bridge_default_config(&cfg);
    cfg.heartbeat_us = 0u;
    cfg.scan_at_start = false;
    cfg.baud = baud;
    cfg.idle_gap_us = idle_gap_us;
    assert_int_equal(urb_bridge_init(b, &cfg, hal, &r->dl), URB_OK);
    return b;
}

/* The time of a poll after the last byte at `last`: at it, inside the gap, at its edge, past it,
 * before it (the interrupt stored a byte after the poll read the clock) or half the clock away. */
static uint32_t poll_time(uint32_t *s, uint32_t last, uint32_t gap)
{
    switch (below(s, 8u)) {
    case 0u:
        return last + gap;
    case 1u:
        return last + gap + 1u;
    case 2u:
        return last + gap + 1u + below(s, 3000u);
    case 3u:
        return last - 1u - below(s, 300u);
    case 4u:
        return last + ((below(s, 2u) == 0u) ? 0x7FFFFFFFu : 0x80000000u);
    default:
        return last + below(s, gap + 1u);
    }
}

/* The distance to the next byte: back to back mostly, else anywhere up to the gap, at its edge,
 * just past it or far past it. */
static uint32_t byte_spacing(uint32_t *s, uint32_t byte_us, uint32_t gap)
{
    switch (below(s, 12u)) {
    case 0u:
        return gap;
    case 1u:
        return gap + 1u;
    case 2u:
        return gap + 1u + below(s, 100000u);
    case 3u:
        return byte_us + below(s, gap - byte_us + 1u);
    default:
        return byte_us;
    }
}

static unsigned poll_budget(uint32_t *s)
{
    uint32_t const k = below(s, 8u);
    return (k < 6u) ? k : ((k == 6u) ? URB_BRIDGE_HUNT_CHECKS : 255u);
}

static const uint32_t BAUDS[4] = {115200u, 9600u, 1000000u, 460800u};
static const uint32_t IDLE_GAPS[3] = {0u, 40u, 1500u};

/* RS232: random streams of requests, damaged requests and garbage, at random times, polled at random
 * times with random budgets (bursts without polls overrun the ring), compared with the model after
 * every received byte and every poll, then drained at the end. */
static void rs232_matches_its_model(void **state)
{
    (void)state;
    uint32_t s = 0x5EED2329u;
    urb_hosted_rig_t *rig = rig_new(16u, 0u);
    unsigned frames = 0u;
    for (unsigned round = 0u; round < 48u; round++) {
        uint32_t const baud = BAUDS[round % 4u];
        uint32_t const idle_gap = IDLE_GAPS[(round / 4u) % 3u];
        uint32_t const byte_us = (10000000u + baud - 1u) / baud;
        rs232_model_t m;
        memset(&m, 0, sizeof m);
        m.gap_us = byte_us + ((idle_gap != 0u) ? idle_gap : (20000000u + baud - 1u) / baud);
        urb_bridge_t *b = bridge_over_garbage(&s, rig, &rig->hal.hal, baud, idle_gap);
        assert_int_equal(b->rx_gap_us, m.gap_us);
        expect_rs232(b, &m);
        uint32_t t = (round % 3u == 0u) ? 0xFFFFFFFFu - below(&s, 20000u) : rnd(&s);
        unsigned const pieces = 20u + below(&s, 30u);
        for (unsigned piece = 0u; piece < pieces; piece++) {
            uint8_t f[40];
            size_t const n = stream_piece(&s, f);
            bool const burst = below(&s, 10u) == 0u; /* no poll: the ring may overrun */
            bool const messy = below(&s, 3u) == 0u;  /* gaps and idle polls inside the piece */
            for (size_t i = 0u; i < n; i++) {
                t += (messy || (i == 0u)) ? byte_spacing(&s, byte_us, m.gap_us) : byte_us;
                urb_bridge_uart_rx(b, f[i], t);
                model_rx(&m, f[i], t);
                expect_rs232(b, &m);
                for (uint32_t polls = burst ? 0u : below(&s, 3u); polls > 0u; polls--) {
                    uint32_t const now = (messy || (i + 1u == n)) ? poll_time(&s, t, m.gap_us) : t;
                    unsigned const checks = poll_budget(&s);
                    urbb_uart_parse(b, now, (uint8_t)checks);
                    model_parse(&m, now, checks);
                    expect_rs232(b, &m);
                }
            }
        }
        for (unsigned i = 0u; (i < 100u) && ((m.held_len > 0u) || (m.ring_in != m.ring_out)); i++) {
            uint32_t const now = t + m.gap_us + 1u; /* idle: a partial frame is flushed */
            urbb_uart_drain(b, now);
            model_parse(&m, now, URB_BRIDGE_HUNT_CHECKS);
            expect_rs232(b, &m);
        }
        frames += m.st.frames;
        free(b);
    }
    print_message("rs232 model: %u frames\n", frames);
    assert_true(frames > 500u); /* the streams reach admission, not only the hunting */
    rig_free(rig);
}

/* RS232: 1 to 70 bytes queued back to back without a poll (requests, then a cut one; past 64 the
 * ring overruns), then polls on an idle line until all is settled: the byte cap per poll meets the
 * idle flush at every position, the longest frames meet the budget, compared after every poll. */
static void rs232_queued_bytes_then_idle_polls(void **state)
{
    (void)state;
    uint32_t s = 0x0DDBA11u;
    urb_hosted_rig_t *rig = rig_new(16u, 0u);
    for (unsigned q = 1u; q <= 70u; q++) {
        for (unsigned variant = 0u; variant < 3u; variant++) {
            rs232_model_t m;
            memset(&m, 0, sizeof m);
            urb_bridge_t *b = bridge_over_garbage(&s, rig, &rig->hal.hal, 115200u, 0u);
            m.gap_us = b->rx_gap_us;
            uint8_t bytes[80];
            size_t n = 0u;
            while (n < q) {
                uint8_t f[40];
                size_t const k = (variant == 2u) ? stream_piece(&s, f) : good_frame(&s, f, variant == 0u);
                size_t const take = (n + k <= q) ? k : q - n;
                memcpy(bytes + n, f, take);
                n += take;
            }
            uint32_t t = rnd(&s);
            for (size_t i = 0u; i < n; i++) {
                t += BYTE_US;
                urb_bridge_uart_rx(b, bytes[i], t);
                model_rx(&m, bytes[i], t);
            }
            expect_rs232(b, &m);
            for (unsigned poll = 0u; (poll < 40u) && ((m.held_len > 0u) || (m.ring_in != m.ring_out)); poll++) {
                uint32_t const now = t + m.gap_us + 1u + poll;
                unsigned const checks = (poll % 2u == 0u) ? URB_BRIDGE_HUNT_CHECKS : 255u;
                urbb_uart_parse(b, now, (uint8_t)checks);
                model_parse(&m, now, checks);
                expect_rs232(b, &m);
            }
            assert_int_equal(m.held_len, 0u);
            assert_int_equal(m.ring_in, m.ring_out);
            free(b);
        }
    }
    rig_free(rig);
}

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

int run_uplink_model_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(rs232_matches_its_model),
        cmocka_unit_test(rs232_queued_bytes_then_idle_polls),
        cmocka_unit_test(usb_matches_its_model),
        cmocka_unit_test(usb_transfers_cut_at_every_length),
        cmocka_unit_test(uart_tx_matches_its_model),
    };
    return cmocka_run_group_tests_name("bridge_uplink_model", tests, NULL, NULL);
}
