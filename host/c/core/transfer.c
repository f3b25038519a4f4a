/*
 * The transfer record (host/urb/managers/base.py Transfer): building requests, wire sizes.
 */
#include "urb_transfer.h"

#include <string.h>

bool urb_transfer_owned(const urb_transfer_t *t)
{
    return (t != NULL) && (t->state == URB_XFER_QUEUED || t->state == URB_XFER_IN_FLIGHT ||
                           t->state == URB_XFER_COMPLETED);
}

/* Clears the request and its outcome; the caller has checked the arguments. */
static void reset(urb_transfer_t *t, uint8_t address, uint8_t mailbox, bool read, uint8_t length)
{
    memset(t, 0, sizeof *t);
    t->address = address;
    t->mailbox = mailbox;
    t->read = read;
    t->length = length;
    t->seq = -1;
    t->status = -1;
    t->state = URB_XFER_IDLE;
    t->submitted_ns = URB_NO_TIME;
    t->sent_ns = URB_NO_TIME;
    t->completed_ns = URB_NO_TIME;
    t->callback_ns = URB_NO_TIME;
}

/* Whether a request can be built; the transfer's own state is not read: a fresh, uninitialised
 * transfer on the stack must build (its state bytes are garbage until then). */
static int32_t check(const urb_transfer_t *t, uint8_t address, uint8_t mailbox, uint8_t length)
{
    if ((t == NULL) || (address > 127u) || (mailbox > 7u) || (length < 1u) || (length > URB_HOST_MAILBOX_MAX)) {
        return URB_HOST_EINVAL;
    }
    return URB_HOST_OK;
}

int32_t urb_transfer_read(urb_transfer_t *t, uint8_t address, uint8_t mailbox, uint8_t length)
{
    int32_t const rc = check(t, address, mailbox, length);
    if (rc == URB_HOST_OK) {
        reset(t, address, mailbox, true, length);
    }
    return rc;
}

int32_t urb_transfer_write(urb_transfer_t *t, uint8_t address, uint8_t mailbox, const uint8_t *data,
                           uint8_t length)
{
    int32_t const rc = (data == NULL) ? URB_HOST_EINVAL : check(t, address, mailbox, length);
    if (rc == URB_HOST_OK) {
        uint8_t copy[URB_HOST_MAILBOX_MAX];
        memcpy(copy, data, length); /* data may point into *t */
        reset(t, address, mailbox, false, length);
        memcpy(t->data, copy, length);
    }
    return rc;
}

int32_t urb_transfer_set_callback(urb_transfer_t *t, urb_done_fn fn, void *user)
{
    if (t == NULL) {
        return URB_HOST_EINVAL;
    }
    if (urb_transfer_owned(t)) {
        return URB_HOST_EBUSY;
    }
    t->on_done = fn;
    t->user = user;
    return URB_HOST_OK;
}

int32_t urb_transfer_set_answer_within(urb_transfer_t *t, urb_ns_t answer_within_ns)
{
    if ((t == NULL) || (answer_within_ns < 0) || (answer_within_ns > 3600LL * URB_NS_PER_S)) {
        return URB_HOST_EINVAL;
    }
    if (urb_transfer_owned(t)) {
        return URB_HOST_EBUSY;
    }
    t->answer_within_ns = answer_within_ns;
    return URB_HOST_OK;
}

bool urb_transfer_ok(const urb_transfer_t *t)
{
    return (t != NULL) && (t->state == URB_XFER_COMPLETED || t->state == URB_XFER_DONE) &&
           (t->flags == URB_FLAG_NONE);
}

size_t urb_transfer_response_size(const urb_transfer_t *t, uint8_t status)
{
    if (t == NULL) {
        return 0u;
    }
    size_t const covered = 1u + ((t->read && status == 0u) ? t->length : 0u);
    return covered + ((covered <= 14u) ? 1u : 2u);
}

size_t urb_transfer_request_size(const urb_transfer_t *t)
{
    if (t == NULL) {
        return 0u;
    }
    size_t const covered = 3u + (t->read ? 0u : t->length);
    return covered + ((covered <= 14u) ? 1u : 2u);
}

urb_ns_t urb_transfer_latency_ns(const urb_transfer_t *t)
{
    if ((t == NULL) || (t->callback_ns == URB_NO_TIME) || (t->submitted_ns == URB_NO_TIME)) {
        return -1;
    }
    return t->callback_ns - t->submitted_ns;
}
