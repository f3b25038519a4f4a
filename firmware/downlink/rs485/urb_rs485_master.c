/*
 * RS485 downlink master: the bridge side of the poll cycle in urb_rs485_master.h.
 *
 * Phases (the bridge side of Rs485Poll.tla): QUIET (waiting for t3.5 of silence before sending), SEND (driving
 * the line, echo checked byte by byte), SENT (own frame out, waiting for its t3.5 end), WAIT (the
 * node's turn, nothing heard yet), ANSWER (its answer arriving), DRAIN (after a collision, or the
 * request's frame broken after its last byte: waiting for silence), DONE (outcome ready for poll).
 *
 * Seeded bugs for the mutant checks: URB_MUTANT_RS485_NO_ECHO_CHECK (a collision goes unnoticed),
 * URB_MUTANT_RS485_SEND_WHILE_BUSY (the bridge sends without waiting for silence),
 * URB_MUTANT_RS485_SILENCE_AS_TIMEOUT (no answer is reported TIMEOUT instead of NO_NODE).
 */
#include "urb_rs485_master.h"

#include "urb_core.h"
#include "urb_rs485_wire.h"

enum {
    PH_IDLE = 0u,
    PH_QUIET = 1u,
    PH_SEND = 2u,
    PH_SENT = 3u,
    PH_WAIT = 4u,
    PH_ANSWER = 5u,
    PH_DRAIN = 6u,
    PH_DONE = 7u,
};

#if defined(__GNUC__) || defined(__clang__)
#define BARRIER() __asm__ __volatile__("" ::: "memory")
#else
#define BARRIER() ((void)0)
#endif

static void lock(const urb_rs485_master_t *m, bool locked)
{
    if (m->hal->lock != NULL) {
        m->hal->lock(m->hal->ctx, locked);
    }
}

uint32_t urb_rs485_master_timeout_us(uint32_t baud)
{
    urb_rs485_timing_t t;
    urb_rs485_timing(&t, baud);
    /* a 36-byte request, a 35-byte answer, two t3.5 silences and the turnaround, doubled */
    uint32_t const once = (2u * (uint32_t)URB_RS485_MAX_FRAME - 1u) * t.char_us +
                          2u * (uint32_t)t.t35_us + t.turnaround_us;
    uint32_t const two = 2u * once;
    return (two > 2000u) ? two : 2000u;
}

void urb_rs485_master_init(urb_rs485_master_t *m, const urb_rs485_hal_t *hal, uint32_t baud, uint32_t now)
{
    urb_rs485_timing_t t;
    urb_rs485_timing(&t, baud);
    m->hal = hal;
    urb_rs485_rx_init(&m->rx, &t, now);
    m->timeout_us = urb_rs485_master_timeout_us(baud);
    m->op = URB_DL_SYNC;
    m->address = 0u;
    m->mailbox = 0u;
    m->length = 0u;
    m->data = NULL;
    m->n_tx = 0u;
    m->pos = 0u;
    m->echo = 0u;
    m->phase = PH_IDLE;
    m->result = URB_STATUS_OK;
    m->cut = false;
    m->t0 = now;
    m->t_sent = now;
    m->stats.collisions = 0u;
    m->stats.silences = 0u;
    m->stats.babble = 0u;
    m->stats.bad = 0u;
    m->stats.broken = 0u;
    m->stats.busy_line = 0u;
}

bool urb_rs485_master_busy(const urb_rs485_master_t *m)
{
    uint8_t const ph = m->phase;
    return (ph != PH_IDLE) && (ph != PH_DONE);
}

void urb_rs485_master_stats(const urb_rs485_master_t *m, urb_rs485_master_stats_t *out)
{
    *out = m->stats;
}

static void finish(urb_rs485_master_t *m, uint8_t result)
{
    m->result = result;
    m->phase = PH_DONE;
}

/* An answer that is not what a node sends: corrupt. For a read, CHECKSUM (nothing changed at the
 * node); for a write or a probe the node may have stored the request before its answer was
 * garbled, so only TIMEOUT is true (Rs485Poll.tla StatusTruthful). */
static uint8_t garbled(urb_rs485_master_t *m)
{
    m->stats.bad++;
    return (m->op == URB_DL_READ) ? URB_STATUS_CHECKSUM : URB_STATUS_TIMEOUT;
}

/* The answer frame ended: its outcome (Rs485Poll.tla: AnswerEnd). */
static uint8_t judge(urb_rs485_master_t *m, const urb_rs485_frame_t *f)
{
    urb_rs485_response_t r;
    if (!f->check_ok || (f->n > URB_RS485_MAX_FRAME) ||
        (urb_rs485_response_decode(&r, m->ans, f->n) < 0) || (r.mailbox != m->mailbox)) {
        return garbled(m); /* corrupt, not an answer, or for another mailbox */
    }
    if (m->op == URB_DL_PROBE) {
        return URB_STATUS_OK; /* any answer: the node took its address */
    }
    if (r.status == URB_STATUS_OK) {
        if (m->op == URB_DL_READ) {
            if (r.data_len != m->length) {
                return URB_STATUS_SIZE_MISMATCH;
            }
            /* loop bound: 32 bytes */
            for (uint8_t i = 0u; i < r.data_len; i++) {
                m->data[i] = r.data[i];
            }
            return URB_STATUS_OK;
        }
        return (r.data_len == 0u) ? URB_STATUS_OK : garbled(m);
    }
    if ((r.data_len != 0u) || ((r.status != URB_STATUS_NODE_BUSY) && (r.status != URB_STATUS_CHECKSUM) &&
                             (r.status != URB_STATUS_SIZE_MISMATCH) && (r.status != URB_STATUS_BAD_REQUEST))) {
        return garbled(m); /* a refusal a node does not send */
    }
    return r.status;
}

/* Frame-level events of the receiver, in the phase they arrive. */
static void frame_end(urb_rs485_master_t *m)
{
    uint8_t const ph = m->phase;
    const urb_rs485_frame_t *f = &m->rx.last;
    if (ph == PH_SENT) {
        /* our own frame ended: exactly the bytes sent, or someone talked right after us */
        if (f->n != m->n_tx) {
            m->stats.collisions++;
            finish(m, (m->op == URB_DL_SYNC) ? URB_STATUS_OK : URB_STATUS_TIMEOUT);
            return;
        }
        if (m->op == URB_DL_SYNC) {
            finish(m, URB_STATUS_OK);
            return;
        }
        m->t_sent = f->t_last;
        m->phase = PH_WAIT; /* Rs485Poll.tla: SendEnd, the node's turn */
        return;
    }
    if (ph == PH_ANSWER) {
        finish(m, judge(m, f));
        return;
    }
    if (ph == PH_SEND) {
        if (m->echo != 0u) {
            /* our frame ended before all its bytes were out (the UART stalled for t3.5): the line
             * carried a shorter frame, which a node may have taken if its check passes */
            m->hal->tx_abort(m->hal->ctx);
            m->stats.collisions++;
            m->cut = !f->check_ok;
            m->phase = PH_DRAIN;
        }
        return;
    }
    if (ph == PH_DRAIN) {
        /* Rs485Poll.tla: Drain, the line is silent after a collision. The frame that ended holds
         * our bytes up to the collision and whatever joined them (the other talker going on): if
         * its check passes, a node may have taken it, and only TIMEOUT is true. */
        finish(m, (m->cut && !f->check_ok) ? URB_STATUS_BUS_STUCK : URB_STATUS_TIMEOUT);
    }
}

/* The frame cut after its n-th byte, `last` as the line carried it: would a node's receiver find
 * it a frame for itself (a select byte and a check that passes: urb_rs485_frame.c)? With CRC-8
 * on short frames, about one cut in 256 does (found by fuzz_rs485, 2026-11-29: a 31-byte write
 * cut at its 9th byte was stored as a 6-byte write while the bridge said BUS_STUCK).
 * In constant time, from the receiver's running CRCs (issue #39): recomputing the check over the
 * cut bytes took up to 33 CRC steps inside the byte's interrupt, 570 model cycles already for a
 * 4-byte write against one character at 1 Mb/s (480; found by fw_rs485_master). The receiver's
 * frame is the cut frame: send() starts on a silent line, so the first echo started that frame
 * and every echo as sent joined it; `last` joined it too (rx.n == n) unless a silence over t1.5
 * before it broke the frame (rx.n == n - 1: the receiver then left its state as it was). Its
 * CRCs cover every byte of its frame but the last two (urb_rs485.h), so buf[0 .. rx.n - 3], and
 * at most two steps over the bytes sent finish the cut frame's check, whatever its length. Same
 * verdict as the recomputation (tests/firmware/rs485/test_rs485.c: test_master_cut_verdict). */
static bool cut_frame_passes_check(const urb_rs485_master_t *m, uint8_t n, uint8_t last)
{
    uint8_t const cl = urb_rs485_check_len(n);
    uint8_t const have = m->rx.n;
    if ((n < 3u) || (cl == 0u)) {
        return false;
    }
    if ((have != n) && ((uint8_t)(have + 1u) != n)) {
        return true; /* not the cut frame (not reached, see above): TIMEOUT, which claims nothing */
    }
    uint8_t const covered = (uint8_t)(n - cl); /* the check covers buf[0 .. covered - 1] */
    uint8_t i = (uint8_t)(have - 2u);          /* the receiver's CRCs cover buf[0 .. i - 1] */
    if (cl == 1u) {
        uint8_t c = m->rx.crc8;
        if ((uint8_t)(i + 1u) < covered) {
            c = urb_crc8_link_check_byte(c, m->buf[i]); /* `last` broke the frame: one step more */
            i++;
        }
        c = urb_crc8_link_check_byte(c, m->buf[i]);
        return urb_crc8_link_check_final(c) == last;
    }
    uint16_t c = m->rx.crc16;
    if (i < covered) {
        c = urb_crc16_link_check_byte(c, m->buf[i]); /* `last` broke the frame */
    }
    c = urb_crc16_link_check_final(c);
    return ((uint8_t)c == m->buf[n - 2u]) && ((uint8_t)(c >> 8) == last);
}

void urb_rs485_master_rx(urb_rs485_master_t *m, uint8_t byte, uint32_t t)
{
    uint32_t const long_before = m->rx.too_long;
    uint8_t const ev = urb_rs485_rx_byte(&m->rx, byte, t);
    if ((ev & URB_RS485_EV_END) != 0u) {
        frame_end(m);
    }
    uint8_t const ph = m->phase;
    if (ph == PH_SEND) {
        uint8_t const k = m->echo;
        bool same = (k < m->n_tx) && (byte == m->buf[k]) && ((ev & URB_RS485_EV_BROKEN) == 0u);
#if defined(URB_MUTANT_RS485_NO_ECHO_CHECK)
        same = k < m->n_tx; /* mutant: the echo is not compared */
#endif
        if (same) {
            m->echo = (uint8_t)(k + 1u);
            if (m->echo == m->n_tx) {
                m->phase = PH_SENT; /* all out; the frame ends at its t3.5 */
            }
            return;
        }
        /* Rs485Poll.tla: CollideMid. Stop driving; a frame cut before its last byte reaches nobody,
         * unless what the line carried is itself a well-formed shorter frame (a frame's length is
         * its byte count): then the node may have taken it, and only TIMEOUT is true. A cut drains
         * even when its frame passes (TIMEOUT at its end): in SENT, bytes joining it up to the
         * request's length made it look like the request sent whole, and the node's silence was
         * reported NO_NODE (found by fw_rs485_master, PART=1,OP=1, 2026-11-30). */
        m->hal->tx_abort(m->hal->ctx);
        m->stats.collisions++;
        bool const last_byte = (uint8_t)(k + 1u) >= m->n_tx;
        bool const broke = (ev & URB_RS485_EV_BROKEN) != 0u;
        /* the last byte came after a silence over t1.5 and broke the frame: no node takes it, as
         * when a byte breaks it after the last (below) */
        m->cut = last_byte ? broke : !cut_frame_passes_check(m, (uint8_t)(k + 1u), byte);
        if (!last_byte || broke || (m->op == URB_DL_SYNC)) {
            m->phase = PH_DRAIN;
        } else {
            m->phase = PH_SENT; /* the last byte: the node's check decides */
        }
        return;
    }
    if ((ph == PH_SENT) && ((ev & URB_RS485_EV_BROKEN) != 0u)) {
        /* Rs485Poll.tla BabbleStartWith (its break): the request's last byte was out, then a byte after a silence over
         * t1.5 (another talker, noise) broke its frame before its t3.5 (or made it longer than any
         * frame). Every node's receiver discards it (urb_rs485.h), so no node took the request:
         * BUS_STUCK (not executed) once the line is silent again. Staying in SENT was wrong: the
         * receiver drops a broken frame without an end event, so the next frame that ended (another
         * talker's) was taken for the request's, and with the request's length the node's silence
         * was reported NO_NODE (issue #39, 2026-11-30: test_master_broken_after_sent). */
        m->stats.collisions++;
        m->cut = true;
        m->phase = PH_DRAIN;
        return;
    }
    if ((ph == PH_WAIT) && ((ev & URB_RS485_EV_START) != 0u)) {
        m->phase = PH_ANSWER; /* Rs485Poll.tla Answer (the node's) */
        m->ans[0] = byte;
        return;
    }
    if (ph == PH_ANSWER) {
        if ((ev & URB_RS485_EV_BROKEN) != 0u) {
            if (m->rx.too_long != long_before) {
                finish(m, garbled(m)); /* longer than any answer: babbling */
            } else {
                m->stats.broken++;
                finish(m, URB_STATUS_TIMEOUT); /* the answer stalled: Modbus discards it */
            }
            return;
        }
        uint8_t const k = (uint8_t)(m->rx.n - 1u);
        if (k < URB_RS485_MAX_FRAME) {
            m->ans[k] = byte;
        }
        return;
    }
    if ((ph == PH_IDLE) || (ph == PH_DONE) || (ph == PH_QUIET) || (ph == PH_WAIT)) {
        m->stats.babble++; /* Rs485Poll.tla BabbleStart, heard while nobody was polled */
    }
}

bool urb_rs485_master_tx_next(urb_rs485_master_t *m, uint8_t *byte)
{
    if ((m->phase != PH_SEND) || (m->pos >= m->n_tx)) {
        return false;
    }
    *byte = m->buf[m->pos];
    m->pos = (uint8_t)(m->pos + 1u);
    return true;
}

/* Starts driving the line with the planned frame (Rs485Poll.tla: Poll). */
static void send(urb_rs485_master_t *m)
{
    m->pos = 0u;
    m->echo = 0u;
    m->cut = false;
    m->phase = PH_SEND;
    m->hal->tx_start(m->hal->ctx);
}

static bool master_begin(void *ctx, const urb_downlink_txn_t *t, uint32_t now)
{
    urb_rs485_master_t *m = (urb_rs485_master_t *)ctx;
    if (m->phase != PH_IDLE) {
        return false;
    }
    lock(m, true);
    m->op = t->op;
    m->address = (uint8_t)(t->address & 0x7Fu);
    m->mailbox = (t->op == URB_DL_PROBE) ? 0u : (uint8_t)(t->mailbox & 7u);
    m->length = (t->length > 32u) ? 32u : t->length;
    m->data = t->data;
    m->t0 = now;
    int32_t n = 0;
    if (t->op == URB_DL_SYNC) {
        urb_rs485_sync_t s = {t->counter};
        n = urb_rs485_sync_encode(&s, m->buf, sizeof m->buf);
    } else if (t->op != URB_DL_CLEAR) {
        urb_rs485_request_t q;
        q.address = (m->address == 0u) ? 1u : m->address;
        q.select.mailbox = m->mailbox;
        q.select.read = t->op == URB_DL_READ;
        q.data_len = (t->op == URB_DL_WRITE) ? m->length : 0u;
        /* loop bound: 32 bytes */
        for (uint8_t i = 0u; i < q.data_len; i++) {
            q.data[i] = m->data[i];
        }
        n = urb_rs485_request_encode(&q, m->buf, sizeof m->buf);
    } else {
        /* CLEAR sends nothing: it waits for silence */
    }
    m->n_tx = (n > 0) ? (uint8_t)n : 0u;
    m->phase = PH_QUIET;
#if defined(URB_MUTANT_RS485_SEND_WHILE_BUSY)
    if (m->n_tx > 0u) {
#else
    if ((m->n_tx > 0u) && urb_rs485_rx_silent(&m->rx, now)) {
#endif
        send(m);
    }
    lock(m, false);
    return true;
}

static int8_t master_poll(void *ctx, uint32_t now)
{
    urb_rs485_master_t *m = (urb_rs485_master_t *)ctx;
    lock(m, true);
    if ((urb_rs485_rx_poll(&m->rx, now) & URB_RS485_EV_END) != 0u) {
        frame_end(m);
    }
    if ((m->phase == PH_DRAIN) && urb_rs485_rx_silent(&m->rx, now)) {
        /* silent after a collision whose frame broke (a silence over t1.5 inside: the receiver
         * drops it without an end event) or ended already: no node took it, Rs485Poll.tla Drain */
        finish(m, m->cut ? URB_STATUS_BUS_STUCK : URB_STATUS_TIMEOUT);
    }
    uint8_t const ph = m->phase;
    BARRIER();
    int8_t out = URB_DOWNLINK_BUSY;
    bool const late = (uint32_t)(now - m->t0) > m->timeout_us;
    const urb_rs485_timing_t *tm = &m->rx.tm;
    if (ph == PH_IDLE) {
        out = URB_DOWNLINK_IDLE;
    } else if (ph == PH_DONE) {
        m->phase = PH_IDLE; /* Rs485Poll.tla: Report */
        out = (int8_t)m->result;
    } else if (ph == PH_QUIET) {
        if (urb_rs485_rx_silent(&m->rx, now)) {
            if (m->n_tx == 0u) {
                m->phase = PH_IDLE;
                out = (int8_t)URB_STATUS_OK; /* CLEAR: the line is quiet */
            } else {
                send(m);
            }
        } else if (late) {
            m->stats.busy_line++;
            m->phase = PH_IDLE;
            out = (int8_t)URB_STATUS_BUS_STUCK; /* a babbler holds the line: not executed */
        } else {
            /* the line is busy, and not for long yet: keep waiting */
        }
    } else if (ph == PH_WAIT) {
        uint32_t const limit = (uint32_t)tm->t35_us + tm->turnaround_us + tm->char_us;
        if ((uint32_t)(now - m->t_sent) > limit) {
            m->stats.silences++;
            m->phase = PH_IDLE;
#if defined(URB_MUTANT_RS485_SILENCE_AS_TIMEOUT)
            out = (int8_t)URB_STATUS_TIMEOUT;
#else
            out = (int8_t)URB_STATUS_NO_NODE; /* Rs485Poll.tla: Silence */
#endif
        }
    } else if (late) {
        /* SEND without echo (a transceiver fault), SENT, ANSWER or DRAIN that never ends */
        if (ph == PH_SEND) {
            m->hal->tx_abort(m->hal->ctx);
        }
        m->phase = PH_IDLE;
        out = (int8_t)((ph == PH_DRAIN) && m->cut ? URB_STATUS_BUS_STUCK : URB_STATUS_TIMEOUT);
    } else {
        /* still running */
    }
    lock(m, false);
    return out;
}

void urb_rs485_master_downlink(urb_rs485_master_t *m, urb_downlink_t *dl)
{
    dl->ctx = m;
    dl->kind = (uint8_t)URB_DOWNLINK_KIND_RS485;
    dl->bitrate_kbps = (uint16_t)(m->rx.tm.baud / 1000u);
    dl->first_address = 1u;
    dl->last_address = (uint8_t)URB_RS485_LAST_ADDRESS;
    dl->begin = master_begin;
    dl->poll = master_poll;
}
