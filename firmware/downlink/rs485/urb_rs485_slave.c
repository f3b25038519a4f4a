/*
 * RS485 downlink slave: the node side of the poll cycle (urb_rs485_slave.h).
 *
 * Seeded bugs for the mutant checks: URB_MUTANT_RS485_COMMIT_BAD_CHECK (a write whose check failed
 * is committed), URB_MUTANT_RS485_ANSWER_OTHERS (the node answers frames addressed to another
 * node), URB_MUTANT_RS485_PROBE_WRITES (a probe begins a write: the mailbox is touched),
 * URB_MUTANT_RS485_KEEP_CUT_READ (a cut answer's read stays latched: read_begin twice, the old code).
 */
#include "urb_rs485_slave.h"

#include "urb_core.h"
#include "urb_runtime.h"

#define SELECT_READ 0x80u     /* MailboxSelect.read */
#define SELECT_RESERVED 0x78u /* MailboxSelect._ */
#define SELECT_MAILBOX 0x07u
#define RESPONSE_BIT 0x80u    /* Rs485Response.response, Rs485Request.response */

bool urb_rs485_slave_init(urb_rs485_slave_t *s, const urb_rs485_hal_t *hal, const urb_dl_mailbox_t *mb, uint8_t address, const urb_rs485_timing_t *t, uint32_t now)
{
    if ((s == NULL) || (hal == NULL) || (mb == NULL) || (t == NULL) || (address == 0u) ||
        (address > URB_RS485_LAST_ADDRESS) || (hal->tx_start == NULL) || (hal->wake_at == NULL) ||
        (mb->inbox_size == NULL) || (mb->outbox_size == NULL) || (mb->write_begin == NULL) ||
        (mb->write_commit == NULL) || (mb->write_abort == NULL) || (mb->read_begin == NULL) ||
        (mb->read_end == NULL) || (mb->sync == NULL)) {
        return false;
    }
    s->hal = hal;
    s->mb = mb;
    urb_rs485_rx_init(&s->rx, t, now);
    s->address = address;
    s->mine = 0u;
    s->wbuf = NULL;
    s->wsize = 0u;
    s->wbox = URB_RS485_SLAVE_NONE;
    s->tx_head = 0u;
    s->tx_data = NULL;
    s->tx_len = 0u;
    s->tx_pos = 0u;
    s->tx_check[0] = 0u;
    s->tx_check[1] = 0u;
    s->tx_total = 0u;
    s->reading = URB_RS485_SLAVE_NONE;
    s->stats.answered = 0u;
    s->stats.bad_check = 0u;
    s->stats.syncs = 0u;
    hal->wake_at(hal->ctx, urb_rs485_rx_deadline(&s->rx));
    return true;
}

bool urb_rs485_slave_sending(const urb_rs485_slave_t *s)
{
    return s->tx_total != 0u;
}

void urb_rs485_slave_stats(const urb_rs485_slave_t *s, urb_rs485_slave_stats_t *out)
{
    *out = s->stats;
}

static void fault(const urb_rs485_slave_t *s, uint8_t code)
{
    if (s->mb->fault != NULL) {
        s->mb->fault(s->mb->ctx, code);
    }
}

static void abort_write(urb_rs485_slave_t *s)
{
    if (s->wbuf != NULL) {
        s->mb->write_abort(s->mb->ctx, s->wbox); /* MailboxInbox.tla IsrWriteAbort */
    }
    s->wbuf = NULL;
    s->wbox = URB_RS485_SLAVE_NONE;
}

/* Starts the answer (Rs485Poll.tla: Answer): header, data, check; the port pulls the bytes. */
static void answer(urb_rs485_slave_t *s, uint8_t status, uint8_t mailbox, const uint8_t *data, uint8_t len)
{
    s->tx_head = (uint8_t)((status & 0x0Fu) | ((mailbox & SELECT_MAILBOX) << 4) | RESPONSE_BIT);
    s->tx_data = data;
    s->tx_len = len;
    s->tx_pos = 0u;
    s->tx_total = (uint8_t)(1u + len + urb_link_check_size(1u + (size_t)len));
    s->stats.answered++;
    s->hal->tx_start(s->hal->ctx);
}

/* A frame addressed to this node ended: decide and answer (the order in urb_rs485_slave.h). */
static void request(urb_rs485_slave_t *s, const urb_rs485_frame_t *f)
{
    uint8_t const n = f->n;
    uint8_t const cl = urb_rs485_check_len(n);
    if (n < 3u) {
        abort_write(s);
        return; /* no select byte: nothing to answer about */
    }
    uint8_t const sel = f->head[1];
    uint8_t const m = (uint8_t)(sel & SELECT_MAILBOX);
#if !defined(URB_MUTANT_RS485_COMMIT_BAD_CHECK)
    if (!f->check_ok) {
        abort_write(s);
        s->stats.bad_check++;
        fault(s, URB_DL_FAULT_CHECKSUM);
        answer(s, URB_STATUS_CHECKSUM, m, NULL, 0u);
        return;
    }
#endif
    uint8_t const data_len = (cl == 0u) ? 0u : (uint8_t)(n - 2u - cl);
    if ((sel & SELECT_RESERVED) != 0u) {
        abort_write(s);
        answer(s, URB_STATUS_BAD_REQUEST, m, NULL, 0u);
        return;
    }
    if ((sel & SELECT_READ) != 0u) {
        uint8_t const size = s->mb->outbox_size(s->mb->ctx, m);
        if ((data_len != 0u) || (size == 0u)) {
            answer(s, URB_STATUS_BAD_REQUEST, m, NULL, 0u);
            return;
        }
        s->reading = m;
        answer(s, URB_STATUS_OK, m, s->mb->read_begin(s->mb->ctx, m), size); /* MailboxOutbox.tla IsrReadBegin */
        return;
    }
    if (data_len == 0u) {
        abort_write(s);
        answer(s, URB_STATUS_OK, m, NULL, 0u); /* a probe */
        return;
    }
    uint8_t const size = s->mb->inbox_size(s->mb->ctx, m);
    if (size == 0u) {
        answer(s, URB_STATUS_BAD_REQUEST, m, NULL, 0u);
        return;
    }
    if (data_len != size) {
        abort_write(s);
        answer(s, URB_STATUS_SIZE_MISMATCH, m, NULL, 0u);
        return;
    }
    if (s->wbuf == NULL) {
        fault(s, URB_DL_FAULT_OVERRUN);
        answer(s, URB_STATUS_NODE_BUSY, m, NULL, 0u); /* IsrWriteBegin refused */
        return;
    }
    s->wbuf = NULL;
    s->wbox = URB_RS485_SLAVE_NONE;
    s->mb->write_commit(s->mb->ctx, m); /* MailboxInbox.tla IsrWriteCommit */
    answer(s, URB_STATUS_OK, m, NULL, 0u);
}

/* A frame ended, so the line was silent for t3.5: an answer not all sent by now was cut (the UART
 * stalled, the driver lost the line) and the bridge has given up on it. Drop it, ending its read as
 * not complete, before anything else is begun: a second read_begin, or a later answer's end, must
 * not find the outbox still latched (urb_dl_slave.h: a read is begun and ended exactly once). */
static void drop_answer(urb_rs485_slave_t *s)
{
#if !defined(URB_MUTANT_RS485_KEEP_CUT_READ)
    if (s->reading != URB_RS485_SLAVE_NONE) {
        s->mb->read_end(s->mb->ctx, s->reading, false); /* MailboxOutbox.tla IsrReadEnd */
        s->reading = URB_RS485_SLAVE_NONE;
    }
    s->tx_total = 0u;
    s->tx_pos = 0u;
#else
    (void)s;
#endif
}

/* A frame ended. `in_time`: at its t3.5 silence (a poll); false when the next frame's first byte
 * ended it (the port missed the deadline): answering now would talk over that frame, so the
 * request is dropped unanswered (the bridge sees silence). */
static void frame_end(urb_rs485_slave_t *s, bool in_time)
{
    const urb_rs485_frame_t *f = &s->rx.last;
    bool const mine = s->mine != 0u;
    s->mine = 0u;
    drop_answer(s);
    if (mine && in_time) {
        request(s, f);
        return;
    }
    abort_write(s);
    if ((f->n == 3u) && f->check_ok && (f->head[0] == URB_RS485_BROADCAST)) {
        s->stats.syncs++;
        s->mb->sync(s->mb->ctx, f->t_first, f->head[1]); /* SYNC: Rs485Sync(counter) */
    }
}

/* A byte of a frame addressed to this node: the write's data go to the inbox as they come. */
static void data_byte(urb_rs485_slave_t *s, uint8_t k, uint8_t byte)
{
    uint8_t const sel = s->rx.head[1];
    if ((sel & (SELECT_READ | SELECT_RESERVED)) != 0u) {
        return; /* a read or a bad select: no data to keep */
    }
    uint8_t const m = (uint8_t)(sel & SELECT_MAILBOX);
#if defined(URB_MUTANT_RS485_PROBE_WRITES)
    uint8_t const first = 2u;
#else
    uint8_t const first = 3u; /* byte 2 may be a probe's check: wait for a second data position */
#endif
    if (k == first) {
        s->wsize = s->mb->inbox_size(s->mb->ctx, m);
        if (s->wsize != 0u) {
            s->wbuf = s->mb->write_begin(s->mb->ctx, m); /* MailboxInbox.tla IsrWriteBegin */
            s->wbox = (s->wbuf != NULL) ? m : URB_RS485_SLAVE_NONE;
            if ((s->wbuf != NULL) && (first == 3u)) {
                s->wbuf[0] = s->rx.hold[0]; /* byte 2, held by the receiver */
            }
        }
    }
    if ((s->wbuf != NULL) && (k >= first)) {
        uint8_t const i = (uint8_t)(k - 2u);
        if (i < s->wsize) {
            s->wbuf[i] = byte;
        }
    }
}

void urb_rs485_slave_rx(urb_rs485_slave_t *s, uint8_t byte, uint32_t t)
{
    uint8_t const ev = urb_rs485_rx_byte(&s->rx, byte, t);
    if ((ev & URB_RS485_EV_END) != 0u) {
        frame_end(s, false);
    }
    if ((ev & URB_RS485_EV_START) != 0u) {
        abort_write(s);
#if defined(URB_MUTANT_RS485_ANSWER_OTHERS)
        s->mine = ((byte & RESPONSE_BIT) == 0u) && (byte != 0u) ? 1u : 0u;
#else
        s->mine = (byte == s->address) ? 1u : 0u; /* address, direction bit clear */
#endif
    } else if ((ev & URB_RS485_EV_BROKEN) != 0u) {
        abort_write(s);
        s->mine = 0u; /* Modbus: a broken frame is discarded */
    } else if (((ev & URB_RS485_EV_BYTE) != 0u) && (s->mine != 0u)) {
        data_byte(s, (uint8_t)(s->rx.n - 1u), byte);
    } else {
        /* not ours */
    }
    s->hal->wake_at(s->hal->ctx, urb_rs485_rx_deadline(&s->rx));
}

void urb_rs485_slave_poll(urb_rs485_slave_t *s, uint32_t now)
{
    if ((urb_rs485_rx_poll(&s->rx, now) & URB_RS485_EV_END) != 0u) {
        frame_end(s, true);
    }
}

bool urb_rs485_slave_tx_next(urb_rs485_slave_t *s, uint8_t *byte)
{
    uint8_t const k = s->tx_pos;
    if (k >= s->tx_total) {
        return false;
    }
    uint8_t const covered = (uint8_t)(1u + s->tx_len);
    uint8_t b;
    if (k == 0u) {
        b = s->tx_head;
    } else if (k < covered) {
        b = s->tx_data[k - 1u]; /* MailboxOutbox.tla IsrReadByte */
    } else {
        b = s->tx_check[k - covered];
    }
    if (k + 1u == covered) {
        /* the check over the header and data, now that they are out (O(size), once) */
        uint32_t const c = urb_link_check(&s->tx_head, 1u, s->tx_data, s->tx_len);
        s->tx_check[0] = (uint8_t)(c & 0xFFu);
        s->tx_check[1] = (uint8_t)((c >> 8) & 0xFFu);
    }
    s->tx_pos = (uint8_t)(k + 1u);
    if (s->tx_pos >= s->tx_total) {
        s->tx_total = 0u;
        s->tx_pos = 0u;
        if (s->reading != URB_RS485_SLAVE_NONE) {
            s->mb->read_end(s->mb->ctx, s->reading, true); /* MailboxOutbox.tla IsrReadEnd */
            s->reading = URB_RS485_SLAVE_NONE;
        }
    }
    *byte = b;
    return true;
}
