/*
 * The request FIFO of firmware/bridge/bridge.c against a reference model, for the mutation score
 * (tests/mutation/README.md, component "bridge FIFO"). The bridge runs on a scripted downlink
 * (scripted_rig.h: the test ends each transaction with an outcome it draws, refuses begins, loses
 * transactions); requests enter through urbb_frame, as both uplink parsers hand them over. Random
 * request sequences (admitted, BUSY only when every data slot is taken, admission errors, requests
 * past the host's window, frames failing their check or a schema rule, BridgeInfo and BridgeScan
 * reads, NOP, SET_HEARTBEAT, BUS_CLEAR and unknown commands) meet random downlink outcomes
 * (probes, identifications), heartbeat ticks, uplinks without room and lost transactions. After
 * every poll the model predicts the downlink transaction begun (kind, address, mailbox, length,
 * payload, SYNC counter), the requests still outstanding, the bridge's idleness, its heartbeat
 * period and its counters; every response that leaves is compared (seq, status, data) in request
 * order on its own uplink.
 *
 * The model is written from the contracts (Bridge.tla, urb_bridge.h, urb_downlink.h, the comments
 * of bridge.c), in plain arrays: a list of outstanding requests in arrival order, each with its
 * final status or "pending"; the data slots are the entries that hold one.
 */
#include <string.h>

#include "bridge_internal.h"
#include "scripted_rig.h"
#include "support.h"
#include "urb_runtime.h"

#define PENDING 0xFFu
#define OUT_MAX 256u

/* ===== The model ================================================================================ */

typedef struct {
    uint8_t seq, uplink, status; /* status: final, or PENDING */
    bool slot;                   /* holds a data slot (admitted OK) */
    uint8_t address, mailbox, length;
    bool read;
    uint8_t data[32];            /* a write's payload; an OK read's data */
} m_entry_t;

typedef struct {
    uint8_t seq, status, len;
    uint8_t data[32];
} m_response_t;

typedef struct {
    uint8_t depth;
    m_entry_t q[URB_BRIDGE_RING_MAX];
    unsigned n;
    bool known[128], present[128];
    bool probing, size_checked;
    uint8_t activity; /* URBB_ACT_NONE, _REQUEST, _PROBE, _LEARN */
    uint32_t frames, busy, window_overflow, responses, syncs, syncs_missed;
    uint8_t hb_ticks, hb_done;
    uint16_t heartbeat_us;
    unsigned clears, set_heartbeats; /* witnesses */
    unsigned probes, learns, lost, held[2]; /* witnesses: transactions, and responses held for room */
    unsigned absent_no_node;               /* witness: NO_NODE of a node held absent, answered at once */
    m_response_t out[2][OUT_MAX]; /* per uplink: responses sent and not yet read, n_out modulo OUT_MAX */
    unsigned n_out[2], n_seen[2];
} model_t;

static uint32_t rng_state;

static uint32_t rnd(uint32_t n)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 17;
    rng_state ^= rng_state << 5;
    return rng_state % n;
}

static void model_init(model_t *m, uint8_t depth)
{
    memset(m, 0, sizeof *m);
    m->depth = depth;
    for (uint8_t a = SRIG_FIRST; a <= SRIG_LAST; a++) {
        m->known[a] = srig_present_at_start(a);
        m->present[a] = srig_present_at_start(a);
    }
}

static unsigned slots_taken(const model_t *m)
{
    unsigned k = 0u;
    for (unsigned i = 0u; i < m->n; i++) {
        k += m->q[i].slot ? 1u : 0u;
    }
    return k;
}

static m_entry_t *first_pending(model_t *m)
{
    for (unsigned i = 0u; i < m->n; i++) {
        if (m->q[i].status == PENDING) {
            return &m->q[i];
        }
    }
    return NULL;
}

/* -1 when the bridge does not know the size of (a, box, read). */
static int known_size(const model_t *m, uint8_t a, uint8_t box, bool read)
{
    uint8_t in[8], out[8];
    if (a == 0u) {
        return read ? urb_node_bridge_outbox_sizes[box] : urb_node_bridge_inbox_sizes[box];
    }
    if (!m->known[a]) {
        return -1;
    }
    srig_node_sizes(a, in, out);
    return read ? out[box] : in[box];
}

/* A request as a frame: well-formed, or one that passes its check but breaks a schema rule (a
 * read of 0 bytes: answered BAD_REQUEST), or one that fails its check (not admitted at all). */
typedef enum { FRAME_OK, FRAME_RANGE, FRAME_BAD_CHECK } frame_kind_t;

static uint8_t encode(uint8_t *f, const m_entry_t *e, frame_kind_t kind)
{
    size_t n;
    if (e->read || (kind == FRAME_RANGE)) {
        n = enc_read(f, e->address, e->mailbox, e->seq, (kind == FRAME_RANGE) ? 1u : e->length);
        if (kind == FRAME_RANGE) {
            f[2] = 0u;
            f[3] = (uint8_t)urb_link_check(NULL, 0u, f, 3u);
        }
    } else {
        n = enc_write(f, e->address, e->mailbox, e->seq, e->length, e->data);
    }
    if (kind == FRAME_BAD_CHECK) {
        f[n - 1u] ^= 0x5Au;
    }
    return (uint8_t)n;
}

/* Bridge.tla SubmitAndAdmit, through urbb_frame. */
static void submit(srig_t *r, model_t *m, m_entry_t e, frame_kind_t kind)
{
    uint8_t f[URB_BRIDGE_FRAME_MAX];
    uint8_t const n = encode(f, &e, kind);
    bool const taken = urbb_frame(&r->b, e.uplink, f, n);
    assert_int_equal(taken, kind != FRAME_BAD_CHECK);
    if (kind == FRAME_BAD_CHECK) {
        return;
    }
    m->frames++;
    if (m->n >= URB_BRIDGE_RING_MAX) {
        m->window_overflow++;
        return;
    }
    e.slot = false;
    e.status = PENDING;
    if (kind == FRAME_RANGE) {
        e.status = URB_STATUS_BAD_REQUEST;
    } else if ((e.address != 0u) && ((e.address < SRIG_FIRST) || (e.address > SRIG_LAST))) {
        e.status = URB_STATUS_BAD_REQUEST;
    } else {
        int const size = known_size(m, e.address, e.mailbox, e.read);
        if ((size >= 0) && (size != e.length)) {
            e.status = URB_STATUS_SIZE_MISMATCH;
        } else if (slots_taken(m) >= m->depth) {
            e.status = URB_STATUS_BUSY;
            m->busy++;
        } else {
            e.slot = true;
        }
    }
    m->q[m->n++] = e;
}

static void m_complete(model_t *m, uint8_t status)
{
    m_entry_t *p = first_pending(m);
    assert_non_null(p);
    if ((status == URB_STATUS_OK) && p->read && (p->address != 0u) && (p->mailbox == 0u) &&
        (p->length == URB_IDENTIFICATION_SIZE)) {
        m->known[p->address] = true; /* the host read an identification: the bridge learns it */
    }
    p->status = status;
    m->size_checked = false;
}

static void m_served(model_t *m, uint8_t status)
{
    m_entry_t const *p = first_pending(m);
    uint8_t const a = p->address;
    if (a == 0u) {
        m_complete(m, status); /* BUS_CLEAR: the downlink's outcome, as it is */
        return;
    }
    if (status == URB_STATUS_NO_NODE) {
        if (m->present[a]) {
            m->probing = true;
            return;
        }
        m->absent_no_node++;
        m_complete(m, URB_STATUS_NO_NODE);
        return;
    }
    if ((status != URB_STATUS_TIMEOUT) && (status != URB_STATUS_BUS_STUCK)) {
        m->present[a] = true;
    }
    if (((status == URB_STATUS_BAD_REQUEST) || (status == URB_STATUS_SIZE_MISMATCH)) &&
        ((known_size(m, a, p->mailbox, p->read) >= 0) || m->size_checked)) {
        status = URB_STATUS_CHECKSUM;
    }
    m_complete(m, status);
}

static void m_probed(model_t *m, uint8_t status)
{
    m->probing = false;
    if (status == URB_STATUS_OK) {
        status = URB_STATUS_TIMEOUT;
    } else if (status == URB_STATUS_NO_NODE) {
        m->present[first_pending(m)->address] = false;
    }
    m_complete(m, status);
}

static void m_identified(model_t *m, uint8_t status)
{
    m_entry_t const *p = first_pending(m);
    uint8_t in[8], out[8];
    if ((status == URB_STATUS_TIMEOUT) || (status == URB_STATUS_BUS_STUCK)) {
        m_complete(m, status);
        return;
    }
    if (status == URB_STATUS_NO_NODE) {
        m->present[p->address] = false;
        m_complete(m, URB_STATUS_NO_NODE);
        return;
    }
    m->present[p->address] = true;
    if (status != URB_STATUS_OK) {
        m_complete(m, URB_STATUS_CHECKSUM);
        return;
    }
    m->known[p->address] = true;
    srig_node_sizes(p->address, in, out);
    if ((p->read ? out[p->mailbox] : in[p->mailbox]) != p->length) {
        m_complete(m, URB_STATUS_SIZE_MISMATCH);
        return;
    }
    m->size_checked = true;
}

/* A local request (address 0): true when it completed at once (its data, for a read, in p->data);
 * false when it went to the downlink (BUS_CLEAR) or waits for it. */
static bool m_local(model_t *m, srig_t *r, m_entry_t *p, unsigned begins_before)
{
    if (p->read && (p->mailbox == URB_NODE_BRIDGE_OUTBOX_BRIDGE_INFO)) {
        urb_bridge_info_t info = {0u, 400u, m->depth, m->heartbeat_us, URB_BRIDGE_FW_MAJOR, URB_BRIDGE_FW_MINOR,
                                  URB_BRIDGE_FW_PATCH};
        assert_int_equal(urb_bridge_info_encode(&info, p->data, sizeof p->data), (int32_t)URB_BRIDGE_INFO_SIZE);
        m_complete(m, URB_STATUS_OK);
        return true;
    }
    if (p->read) {
        urb_bridge_scan_t scan;
        for (unsigned a = 0u; a < 128u; a++) {
            scan.present[a] = m->present[a];
        }
        assert_int_equal(urb_bridge_scan_encode(&scan, p->data, sizeof p->data), (int32_t)URB_BRIDGE_SCAN_SIZE);
        m_complete(m, URB_STATUS_OK);
        return true;
    }
    uint8_t const opcode = p->data[0];
    if (opcode == URB_BRIDGE_OPCODE_SET_HEARTBEAT) {
        m->heartbeat_us = (uint16_t)(p->data[1] | (p->data[2] << 8));
        m->hb_done = m->hb_ticks; /* ticks of the old period do not trigger a SYNC */
        m->set_heartbeats++;
        m_complete(m, URB_STATUS_OK);
        return true;
    }
    if (opcode == URB_BRIDGE_OPCODE_BUS_CLEAR) {
        if (!r->refuse) {
            assert_int_equal(r->begins, begins_before + 1u);
            assert_int_equal(r->txn.op, URB_DL_CLEAR);
            m->activity = URBB_ACT_REQUEST;
            m->clears++;
        }
        return false;
    }
    m_complete(m, (opcode == URB_BRIDGE_OPCODE_NOP) ? URB_STATUS_OK : URB_STATUS_BAD_REQUEST);
    return true;
}

/* Bridge.tla Serve, first half (start_next): the transaction the bridge must begin, checked
 * against the one the scripted downlink saw; local requests complete on the way. */
static void m_start_next(model_t *m, srig_t *r, unsigned begins_before)
{
    if ((m->hb_ticks != m->hb_done) && (m->heartbeat_us == 0u)) {
        m->hb_done = m->hb_ticks; /* SYNC off: the tick is dropped */
    }
    if (m->hb_ticks != m->hb_done) {
        /* the SYNC goes first; while the downlink refuses it nothing else starts */
        if (!r->refuse) {
            assert_int_equal(r->begins, begins_before + 1u);
            assert_int_equal(r->txn.op, URB_DL_SYNC);
            assert_int_equal(r->txn.counter, m->hb_ticks);
            m->syncs_missed += (uint8_t)(m->hb_ticks - m->hb_done - 1u);
            m->hb_done = m->hb_ticks;
            m->syncs++;
            m->activity = URBB_ACT_SYNC;
        } else {
            assert_int_equal(r->begins, begins_before);
        }
        return;
    }
    if (m->probing) {
        if (!r->refuse) {
            assert_int_equal(r->begins, begins_before + 1u);
            assert_int_equal(r->txn.op, URB_DL_PROBE);
            assert_int_equal(r->txn.address, first_pending(m)->address);
            m->activity = URBB_ACT_PROBE;
            m->probes++;
        }
        return;
    }
    for (unsigned i = 0u; i < URB_BRIDGE_FIFO_MAX; i++) {
        m_entry_t *p = first_pending(m);
        if (p == NULL) {
            break;
        }
        if (p->address == 0u) {
            if (!m_local(m, r, p, begins_before)) {
                return;
            }
            continue;
        }
        bool const fixed_size = (p->mailbox == 0u) &&
                                (p->length == (p->read ? URB_IDENTIFICATION_SIZE : URB_COMMAND_SIZE));
        bool const learn = !m->size_checked && !fixed_size && (known_size(m, p->address, p->mailbox, p->read) < 0);
        if (r->refuse) {
            break;
        }
        assert_int_equal(r->begins, begins_before + 1u);
        assert_int_equal(r->txn.address, p->address);
        if (learn) {
            assert_int_equal(r->txn.op, URB_DL_READ);
            assert_int_equal(r->txn.mailbox, 0u);
            assert_int_equal(r->txn.length, URB_IDENTIFICATION_SIZE);
            assert_true(r->txn.reselect);
            m->activity = URBB_ACT_LEARN;
            m->learns++;
        } else {
            assert_int_equal(r->txn.op, p->read ? URB_DL_READ : URB_DL_WRITE);
            assert_int_equal(r->txn.mailbox, p->mailbox);
            assert_int_equal(r->txn.length, p->length);
            assert_false(r->txn.reselect);
            if (!p->read) {
                assert_memory_equal(r->txn.data, p->data, p->length);
            }
            m->activity = URBB_ACT_REQUEST;
        }
        return;
    }
    assert_int_equal(r->begins, begins_before);
}

static uint8_t response_len(const m_entry_t *e)
{
    if ((e->status == URB_STATUS_OK) && e->slot && e->read) {
        return (uint8_t)(1u + e->length + urb_link_check_size(1u + (size_t)e->length));
    }
    return 2u;
}

/* Bridge.tla Emit: the final responses at the head leave while their uplink has room (its room
 * read from the uplink's state before the poll: bridge_uplink.c is not what this group tests). */
static void m_emit(model_t *m, unsigned usb_room_bytes, unsigned usb_room_count, unsigned uart_room, bool uart_drains)
{
    while ((m->n > 0u) && (m->q[0].status != PENDING)) {
        m_entry_t const *e = &m->q[0];
        uint8_t const len = response_len(e);
        if (e->uplink == URBB_UPLINK_USB) {
            if ((len > usb_room_bytes) || (usb_room_count == 0u)) {
                m->held[URBB_UPLINK_USB]++;
                return;
            }
            usb_room_bytes -= len;
            usb_room_count--;
        } else {
            if (len > uart_room) {
                m->held[URBB_UPLINK_RS232]++;
                return;
            }
            uart_room -= uart_drains ? 0u : len; /* the kick took the bytes at once */
        }
        assert_true(m->n_out[e->uplink] - m->n_seen[e->uplink] < OUT_MAX);
        m_response_t *o = &m->out[e->uplink][m->n_out[e->uplink]++ % OUT_MAX];
        o->seq = e->seq;
        o->status = e->status;
        o->len = (len > 2u) ? e->length : 0u;
        memcpy(o->data, e->data, o->len);
        m->responses++;
        memmove(&m->q[0], &m->q[1], (m->n - 1u) * sizeof m->q[0]);
        m->n--;
    }
}

/* One poll of the bridge and of the model, then every observable compared. */
static void poll_both(srig_t *r, model_t *m)
{
    uint8_t const c = r->b.usb_cur;
    unsigned const usb_room_bytes = URB_BRIDGE_USB_BUF - r->b.usb_len[c];
    unsigned const usb_room_count = 128u - r->b.usb_count[c];
    unsigned const uart_room = URB_BRIDGE_TX_RING - (uint8_t)(r->b.tx_head - r->b.tx_tail);
    /* what the downlink will report */
    bool const reports = r->busy && (r->done || r->lose);
    uint8_t const status = r->lose ? URB_STATUS_TIMEOUT : r->outcome;
    unsigned const begins_before = r->begins;
    urb_bridge_poll(&r->b);
    if (reports) {
        uint8_t const act = m->activity;
        m->activity = URBB_ACT_NONE;
        if (act == URBB_ACT_REQUEST) {
            m_served(m, status);
        } else if (act == URBB_ACT_PROBE) {
            m_probed(m, status);
        } else if (act == URBB_ACT_LEARN) {
            m_identified(m, status);
        } else {
            assert_int_equal(act, URBB_ACT_SYNC); /* its outcome changes nothing */
        }
    }
    if (m->activity == URBB_ACT_NONE) {
        m_start_next(m, r, begins_before);
    } else {
        assert_int_equal(r->begins, begins_before);
    }
    m_emit(m, usb_room_bytes, usb_room_count, uart_room, !r->tx_stall);

    urb_bridge_stats_t const *s = urb_bridge_stats(&r->b);
    assert_int_equal(urb_bridge_outstanding(&r->b), m->n);
    assert_int_equal(s->frames, m->frames);
    assert_int_equal(s->busy, m->busy);
    assert_int_equal(s->window_overflow, m->window_overflow);
    assert_int_equal(s->responses, m->responses);
    assert_int_equal(s->syncs, m->syncs);
    assert_int_equal(s->syncs_missed, m->syncs_missed);
    assert_int_equal(r->period, m->heartbeat_us);
    bool const head_final = (m->n > 0u) && (m->q[0].status != PENDING);
    bool const idle = (m->activity == URBB_ACT_NONE) && (first_pending(m) == NULL) && !head_final &&
                      (m->hb_ticks == m->hb_done);
    assert_int_equal(urb_bridge_idle(&r->b), idle);
    assert_int_equal(r->busy, m->activity != URBB_ACT_NONE);
}

/* Compares the responses in bytes[0 .. len) with the next ones the model sent on `uplink`. */
static size_t check_responses(model_t *m, uint8_t uplink, const uint8_t *bytes, size_t len)
{
    size_t pos = 0u;
    size_t k = 0u;
    for (; pos < len; k++) {
        assert_true(m->n_seen[uplink] < m->n_out[uplink]);
        m_response_t const *o = &m->out[uplink][m->n_seen[uplink]++ % OUT_MAX];
        size_t const n = (o->len > 0u) ? 1u + o->len + urb_link_check_size(1u + (size_t)o->len) : 2u;
        assert_true(pos + n <= len);
        urb_uplink_response_t got;
        assert_int_equal(urb_uplink_response_decode(&got, bytes + pos, n), (int32_t)n);
        assert_int_equal(got.seq, o->seq);
        assert_int_equal(got.status, o->status);
        assert_int_equal(got.data_len, o->len);
        assert_memory_equal(got.data, o->data, o->len);
        pos += n;
    }
    assert_int_equal(pos, len);
    return k;
}

static void read_uart(srig_t *r, model_t *m)
{
    srig_drain_uart(r);
    (void)check_responses(m, URBB_UPLINK_RS232, r->tx, r->tx_len);
    r->tx_len = 0u;
}

static void read_usb(srig_t *r, model_t *m)
{
    uint8_t in[URB_BRIDGE_USB_BUF];
    size_t const got = urb_bridge_usb_in(&r->b, in, sizeof in);
    if (got == 0u) {
        return;
    }
    urb_usb_batch_header_t h;
    assert_int_equal(urb_usb_batch_header_decode(&h, in, 4u), 4);
    assert_int_equal(check_responses(m, URBB_UPLINK_USB, in + 4, got - 4u), h.count);
}

/* ===== Random sequences ========================================================================= */

static const uint8_t ADDRESSES[] = {0u, 0u, 7u, SRIG_FIRST, 9u, 10u, 11u, 12u, SRIG_LAST, 16u, 0x77u};

static m_entry_t random_request(void)
{
    m_entry_t e;
    memset(&e, 0, sizeof e);
    e.seq = (uint8_t)rnd(16u);
    e.uplink = (uint8_t)rnd(2u);
    e.address = ADDRESSES[rnd(sizeof ADDRESSES)];
    e.read = rnd(2u) == 0u;
    if (e.address == 0u) {
        e.mailbox = (uint8_t)rnd(e.read ? 2u : 1u); /* BridgeInfo, BridgeScan, BridgeCommand */
        e.length = e.read ? ((e.mailbox == 0u) ? URB_BRIDGE_INFO_SIZE : URB_BRIDGE_SCAN_SIZE) : URB_BRIDGE_COMMAND_SIZE;
        if (!e.read) {
            static const uint8_t OPCODES[] = {URB_BRIDGE_OPCODE_NOP, URB_BRIDGE_OPCODE_SET_HEARTBEAT,
                                              URB_BRIDGE_OPCODE_BUS_CLEAR, URB_BRIDGE_OPCODE_BUS_CLEAR, 9u};
            urb_bridge_command_t cmd = {OPCODES[rnd(sizeof OPCODES)], (rnd(2u) == 0u) ? 0u : (uint16_t)(500u + rnd(1000u))};
            if (cmd.opcode == 9u) { /* an unknown opcode (BAD_REQUEST) does not encode: written by hand */
                e.data[0] = cmd.opcode;
            } else {
                assert_int_equal(urb_bridge_command_encode(&cmd, e.data, 3u), 3);
            }
        }
    } else {
        uint8_t in[8], out[8];
        srig_node_sizes((e.address >= SRIG_FIRST) && (e.address <= SRIG_LAST) ? e.address : SRIG_FIRST, in, out);
        e.mailbox = (uint8_t)rnd(4u);
        e.length = e.read ? out[e.mailbox] : in[e.mailbox];
        if ((e.length == 0u) || (rnd(6u) == 0u)) {
            e.length = (uint8_t)(1u + rnd(32u));
        }
        for (uint8_t i = 0u; i < e.length; i++) {
            e.data[i] = (uint8_t)rnd(256u);
        }
    }
    if ((e.address == 0u) && (rnd(8u) == 0u)) {
        e.length = (uint8_t)(1u + rnd(32u)); /* most likely a SIZE_MISMATCH of the bridge's own mailbox */
    }
    return e;
}

static const uint8_t OUTCOMES[] = {URB_STATUS_OK,           URB_STATUS_OK,       URB_STATUS_OK,      URB_STATUS_NO_NODE,
                                   URB_STATUS_NODE_BUSY,    URB_STATUS_CHECKSUM, URB_STATUS_TIMEOUT, URB_STATUS_BUS_STUCK,
                                   URB_STATUS_BAD_REQUEST, URB_STATUS_SIZE_MISMATCH};

/* Which addresses have a node on the bus now (nodes come and go: hot plug). */
static bool plugged[128];

/* The downlink ends its transaction: a node that is not plugged in mostly does not acknowledge
 * (NO_NODE); otherwise any outcome. A node's data for an OK read: its identification for outbox 0,
 * random bytes for the others, which the model expects in the response. */
static void finish_random(srig_t *r, model_t *m)
{
    bool const addressed = (r->txn.op != URB_DL_SYNC) && (r->txn.op != URB_DL_CLEAR);
    uint8_t const status = (addressed && !plugged[r->txn.address] && (rnd(5u) != 0u)) ? URB_STATUS_NO_NODE
                                                                                       : OUTCOMES[rnd(sizeof OUTCOMES)];
    uint8_t data[32];
    if ((r->txn.op == URB_DL_READ) && (r->txn.mailbox == 0u) && (r->txn.length == URB_IDENTIFICATION_SIZE)) {
        srig_node_identification(r->txn.address, data);
    } else {
        for (uint8_t i = 0u; i < 32u; i++) {
            data[i] = (uint8_t)rnd(256u);
        }
    }
    if ((m->activity == URBB_ACT_REQUEST) && (status == URB_STATUS_OK) && (r->txn.op == URB_DL_READ)) {
        m_entry_t *p = first_pending(m);
        memcpy(p->data, data, p->length);
    }
    srig_finish(r, status, data);
}

/* What the random runs reached, summed over the runs of a test. */
static struct {
    unsigned busy, window_overflow, probes, learns, lost, held[2], local_bursts, wraps, syncs, syncs_missed, clears,
        set_heartbeats, absent_no_node;
} witness;

static void random_run(uint32_t seed, uint8_t depth, uint16_t heartbeat_us, unsigned steps)
{
    rng_state = seed;
    static srig_t r;
    static model_t m;
    srig_init(&r, depth, heartbeat_us);
    model_init(&m, depth);
    m.heartbeat_us = heartbeat_us;
    assert_int_equal(r.b.present[1], 0x8Du); /* 8, 10, 11, 15: the scan's map is the model's */
    unsigned local_burst = 0u;
    bool usb_host_away = false;
    for (uint8_t a = SRIG_FIRST; a <= SRIG_LAST; a++) {
        plugged[a] = srig_present_at_start(a);
    }
    for (unsigned step = 0u; step < steps; step++) {
        uint32_t const x = rnd(1000u);
        if (x < 100u) {
            unsigned const burst = (rnd(8u) == 0u) ? 1u + rnd(40u) : 1u;
            for (unsigned k = 0u; k < burst; k++) {
                uint32_t const y = rnd(40u);
                submit(&r, &m, random_request(), (y == 0u) ? FRAME_BAD_CHECK : ((y == 1u) ? FRAME_RANGE : FRAME_OK));
            }
        } else if ((x < 120u) && (slots_taken(&m) == 0u) && (m.n + depth <= URB_BRIDGE_RING_MAX)) {
            /* a full FIFO of local requests: each poll serves at most one per data slot */
            for (unsigned k = 0u; k < depth; k++) {
                m_entry_t e;
                memset(&e, 0, sizeof e);
                e.seq = (uint8_t)k;
                e.uplink = URBB_UPLINK_USB;
                e.read = true;
                e.length = URB_BRIDGE_INFO_SIZE;
                submit(&r, &m, e, FRAME_OK);
            }
            local_burst++;
        } else if (x < 400u) {
            if (r.busy && !r.done && !r.lose) {
                if (rnd(30u) == 0u) {
                    r.lose = true;
                    m.lost++;
                } else {
                    finish_random(&r, &m);
                }
            }
        } else if (x < 440u) {
            urb_bridge_heartbeat(&r.b); /* the heartbeat interrupt */
            m.hb_ticks++;
        } else if (x < 480u) {
            r.refuse = !r.refuse && (rnd(3u) == 0u);
        } else if (x < 492u) {
            r.tx_stall = !r.tx_stall;
            if (!r.tx_stall) {
                read_uart(&r, &m);
            }
        } else if (x < 505u) {
            urb_bridge_usb_sof(&r.b);
        } else if (x < 507u) {
            usb_host_away = !usb_host_away; /* the host stops reading for a while: the batch fills */
        } else if (x < 512u) {
            uint8_t const a = (uint8_t)(SRIG_FIRST + rnd(SRIG_LAST - SRIG_FIRST + 1u));
            plugged[a] = !plugged[a];
        } else if ((x < 540u) && !usb_host_away) {
            read_usb(&r, &m);
        } else {
            poll_both(&r, &m);
            if (!r.tx_stall) {
                read_uart(&r, &m);
            }
        }
    }
    /* drain: everything admitted is answered, nothing more */
    r.refuse = false;
    r.tx_stall = false;
    for (unsigned k = 0u; (k < 2000u) && ((m.n > 0u) || r.busy); k++) {
        if (r.busy && !r.done && !r.lose) {
            finish_random(&r, &m);
        }
        poll_both(&r, &m);
        read_uart(&r, &m);
        urb_bridge_usb_sof(&r.b);
        read_usb(&r, &m);
    }
    read_uart(&r, &m);
    urb_bridge_usb_sof(&r.b);
    read_usb(&r, &m);
    assert_int_equal(m.n, 0u);
    assert_int_equal(m.n_seen[0], m.n_out[0]);
    assert_int_equal(m.n_seen[1], m.n_out[1]);
    witness.busy += m.busy;
    witness.window_overflow += m.window_overflow;
    witness.probes += m.probes;
    witness.learns += m.learns;
    witness.lost += m.lost;
    witness.held[0] += m.held[0];
    witness.held[1] += m.held[1];
    witness.local_bursts += local_burst;
    witness.wraps += m.responses / URB_BRIDGE_RING_MAX;
    witness.syncs += m.syncs;
    witness.syncs_missed += m.syncs_missed;
    witness.clears += m.clears;
    witness.set_heartbeats += m.set_heartbeats;
    witness.absent_no_node += m.absent_no_node;
}

/* Witnesses that the random runs reach what they compare: a data-slot FIFO and a response ring
 * that wrap many times, BUSY, window overflows, probes and identifications, both uplinks. */
static void model_random_depths(void **state)
{
    (void)state;
    random_run(0x1234567u, 1u, 1000u, 6000u);
    random_run(0x89ABCDEu, 3u, 0u, 6000u);
    random_run(0x2468ACEu, URB_BRIDGE_FIFO_MAX, 1000u, 8000u);
    /* witnesses: every path compared was taken; the ring and the slot FIFO wrapped many times */
    assert_true((witness.busy > 0u) && (witness.window_overflow > 0u) && (witness.probes > 0u));
    assert_true((witness.learns > 0u) && (witness.lost > 0u) && (witness.local_bursts > 0u));
    assert_true((witness.held[0] > 0u) && (witness.held[1] > 0u) && (witness.wraps > 50u));
    assert_true((witness.syncs > 0u) && (witness.syncs_missed > 0u) && (witness.clears > 0u) &&
                (witness.set_heartbeats > 0u) && (witness.absent_no_node > 0u));
}

/* Sends one request through urbb_frame and polls once. */
static void request(srig_t *r, uint8_t uplink, uint8_t address, uint8_t mailbox, uint8_t seq, uint8_t length)
{
    m_entry_t e;
    memset(&e, 0, sizeof e);
    e.uplink = uplink;
    e.address = address;
    e.mailbox = mailbox;
    e.seq = seq;
    e.length = length;
    e.read = true;
    uint8_t f[URB_BRIDGE_FRAME_MAX];
    uint8_t const n = encode(f, &e, FRAME_OK);
    assert_true(urbb_frame(&r->b, uplink, f, n));
    urb_bridge_poll(&r->b);
}

/* urb_bridge_idle (a port sleeps on it): false while a received byte waits in the ring, while the
 * assembler holds part of a frame (its idle gap must still be timed), while a heartbeat tick waits
 * for its SYNC, and while a final response waits for room on its uplink, even the only one. */
static void idle_only_when_nothing_waits(void **state)
{
    (void)state;
    static srig_t r;
    srig_init(&r, URB_BRIDGE_FIFO_MAX, 1000u);
    assert_true(urb_bridge_idle(&r.b));
    /* a byte received, not yet polled; then held as the start of a frame */
    r.now = 1000u;
    urb_bridge_uart_rx(&r.b, 0x41u, r.now);
    assert_false(urb_bridge_idle(&r.b));
    r.now += 10u;
    urb_bridge_poll(&r.b);
    assert_int_equal(r.b.rs232.len, 1u);
    assert_false(urb_bridge_idle(&r.b));
    r.now += 10000u; /* the idle gap drops it */
    urb_bridge_poll(&r.b);
    assert_int_equal(urb_bridge_stats(&r.b)->gap_drops, 1u);
    assert_true(urb_bridge_idle(&r.b));
    /* a heartbeat tick: its SYNC is due */
    urb_bridge_heartbeat(&r.b);
    assert_false(urb_bridge_idle(&r.b));
    urb_bridge_poll(&r.b);
    assert_int_equal(r.txn.op, URB_DL_SYNC);
    srig_finish(&r, URB_STATUS_OK, NULL);
    urb_bridge_poll(&r.b);
    assert_true(urb_bridge_idle(&r.b));
    /* the UART stalls: ten BridgeInfo responses of 12 bytes fill 120 of its 128 bytes, the
     * eleventh waits, alone in the ring, final */
    r.tx_stall = true;
    for (uint8_t i = 0u; i < 10u; i++) {
        request(&r, URBB_UPLINK_RS232, 0u, URB_NODE_BRIDGE_OUTBOX_BRIDGE_INFO, i, URB_BRIDGE_INFO_SIZE);
    }
    assert_int_equal(urb_bridge_outstanding(&r.b), 0u);
    assert_true(urb_bridge_idle(&r.b));
    request(&r, URBB_UPLINK_RS232, 0u, URB_NODE_BRIDGE_OUTBOX_BRIDGE_INFO, 10u, URB_BRIDGE_INFO_SIZE);
    assert_int_equal(urb_bridge_outstanding(&r.b), 1u);
    assert_false(urb_bridge_idle(&r.b));
    r.tx_stall = false;
    srig_drain_uart(&r);
    urb_bridge_poll(&r.b);
    assert_int_equal(urb_bridge_outstanding(&r.b), 0u);
    assert_true(urb_bridge_idle(&r.b));
    assert_int_equal(r.tx_len, 11u * 12u);
    assert_int_equal(urb_bridge_stats(&r.b)->responses, 11u);
}

/* A downlink that breaks its contract and reports a status outside urb_status_t: the response
 * cannot be encoded; the bridge drops it rather than wedging the ring (emit_entry), and the next
 * request is answered as usual. */
static void unencodable_response_is_dropped(void **state)
{
    (void)state;
    static srig_t r;
    srig_init(&r, 4u, 0u);
    request(&r, URBB_UPLINK_RS232, 8u, 1u, 3u, 4u);
    assert_int_equal(r.txn.op, URB_DL_READ);
    uint8_t data[4] = {1u, 2u, 3u, 4u};
    srig_finish(&r, 100u, data); /* 9 .. 127: a status poll() can return, no urb_status_t */
    urb_bridge_poll(&r.b);
    assert_int_equal(urb_bridge_outstanding(&r.b), 0u);
    assert_int_equal(urb_bridge_stats(&r.b)->responses, 0u);
    assert_int_equal(r.tx_len, 0u);
    request(&r, URBB_UPLINK_RS232, 8u, 1u, 4u, 4u);
    srig_finish(&r, URB_STATUS_OK, data);
    urb_bridge_poll(&r.b);
    stream_t s = {r.tx, r.tx_len, 0u};
    uint8_t got[4];
    expect_response(&s, 4u, URB_STATUS_OK, 4u, got);
    expect_end(&s);
    assert_memory_equal(got, data, 4u);
}

int run_fifo_model_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(model_random_depths),
        cmocka_unit_test(idle_only_when_nothing_waits),
        cmocka_unit_test(unencodable_response_is_dropped),
    };
    return cmocka_run_group_tests_name("bridge_fifo_model", tests, NULL, NULL);
}
