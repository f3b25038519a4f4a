/* usb.c: full-speed host controller frames, bulk transactions and the Fig. 9 driver. See usb.h. */
#include "usb.h"

#include <math.h>
#include <string.h>

static void build_stuff_table(uint8_t stuff_table[256][6][2]);

void urbsim_usb_init(urbsim_usb_bus_t *u, urbsim_kernel_t *k, urbsim_trace_t *tr, const char *name,
                     urbsim_clock_t *clock, urbsim_ns_t phase_ns)
{
    memset(u, 0, sizeof *u);
    u->k = k;
    u->tr = tr;
    strncpy(u->name, name, sizeof u->name - 1u);
    u->clock = clock;
    u->bitrate = 12e6;
    u->max_packet = 64;
    u->phase_ns = phase_ns % URBSIM_NS_PER_MS;
    u->hc_irq_ns = 20 * URBSIM_NS_PER_US;
    u->eof_guard_ns = 4 * URBSIM_NS_PER_US;
    u->nak_next_frame = false;
    build_stuff_table(u->stuff);
}

int urbsim_usb_attach(urbsim_usb_bus_t *u, urbsim_usb_dev_t *d)
{
    if (u->n_devs >= URBSIM_USB_MAX_DEVS) {
        return -1;
    }
    d->attached = true;
    if (d->in_size == 0u) {
        d->in_size = URBSIM_USB_MAX_XFER;
    }
    u->devs[u->n_devs] = d;
    return (int)u->n_devs++;
}

/* Bits added by bit stuffing: a 0 after every run of six 1s, bytes sent LSB first. The count for
 * one byte depends only on the byte and the run of 1s it starts with (0..5): a 256 x 6 table of
 * (stuffed bits, run after the byte), built with the bus (urbsim_usb_init). */
static void build_stuff_table(uint8_t stuff_table[256][6][2])
{
    for (unsigned byte = 0; byte < 256u; byte++) {
        for (unsigned run0 = 0; run0 < 6u; run0++) {
            unsigned ones = run0, extra = 0;
            for (unsigned bit = 0; bit < 8u; bit++) {
                if ((byte >> bit) & 1u) {
                    if (++ones == 6u) {
                        extra++;
                        ones = 0;
                    }
                } else {
                    ones = 0;
                }
            }
            stuff_table[byte][run0][0] = (uint8_t)extra;
            stuff_table[byte][run0][1] = (uint8_t)ones;
        }
    }
}

static uint32_t stuffed_bits(const uint8_t (*stuff_table)[6][2], const uint8_t *data, uint32_t n)
{
    uint32_t extra = 0;
    uint8_t ones = 0;
    for (uint32_t i = 0; i < n; i++) {
        extra += stuff_table[data[i]][ones][0];
        ones = stuff_table[data[i]][ones][1];
    }
    return extra;
}

static uint32_t packet_bits(const urbsim_usb_bus_t *u, const uint8_t *data, uint32_t n)
{
    /* token, gap, data packet (SYNC, PID, data, CRC16, EOP: 35 + 8n bits and the stuffed ones), gap,
     * handshake, gap */
    return 35u + URBSIM_USB_GAP_BITS + (35u + 8u * n + (data ? stuffed_bits(u->stuff, data, n) : 0u)) +
           URBSIM_USB_GAP_BITS + 19u + URBSIM_USB_GAP_BITS;
}

uint32_t urbsim_usb_transfer_bits(const urbsim_usb_bus_t *u, const uint8_t *data, uint32_t len)
{
    uint32_t bits = 0, off = 0;
    do {
        uint32_t n = len - off < u->max_packet ? len - off : u->max_packet;
        bits += packet_bits(u, data ? data + off : NULL, n);
        off += n;
        if (n == u->max_packet && off == len) {
            bits += packet_bits(u, NULL, 0); /* zero-length packet ends an exact multiple */
        }
    } while (off < len);
    return bits;
}

urbsim_ns_t urbsim_usb_bits_ns(const urbsim_usb_bus_t *u, uint32_t bits)
{
    return (urbsim_ns_t)llround((double)bits * 1e9 / u->bitrate);
}

static bool push_urb(urbsim_usb_bus_t *u, uint32_t dev, bool in, const uint8_t *data, uint32_t len)
{
    if (u->urb_len >= URBSIM_USB_MAX_URBS || len > URBSIM_USB_MAX_XFER || dev >= u->n_devs) {
        return false;
    }
    urbsim_usb_urb_t *r = &u->urbs[(u->urb_head + u->urb_len) % URBSIM_USB_MAX_URBS];
    r->dev = (uint8_t)dev;
    r->in = in;
    r->len = (uint16_t)len;
    r->got = 0;
    r->sent = 0;
    r->submitted = u->k->now;
    if (data && len) {
        memcpy(r->data, data, len);
    }
    u->urb_len++;
    return true;
}

bool urbsim_usb_write(urbsim_usb_bus_t *u, uint32_t dev, const uint8_t *data, uint32_t len)
{
    urbsim_trace(u->tr, URBSIM_TR_FRAME, u->k->now, u->name, "urb_out", ",\"dev\":%u,\"len\":%u", dev, len);
    return push_urb(u, dev, false, data, len);
}

bool urbsim_usb_read(urbsim_usb_bus_t *u, uint32_t dev)
{
    if (dev >= u->n_devs) {
        return false;
    }
    return push_urb(u, dev, true, NULL, u->devs[dev]->in_size);
}

/* Event kinds (bits 0..7; EV_SOF_END carries the frame number above, EV_DEV_IN_DONE the device). */
enum { EV_SOF, EV_TXN, EV_OUT_DONE, EV_IN_DONE, EV_CALLBACK, EV_SOF_END, EV_DEV_IN_DONE };

static void ev_usb(void *ctx, uint64_t arg, urbsim_ns_t now);

/* Virtual time of the start of frame number f, from the controller's clock. */
static urbsim_ns_t sof_time(urbsim_usb_bus_t *u, uint64_t f)
{
    double local = (double)u->phase_ns + (double)f * (double)URBSIM_NS_PER_MS;
    return u->clock ? urbsim_clock_virtual_at(u->clock, local) : (urbsim_ns_t)local;
}

void urbsim_usb_run(urbsim_usb_bus_t *u)
{
    if (u->running) {
        return;
    }
    u->running = true;
    /* The first frame boundary at or after now. */
    uint64_t f = 0;
    while (sof_time(u, f) < u->k->now) {
        f++;
    }
    u->frame = f;
    urbsim_kernel_at(u->k, sof_time(u, f), ev_usb, u, EV_SOF);
    for (uint32_t i = 0; i < u->n_devs; i++) {
        if (u->devs[i]->read_always) {
            urbsim_usb_read(u, i);
        }
    }
}

/* Run the transaction at the head of this frame's snapshot, at the bus cursor `now`. */
static void run_txn(urbsim_usb_bus_t *u, urbsim_ns_t now)
{
    if (u->cursor_budget == 0u || u->urb_len == 0u) {
        return;
    }
    urbsim_usb_urb_t *r = &u->urbs[u->urb_head];
    urbsim_usb_dev_t *d = u->devs[r->dev];
    urbsim_ns_t limit = u->next_sof_t - u->eof_guard_ns;
    uint32_t bits;
    uint32_t n = 0;
    bool out_nak = false;
    uint8_t buf[URBSIM_USB_MAX_XFER];
    if (r->in) {
        /* The token goes out only if a transaction with a full data packet fits: the controller
         * cannot know the answer's length before. */
        uint32_t first = r->len < u->max_packet ? r->len : u->max_packet;
        if (now + urbsim_usb_bits_ns(u, packet_bits(u, NULL, first) + 8u * first / 6u) > limit) {
            d->deferred++;
            return;
        }
        if (r->got == 0u) {
            n = d->on_in ? d->on_in(d->ctx, buf, r->len, now) : 0u;
            if (n > r->len) {
                n = r->len;
            }
        } else {
            n = r->got; /* the rest of an answer begun in an earlier frame */
            memcpy(buf, r->data, n);
        }
        bits = n ? urbsim_usb_transfer_bits(u, buf + r->sent, n - r->sent) : URBSIM_USB_NAK_BITS;
        if (n && now + urbsim_usb_bits_ns(u, bits) > limit) {
            /* Longer than what is left of the frame: the packets that fit now, the rest next frame
             * (the URB stays at the head of the queue). */
            uint32_t part = 0, off = r->sent;
            while (off < n) { /* when only the zero-length packet is left, it is the rest */
                uint32_t p = n - off < u->max_packet ? n - off : u->max_packet;
                uint32_t pb = packet_bits(u, buf + off, p);
                if (part > 0u && now + urbsim_usb_bits_ns(u, part + pb) > limit) {
                    break;
                }
                part += pb;
                off += p;
            }
            memcpy(r->data, buf, n);
            r->got = (uint16_t)n;
            r->sent = (uint16_t)off;
            u->busy_bits += part;
            d->deferred++;
            urbsim_trace(u->tr, URBSIM_TR_BUS, now, u->name, "in_part", ",\"dev\":%u,\"len\":%u,\"end\":%llu",
                         r->dev, off, (unsigned long long)(now + urbsim_usb_bits_ns(u, part)));
            return; /* the frame is over for this controller */
        }
    } else {
        bits = urbsim_usb_transfer_bits(u, r->data, r->len);
        if (now + urbsim_usb_bits_ns(u, bits) > limit) {
            d->deferred++; /* does not fit in what is left of the frame: next frame */
            return;
        }
        if (d->attached && d->out_busy && d->out_busy(d->ctx)) {
            /* The device's buffer is still full: token and first data packet, then its NAK. */
            uint32_t first = r->len < u->max_packet ? r->len : u->max_packet;
            bits = packet_bits(u, r->data, first);
            out_nak = true;
        }
    }
    urbsim_usb_urb_t taken = *r;
    u->urb_head = (u->urb_head + 1u) % URBSIM_USB_MAX_URBS;
    u->urb_len--;
    u->cursor_budget--;
    urbsim_ns_t end = now + urbsim_usb_bits_ns(u, bits);
    u->busy_bits += bits;
    if ((taken.in && n == 0u) || out_nak) {
        if (out_nak) {
            d->out_naks++;
        } else {
            d->naks++;
        }
        urbsim_trace(u->tr, URBSIM_TR_BUS, now, u->name, out_nak ? "out_nak" : "in_nak", ",\"dev\":%u", taken.dev);
        if (u->nak_next_frame) {
            /* Retried in the next frame: back into the queue, keeping its submission time. */
            urbsim_usb_urb_t *again = &u->urbs[(u->urb_head + u->urb_len) % URBSIM_USB_MAX_URBS];
            *again = taken;
            u->urb_len++;
        } else {
            /* Retried in this frame, after the frame's other transactions (a pass of the bulk
             * list): back into the frame's schedule as its last URB, ahead of those submitted
             * since its SOF, keeping its submission time. */
#ifdef URBSIM_MUTANT_NAK_TAIL /* seeded bug (mk/sim.mk): the retry joins the queue's tail, so the frame
                                 runs a URB submitted after its SOF */
            u->urbs[(u->urb_head + u->urb_len) % URBSIM_USB_MAX_URBS] = taken;
#else
            for (uint32_t j = u->urb_len; j > u->cursor_budget; j--) {
                u->urbs[(u->urb_head + j) % URBSIM_USB_MAX_URBS] =
                    u->urbs[(u->urb_head + j - 1u) % URBSIM_USB_MAX_URBS];
            }
            u->urbs[(u->urb_head + u->cursor_budget) % URBSIM_USB_MAX_URBS] = taken;
#endif
            u->urb_len++;
            u->cursor_budget++;
        }
    } else if (u->done_len < URBSIM_USB_MAX_DONE) {
        urbsim_usb_urb_t *c = &u->done[(u->done_head + u->done_len) % URBSIM_USB_MAX_DONE];
        *c = taken;
        if (taken.in) {
            memcpy(c->data, buf, n);
            c->len = (uint16_t)n;
            d->ins++;
        } else {
            d->outs++;
        }
        u->done_len++;
        urbsim_trace(u->tr, URBSIM_TR_BUS, now, u->name, taken.in ? "in" : "out", ",\"dev\":%u,\"len\":%u,\"end\":%llu",
                     taken.dev, (unsigned)c->len, (unsigned long long)end);
        urbsim_kernel_at(u->k, end, ev_usb, u, taken.in ? EV_IN_DONE : EV_OUT_DONE);
    } else if (taken.in) {
        /* No room for the driver's completion (never seen: 16 within hc_irq_ns); the device still
         * got its acknowledgement and must not keep its buffer busy. */
        urbsim_kernel_at(u->k, end, ev_usb, u, EV_DEV_IN_DONE | ((uint64_t)taken.dev << 8));
    }
    urbsim_kernel_at(u->k, end, ev_usb, u, EV_TXN);
}

/* The oldest completed transfer (completions are handled in transaction order). */
static urbsim_usb_urb_t *done_head(urbsim_usb_bus_t *u)
{
    return &u->done[u->done_head];
}

static void ev_usb(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    urbsim_usb_bus_t *u = ctx;
    switch ((int)(arg & 0xFFu)) {
    case EV_SOF: {
        u->frames++;
        u->sof_t = now;
        u->next_sof_t = sof_time(u, u->frame + 1u);
        urbsim_kernel_at(u->k, u->next_sof_t, ev_usb, u, EV_SOF);
        urbsim_ns_t sof_end = now + urbsim_usb_bits_ns(u, URBSIM_USB_SOF_BITS);
        /* The first token after the inter-packet gap (rounded once: the bits, not the two parts). */
        urbsim_ns_t first_txn = now + urbsim_usb_bits_ns(u, URBSIM_USB_SOF_BITS + URBSIM_USB_GAP_BITS);
        uint16_t fn = (uint16_t)(u->frame & 0x7FFu);
        urbsim_trace(u->tr, URBSIM_TR_BUS, now, u->name, "sof", ",\"frame\":%u", fn);
        /* The devices see the SOF at the end of its packet: called then, before this frame's first
         * transaction. */
        urbsim_kernel_at(u->k, sof_end, ev_usb, u, EV_SOF_END | ((uint64_t)fn << 8));
        /* The frame's schedule: every URB submitted before this SOF, in submission order. */
        uint32_t n = 0;
        while (n < u->urb_len && u->urbs[(u->urb_head + n) % URBSIM_USB_MAX_URBS].submitted < now) {
            n++;
        }
        u->cursor_budget = n;
        u->frame++;
        if (n) {
            urbsim_kernel_at(u->k, first_txn, ev_usb, u, EV_TXN);
        }
        break;
    }
    case EV_SOF_END: {
        uint16_t fn = (uint16_t)(arg >> 8);
        for (uint32_t i = 0; i < u->n_devs; i++) {
            if (u->devs[i]->attached && u->devs[i]->on_sof) {
                u->devs[i]->on_sof(u->devs[i]->ctx, fn, now);
            }
        }
        break;
    }
    case EV_TXN:
        run_txn(u, now);
        break;
    case EV_DEV_IN_DONE: {
        urbsim_usb_dev_t *d = u->devs[(arg >> 8) & 0xFFu];
        if (d->attached && d->on_in_done) {
            d->on_in_done(d->ctx, now);
        }
        break;
    }
    case EV_OUT_DONE:
    case EV_IN_DONE: {
        /* Device side sees OUT data, or the acknowledgement of its IN data, at the end of the
         * transaction; the host controller raises the completion interrupt hc_irq_ns later. */
        urbsim_usb_urb_t *c = &u->done[(u->done_head + u->done_pending) % URBSIM_USB_MAX_DONE];
        u->done_pending++;
        urbsim_usb_dev_t *d = u->devs[c->dev];
        if (!c->in && d->attached && d->on_out) {
            d->on_out(d->ctx, c->data, c->len, now);
        } else if (c->in && d->attached && d->on_in_done) {
            d->on_in_done(d->ctx, now);
        }
        urbsim_kernel_at(u->k, now + u->hc_irq_ns, ev_usb, u, EV_CALLBACK);
        break;
    }
    default: {
        /* Driver completion callback (write or read), oldest first. */
        urbsim_usb_urb_t *c = done_head(u);
        urbsim_usb_dev_t *d = u->devs[c->dev];
        if (c->in) {
            urbsim_trace(u->tr, URBSIM_TR_FRAME, now, u->name, "read_cb", ",\"dev\":%u,\"len\":%u", c->dev, c->len);
            if (d->read_always) {
                urbsim_usb_read(u, c->dev); /* keep one IN pending */
            }
            if (d->host_read) {
                d->host_read(d->hctx, c->data, c->len, now);
            }
        } else {
            urbsim_trace(u->tr, URBSIM_TR_FRAME, now, u->name, "write_cb", ",\"dev\":%u", c->dev);
            if (d->auto_read && !d->read_always) {
                urbsim_usb_read(u, c->dev); /* Fig. 9: the write callback issues the read */
            }
        }
        u->done_head = (u->done_head + 1u) % URBSIM_USB_MAX_DONE;
        u->done_len--;
        u->done_pending--;
        break;
    }
    }
}
