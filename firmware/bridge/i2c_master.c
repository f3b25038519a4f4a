/*
 * I2C downlink master: the bridge side of the downlink contract in urb_downlink.h.
 *
 * Split in two halves so the interrupt never waits:
 *  - urb_i2c_master_event() (interrupt): one HAL event in, at most one HAL operation out, O(1);
 *  - master_begin()/master_poll() (main loop): set up a transaction (the write check is computed
 *    here, O(length)), verify a read check, time out, bit-bang a bus clear one half clock per call.
 * Each bus outcome maps to the status that names its cause (Bridge.tla Serve, ErrorNamesCause).
 */
#include "bridge_internal.h"

#include "urb_core.h"
#include "urb_runtime.h"

/* Phases. Busy ones wait for a HAL event; FINISH/FAULT wait for poll(). */
enum {
    PH_IDLE = 0u,   /* nothing running (or the outcome was reported) */
    PH_START = 1u,  /* waiting for the first START */
    PH_TX = 2u,     /* waiting for the ACK of byte `pos` of hdr+data+tail */
    PH_RSTART = 3u, /* waiting for the repeated START after a read-select */
    PH_ADDR_R = 4u, /* waiting for the ACK of the read address */
    PH_RX = 5u,     /* waiting for read byte `pos` */
    PH_FINISH = 6u, /* bus part over (STOP sent); `result` holds the outcome before checks */
    PH_FAULT = 7u,  /* the controller reported an error */
    PH_CLEAR = 8u,  /* bit-banging the bus clear (poll only) */
};

#define BOTH_LINES (URB_I2C_SCL | URB_I2C_SDA)
#define CLEAR_FOR_COMMAND 0xFEu /* clear_for: an explicit URB_DL_CLEAR (OK when the bus is free after) */

uint32_t urb_i2c_master_timeout_us(uint32_t bitrate_kbps)
{
    /* bits x 1000 / kb/s = us; x 2 for stretching; rounded up without overflow for any rate */
    uint32_t const bits_ms = 2u * URB_I2C_LONGEST_BITS * 1000u;
    uint32_t t = URB_I2C_MIN_TIMEOUT_US;
    if (bitrate_kbps > 0u) {
        uint32_t const bus = (bits_ms - 1u) / bitrate_kbps + 1u;
        if (bus > t) {
            t = bus;
        }
    }
    return t;
}

void urb_i2c_master_default_config(urb_i2c_master_config_t *cfg)
{
    cfg->bitrate_kbps = 400u;
    cfg->timeout_us = urb_i2c_master_timeout_us(cfg->bitrate_kbps); /* 2000 us */
    cfg->clear_half_us = 5u;
}

static void forget_all(urb_i2c_master_t *m)
{
    /* loop bound: 128 addresses */
    for (uint8_t a = 0u; a < 128u; a++) {
        m->sel[a] = URB_I2C_NO_SELECTION;
    }
}

void urb_i2c_master_init(urb_i2c_master_t *m, const urb_i2c_hal_t *hal, const urb_i2c_master_config_t *cfg)
{
    m->hal = hal;
    m->cfg = *cfg;
    m->phase = PH_IDLE;
    m->pos = 0u;
    m->result = URB_STATUS_OK;
    m->op = URB_DL_SYNC;
    m->address = 0u;
    m->mailbox = 0u;
    m->length = 0u;
    m->data = NULL;
    m->n_hdr = 0u;
    m->n_data = 0u;
    m->n_tail = 0u;
    m->n_rx = 0u;
    m->read_after = false;
    m->t0 = 0u;
    m->clear_step = 0u;
    m->clear_for = URB_STATUS_BUS_STUCK;
    m->t_step = 0u;
    m->bus_clears = 0u;
    m->timeouts = 0u;
    forget_all(m);
}

uint8_t urb_i2c_master_selection(const urb_i2c_master_t *m, uint8_t address)
{
    return m->sel[address & 0x7Fu];
}

bool urb_i2c_master_busy(const urb_i2c_master_t *m)
{
    uint8_t const ph = m->phase;
    return (ph >= PH_START) && (ph <= PH_RX);
}

bool urb_i2c_master_deadline(const urb_i2c_master_t *m, uint32_t *deadline_us)
{
    if (!urb_i2c_master_busy(m)) {
        return false;
    }
    *deadline_us = m->t0 + m->cfg.timeout_us + 1u; /* poll() times out once now - t0 > timeout_us */
    return true;
}

uint32_t urb_i2c_master_timeouts(const urb_i2c_master_t *m)
{
    return m->timeouts;
}

uint32_t urb_i2c_master_bus_clears(const urb_i2c_master_t *m)
{
    return m->bus_clears;
}

/* Byte `pos` of the write sequence: header (address, select), data, check. */
static uint8_t tx_byte(const urb_i2c_master_t *m, uint8_t pos)
{
    if (pos < m->n_hdr) {
        return m->hdr[pos];
    }
    pos = (uint8_t)(pos - m->n_hdr);
    if (pos < m->n_data) {
        return m->data[pos];
    }
    return m->tail[(uint8_t)(pos - m->n_data) & 1u];
}

/* The status a NACK of byte `pos` names (contract in urb_downlink.h). */
static uint8_t nack_status(const urb_i2c_master_t *m, uint8_t pos)
{
    if (m->op == URB_DL_SYNC) {
        return URB_STATUS_OK; /* no node acknowledging the general call is not an error */
    }
    if (pos == 0u) {
        return URB_STATUS_NO_NODE; /* Discovery.tla HostRequest: a vanished node gets NO_NODE (bridge.c decides) */
    }
    if (pos == 1u) {
        return URB_STATUS_BAD_REQUEST; /* the node has no such mailbox */
    }
    if (pos == 2u) {
        return URB_STATUS_NODE_BUSY; /* the node's MailboxInbox.tla IsrWriteBegin NACKs when both buffers are taken */
    }
    if (pos < (uint8_t)(2u + m->n_data)) {
        return URB_STATUS_SIZE_MISMATCH; /* more data than the inbox holds */
    }
    return URB_STATUS_CHECKSUM; /* the node's MailboxInbox.tla IsrWriteAbort: it refused the check */
}

static void finish_bus(urb_i2c_master_t *m, uint8_t result)
{
    m->result = result;
    m->phase = PH_FINISH; /* before stop(): the HAL may interrupt right after it */
    m->hal->stop(m->hal->ctx);
}

/* Interrupt side. Every branch does O(1) work and issues at most one HAL operation. The phase is
 * written before the operation so that an event arriving at once finds the right phase. */
void urb_i2c_master_event(urb_i2c_master_t *m, urb_i2c_event_t ev, uint8_t byte)
{
    const urb_i2c_hal_t *h = m->hal;
    uint8_t const ph = m->phase;
    if ((ph == PH_IDLE) || (ph >= PH_FINISH)) {
        return; /* late event of an aborted transaction: nothing to do */
    }
    if (ev == URB_I2C_EV_ERROR) {
        m->phase = PH_FAULT; /* lines checked, bus cleared if needed, in poll() */
        return;
    }
    switch (ph) {
    case PH_START:
    case PH_RSTART:
        if (ev != URB_I2C_EV_START) {
            break;
        }
        if ((ph == PH_START) && (m->n_hdr > 0u)) {
            m->pos = 0u;
            m->phase = PH_TX;
            h->write(h->ctx, m->hdr[0]);
        } else {
            /* read with a cached selection, or the repeated START after the select */
            m->phase = PH_ADDR_R;
            h->write(h->ctx, (uint8_t)((uint8_t)(m->address << 1) | 1u));
        }
        return;
    case PH_TX:
        if (ev == URB_I2C_EV_NACK) {
            finish_bus(m, nack_status(m, m->pos));
            return;
        }
        if (ev != URB_I2C_EV_ACK) {
            break;
        }
        {
            uint8_t const next = (uint8_t)(m->pos + 1u);
            if (next < (uint8_t)(m->n_hdr + m->n_data + m->n_tail)) {
                m->pos = next;
                h->write(h->ctx, tx_byte(m, next));
            } else if (m->read_after) {
                m->phase = PH_RSTART;
                h->start(h->ctx);
            } else {
                finish_bus(m, URB_STATUS_OK);
            }
        }
        return;
    case PH_ADDR_R:
        if (ev == URB_I2C_EV_NACK) {
            finish_bus(m, URB_STATUS_NO_NODE); /* Discovery.tla HostRequest (VanishedGetNoNode) */
            return;
        }
        if (ev != URB_I2C_EV_ACK) {
            break;
        }
        m->pos = 0u;
        m->phase = PH_RX;
        h->read(h->ctx, m->n_rx > 1u); /* ACK all but the last byte */
        return;
    case PH_RX:
        if (ev != URB_I2C_EV_BYTE) {
            break;
        }
        {
            uint8_t const k = m->pos;
            if (k < m->length) {
                m->data[k] = byte;
            } else {
                m->rx_check[(uint8_t)(k - m->length) & 1u] = byte;
            }
            uint8_t const next = (uint8_t)(k + 1u);
            if (next < m->n_rx) {
                m->pos = next;
                h->read(h->ctx, (uint8_t)(next + 1u) < m->n_rx);
            } else {
                finish_bus(m, URB_STATUS_OK); /* the check is verified in poll(), O(length) */
            }
        }
        return;
    default:
        break;
    }
    m->phase = PH_FAULT; /* an event the phase does not expect: treat like a bus error */
}

static void start_clear(urb_i2c_master_t *m, uint32_t now, uint8_t clear_for)
{
    /* A bus clear may reset node state machines: every cached selection is suspect. */
    forget_all(m);
    m->bus_clears++;
    m->clear_for = clear_for;
    m->clear_step = 0u;
    m->t_step = now;
    m->phase = PH_CLEAR;
}

/* One step of the standard bus clear (UM10204 3.1.16): nine SCL pulses with SDA released, so a
 * node stuck in the middle of a byte clocks it out and releases SDA, then a STOP. One half clock
 * per call; the caller returns to the main loop in between (never waits). */
static int8_t clear_step(urb_i2c_master_t *m, uint32_t now)
{
    const urb_i2c_hal_t *h = m->hal;
    uint8_t const k = m->clear_step;
    if ((k > 0u) && ((uint32_t)(now - m->t_step) < (uint32_t)m->cfg.clear_half_us)) {
        return URB_DOWNLINK_BUSY;
    }
    m->t_step = now;
    if (k < 18u) {
        /* even k: SCL low, odd k: SCL high; SDA released throughout */
        h->drive(h->ctx, ((k & 1u) != 0u) ? BOTH_LINES : URB_I2C_SDA);
    } else if (k == 18u) {
        h->drive(h->ctx, 0u); /* SCL low, then SDA low: set up the STOP */
    } else if (k == 19u) {
        h->drive(h->ctx, URB_I2C_SCL); /* SCL high, SDA still low */
    } else if (k == 20u) {
        h->drive(h->ctx, BOTH_LINES); /* SDA rises while SCL is high: STOP */
    } else {
        h->release(h->ctx);
        bool const free_bus = (h->lines(h->ctx) & BOTH_LINES) == BOTH_LINES;
        m->phase = PH_IDLE;
        if ((m->clear_for == CLEAR_FOR_COMMAND) && free_bus) {
            return (int8_t)URB_STATUS_OK;
        }
        return (int8_t)URB_STATUS_BUS_STUCK; /* the request was not executed */
    }
    m->clear_step = (uint8_t)(k + 1u);
    return URB_DOWNLINK_BUSY;
}

/* After an error event or a timeout (the controller is already stopped): a line held low means a
 * stuck bus, cleared before anything else; free lines mean the node did not finish in time. */
static int8_t fault(urb_i2c_master_t *m, uint32_t now)
{
    const urb_i2c_hal_t *h = m->hal;
    if (m->op != URB_DL_SYNC) {
        m->sel[m->address & 0x7Fu] = URB_I2C_NO_SELECTION; /* the node may be anywhere in its frame */
    }
#ifndef URB_MUTANT_NO_BUS_CLEAR
    if ((h->lines(h->ctx) & BOTH_LINES) != BOTH_LINES) {
        start_clear(m, now, URB_STATUS_BUS_STUCK);
        return URB_DOWNLINK_BUSY;
    }
#else
    (void)now;
#endif
    h->release(h->ctx);
    m->phase = PH_IDLE;
    return (int8_t)URB_STATUS_TIMEOUT;
}

/* The bus part is over: verify a read's check and keep the selection cache truthful. */
static int8_t finish(urb_i2c_master_t *m)
{
    uint8_t result = m->result;
    uint8_t const a = m->address & 0x7Fu;
    if (m->op == URB_DL_READ) {
        if (result == URB_STATUS_OK) {
            uint8_t const select = (uint8_t)(m->mailbox | 0x80u);
            uint32_t const want = urb_link_check(&select, 1u, m->data, m->length);
            uint32_t got = m->rx_check[0];
            if (m->n_rx > (uint8_t)(m->length + 1u)) {
                got |= (uint32_t)m->rx_check[1] << 8;
            }
            if (got != want) {
                result = URB_STATUS_CHECKSUM; /* DownlinkReadResponse failed: corrupt, or the node lost its selection */
            }
        }
        if (result == URB_STATUS_OK) {
            m->sel[a] = m->mailbox;
        }
#ifdef URB_MUTANT_NO_SEL_INVALIDATE
        else if (result == URB_STATUS_CHECKSUM) {
            m->sel[a] = m->mailbox; /* mutant: trusts a selection the node may have lost */
        }
#endif
        else {
            m->sel[a] = URB_I2C_NO_SELECTION; /* the node may have reset: select again next time */
        }
    } else if (m->op == URB_DL_WRITE) {
        /* NODE_BUSY, SIZE_MISMATCH and CHECKSUM come from a node that followed the contract: its
         * read selection is intact. Anything else (NO_NODE, BAD_REQUEST) may hide a reset. */
        if ((result == URB_STATUS_NO_NODE) || (result == URB_STATUS_BAD_REQUEST)) {
            m->sel[a] = URB_I2C_NO_SELECTION;
        }
    } else if (m->op == URB_DL_SYNC) {
        result = URB_STATUS_OK; /* nobody answers a broadcast */
    } else {
        /* PROBE: OK or NO_NODE, as the address was acknowledged or not */
    }
    m->phase = PH_IDLE;
    return (int8_t)result;
}

static bool master_begin(void *ctx, const urb_downlink_txn_t *t, uint32_t now)
{
    urb_i2c_master_t *m = (urb_i2c_master_t *)ctx;
    const urb_i2c_hal_t *h = m->hal;
    if (m->phase != PH_IDLE) {
        return false;
    }
    m->op = t->op;
    m->address = (uint8_t)(t->address & 0x7Fu);
    m->mailbox = (uint8_t)(t->mailbox & 0x07u);
    m->length = (t->length > 32u) ? 32u : t->length;
    m->data = t->data;
    m->n_hdr = 0u;
    m->n_data = 0u;
    m->n_tail = 0u;
    m->n_rx = 0u;
    m->read_after = false;
    m->result = URB_STATUS_OK;
    m->pos = 0u;
    if (t->op == URB_DL_CLEAR) {
        start_clear(m, now, CLEAR_FOR_COMMAND);
        return true;
    }
#ifndef URB_MUTANT_NO_BUS_CLEAR
    if ((h->lines(h->ctx) & BOTH_LINES) != BOTH_LINES) {
        /* A line held low before we start: clear it and do not execute the request. */
        start_clear(m, now, URB_STATUS_BUS_STUCK);
        return true;
    }
#endif
    if (t->op == URB_DL_WRITE) {
        /* DownlinkWrite: address, select (bit 7 = 0), data, check over select+data. */
        m->hdr[0] = (uint8_t)(m->address << 1);
        m->hdr[1] = m->mailbox;
        m->n_hdr = 2u;
        m->n_data = m->length;
        uint32_t const check = urb_link_check(&m->hdr[1], 1u, m->data, m->length);
        m->tail[0] = (uint8_t)(check & 0xFFu);
        m->tail[1] = (uint8_t)((check >> 8) & 0xFFu);
        m->n_tail = (uint8_t)urb_link_check_size(1u + (size_t)m->length);
    } else if (t->op == URB_DL_READ) {
        if (t->reselect || (m->sel[m->address] != m->mailbox)) {
            /* DownlinkReadSelect, then a repeated START for the read. */
            m->hdr[0] = (uint8_t)(m->address << 1);
            m->hdr[1] = (uint8_t)(m->mailbox | 0x80u);
            m->n_hdr = 2u;
            m->read_after = true;
        }
        m->n_rx = (uint8_t)(m->length + urb_link_check_size(1u + (size_t)m->length));
    } else if (t->op == URB_DL_PROBE) {
        m->hdr[0] = (uint8_t)(m->address << 1); /* the address alone, then STOP */
        m->n_hdr = 1u;
    } else {
        /* SyncBroadcast on the general call address. */
        m->hdr[0] = 0x00u;
        m->hdr[1] = (uint8_t)URB_SYNC_MAGIC;
        m->hdr[2] = t->counter;
        m->n_hdr = 3u;
    }
    m->t0 = now;
    m->phase = PH_START; /* before start(): its event may come at once */
    h->start(h->ctx);
    return true;
}

static int8_t master_poll(void *ctx, uint32_t now)
{
    urb_i2c_master_t *m = (urb_i2c_master_t *)ctx;
    uint8_t const ph = m->phase;
    URB_BARRIER(); /* read the phase before the data the interrupt wrote */
    switch (ph) {
    case PH_IDLE:
        return URB_DOWNLINK_IDLE;
    case PH_FINISH:
        return finish(m);
    case PH_FAULT:
        return fault(m, now);
    case PH_CLEAR:
        return clear_step(m, now);
    default:
        if ((uint32_t)(now - m->t0) > m->cfg.timeout_us) {
            /* No completion in time (a node stretching SCL for ever, a lost event). Stop the
             * controller first so no late event races the fault handling. */
            m->hal->abort(m->hal->ctx);
            m->timeouts++;
            return fault(m, now);
        }
        return URB_DOWNLINK_BUSY;
    }
}

void urb_i2c_master_downlink(urb_i2c_master_t *m, urb_downlink_t *dl)
{
    dl->ctx = m;
    dl->kind = (uint8_t)URB_DOWNLINK_KIND_I2C;
    dl->bitrate_kbps = m->cfg.bitrate_kbps;
    dl->first_address = (uint8_t)URB_I2C_FIRST_ADDRESS;
    dl->last_address = (uint8_t)URB_I2C_LAST_ADDRESS;
    dl->begin = master_begin;
    dl->poll = master_poll;
}
