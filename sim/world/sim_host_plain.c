/*
 * sim_host_plain.c: the plain requests of the C host (see sim_host_c.h): periodic reads and writes
 * submitted by the application's loop after the axes' reads (the 100-Hz sensors of Fig. 20, the
 * loads of bandwidth.py and latency.py), and one-off requests of the application's set-up.
 */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "sim_host_c_internal.h"

/* The plain requests due this period, in the order they were added. */
void chost_plain_tick(urbsim_chost_t *h)
{
    for (int k = 0; k < h->n_reads; k++) {
#ifdef URBSIM_MUTANT_CHOST_PLAIN_REVERSED
        int i = h->n_reads - 1 - k; /* seeded bug: a period's plain requests go out last added first */
#else
        int i = k;
#endif
        ch_read_t *r = &h->read[i];
        if (h->loop_runs < r->first || (h->loop_runs - r->first) % r->every != 0u) {
            continue;
        }
        xfer_t *x = chost_xfer_get(h);
        if (!x) {
            return;
        }
        if (r->read) {
            urb_transfer_read(&x->t, r->address, r->mailbox, r->length);
        } else {
            if (r->counter) {
                memset(r->data, (int)(h->loop_runs & 0xFFu), r->length);
            }
            urb_transfer_write(&x->t, r->address, r->mailbox, r->data, r->length);
        }
        x->axis = -1;
        chost_submit(h, x, r->bridge);
    }
}

int urbsim_chost_read(urbsim_chost_t *h, int bridge, int address, int mailbox, int length, int every)
{
    return urbsim_chost_write(h, bridge, address, mailbox, NULL, length, every);
}

int urbsim_chost_write(urbsim_chost_t *h, int bridge, int address, int mailbox, const uint8_t *data, int length,
                       int every)
{
    if (!h || h->n_reads == CH_MAX_READS || bridge < 0 || bridge >= CH_MAX_BRIDGES || !h->b[bridge].on || address < 1 ||
        address > 127 || mailbox < 0 || mailbox > 7 || length < 1 || length > 32 || every < 1) {
        return -1;
    }
    ch_read_t *r = &h->read[h->n_reads];
    *r = (ch_read_t){.bridge = bridge, .address = (uint8_t)address, .mailbox = (uint8_t)mailbox,
                     .length = (uint8_t)length, .read = data == NULL, .every = (uint32_t)every,
                     .first = (uint32_t)every};
    if (data) {
        memcpy(r->data, data, (size_t)length);
    }
    return h->n_reads++;
}

int urbsim_chost_first(urbsim_chost_t *h, int plain, int first)
{
    if (!h || plain < 0 || plain >= h->n_reads || first < 1) {
        return -1;
    }
    h->read[plain].first = (uint32_t)first;
    return 0;
}

int urbsim_chost_counter(urbsim_chost_t *h, int plain)
{
    if (!h || plain < 0 || plain >= h->n_reads || h->read[plain].read) {
        return -1;
    }
    h->read[plain].counter = true;
    return 0;
}

int urbsim_chost_submit(urbsim_chost_t *h, int bridge, int address, int mailbox, const uint8_t *data, int length)
{
    if (!h || bridge < 0 || bridge >= CH_MAX_BRIDGES || !h->b[bridge].on || address < 1 || address > 127 || mailbox < 0 ||
        mailbox > 7 || length < 1 || length > 32) {
        return -1;
    }
    xfer_t *x = chost_xfer_get(h);
    if (!x) {
        return -1;
    }
    int32_t rc = data ? urb_transfer_write(&x->t, (uint8_t)address, (uint8_t)mailbox, data, (uint8_t)length)
                      : urb_transfer_read(&x->t, (uint8_t)address, (uint8_t)mailbox, (uint8_t)length);
    if (rc != URB_HOST_OK) {
        chost_xfer_put(h, x);
        return -1;
    }
    x->axis = -1;
    uint64_t errors = h->errors;
    chost_submit(h, x, bridge);
    return h->errors == errors ? 0 : -1;
}
