/*
 * CAN downlink master: the bridge side of the contract in urb_can_master.h.
 *
 * begin() plans the request's transfer and queues its frames as the controller takes them; the
 * interrupt side queues the rest as frames leave (tx_done) and reassembles the answer (rx); poll()
 * gives the outcome, times out, and follows a recovery. Each outcome names its cause with the
 * status the I2C master gives for the same failure (Bridge.tla Serve, Bridge.tla ErrorNamesCause).
 *
 * Seeded bugs for the mutant checks: URB_MUTANT_CAN_NO_TID_FILTER (an answer with another
 * transfer id, a late one, is taken), URB_MUTANT_CAN_BUSOFF_AS_TIMEOUT (a bus-off controller is
 * reported TIMEOUT and not recovered), URB_MUTANT_CAN_SAME_TID (the transfer id never advances).
 */
#include "urb_can_master.h"

#include "urb_can_wire.h"
#include "urb_core.h"
#include "urb_runtime.h"

enum {
    PH_IDLE = 0u,    /* nothing running, or the outcome was reported */
    PH_SEND = 1u,    /* the request's frames are being sent */
    PH_WAIT = 2u,    /* request sent, no frame of the answer yet */
    PH_DONE = 3u,    /* outcome in `result`, for the next poll */
    PH_RECOVER = 4u, /* waiting for the controller to be error-active again */
};

#if defined(__GNUC__) || defined(__clang__)
#define BARRIER() __asm__ __volatile__("" ::: "memory")
#else
#define BARRIER() ((void)0)
#endif

static void lock(const urb_can_master_t *m, bool locked)
{
    if (m->hal->lock != NULL) {
        m->hal->lock(m->hal->ctx, locked);
    }
}

uint32_t urb_can_master_timeout_us(uint32_t bitrate_kbps)
{
    uint32_t t = URB_CAN_MIN_TIMEOUT_US;
    if (bitrate_kbps > 0u) {
        /* bits x 1000 / (kb/s) = us, rounded up; x 2 for arbitration and error frames */
        uint32_t const bus = (2u * URB_CAN_LONGEST_BITS * 1000u - 1u) / bitrate_kbps + 1u;
        if (bus + URB_CAN_NODE_LATENCY_US > t) {
            t = bus + URB_CAN_NODE_LATENCY_US;
        }
    }
    return t;
}

uint32_t urb_can_master_recover_us(uint32_t bitrate_kbps)
{
    uint32_t t = 1000u;
    if (bitrate_kbps > 0u) {
        uint32_t const bus = (2u * URB_CAN_RECOVERY_BITS * 1000u - 1u) / bitrate_kbps + 1u;
        if (bus > t) {
            t = bus;
        }
    }
    return t;
}

void urb_can_master_default_config(urb_can_master_config_t *cfg)
{
    cfg->bitrate_kbps = 1000u;
    cfg->timeout_us = urb_can_master_timeout_us(cfg->bitrate_kbps);
    cfg->recover_us = urb_can_master_recover_us(cfg->bitrate_kbps);
}

void urb_can_master_init(urb_can_master_t *m, const urb_can_hal_t *hal, const urb_can_master_config_t *cfg)
{
    m->hal = hal;
    m->cfg = *cfg;
    m->op = URB_DL_SYNC;
    m->address = 0u;
    m->mailbox = 0u;
    m->length = 0u;
    m->tid = 0u;
    m->data = NULL;
    m->sync_payload[0] = 0u;
    m->refusal[0] = 0u;
    m->expect_id = 0u;
    m->frames_total = 0u;
    m->frames_sent = 0u;
    m->clear_result = URB_STATUS_BUS_STUCK;
    m->frame_ready = false;
    m->answered = false;
    m->t0 = 0u;
    m->recover_t0 = 0u;
    m->recovering = false; /* a bus-off at the first request starts a recovery */
    urb_can_tx_init(&m->tx, NULL, 0u, 0u);
    urb_can_rx_reset(&m->rx);
    m->frame.id = 0u;
    m->frame.len = 0u;
    m->phase = PH_IDLE;
    m->result = URB_STATUS_OK;
    m->stats.timeouts = 0u;
    m->stats.bus_off = 0u;
    m->stats.recoveries = 0u;
    m->stats.stale = 0u;
    m->stats.foreign = 0u;
    m->stats.repeated = 0u;
    m->stats.crc_errors = 0u;
    /* loop bound: 64 addresses x 16 sessions */
    for (uint8_t a = 0u; a <= URB_CAN_LAST_ADDRESS; a++) {
        for (uint8_t s = 0u; s < 16u; s++) {
            m->next_tid[a][s] = 0u;
        }
    }
}

uint8_t urb_can_master_next_tid(const urb_can_master_t *m, uint8_t address, uint8_t session)
{
    return m->next_tid[address & URB_CAN_LAST_ADDRESS][session & 15u];
}

bool urb_can_master_busy(const urb_can_master_t *m)
{
    uint8_t const ph = m->phase;
    return (ph == PH_SEND) || (ph == PH_WAIT) || (ph == PH_RECOVER);
}

void urb_can_master_stats(const urb_can_master_t *m, urb_can_master_stats_t *out)
{
    *out = m->stats;
}

/* Queues frames while the controller takes them (at most the transfer's 5). The frame the
 * controller refused stays in `frame` for the next call. */
static void pump(urb_can_master_t *m)
{
    /* loop bound: URB_CAN_MAX_FRAMES frames */
    for (uint8_t i = 0u; i < URB_CAN_MAX_FRAMES; i++) {
        if (!m->frame_ready) {
            uint8_t const n = urb_can_tx_next(&m->tx, m->frame.data); /* CanTransfer.tla SendFrame */
            if (n == 0u) {
                return;
            }
            m->frame.len = n;
            m->frame_ready = true;
        }
        if (!m->hal->tx(m->hal->ctx, &m->frame)) {
            return;
        }
        m->frame_ready = false;
    }
}

/* A completed answer's outcome (the contract in urb_can_master.h). */
static uint8_t answer_status(urb_can_master_t *m)
{
    uint8_t const n = urb_can_rx_len(&m->rx);
    if (m->op == URB_DL_READ) {
        if (n == 0u) {
            return URB_STATUS_BAD_REQUEST; /* the node has no such outbox */
        }
        return (n == m->length) ? URB_STATUS_OK : URB_STATUS_SIZE_MISMATCH;
    }
    if (m->op == URB_DL_PROBE) {
        return URB_STATUS_OK; /* any answer: the node took its address */
    }
    if (n == 0u) {
        return URB_STATUS_OK; /* a write the node stored */
    }
    /* Not an answer a node sends: corrupt. The node may have stored the write before its answer
     * was garbled, so only TIMEOUT is true (Bridge.tla WriteStatusTruthful; Rs485Poll.tla found it). */
    urb_can_write_refusal_t refusal;
    if ((n != 1u) || (urb_can_write_refusal_decode(&refusal, m->refusal, 1u) < 0)) {
        return URB_STATUS_TIMEOUT;
    }
    uint8_t const st = refusal.status;
    if ((st == URB_STATUS_NODE_BUSY) || (st == URB_STATUS_CHECKSUM) || (st == URB_STATUS_SIZE_MISMATCH) ||
        (st == URB_STATUS_BAD_REQUEST)) {
        return st;
    }
    return URB_STATUS_TIMEOUT;
}

void urb_can_master_rx(urb_can_master_t *m, const urb_can_frame_t *frame)
{
    uint8_t const ph = m->phase;
    if ((ph != PH_SEND) && (ph != PH_WAIT)) {
        return; /* no answer awaited: a late frame */
    }
    if ((frame->id != m->expect_id) || (frame->len == 0u) || (frame->len > URB_CAN_MTU)) {
        m->stats.foreign++;
        return;
    }
#if !defined(URB_MUTANT_CAN_NO_TID_FILTER)
    if ((frame->data[frame->len - 1u] & URB_CAN_TAIL_TID) != m->tid) {
        m->stats.stale++; /* an answer to an earlier request on this mailbox (the transfer id filter) */
        return;
    }
#endif
    bool const read = m->op == URB_DL_READ;
    urb_can_rx_result_t const r = urb_can_rx_frame(&m->rx, frame->data, frame->len, read ? m->data : m->refusal,
                                                   read ? m->length : 1u);
    if (r == URB_CAN_RX_MORE) {
        m->answered = true;
        return;
    }
    if (r == URB_CAN_RX_DONE) {
        m->result = answer_status(m);
    } else if (r == URB_CAN_RX_CRC) {
        m->stats.crc_errors++;
        /* a write's answer is one frame (no CRC): a failed multi-frame one is garbled, and the node
         * may have stored the write, so only TIMEOUT is true (as answer_status; fw_can_master) */
        m->result = (m->op == URB_DL_WRITE) ? URB_STATUS_TIMEOUT : URB_STATUS_CHECKSUM;
    } else {
        m->stats.repeated++;
        return;
    }
    m->answered = true;
    m->phase = PH_DONE;
}

void urb_can_master_tx_done(urb_can_master_t *m)
{
    if (m->phase != PH_SEND) {
        return; /* a frame of an abandoned transaction */
    }
    m->frames_sent++;
    if (m->frames_sent < m->frames_total) {
        pump(m);
        return;
    }
    if (m->op == URB_DL_SYNC) {
        m->result = URB_STATUS_OK; /* nobody answers a broadcast */
        m->phase = PH_DONE;
        return;
    }
    m->phase = PH_WAIT;
}

static void start_recovery(urb_can_master_t *m, uint32_t now, uint8_t report)
{
    m->hal->tx_abort(m->hal->ctx);
    m->hal->recover(m->hal->ctx);
    m->stats.recoveries++;
    m->clear_result = report;
    m->t0 = now;
    m->recover_t0 = now;
    m->recovering = true;
    m->phase = PH_RECOVER;
}

static bool master_begin(void *ctx, const urb_downlink_txn_t *t, uint32_t now)
{
    urb_can_master_t *m = (urb_can_master_t *)ctx;
    const urb_can_hal_t *h = m->hal;
    if (m->phase != PH_IDLE) {
        return false;
    }
    lock(m, true);
    m->op = t->op;
    m->address = (uint8_t)(t->address & URB_CAN_LAST_ADDRESS);
    m->mailbox = (uint8_t)(t->mailbox & 7u);
    m->length = (t->length > URB_CAN_MAX_PAYLOAD) ? (uint8_t)URB_CAN_MAX_PAYLOAD : t->length;
    m->data = t->data;
    m->answered = false;
    m->frame_ready = false;
    m->frames_sent = 0u;
    m->result = URB_STATUS_TIMEOUT;
    urb_can_rx_reset(&m->rx);
    if (t->op == URB_DL_CLEAR) {
        start_recovery(m, now, URB_STATUS_OK);
        lock(m, false);
        return true;
    }
    if (h->state(h->ctx) != (uint8_t)URB_CAN_BUS_OFF) {
        m->recovering = false; /* back on the bus */
    } else {
#if defined(URB_MUTANT_CAN_BUSOFF_AS_TIMEOUT)
        m->result = URB_STATUS_TIMEOUT;
        m->phase = PH_DONE;
#else
        /* as a stuck I2C bus: the request is not executed, the bus is cleared (recovered) first */
        m->stats.bus_off++;
#if !defined(URB_MUTANT_CAN_WAIT_EACH_RECOVERY)
        if (m->recovering) {
            /* a recovery asked for by an earlier transaction has not brought the controller back:
             * report at once (asking again when the last ask is older than a recovery), as a bus
             * clear of a still stuck I2C bus does; waiting a recovery out for every transaction
             * would let the heartbeat's SYNCs (one per period, each longer than the period) starve
             * the host's requests for as long as the bus is off */
            if ((uint32_t)(now - m->recover_t0) > m->cfg.recover_us) {
                m->hal->recover(m->hal->ctx);
                m->stats.recoveries++;
                m->recover_t0 = now;
            }
            m->result = URB_STATUS_BUS_STUCK;
            m->phase = PH_DONE;
            lock(m, false);
            return true;
        }
#endif
        start_recovery(m, now, URB_STATUS_BUS_STUCK);
#endif
        lock(m, false);
        return true;
    }
    uint16_t id;
    const uint8_t *payload = NULL;
    uint8_t len = 0u;
    if (t->op == URB_DL_SYNC) {
        id = URB_CAN_SYNC_ID;
        m->sync_payload[0] = t->counter;
        payload = m->sync_payload;
        len = 1u;
        m->tid = (uint8_t)(t->counter & URB_CAN_TAIL_TID);
        m->expect_id = 0xFFFFu; /* no answer */
    } else {
        bool const read = t->op == URB_DL_READ;
        uint8_t const box = (t->op == URB_DL_PROBE) ? 0u : m->mailbox;
        uint8_t const s = urb_can_session(box, read);
        id = urb_can_id(m->address, box, read, URB_CAN_REQUEST);
        m->expect_id = urb_can_id(m->address, box, read, URB_CAN_RESPONSE);
        m->tid = m->next_tid[m->address][s];
#if !defined(URB_MUTANT_CAN_SAME_TID)
        m->next_tid[m->address][s] = (uint8_t)((m->tid + 1u) & URB_CAN_TAIL_TID);
#endif
        if (t->op == URB_DL_WRITE) {
            payload = m->data;
            len = m->length;
        }
    }
    m->frame.id = id;
    urb_can_tx_init(&m->tx, payload, len, m->tid); /* CanTransfer.tla SendStart */
    m->frames_total = urb_can_frames(len);
    m->t0 = now;
    m->phase = PH_SEND;
    pump(m);
    lock(m, false);
    return true;
}

static int8_t master_poll(void *ctx, uint32_t now)
{
    urb_can_master_t *m = (urb_can_master_t *)ctx;
    const urb_can_hal_t *h = m->hal;
    uint8_t const ph = m->phase;
    BARRIER(); /* read the phase before what the interrupt wrote */
    if (ph == PH_IDLE) {
        return URB_DOWNLINK_IDLE;
    }
    if (ph == PH_DONE) {
        m->phase = PH_IDLE;
        return (int8_t)m->result;
    }
    if (ph == PH_RECOVER) {
        if (h->state(h->ctx) == (uint8_t)URB_CAN_ERROR_ACTIVE) {
            m->recovering = false;
            m->phase = PH_IDLE;
            return (int8_t)m->clear_result;
        }
        if ((uint32_t)(now - m->t0) > m->cfg.recover_us) {
            m->phase = PH_IDLE;
            return (int8_t)URB_STATUS_BUS_STUCK; /* still not back on the bus */
        }
        return URB_DOWNLINK_BUSY;
    }
    lock(m, true);
    if (m->phase == PH_DONE) {
        /* the interrupt finished it meanwhile */
        m->phase = PH_IDLE;
        lock(m, false);
        return (int8_t)m->result;
    }
    if ((uint32_t)(now - m->t0) <= m->cfg.timeout_us) {
        if (m->phase == PH_SEND) {
            pump(m); /* a slot the controller refused before may be free now */
        }
        lock(m, false);
        return URB_DOWNLINK_BUSY;
    }
    h->tx_abort(h->ctx);
    m->stats.timeouts++;
    uint8_t result = URB_STATUS_TIMEOUT; /* request not all sent, or an answer begun and not ended */
    if ((m->phase == PH_WAIT) && !m->answered) {
        result = URB_STATUS_NO_NODE; /* nobody answered: no node took the address */
    }
    m->phase = PH_IDLE;
    lock(m, false);
    return (int8_t)result;
}

void urb_can_master_downlink(urb_can_master_t *m, urb_downlink_t *dl)
{
    dl->ctx = m;
    dl->kind = (uint8_t)URB_DOWNLINK_KIND_CAN;
    dl->bitrate_kbps = m->cfg.bitrate_kbps;
    dl->first_address = (uint8_t)URB_CAN_FIRST_ADDRESS;
    dl->last_address = (uint8_t)URB_CAN_LAST_ADDRESS;
    dl->begin = master_begin;
    dl->poll = master_poll;
}
