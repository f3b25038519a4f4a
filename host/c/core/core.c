/*
 * The protocol core of one bridge: MatchingCore, Rs232Core and UsbCore of the Python library
 * (host/urb/managers/rs232_core.py, usb_core.py), rule for rule. The matcher is matcher.c.
 */
#include "urb_host_core.h"
#include "urb_host_internal.h"

#include <stdio.h>
#include <string.h>

#include "urb_core.h"

#define HOUR_NS (3600LL * URB_NS_PER_S)
#define MIN_BATCH_BYTES (URB_USB_HEADER_SIZE + URB_REQUEST_MAX)

static urb_ns_t max_ns(urb_ns_t a, urb_ns_t b) { return (a > b) ? a : b; }
static urb_ns_t min_ns(urb_ns_t a, urb_ns_t b) { return (a < b) ? a : b; }

/* Python's // for the milliseconds of a lost reason (a negative duration floors). */
static long long floor_ms(urb_ns_t ns)
{
    long long q = ns / URB_NS_PER_MS;
    if ((ns % URB_NS_PER_MS != 0) && (ns < 0)) {
        q--;
    }
    return q;
}

void urbh_copy_reason(char *dst, const char *reason)
{
    size_t n = (reason == NULL) ? 0u : strlen(reason);
    if (n > URB_REASON_MAX - 1u) {
        n = URB_REASON_MAX - 1u;
    }
    if (n > 0u) {
        memcpy(dst, reason, n);
    }
    dst[n] = '\0';
}

void urb_core_default_config(urb_core_config_t *cfg, urb_link_kind_t kind)
{
    if ((cfg == NULL) || ((kind != URB_LINK_RS232) && (kind != URB_LINK_USB))) {
        return;
    }
    cfg->window = (kind == URB_LINK_RS232) ? 4u : (uint8_t)URB_MAX_WINDOW;
    cfg->timeout_ns = ((kind == URB_LINK_RS232) ? 100 : 50) * URB_NS_PER_MS;
    cfg->lost_after_ns = 500 * URB_NS_PER_MS;
    cfg->lost_after_timeouts = 8u;
    cfg->placeholder_ns = URB_PLACEHOLDER_NS;
    cfg->resync_gap_ns = 20 * URB_NS_PER_MS;
    cfg->max_batch = 14u;
    cfg->batch_bytes = (uint16_t)URB_USB_BATCH_MAX;
}

static bool in_range(urb_ns_t v, urb_ns_t lo, urb_ns_t hi) { return (v >= lo) && (v <= hi); }

int32_t urb_core_init(urb_core_t *core, urb_link_kind_t kind, const urb_core_config_t *cfg)
{
    urb_core_config_t c;
    if ((core == NULL) || ((kind != URB_LINK_RS232) && (kind != URB_LINK_USB))) {
        return URB_HOST_EINVAL;
    }
    if (cfg == NULL) {
        urb_core_default_config(&c, kind);
    } else {
        c = *cfg;
    }
    if ((c.window < 1u) || (c.window > URB_MAX_WINDOW) || !in_range(c.timeout_ns, 1, HOUR_NS) ||
        !in_range(c.lost_after_ns, 1, HOUR_NS) || (c.lost_after_timeouts < 1u) ||
        !in_range(c.placeholder_ns, 0, HOUR_NS) || !in_range(c.resync_gap_ns, 1, HOUR_NS) ||
        (c.max_batch < 1u) || (c.max_batch > URB_MAX_WINDOW) || (c.batch_bytes < MIN_BATCH_BYTES) ||
        (c.batch_bytes > URB_USB_BATCH_MAX)) {
        return URB_HOST_EINVAL;
    }
    memset(core, 0, sizeof *core);
    core->kind = (uint8_t)kind;
    core->cfg = c;
    urb_matcher_init(&core->m);
    core->next_seq = 1u; /* the n-th request carries n mod 16, as Bridge.tla's SeqOf */
    core->frame = 1u;    /* 0 is what an idle bridge labels its buffers with before the first OUT */
    core->handover_until_ns = URB_NO_TIME;
    return URB_HOST_OK;
}

/* ----- the queue --------------------------------------------------------------------------- */

static void enqueue(urb_core_t *core, urb_transfer_t *t)
{
    t->next = NULL;
    if (core->q_tail == NULL) {
        core->q_head = t;
    } else {
        core->q_tail->next = t;
    }
    core->q_tail = t;
    core->queued++;
    t->state = URB_XFER_QUEUED;
}

static urb_transfer_t *dequeue(urb_core_t *core)
{
    urb_transfer_t *t = core->q_head;
    core->q_head = t->next;
    if (core->q_head == NULL) {
        core->q_tail = NULL;
    }
    core->queued--;
    t->next = NULL;
    return t;
}

/* Every queued request completes BRIDGE_LOST with `reason`; the queue is empty after. */
static void lose_queued(urb_core_t *core, urb_ns_t now, const char *reason)
{
    while (core->q_head != NULL) {
        urbh_lose(&core->m, dequeue(core), now, reason);
    }
}

/* ----- MatchingCore ------------------------------------------------------------------------- */

static const char *silence_text(const urb_core_t *core)
{
    return (core->kind == URB_LINK_USB) ? "the bridge returned no USB transfer" : "the bridge sent nothing";
}

static urb_ns_t lifetime_ns(const urb_core_t *core)
{
    return max_ns(core->cfg.placeholder_ns, core->cfg.timeout_ns);
}

/* Is anything in flight due by `now`: a placeholder whose lifetime is over, or (with `live`) a live
 * request whose timeout has come? What urb_matcher_expire (placeholders) and urb_matcher_time_out
 * (both) look for: when nothing is, they change nothing and are skipped. This walk steps the ring
 * index instead of computing urbh_at's modulo for every slot, at a quarter of their cost: they run
 * once per submission and per poll, and the answer is almost always no. */
static bool due_in_flight(const urb_matcher_t *m, urb_ns_t now, bool live)
{
    uint32_t x = m->head;
    for (uint32_t i = 0u; i < m->count; i++) {
        bool const placeholder = (m->slot[x].t == NULL);
        if (placeholder ? (now >= m->slot[x].expires_ns) : (live && (now >= m->slot[x].due_ns))) {
            return true;
        }
        x = (x + 1u == URB_MATCHER_SLOTS) ? 0u : x + 1u;
    }
    return false;
}

/* urb_matcher_expire, when it has a placeholder to release. */
static void expire(urb_core_t *core, urb_ns_t now)
{
    if (due_in_flight(&core->m, now, false)) {
        urb_matcher_expire(&core->m, now);
    }
}

urb_ns_t urb_core_busy_until(const urb_core_t *core)
{
    if ((core == NULL) || (core->m.count == 0u)) {
        return URB_NO_TIME;
    }
    urb_ns_t until = URB_NO_TIME;
    for (uint32_t i = 0u; i < core->m.count; i++) {
        until = max_ns(until, core->m.slot[urbh_at(&core->m, i)].expires_ns);
    }
    return until;
}

void urb_core_hand_over(urb_core_t *core, urb_ns_t until_ns)
{
    if (core == NULL) {
        return;
    }
    /* Bridge.tla: HostRestart (a new process sends nothing before the previous one's answers are over) */
    core->handover_until_ns = (core->handover_until_ns == URB_NO_TIME) ? until_ns
                                                                     : max_ns(until_ns, core->handover_until_ns);
    if (core->kind == URB_LINK_USB) {
        core->flushing = true;
        core->flush_empty_from_ns = max_ns(core->flush_empty_from_ns, until_ns + 2 * URB_USB_FRAME_NS);
    }
}

/* Before the hand-over's instant at `now`; once it has come, the silence rule counts from it. */
static bool handover_wait(urb_core_t *core, urb_ns_t now)
{
    if ((core->handover_until_ns != URB_NO_TIME) && (now >= core->handover_until_ns)) {
        core->active_since_ns = max_ns(core->active_since_ns, core->handover_until_ns);
        core->handover_until_ns = URB_NO_TIME;
    }
    return core->handover_until_ns != URB_NO_TIME;
}

static bool handing_over(urb_core_t *core, urb_ns_t now)
{
    bool const waiting = handover_wait(core, now);
    return waiting || ((core->kind == URB_LINK_USB) && core->flushing);
}

static bool valid_request(const urb_transfer_t *t)
{
    return (t->address <= 127u) && (t->mailbox <= 7u) && (t->length >= 1u) && (t->length <= URB_HOST_MAILBOX_MAX) &&
           in_range(t->answer_within_ns, 0, HOUR_NS);
}

int32_t urb_core_submit(urb_core_t *core, urb_transfer_t *t, urb_ns_t now)
{
    if ((core == NULL) || (t == NULL) || !valid_request(t)) {
        return URB_HOST_EINVAL;
    }
    if (urb_transfer_owned(t)) {
        return URB_HOST_EBUSY;
    }
    /* UsbUplink.tla: Submit (and the host's part of Bridge.tla SubmitAndAdmit) */
    t->seq = -1;
    t->status = -1;
    t->response_len = 0u;
    t->flags = URB_FLAG_NONE;
    t->submitted_ns = now;
    t->sent_ns = URB_NO_TIME;
    t->completed_ns = URB_NO_TIME;
    t->callback_ns = URB_NO_TIME;
    t->lost_reason[0] = '\0';
    if (core->lost || core->closing) {
        /* Bridge.tla SubmitAndAdmit needs linkUp: a lost core completes it at once */
        urbh_lose(&core->m, t, now, core->lost ? core->lost_reason : URBH_CLOSED_REASON);
        return URB_HOST_OK;
    }
    expire(core, now);
    if ((core->queued == 0u) && (core->m.count == 0u)) {
        core->active_since_ns = now;
    }
    enqueue(core, t);
    return URB_HOST_OK;
}

void urb_core_link_lost(urb_core_t *core, urb_ns_t now, const char *reason)
{
    if ((core == NULL) || core->lost) {
        return;
    }
    /* Bridge.tla: HostLinkLost (live requests in flight become placeholders) */
    core->lost = true;
    urbh_copy_reason(core->lost_reason, (reason == NULL) ? "the uplink was lost" : reason);
    for (uint32_t i = 0u; i < core->m.count; i++) {
        uint32_t const x = urbh_at(&core->m, i);
        if (core->m.slot[x].t != NULL) {
            urbh_lose(&core->m, core->m.slot[x].t, now, core->lost_reason);
            core->m.slot[x].t = NULL;
        }
    }
    lose_queued(core, now, core->lost_reason);
    core->m.rx_len = 0u;
    core->m.rx_start = 0u;
    core->partial = false;
}

void urb_core_reset(urb_core_t *core, urb_ns_t now)
{
    if (core == NULL) {
        return;
    }
    /* Bridge.tla: HostReopen (the placeholders stay: reopening the uplink does not reset the bridge) */
    urb_core_link_lost(core, now, "the uplink was reset (reconnect)");
    core->lost = false;
    core->lost_reason[0] = '\0';
    core->closing = false;
    core->last_heard_ns = now;
    core->active_since_ns = now;
    core->silent_timeouts = 0u;
    expire(core, now);
}

bool urb_core_drained(const urb_core_t *core)
{
    return (core == NULL) || core->lost || (core->m.count == 0u);
}

urb_ns_t urb_core_start_drain(urb_core_t *core, urb_ns_t now)
{
    if (core == NULL) {
        return URB_NO_TIME;
    }
    core->closing = true;
    lose_queued(core, now, URBH_CLOSED_REASON);
    return urb_core_drained(core) ? URB_NO_TIME : urb_core_busy_until(core);
}

int32_t urb_core_set_window(urb_core_t *core, uint8_t window)
{
    if ((core == NULL) || (window < 1u) || (window > URB_MAX_WINDOW)) {
        return URB_HOST_EINVAL;
    }
    core->cfg.window = window;
    return URB_HOST_OK;
}

/* The bridge sent something: it is alive. */
static void heard(urb_core_t *core, urb_ns_t now)
{
    core->last_heard_ns = now;
    core->silent_timeouts = 0u;
}

/* Whence silence counts: the bridge's last sign of life, the start of the host's outstanding
 * work, the end of a hand-over, or the end of a long request's answer time. */
static urb_ns_t silent_since(const urb_core_t *core)
{
    urb_ns_t t = max_ns(core->last_heard_ns, core->active_since_ns);
    t = max_ns(t, (core->handover_until_ns == URB_NO_TIME) ? 0 : core->handover_until_ns);
    return max_ns(t, core->quiet_until_ns);
}

/* After received responses were matched: a long request answered no longer excuses silence. */
static void matched(urb_core_t *core)
{
    if (core->quiet_until_ns != 0) {
        core->quiet_until_ns = min_ns(core->quiet_until_ns, urb_matcher_long_until(&core->m));
    }
}

static uint32_t time_out(urb_core_t *core, urb_ns_t now)
{
    if (!due_in_flight(&core->m, now, true)) {
        return 0u; /* urb_matcher_time_out would time out and release nothing */
    }
    uint32_t const n = urb_matcher_time_out(&core->m, now);
    core->silent_timeouts += n;
    return n;
}

/* Declares a silent bridge lost: lost_after_timeouts requests in a row timed out (the last
 * `timed_out` of them now) with nothing heard for lost_after_ns, or lost_after_ns of silence with
 * requests outstanding. Bridge.tla: HostLinkLost (a silent bridge) */
static void lost_if_silent(urb_core_t *core, urb_ns_t now, uint32_t timed_out)
{
    char reason[URB_REASON_MAX];
    urb_ns_t const quiet = now - core->last_heard_ns;
    if ((timed_out > 0u) && (core->silent_timeouts >= core->cfg.lost_after_timeouts) &&
        (quiet >= core->cfg.lost_after_ns)) {
        (void)snprintf(reason, sizeof reason, "%lu requests in a row got no response and %s for %lld ms",
                       (unsigned long)core->silent_timeouts, silence_text(core), floor_ms(quiet));
        urb_core_link_lost(core, now, reason);
        return;
    }
    urb_ns_t const since = silent_since(core);
    if (((core->m.count > 0u) || (core->queued > 0u)) && (now - since >= core->cfg.lost_after_ns)) {
        (void)snprintf(reason, sizeof reason, "%s for %lld ms with requests outstanding", silence_text(core),
                       floor_ms(now - since));
        urb_core_link_lost(core, now, reason);
    }
}

/* Gives the next queued request its sequence number, puts it in flight and writes its frame to
 * buf (cap bytes of room, at least the frame's size); returns the frame's size. */
static size_t send(urb_core_t *core, urb_ns_t now, uint8_t *buf, size_t cap)
{
    urb_transfer_t *t = dequeue(core);
    uint8_t const seq = core->next_seq;
    core->next_seq = (uint8_t)((core->next_seq + 1u) % URB_SEQ_MOD);
    t->sent_ns = now;
    /* served after a long request ahead of it; quiet_until_ns is 0 only while none is in flight (it
     * is set when one is sent and lowered to urb_matcher_long_until, 0 without one, after matching;
     * all times are >= 0 on urb_now_ns's clock), and then urb_matcher_long_until's walk would give 0 */
    urb_ns_t const start = max_ns(now, (core->quiet_until_ns == 0) ? 0 : urb_matcher_long_until(&core->m));
    urb_ns_t const due = start + max_ns(core->cfg.timeout_ns, t->answer_within_ns);
    urb_ns_t const expires = start + max_ns(lifetime_ns(core), t->answer_within_ns);
    if (t->answer_within_ns > 0) {
        core->quiet_until_ns = max_ns(core->quiet_until_ns, start + t->answer_within_ns);
    }
    (void)urb_matcher_push(&core->m, t, seq, due, expires); /* the window keeps count < URB_MATCHER_SLOTS */
    int32_t n;
    if (t->read) {
        urb_uplink_read_request_t r = {t->address, t->mailbox, seq, t->length};
        n = urb_uplink_read_request_encode(&r, buf, cap);
    } else {
        urb_uplink_write_request_t w;
        w.address = t->address;
        w.mailbox = t->mailbox;
        w.seq = seq;
        w.length = t->length;
        memcpy(w.data, t->data, t->length);
        n = urb_uplink_write_request_encode(&w, buf, cap);
    }
    return (n > 0) ? (size_t)n : 0u; /* valid_request() checked every field the encoder checks */
}

urb_transfer_t *urb_core_take_completed(urb_core_t *core)
{
    return (core == NULL) ? NULL : urb_matcher_take(&core->m);
}

urb_ns_t urb_core_next_deadline(const urb_core_t *core)
{
    if (core == NULL) {
        return URB_NEVER;
    }
    urb_ns_t next;
    if ((core->handover_until_ns != URB_NO_TIME) && (core->queued > 0u) && !core->lost) {
        next = core->handover_until_ns;
    } else if (core->lost || (core->m.count == 0u)) {
        return URB_NEVER;
    } else {
        next = min_ns(silent_since(core) + core->cfg.lost_after_ns, urb_matcher_next_event(&core->m));
    }
    /* a partial RS232 frame is dropped after the resync gap, during a hand-over too (rs232_core.py) */
    if ((core->kind == URB_LINK_RS232) && core->partial) {
        next = min_ns(next, core->last_heard_ns + core->cfg.resync_gap_ns);
    }
    return next;
}

bool urb_core_busy(const urb_core_t *core)
{
    return (core != NULL) && ((core->queued > 0u) || (core->m.count > 0u));
}

bool urb_core_has_queued(const urb_core_t *core)
{
    return (core != NULL) && (core->queued > 0u) && (core->m.count < core->cfg.window) && !core->lost;
}

uint32_t urb_core_in_flight(const urb_core_t *core)
{
    return (core == NULL) ? 0u : core->m.count;
}

uint32_t urb_core_placeholders(const urb_core_t *core)
{
    uint32_t n = 0u;
    if (core != NULL) {
        for (uint32_t i = 0u; i < core->m.count; i++) {
            n += (core->m.slot[urbh_at(&core->m, i)].t == NULL) ? 1u : 0u;
        }
    }
    return n;
}

const char *urb_core_lost_reason(const urb_core_t *core)
{
    return ((core == NULL) || !core->lost) ? NULL : core->lost_reason;
}

int32_t urb_core_poll(urb_core_t *core, urb_ns_t now)
{
    if (core == NULL) {
        return URB_HOST_EINVAL;
    }
    if (core->lost) {
        return URB_HOST_OK;
    }
    urb_matcher_t *m = &core->m;
    if (core->kind == URB_LINK_USB) {
        lost_if_silent(core, now, time_out(core, now));
        return URB_HOST_OK;
    }
    if (core->partial && (now - core->last_heard_ns >= core->cfg.resync_gap_ns)) {
        urb_matcher_discard(m, 1u); /* the idle-gap rule: a stalled candidate loses its first byte */
        core->partial = urb_matcher_feed(m, NULL, 0u, now);
    }
    uint32_t const before = m->count;
    uint32_t const timed_out = time_out(core, now);
    if ((m->count != before) && (m->rx_len > 0u)) {
        core->partial = urb_matcher_feed(m, NULL, 0u, now); /* a released number no longer starts a candidate */
    }
    lost_if_silent(core, now, timed_out);
    return URB_HOST_OK;
}

/* ----- RS232 (Rs232Core) ---------------------------------------------------------------------- */

int32_t urb_core_receive(urb_core_t *core, const uint8_t *data, size_t n, urb_ns_t now)
{
    if ((core == NULL) || (core->kind != URB_LINK_RS232) || ((data == NULL) && (n > 0u))) {
        return URB_HOST_EINVAL;
    }
    if (n == 0u) {
        return URB_HOST_OK;
    }
    heard(core, now);
    if (core->lost) {
        core->m.stray_bytes += n;
        return URB_HOST_OK;
    }
    core->partial = urb_matcher_feed(&core->m, data, n, now);
    matched(core);
    return URB_HOST_OK;
}

int32_t urb_core_next_frame(urb_core_t *core, urb_ns_t now, uint8_t *buf, size_t cap)
{
    if ((core == NULL) || (buf == NULL) || (core->kind != URB_LINK_RS232)) {
        return URB_HOST_EINVAL;
    }
    if (cap < URB_REQUEST_MAX) {
        return URB_HOST_ENOSPC;
    }
    if (handing_over(core, now)) {
        return 0;
    }
    if (core->queued > 0u) {
        expire(core, now); /* whatever the polling cadence */
    }
    if ((core->queued == 0u) || (core->m.count >= core->cfg.window) || core->lost) {
        return 0;
    }
    /* the host's side of Bridge.tla SubmitAndAdmit: Len(InFlight) < HostWindow */
    return (int32_t)send(core, now, buf, cap);
}

/* ----- USB (UsbCore) -------------------------------------------------------------------------- */

int32_t urb_core_receive_batch(urb_core_t *core, const uint8_t *data, size_t n, urb_ns_t now)
{
    if ((core == NULL) || (core->kind != URB_LINK_USB) || ((data == NULL) && (n > 0u))) {
        return URB_HOST_EINVAL;
    }
    /* UsbUplink.tla: Callback, for each response of the IN transfer (UsbUplink.tla UsbRead) */
    heard(core, now);
    if (core->lost || (n == 0u)) {
        return URB_HOST_OK;
    }
    core->transfers_in++;
    urb_usb_batch_header_t header;
    bool const header_ok = urb_usb_batch_header_decode(&header, data, (n < URB_USB_HEADER_SIZE) ? n
                                                                                          : URB_USB_HEADER_SIZE) >= 0;
    if (!header_ok) {
        core->bad_headers++; /* the responses carry their own checks: match them anyway */
    }
    size_t const body = (n > URB_USB_HEADER_SIZE) ? n - URB_USB_HEADER_SIZE : 0u;
    if (core->flushing) { /* the previous process's responses: none of ours is in flight */
        core->m.stray_bytes += body;
        if (header_ok && (header.count == 0u) && (now >= core->flush_empty_from_ns)) {
            core->flushing = false;
        }
        return URB_HOST_OK;
    }
    (void)urb_matcher_feed(&core->m, data + ((body > 0u) ? URB_USB_HEADER_SIZE : 0u), body, now);
    matched(core);
    if (core->m.rx_len > 0u) { /* a response never spans two transfers: the rest is garbage */
        urb_matcher_discard(&core->m, core->m.rx_len);
    }
    return URB_HOST_OK;
}

bool urb_core_wants_frame(const urb_core_t *core)
{
    return (core != NULL) && (core->kind == URB_LINK_USB) && !core->lost &&
           ((core->queued > 0u) || (core->m.count > 0u) || core->flushing ||
            (core->handover_until_ns != URB_NO_TIME));
}

int32_t urb_core_frame_out(urb_core_t *core, urb_ns_t now, uint8_t *buf, size_t cap)
{
    if ((core == NULL) || (buf == NULL) || (core->kind != URB_LINK_USB)) {
        return URB_HOST_EINVAL;
    }
    if (cap < core->cfg.batch_bytes) {
        return URB_HOST_ENOSPC;
    }
    if (core->lost) {
        return 0;
    }
    bool const flushing = handing_over(core, now); /* then fetch the previous process's responses */
    if ((core->queued == 0u) && (core->m.count == 0u) && !flushing) {
        return 0;
    }
    if (core->queued > 0u) {
        expire(core, now); /* whatever the polling cadence */
    }
    /* the OUT transfer of UsbUplink.tla UsbWrite: at most MaxBatch, no more than the window leaves room for */
    size_t out_bytes = URB_USB_HEADER_SIZE;
    size_t in_bytes = URB_USB_HEADER_SIZE;
    uint8_t count = 0u;
    while (!flushing && (core->queued > 0u) && (count < core->cfg.max_batch) && (core->m.count < core->cfg.window)) {
        urb_transfer_t const *t = core->q_head;
        size_t const req = urb_transfer_request_size(t);
        size_t const resp = urb_transfer_response_size(t, 0u);
        if ((out_bytes + req > core->cfg.batch_bytes) || (in_bytes + resp > core->cfg.batch_bytes)) {
            break; /* stays buffered for the next frame */
        }
        out_bytes += send(core, now, buf + out_bytes, cap - out_bytes);
        in_bytes += resp;
        count++;
    }
    urb_usb_batch_header_t header = {core->frame, count};
    (void)urb_usb_batch_header_encode(&header, buf, URB_USB_HEADER_SIZE);
    core->frame = (uint16_t)(core->frame % 0xFFFFu + 1u); /* 1..65535, never 0 */
    core->frames_written++;
    return (int32_t)out_bytes;
}
