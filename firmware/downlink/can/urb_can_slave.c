/*
 * CAN downlink slave: the node side of the contract in urb_can_master.h (see urb_can_slave.h).
 *
 * Seeded bugs for the mutant checks: URB_MUTANT_CAN_NO_DEDUP (a repeated request is taken again:
 * a write committed twice), URB_MUTANT_CAN_COMMIT_BAD_CRC (a write whose CRC failed is committed),
 * URB_MUTANT_CAN_KEEP_READ_ON_NEW (a new request leaves the previous answer's outbox latched).
 */
#include "urb_can_slave.h"

#include "urb_can_wire.h"
#include "urb_core.h"

#define FRAME_BITS_MAX 135u /* an 8-byte frame with an 11-bit identifier, stuffed (urb_can_frame_bits_max) */

uint32_t urb_can_slave_dup_window_us(uint32_t bitrate_kbps)
{
    uint32_t const rate = (bitrate_kbps == 0u) ? 125u : bitrate_kbps;
    return (8u * FRAME_BITS_MAX * 1000u + rate - 1u) / rate;
}

bool urb_can_slave_init(urb_can_slave_t *s, const urb_can_hal_t *hal, const urb_dl_mailbox_t *mb, uint8_t address, uint32_t dup_window_us)
{
    if ((s == NULL) || (hal == NULL) || (mb == NULL) || (address < URB_CAN_FIRST_ADDRESS) ||
        (address > URB_CAN_LAST_ADDRESS) || (hal->tx == NULL) || (hal->tx_abort == NULL) || (hal->recover == NULL) ||
        (mb->inbox_size == NULL) || (mb->outbox_size == NULL) || (mb->write_begin == NULL) ||
        (mb->write_commit == NULL) || (mb->write_abort == NULL) || (mb->read_begin == NULL) ||
        (mb->read_end == NULL) || (mb->sync == NULL)) {
        return false;
    }
    s->hal = hal;
    s->mb = mb;
    s->address = address;
    s->dup_window_us = dup_window_us;
    urb_can_rx_reset(&s->rx);
    s->session = URB_CAN_SLAVE_NO_SESSION;
    s->wbuf = NULL;
    s->wsize = 0u;
    s->refusal = URB_STATUS_OK;
    s->last_session = URB_CAN_SLAVE_NO_SESSION;
    s->last_tid = 0u;
    s->last_t = 0u;
    urb_can_tx_init(&s->tx, NULL, 0u, 0u);
    s->frame.id = 0u;
    s->frame.len = 0u;
    s->answer[0] = 0u;
    s->reading = URB_CAN_SLAVE_NO_SESSION;
    s->frames_total = 0u;
    s->frames_sent = 0u;
    s->frame_ready = false;
    s->sending = false;
    s->stats.requests = 0u;
    s->stats.duplicates = 0u;
    s->stats.crc_errors = 0u;
    s->stats.dropped = 0u;
    s->stats.bus_off = 0u;
    s->stats.syncs = 0u;
    return true;
}

bool urb_can_slave_sending(const urb_can_slave_t *s)
{
    return s->sending;
}

void urb_can_slave_stats(const urb_can_slave_t *s, urb_can_slave_stats_t *out)
{
    *out = s->stats;
}

static void fault(const urb_can_slave_t *s, uint8_t code)
{
    if (s->mb->fault != NULL) {
        s->mb->fault(s->mb->ctx, code);
    }
}

/* The answer in progress is abandoned (a newer request, bus-off): its queued frames are dropped
 * and a latched outbox is freed, incomplete (MailboxOutbox.tla IsrReadEnd). */
static void drop_answer(urb_can_slave_t *s)
{
    if (!s->sending) {
        return;
    }
    s->hal->tx_abort(s->hal->ctx);
    s->sending = false;
    s->stats.dropped++;
    if (s->reading != URB_CAN_SLAVE_NO_SESSION) {
        s->mb->read_end(s->mb->ctx, s->reading, false);
        s->reading = URB_CAN_SLAVE_NO_SESSION;
    }
}

/* The write in progress is abandoned: MailboxInbox.tla IsrWriteAbort. */
static void drop_write(urb_can_slave_t *s)
{
    if (s->wbuf != NULL) {
        s->mb->write_abort(s->mb->ctx, (uint8_t)(s->session & 7u));
        s->wbuf = NULL;
        s->stats.dropped++;
    }
    urb_can_rx_reset(&s->rx);
    s->session = URB_CAN_SLAVE_NO_SESSION;
}

static void pump(urb_can_slave_t *s)
{
    /* loop bound: URB_CAN_MAX_FRAMES frames */
    for (uint8_t i = 0u; i < URB_CAN_MAX_FRAMES; i++) {
        if (!s->frame_ready) {
            uint8_t const n = urb_can_tx_next(&s->tx, s->frame.data); /* CanTransfer.tla SendFrame */
            if (n == 0u) {
                return;
            }
            s->frame.len = n;
            s->frame_ready = true;
        }
        if (!s->hal->tx(s->hal->ctx, &s->frame)) {
            return;
        }
        s->frame_ready = false;
    }
}

/* Starts the answer to the request just completed on `session` with transfer id `tid`. */
static void answer(urb_can_slave_t *s, uint8_t session, uint8_t tid, const uint8_t *payload, uint8_t len)
{
    s->frame.id = urb_can_id(s->address, (uint8_t)(session & 7u), (session & 8u) != 0u, URB_CAN_RESPONSE);
    urb_can_tx_init(&s->tx, payload, len, tid); /* CanTransfer.tla SendStart, the request's id */
    s->frames_total = urb_can_frames(len);
    s->frames_sent = 0u;
    s->frame_ready = false;
    s->sending = true;
    s->stats.requests++;
    pump(s);
}

static void refuse(urb_can_slave_t *s, uint8_t session, uint8_t tid, uint8_t status)
{
    urb_can_write_refusal_t r = {status};
    (void)urb_can_write_refusal_encode(&r, s->answer, sizeof s->answer);
    answer(s, session, tid, s->answer, 1u);
}

/* A complete request (CanTransfer.tla Complete): the write is committed or refused, the read's
 * outbox latched, and the answer started. */
static void request_done(urb_can_slave_t *s, uint8_t session, uint8_t tid, bool crc_ok)
{
    uint8_t const m = (uint8_t)(session & 7u);
    uint8_t const n = urb_can_rx_len(&s->rx);
    s->session = URB_CAN_SLAVE_NO_SESSION;
    if ((session & 8u) != 0u) {
        uint8_t const size = s->mb->outbox_size(s->mb->ctx, m);
        if (!crc_ok || (n != 0u) || (size == 0u)) {
            answer(s, session, tid, NULL, 0u); /* no such outbox, or not a read request: empty */
            return;
        }
        const uint8_t *buf = s->mb->read_begin(s->mb->ctx, m); /* MailboxOutbox.tla IsrReadBegin */
        s->reading = m;
        answer(s, session, tid, buf, size);
        return;
    }
    uint8_t *const wbuf = s->wbuf;
    s->wbuf = NULL;
#if defined(URB_MUTANT_CAN_COMMIT_BAD_CRC)
    crc_ok = true; /* mutant: the failed CRC is not looked at */
#endif
    if (!crc_ok) {
        if (wbuf != NULL) {
            s->mb->write_abort(s->mb->ctx, m); /* MailboxInbox.tla IsrWriteAbort */
        }
        s->stats.crc_errors++;
        fault(s, URB_DL_FAULT_CHECKSUM);
        refuse(s, session, tid, URB_STATUS_CHECKSUM);
        return;
    }
    if ((n == 0u) && (wbuf == NULL) && (s->refusal == URB_STATUS_OK)) {
        answer(s, session, tid, NULL, 0u); /* a probe: answered, no mailbox touched */
        return;
    }
    if (s->refusal != URB_STATUS_OK) {
        refuse(s, session, tid, s->refusal); /* decided at the start frame: nothing was written */
        return;
    }
    if (n != s->wsize) {
        s->mb->write_abort(s->mb->ctx, m); /* MailboxInbox.tla IsrWriteAbort */
        refuse(s, session, tid, URB_STATUS_SIZE_MISMATCH);
        return;
    }
    s->mb->write_commit(s->mb->ctx, m); /* MailboxInbox.tla IsrWriteCommit */
    answer(s, session, tid, NULL, 0u);
}

/* A start frame of a new request on `session`: the previous request and answer give way. */
static bool request_start(urb_can_slave_t *s, uint8_t session, uint8_t tid, bool probe, uint32_t t)
{
#if !defined(URB_MUTANT_CAN_NO_DEDUP)
    if ((session == s->last_session) && (tid == s->last_tid) && ((uint32_t)(t - s->last_t) < s->dup_window_us)) {
        s->stats.duplicates++; /* CanTransfer.tla Receive, the duplicate filter */
        return false;
    }
#else
    (void)tid;
    (void)t;
#endif
    drop_write(s);
#if !defined(URB_MUTANT_CAN_KEEP_READ_ON_NEW)
    drop_answer(s);
#else
    if (s->sending) {
        s->hal->tx_abort(s->hal->ctx);
        s->sending = false;
    }
#endif
    s->session = session;
    s->refusal = URB_STATUS_OK;
    s->wsize = 0u;
    if (((session & 8u) == 0u) && !probe) {
        uint8_t const m = (uint8_t)(session & 7u);
        s->wsize = s->mb->inbox_size(s->mb->ctx, m);
        if (s->wsize == 0u) {
            s->refusal = URB_STATUS_BAD_REQUEST;
        } else {
            s->wbuf = s->mb->write_begin(s->mb->ctx, m); /* MailboxInbox.tla IsrWriteBegin */
            if (s->wbuf == NULL) {
                s->refusal = URB_STATUS_NODE_BUSY;
                fault(s, URB_DL_FAULT_OVERRUN);
            }
        }
    }
    return true;
}

static void sync(urb_can_slave_t *s, const urb_can_frame_t *f, uint32_t t)
{
    uint8_t const single = URB_CAN_TAIL_START | URB_CAN_TAIL_END | URB_CAN_TAIL_TOGGLE;
    urb_can_sync_t msg;
    if ((f->len == 2u) && ((f->data[1] & single) == single) && (urb_can_sync_decode(&msg, f->data, 1u) >= 0)) {
        s->stats.syncs++;
        s->mb->sync(s->mb->ctx, t, msg.counter);
    }
}

void urb_can_slave_rx(urb_can_slave_t *s, const urb_can_frame_t *f, uint32_t t)
{
    if ((f->len == 0u) || (f->len > URB_CAN_MTU)) {
        return;
    }
    if (f->id == URB_CAN_SYNC_ID) {
        sync(s, f, t);
        return;
    }
    uint16_t const id = f->id;
    if (((id >> 10) != URB_CAN_REQUEST) || (((id >> 4) & 0x3Fu) != s->address)) {
        return; /* an answer, or a request to another node */
    }
    uint8_t const session = (uint8_t)(id & 15u);
    uint8_t const tail = f->data[f->len - 1u];
    uint8_t const tid = (uint8_t)(tail & URB_CAN_TAIL_TID);
    if ((tail & URB_CAN_TAIL_START) != 0u) {
        if ((s->session == session) && urb_can_rx_active(&s->rx) && (tid == urb_can_rx_tid(&s->rx))) {
            /* a repeat of this transfer's start frame: the toggle rule below ignores it */
        } else {
            bool const probe = ((tail & URB_CAN_TAIL_END) != 0u) && (f->len == 1u);
            if (!request_start(s, session, tid, probe, t)) {
                return;
            }
        }
    } else if (s->session != session) {
        return; /* a frame of a request whose start was not taken */
    } else {
        /* a continuation frame of the request in progress */
    }
    urb_can_rx_result_t const r = urb_can_rx_frame(&s->rx, f->data, f->len, s->wbuf, (s->wbuf != NULL) ? s->wsize : 0u);
    if ((r == URB_CAN_RX_DONE) || (r == URB_CAN_RX_CRC)) {
        s->last_session = session;
        s->last_tid = tid;
        s->last_t = t;
        request_done(s, session, tid, r == URB_CAN_RX_DONE);
    }
}

void urb_can_slave_tx_done(urb_can_slave_t *s)
{
    if (!s->sending) {
        return;
    }
    s->frames_sent++;
    if (s->frames_sent < s->frames_total) {
        pump(s);
        return;
    }
    s->sending = false;
    if (s->reading != URB_CAN_SLAVE_NO_SESSION) {
        s->mb->read_end(s->mb->ctx, s->reading, true); /* MailboxOutbox.tla IsrReadEnd: all sent */
        s->reading = URB_CAN_SLAVE_NO_SESSION;
    }
}

void urb_can_slave_state(urb_can_slave_t *s, uint8_t state)
{
    if (state != (uint8_t)URB_CAN_BUS_OFF) {
        return;
    }
    s->stats.bus_off++;
    drop_write(s);
    drop_answer(s);
    fault(s, URB_DL_FAULT_STUCK_BUS);
    s->hal->recover(s->hal->ctx);
}
