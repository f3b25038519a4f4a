/*
 * The response matcher (host/urb/managers/rs232_core.py ResponseMatcher): the requests in flight,
 * the placeholders, hunting through received bytes, completions. Shared by both uplinks.
 */
#include "urb_host_core.h"
#include "urb_host_internal.h"

#include <string.h>

#include "urb_core.h"

#define STATUS_MAX 8u

void urb_matcher_init(urb_matcher_t *m)
{
    if (m != NULL) {
        memset(m, 0, sizeof *m);
    }
}

/* Slots are reached by index (m->slot[at(m, i)].field), never through a pointer computed from a
 * variable index: ESBMC turns such a pointer into an update of the whole matcher (as it does for the
 * bridge, proofs/bmc/fw_bridge_fifo/Makefile) and a bounded proof of the matcher runs out of memory. */
uint32_t urbh_at(const urb_matcher_t *m, uint32_t i)
{
    return (m->head + i) % URB_MATCHER_SLOTS;
}

/* Drops the first n held bytes (n <= rx_len): O(1), the bytes stay where they are. */
static void drop(urb_matcher_t *m, size_t n)
{
    m->rx_len = (uint8_t)(m->rx_len - n);
    m->rx_start = (m->rx_len == 0u) ? 0u : (uint8_t)(m->rx_start + n);
}

static void pop_head(urb_matcher_t *m)
{
    m->head = (uint8_t)((m->head + 1u) % URB_MATCHER_SLOTS);
    m->count--;
}

void urbh_complete(urb_matcher_t *m, urb_transfer_t *t, urb_ns_t now, urb_flags_t flags, int8_t status,
                   const uint8_t *data, uint8_t len)
{
    t->state = URB_XFER_COMPLETED;
    t->completed_ns = now;
    t->flags = flags;
    t->status = status;
    t->response_len = len;
    for (uint8_t i = 0u; i < len; i++) { /* byte loops, not memcpy: ESBMC's library copies cost it dearly */
        t->response[i] = data[i];
    }
    t->next = NULL;
    if (m->done_tail == NULL) {
        m->done_head = t;
    } else {
        m->done_tail->next = t;
    }
    m->done_tail = t;
}

void urbh_lose(urb_matcher_t *m, urb_transfer_t *t, urb_ns_t now, const char *reason)
{
    urbh_complete(m, t, now, URB_FLAG_BRIDGE_LOST, -1, NULL, 0u);
    urbh_copy_reason(t->lost_reason, reason);
}

/* A live request got no response: UPLINK_CHECKSUM when corrupt bytes stood in its place, else
 * UPLINK_TIMEOUT. It stays in flight as a placeholder. */
static void unanswered(urb_matcher_t *m, uint32_t x, urb_ns_t now)
{
    urbh_complete(m, m->slot[x].t, now, m->slot[x].garbage ? URB_FLAG_UPLINK_CHECKSUM : URB_FLAG_UPLINK_TIMEOUT, -1,
                  NULL, 0u);
    m->slot[x].t = NULL;
}

int32_t urb_matcher_push(urb_matcher_t *m, urb_transfer_t *t, uint8_t seq, urb_ns_t due_ns, urb_ns_t expires_ns)
{
    if ((m == NULL) || (t == NULL) || (seq >= URB_SEQ_MOD)) {
        return URB_HOST_EINVAL;
    }
    if (m->count >= URB_MATCHER_SLOTS) {
        return URB_HOST_ENOSPC;
    }
    uint32_t const x = urbh_at(m, m->count);
    m->slot[x].t = t;
    m->slot[x].due_ns = due_ns;
    m->slot[x].expires_ns = expires_ns;
    m->slot[x].seq = seq;
    m->slot[x].length = t->length;
    m->slot[x].read = t->read;
    m->slot[x].garbage = false;
    m->slot[x].long_answer = t->answer_within_ns > 0;
    m->count++;
    t->seq = (int8_t)seq;
    t->state = URB_XFER_IN_FLIGHT;
    return URB_HOST_OK;
}

/* The k oldest requests in flight got no response (a later one was answered): complete the live
 * ones, release the placeholders. */
static void lost_before(urb_matcher_t *m, uint32_t k, urb_ns_t now)
{
    for (uint32_t i = 0u; i < k; i++) {
        uint32_t const x = urbh_at(m, 0u);
        if (m->slot[x].t == NULL) {
            m->released_placeholders++;
        } else {
            unanswered(m, x, now);
        }
        pop_head(m);
    }
}

void urb_matcher_discard(urb_matcher_t *m, size_t n)
{
    if ((m == NULL) || (n == 0u)) {
        return;
    }
    if (n > m->rx_len) {
        n = m->rx_len;
    }
    drop(m, n);
    m->stray_bytes += n;
    for (uint32_t i = 0u; i < m->count; i++) {
        uint32_t const x = urbh_at(m, i);
        if (m->slot[x].t != NULL) {
            m->slot[x].garbage = true;
            break;
        }
    }
}

static size_t response_size(bool read, uint8_t length, uint8_t status)
{
    size_t const covered = 1u + ((read && status == 0u) ? length : 0u);
    return covered + ((covered <= 14u) ? 1u : 2u);
}

uint32_t urbh_find(const urb_matcher_t *m, uint8_t seq)
{
    uint32_t k = 0u;
    while ((k < m->count) && (m->slot[urbh_at(m, k)].seq != seq)) {
        k++;
    }
    return k;
}

/* The framing: what the held bytes start with. It reads the matcher and changes nothing. */
urbh_frame_t urbh_frame_at_head(const urb_matcher_t *m, urbh_candidate_t *c)
{
    if (m->rx_len == 0u) {
        return URBH_FRAME_NOTHING;
    }
    uint8_t const head = m->rx[m->rx_start];
    uint8_t const status = (uint8_t)(head >> 4);
    c->k = urbh_find(m, (uint8_t)(head & 0x0Fu));
    if ((c->k == m->count) || (status > STATUS_MAX)) {
        return URBH_FRAME_STRAY;
    }
    uint32_t const x = urbh_at(m, c->k);
    c->n = response_size(m->slot[x].read, m->slot[x].length, status);
    if (m->rx_len < c->n) {
        return URBH_FRAME_WAIT;
    }
    /* the candidate is copied by index: a pointer at a variable offset into the matcher made the
     * bounded model checker (ESBMC) run out of memory; <= 35 bytes per check */
    uint8_t frame[URB_RESPONSE_MAX];
    for (size_t i = 0u; i < c->n; i++) {
        frame[i] = m->rx[m->rx_start + i];
    }
    if (urb_uplink_response_decode(&c->resp, frame, c->n) < 0) {
        return URBH_FRAME_STRAY;
    }
    return URBH_FRAME_WHOLE;
}

/* The matching: the host's part of Bridge.tla HostMatch (the oldest request in flight whose number
 * the response echoes; the ones before it complete as lost), a step of the bridge's Emit. */
void urbh_deliver(urb_matcher_t *m, const urbh_candidate_t *c, urb_ns_t now)
{
    uint32_t const x = urbh_at(m, c->k);
    urb_transfer_t *const matched = m->slot[x].t;
    bool const data = m->slot[x].read && (c->resp.status == 0u);
    drop(m, c->n);
    lost_before(m, c->k, now);
    pop_head(m);
    if (matched == NULL) { /* the late response to a placeholder: its number is free now */
        m->late_responses++;
        return;
    }
    urbh_complete(m, matched, now, urb_flags_from_status(c->resp.status), (int8_t)c->resp.status,
                  data ? c->resp.data : NULL, data ? c->resp.data_len : 0u);
}

/* Matches every complete response held in rx; true when a partial candidate is left waiting. */
static bool parse(urb_matcher_t *m, urb_ns_t now)
{
    while (m->rx_len > 0u) {
        if (m->count == 0u) {
            urb_matcher_discard(m, m->rx_len); /* nothing is pending: these bytes answer nothing */
            return false;
        }
        urbh_candidate_t c;
        urbh_frame_t const f = urbh_frame_at_head(m, &c);
        if (f == URBH_FRAME_WAIT) {
            return true;
        }
        if (f == URBH_FRAME_STRAY) {
            urb_matcher_discard(m, 1u);
        } else {
            urbh_deliver(m, &c, now);
        }
    }
    return false;
}

bool urb_matcher_feed(urb_matcher_t *m, const uint8_t *data, size_t n, urb_ns_t now)
{
    if ((m == NULL) || ((data == NULL) && (n > 0u))) {
        return false;
    }
    /* Taking the bytes in chunks matches exactly what one parse of them all would: every decision
     * depends only on the held prefix and the requests in flight, and a parse leaves at most a
     * partial candidate (< URB_RESPONSE_MAX bytes) behind. */
    size_t off = 0u;
    bool partial;
    do {
        size_t take = n - off;
        if (take > (size_t)(URB_MATCHER_RX - m->rx_len)) {
            take = (size_t)(URB_MATCHER_RX - m->rx_len);
        }
        if ((size_t)m->rx_start + m->rx_len + take > URB_MATCHER_RX) { /* the held bytes to the front */
            for (uint32_t i = 0u; i < m->rx_len; i++) {
                m->rx[i] = m->rx[m->rx_start + i];
            }
            m->rx_start = 0u;
        }
        for (size_t i = 0u; i < take; i++) {
            m->rx[m->rx_start + m->rx_len + i] = data[off + i];
        }
        if ((take == 0u) && (off < n)) { /* no room: only a build with URB_MATCHER_RX < URB_RESPONSE_MAX */
            urb_matcher_discard(m, 1u);
        }
        m->rx_len = (uint8_t)(m->rx_len + take);
        off += take;
        partial = parse(m, now);
    } while (off < n);
    return partial;
}

void urb_matcher_expire(urb_matcher_t *m, urb_ns_t now)
{
    if (m == NULL) {
        return;
    }
    /* Bridge.tla: HostExpire */
    uint32_t kept = 0u;
    for (uint32_t i = 0u; i < m->count; i++) {
        uint32_t const x = urbh_at(m, i);
        if ((m->slot[x].t == NULL) && (now >= m->slot[x].expires_ns)) {
            m->released_placeholders++;
        } else {
            if (kept != i) { /* a slot moves only behind a released one: most calls release none */
                m->slot[urbh_at(m, kept)] = m->slot[x];
            }
            kept++;
        }
    }
    m->count = (uint8_t)kept;
}

uint32_t urb_matcher_time_out(urb_matcher_t *m, urb_ns_t now)
{
    if (m == NULL) {
        return 0u;
    }
    /* Bridge.tla: HostTimeout (the request stays in flight as a placeholder) */
    uint32_t n = 0u;
    for (uint32_t i = 0u; i < m->count; i++) {
        uint32_t const x = urbh_at(m, i);
        if ((m->slot[x].t != NULL) && (now >= m->slot[x].due_ns)) {
            unanswered(m, x, now);
            n++;
        }
    }
    urb_matcher_expire(m, now);
    return n;
}

urb_ns_t urb_matcher_next_event(const urb_matcher_t *m)
{
    urb_ns_t next = URB_NEVER;
    if (m != NULL) {
        for (uint32_t i = 0u; i < m->count; i++) {
            uint32_t const x = urbh_at(m, i);
            urb_ns_t const t = (m->slot[x].t == NULL) ? m->slot[x].expires_ns : m->slot[x].due_ns;
            if (t < next) {
                next = t;
            }
        }
    }
    return next;
}

urb_ns_t urb_matcher_long_until(const urb_matcher_t *m)
{
    urb_ns_t until = 0;
    if (m != NULL) {
        for (uint32_t i = 0u; i < m->count; i++) {
            uint32_t const x = urbh_at(m, i);
            if (m->slot[x].long_answer && (m->slot[x].expires_ns > until)) {
                until = m->slot[x].expires_ns;
            }
        }
    }
    return until;
}

urb_transfer_t *urb_matcher_take(urb_matcher_t *m)
{
    if ((m == NULL) || (m->done_head == NULL)) {
        return NULL;
    }
    urb_transfer_t *t = m->done_head;
    m->done_head = t->next;
    if (m->done_head == NULL) {
        m->done_tail = NULL;
    }
    t->next = NULL;
    t->state = URB_XFER_DONE;
    return t;
}
