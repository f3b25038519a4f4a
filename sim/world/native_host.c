/*
 * native_host.c: a native model of the host's periodic traffic, for speed (benchmarks, large
 * scenario sweeps): the same uplink frames the host library sends (sequence numbers, one write()
 * per RS232 frame, one USB batch per tick with its frame counter), response matching by order and
 * sequence number, latency and timeout accounting. It runs on the same host CPU model (the OS tick
 * timer of world.c) but never returns control to Python, so a world driven by it runs at the
 * speed of the C core. The host library (sim/urb_sim, SimManager) remains the reference for
 * API-level behaviour; this model does not retransmit, rediscover or reconnect.
 */
#include "native_host.h"

#include <string.h>

#include "urb_core.h"

static size_t check_size(size_t covered)
{
    return covered <= 14u ? 1u : 2u;
}

void nh_init(nh_bridge_t *h, int bridge, int usb, uint32_t period_ticks)
{
    memset(h, 0, sizeof *h);
    h->bridge = bridge;
    h->usb = usb;
    h->period = period_ticks ? period_ticks : 1u;
    h->frame = 1u;
    h->lat_min = UINT64_MAX;
#if defined(URBSIM_MUTANT_UNINIT_SEQ) && defined(__SANITIZE_ADDRESS__)
    /* seeded bug (tools/sim_sanitized.py): the first sequence number read from memory never
     * written, which the builds fill differently (zeros from the system, ASan's 0xbe bytes); here
     * deterministically, so that the comparison of the two builds' traces is shown to fail */
    h->seq = 0xBEBEBEBEu;
#endif
}

int nh_add(nh_bridge_t *h, uint8_t address, uint8_t mailbox, bool read, uint8_t length, uint32_t every)
{
    if (h->n_reqs >= NH_MAX_REQS || length < 1u || length > 32u || mailbox > 7u) {
        return -1;
    }
    nh_req_t *r = &h->reqs[h->n_reqs++];
    r->address = address;
    r->mailbox = mailbox;
    r->read = read;
    r->length = length;
    r->every = every ? every : 1u;
    return 0;
}

/* Encode one request with the next sequence number and remember it; 0 when the window is full. */
static size_t encode(nh_bridge_t *h, const nh_req_t *r, uint8_t *buf, size_t cap, uint64_t now)
{
    if (h->pend_len >= NH_WINDOW) {
        h->skipped++; /* the host library would keep it queued; the model counts it as a miss */
        return 0;
    }
    int32_t n;
    uint8_t seq = (uint8_t)(h->seq & 15u);
    if (r->read) {
        urb_uplink_read_request_t m = {r->address, r->mailbox, seq, r->length};
        n = urb_uplink_read_request_encode(&m, buf, cap);
    } else {
        urb_uplink_write_request_t m;
        memset(&m, 0, sizeof m);
        m.address = r->address;
        m.mailbox = r->mailbox;
        m.seq = seq;
        m.length = r->length;
        for (uint8_t i = 0; i < r->length; i++) {
            m.data[i] = (uint8_t)(h->cycle + i);
        }
        n = urb_uplink_write_request_encode(&m, buf, cap);
    }
    if (n <= 0) {
        return 0;
    }
    h->seq++;
    nh_pending_t *p = &h->pend[(h->pend_head + h->pend_len) % NH_WINDOW];
    p->seq = seq;
    p->read = r->read;
    p->length = r->length;
    p->submitted = now;
    h->pend_len++;
    h->sent++;
    return (size_t)n;
}

size_t nh_cycle(nh_bridge_t *h, uint64_t now, uint8_t *out, size_t cap, size_t *frame_ends, uint32_t *n_frames)
{
    *n_frames = 0;
    if (h->tick++ % h->period != 0u) {
        if (h->usb && h->held_len) {
            size_t send = h->held_len; /* a held batch still goes out with this tick */
            memcpy(out, h->held, send);
            h->held_len = 0;
            return send;
        }
        return 0;
    }
    uint64_t c = h->cycle++;
    size_t at = h->usb ? URB_USB_BATCH_HEADER_MAX_SIZE : 0u;
    uint32_t count = 0;
    for (uint32_t i = 0; i < h->n_reqs; i++) {
        if (c % h->reqs[i].every != 0u) {
            continue;
        }
        size_t n = encode(h, &h->reqs[i], out + at, cap - at, now);
        if (n) {
            at += n;
            frame_ends[(*n_frames)++] = at;
            count++;
        }
    }
    if (h->usb) {
        /* this tick writes the batch prepared at the previous one and prepares the next */
        size_t send = h->held_len;
        uint8_t prev[512];
        memcpy(prev, h->held, send);
        h->held_len = 0;
        if (count != 0u || h->pend_len != 0u) {
            urb_usb_batch_header_t hd = {h->frame, (uint8_t)count};
            h->frame = (uint16_t)(h->frame % 0xFFFFu + 1u); /* never 0: idle buffers are labelled 0 */
            (void)urb_usb_batch_header_encode(&hd, out, URB_USB_BATCH_HEADER_MAX_SIZE);
            memcpy(h->held, out, at);
            h->held_len = at;
        }
        memcpy(out, prev, send);
        *n_frames = 0;
        return send;
    }
    return at;
}

/* The oldest pending request was answered (or not) at `now`. */
static void complete(nh_bridge_t *h, bool ok, uint64_t now)
{
    nh_pending_t *p = &h->pend[h->pend_head];
    if (ok) {
        uint64_t lat = now - p->submitted;
        h->ok++;
        h->lat_sum += lat;
        h->lat_max = lat > h->lat_max ? lat : h->lat_max;
        h->lat_min = lat < h->lat_min ? lat : h->lat_min;
    } else {
        h->failed++;
    }
    h->pend_head = (h->pend_head + 1u) % NH_WINDOW;
    h->pend_len--;
}

/* Try to take one response for the oldest pending request from buf; returns bytes used, 0 when
 * more bytes are needed, or 1 to discard a byte that cannot start it (resynchronisation). */
static size_t take_response(nh_bridge_t *h, const uint8_t *buf, size_t len, uint64_t now)
{
    const nh_pending_t *p = &h->pend[h->pend_head];
    uint8_t status = (uint8_t)(buf[0] >> 4);
    size_t data = (p->read && status == URB_STATUS_OK) ? p->length : 0u;
    size_t n = 1u + data + check_size(1u + data);
    if (len < n) {
        return 0;
    }
    urb_uplink_response_t r;
    if (urb_uplink_response_decode(&r, buf, n) < 0 || r.seq != p->seq) {
        h->resyncs++;
        return 1;
    }
    complete(h, r.status == URB_STATUS_OK, now);
    return n;
}

void nh_receive(nh_bridge_t *h, const uint8_t *data, size_t n, uint64_t now)
{
    if (h->usb) {
        urb_usb_batch_header_t hd;
        if (n < URB_USB_BATCH_HEADER_MAX_SIZE || urb_usb_batch_header_decode(&hd, data, URB_USB_BATCH_HEADER_MAX_SIZE) < 0) {
            return;
        }
        size_t at = URB_USB_BATCH_HEADER_MAX_SIZE;
        for (unsigned i = 0; i < hd.count && at < n && h->pend_len; i++) {
            size_t used = take_response(h, data + at, n - at, now);
            if (used <= 1u) {
                break;
            }
            at += used;
        }
        return;
    }
    for (size_t i = 0; i < n; i++) {
        if (h->rx_len < sizeof h->rx) {
            h->rx[h->rx_len++] = data[i];
        }
        while (h->rx_len && h->pend_len) {
            size_t used = take_response(h, h->rx, h->rx_len, now);
            if (used == 0u) {
                break;
            }
            memmove(h->rx, h->rx + used, h->rx_len - used);
            h->rx_len -= used;
        }
        if (!h->pend_len) {
            h->rx_len = 0; /* stray bytes with nothing pending */
        }
    }
}

void nh_timeouts(nh_bridge_t *h, uint64_t now, uint64_t timeout)
{
    while (h->pend_len && now - h->pend[h->pend_head].submitted > timeout) {
        complete(h, false, now);
        h->timeouts++;
    }
}
