/*
 * Shared pieces of the uplink model tests (uplink_model.h).
 */
#include "uplink_model.h"

#include <stdlib.h>
#include <string.h>

#include "bridge_internal.h"
#include "support.h"
#include "urb_runtime.h"

/* ===== Seeded random numbers (xorshift32: the same seed gives the same inputs) =================== */

uint32_t rnd(uint32_t *s)
{
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *s = x;
    return x;
}

uint32_t below(uint32_t *s, uint32_t n)
{
    return rnd(s) % n;
}

/* ===== Requests: lengths, checks and the admitted requests ======================================= */

/* The length of the request whose first n bytes are f[0..n): 0 while more bytes are needed to tell,
 * IMPOSSIBLE for a write announcing more than 32 bytes (urb_core.h: a read is 4 bytes; a write is 3
 * header bytes, its payload and the link check over them). */
int request_len(const uint8_t *f, size_t n)
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
bool passes_check(const uint8_t *f, size_t n)
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


void admit_frame(admitted_t *a, const uint8_t *f, size_t n)
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
void expect_admitted(urb_bridge_t *b, admitted_t *a, uint8_t uplink)
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
size_t good_frame(uint32_t *s, uint8_t *f, bool longest)
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
size_t sealed_frame(uint32_t *s, uint8_t *f)
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
size_t stream_piece(uint32_t *s, uint8_t *f)
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

void expect_stats(const urb_bridge_t *b, const urb_bridge_stats_t *want)
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

/* A bridge of the rig's downlink over random memory, with `hal`; the rest of its configuration
 * default but `baud` and `idle_gap_us`. */
urb_bridge_t *bridge_over_garbage(uint32_t *s, urb_hosted_rig_t *r, const urb_bridge_hal_t *hal,
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
