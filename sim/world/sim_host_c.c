/*
 * sim_host_c.c: the C host library on the simulated host CPU (see sim_host_c.h). The core
 * (host/c/core) is untouched; this file is its port: SimHost's event loop and SimManager's
 * _after_step, _on_timer and _frame_tick, in C, over the world's public API (urbsim.h). The
 * applications it runs live beside it: sim_host_pd.c (the PD and gait axes) and sim_host_plain.c
 * (plain requests); sim_host_c_internal.h is what they share.
 */
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "sim_host_c_internal.h"

/* ---------------------------------------------------------------- growable arrays */

bool chost_grow(void **p, uint32_t *cap, uint32_t need, size_t size)
{
    if (need <= *cap) {
        return true;
    }
    uint32_t n = *cap ? *cap * 2u : 1024u;
    while (n < need) {
        n *= 2u;
    }
    void *q = realloc(*p, (size_t)n * size);
    if (!q) {
        return false;
    }
    *p = q;
    *cap = n;
    return true;
}

/* ---------------------------------------------------------------- host events (SimHost._events) */

static bool ev_less(const ev_t *a, const ev_t *b)
{
    return a->when < b->when || (a->when == b->when && a->seq < b->seq);
}

static void ev_push(urbsim_chost_t *h, ev_t e)
{
    uint32_t i = h->n_ev++;
    while (i > 0u) {
        uint32_t parent = (i - 1u) / 2u;
        if (!ev_less(&e, &h->heap[parent])) {
            break;
        }
        h->heap[i] = h->heap[parent];
        i = parent;
    }
    h->heap[i] = e;
}

/* SimHost.call_at: run at the OS tick that wakes a thread sleeping until host time when_local. */
static void call_at(urbsim_chost_t *h, int64_t when_local, uint8_t kind, int bridge, int64_t arg)
{
    if (!chost_grow((void **)&h->heap, &h->cap_ev, h->n_ev + 1u, sizeof(ev_t))) {
        h->errors++;
        return;
    }
    ev_push(h, (ev_t){urbsim_host_timer(h->w, when_local), h->seq++, arg, bridge, kind});
}

static ev_t ev_pop(urbsim_chost_t *h)
{
    ev_t top = h->heap[0];
    ev_t last = h->heap[--h->n_ev];
    uint32_t i = 0;
    for (;;) {
        uint32_t c = 2u * i + 1u;
        if (c >= h->n_ev) {
            break;
        }
        if (c + 1u < h->n_ev && ev_less(&h->heap[c + 1u], &h->heap[c])) {
            c++;
        }
        if (!ev_less(&h->heap[c], &last)) {
            break;
        }
        h->heap[i] = h->heap[c];
        i = c;
    }
    if (h->n_ev > 0u) {
        h->heap[i] = last;
    }
    return top;
}

/* ---------------------------------------------------------------- transfers and records */

xfer_t *chost_xfer_get(urbsim_chost_t *h)
{
    if (!h->free_list && h->n_blocks < CH_MAX_BLOCKS) {
        xfer_t *block = calloc(CH_BLOCK, sizeof *block);
        if (block) {
            h->blocks[h->n_blocks++] = block;
            for (int i = CH_BLOCK - 1; i >= 0; i--) {
                chost_xfer_put(h, &block[i]);
            }
        }
    }
    xfer_t *x = h->free_list;
    if (!x) {
        h->errors++; /* out of memory, or a million requests queued */
        return NULL;
    }
    h->free_list = x->next;
    x->next = NULL;
    return x;
}

void chost_xfer_put(urbsim_chost_t *h, xfer_t *x)
{
    x->next = h->free_list;
    h->free_list = x;
}

static void after_step(urbsim_chost_t *h, int b);

/* SimManager.submit: the core takes it, then _after_step. */
void chost_submit(urbsim_chost_t *h, xfer_t *x, int b)
{
    if (!chost_grow((void **)&h->rec, &h->cap_rec, h->n_rec + 1u, sizeof(ch_rec_t))) {
        h->errors++;
        chost_xfer_put(h, x);
        return;
    }
    urb_transfer_t *t = &x->t;
    x->bridge = b;
    x->rec = h->n_rec++;
    h->rec[x->rec] = (ch_rec_t){
        .what = (uint32_t)b << 24 | (uint32_t)t->address << 16 | (uint32_t)t->mailbox << 8 | (t->read ? 1u : 0u),
        .submitted = urbsim_host_local(h->w), .done = URB_NO_TIME, .status = -1};
    t->user = x;
    if (urb_core_submit(&h->b[b].core, t, h->rec[x->rec].submitted) != URB_HOST_OK) {
        h->errors++;
        chost_xfer_put(h, x);
        return;
    }
    h->submitted++;
    after_step(h, b);
}
/* A completion handed back by the core, dispatched: record it once, run its application part. */
static void dispatch(urbsim_chost_t *h, xfer_t *x)
{
    if (!chost_grow((void **)&h->cb, &h->cap_cb, h->n_cb + 1u, sizeof *h->cb)) {
        h->errors++;
        return;
    }
    h->cb[h->n_cb++] = (ch_callback_t){x->rec, urbsim_now(h->w)};
    ch_rec_t *r = &h->rec[x->rec];
    if (r->done != URB_NO_TIME) {
        h->duplicates++;
        return;
    }
    r->done = x->t.completed_ns;
    r->flags = x->t.flags;
#ifdef URBSIM_MUTANT_CHOST_LOSE_UPLINK_TIMEOUT
    r->flags &= ~URB_FLAG_UPLINK_TIMEOUT; /* seeded bug: a lost response is reported as a bare failure */
#endif
    r->status = x->t.status;
    r->len = x->t.response_len <= sizeof r->data ? x->t.response_len : 0u;
    memcpy(r->data, x->t.response, r->len);
    h->completed++;
    if (x->axis >= 0) {
        chost_pd_done(h, x);
    } else if (x->t.read && x->t.flags != URB_FLAG_NONE) {
        h->plain_fails++;
    }
    chost_xfer_put(h, x);
}

/* ---------------------------------------------------------------- SimManager's steps */

static void arm(urbsim_chost_t *h, int b, urb_ns_t deadline)
{
    ch_bridge_t *br = &h->b[b];
    if (deadline == URB_NEVER) {
        return;
    }
    for (uint32_t i = 0; i < br->n_timers; i++) {
        if (br->timer_at[i] <= deadline) {
            return;
        }
    }
    if (br->n_timers == CH_TIMERS) {
        h->errors++;
        return;
    }
    br->timer_at[br->n_timers++] = deadline;
    call_at(h, deadline, EV_TIMER, b, deadline);
}

static void after_step(urbsim_chost_t *h, int b)
{
    ch_bridge_t *br = &h->b[b];
    urb_ns_t now = urbsim_host_local(h->w);
    if (!br->usb) {
        uint8_t frame[URB_REQUEST_MAX];
        int32_t n;
        while ((n = urb_core_next_frame(&br->core, now, frame, sizeof frame)) > 0) {
            if (urbsim_host_send(h->w, b, frame, (uint32_t)n) != n) {
                h->errors++;
            }
        }
    } else if (!br->ticking && urb_core_busy(&br->core)) {
        br->ticking = true;
        call_at(h, (now / NS_PER_MS + 1) * NS_PER_MS, EV_FRAME, b, 0);
    }
    arm(h, b, urb_core_next_deadline(&br->core));
    urb_transfer_t *t;
    while ((t = urb_core_take_completed(&br->core)) != NULL) {
        xfer_t *x = t->user;
#ifdef URBSIM_MUTANT_CHOST_DROP_COMPLETION
        if (++h->taken == 100u) { /* seeded bug: the hundredth completion is never dispatched */
            continue;
        }
#endif
        x->next = NULL;
        if (br->pend_tail) {
            br->pend_tail->next = x;
        } else {
            br->pend_head = x;
        }
        br->pend_tail = x;
    }
    if (br->dispatching) {
        return;
    }
    br->dispatching = true;
    while (br->pend_head) {
        xfer_t *x = br->pend_head;
        br->pend_head = x->next;
        if (!br->pend_head) {
            br->pend_tail = NULL;
        }
        dispatch(h, x);
    }
    br->dispatching = false;
}

static void on_timer(urbsim_chost_t *h, int b, int64_t when)
{
    ch_bridge_t *br = &h->b[b];
    for (uint32_t i = 0; i < br->n_timers; i++) {
        if (br->timer_at[i] == when) {
            br->timer_at[i] = br->timer_at[--br->n_timers];
            break;
        }
    }
    urb_ns_t now = urbsim_host_local(h->w);
    urb_ns_t deadline = urb_core_next_deadline(&br->core);
    if (deadline == URB_NEVER || deadline > now) {
        arm(h, b, deadline);
        return;
    }
    urb_core_poll(&br->core, now);
    after_step(h, b);
}

static void frame_tick(urbsim_chost_t *h, int b)
{
    ch_bridge_t *br = &h->b[b];
    urb_ns_t now = urbsim_host_local(h->w);
    uint8_t out[URB_USB_BATCH_MAX];
    urb_core_poll(&br->core, now);
    int32_t n = urb_core_frame_out(&br->core, now, out, sizeof out);
    if (n > 0 && urbsim_host_send(h->w, b, out, (uint32_t)n) != n) {
        h->errors++;
    }
    br->ticking = false;
    after_step(h, b);
}

static void loop_run(urbsim_chost_t *h)
{
    if (h->left == 0u) {
        return;
    }
    h->left--;
    h->loop_runs++;
    if (chost_pd_tick(h)) {
        chost_plain_tick(h);
    }
    h->next += h->period;
    int64_t now = urbsim_host_local(h->w);
    while (h->next <= now) {
        h->next += h->period; /* overran: skip the missed periods, like a real thread */
    }
    call_at(h, h->next, EV_LOOP, -1, 0);
}

static void receive(urbsim_chost_t *h, int b, const uint8_t *data, uint32_t n)
{
    if (b < 0 || b >= CH_MAX_BRIDGES || !h->b[b].on) {
        return; /* a bridge nobody drives (SimHost: no receiver) */
    }
    ch_bridge_t *br = &h->b[b];
    urb_ns_t now = urbsim_host_local(h->w);
    int32_t rc = br->usb ? urb_core_receive_batch(&br->core, data, n, now) : urb_core_receive(&br->core, data, n, now);
    if (rc != URB_HOST_OK) {
        h->errors++;
    }
    after_step(h, b);
}

/* SimHost.step: run the world to the next host activity no later than limit and perform it. */
static bool step(urbsim_chost_t *h, uint64_t limit)
{
    uint64_t t_py = h->n_ev ? h->heap[0].when : UINT64_MAX;
    uint64_t target = t_py < limit ? t_py : limit;
    int bridge;
    uint32_t more;
    int n = urbsim_run_take(h->w, target, &bridge, &more, h->items[0], CH_ITEM_BYTES);
    if (n == URBSIM_RUN_ERROR) {
        h->errors++;
        return false;
    }
    if (n >= 0) {
        h->wakeups++;
        if (bridge < 0) {
            return true;
        }
        uint32_t k = 0;
        h->item_len[0] = (uint32_t)n;
        h->item_bridge[0] = bridge;
        while (more && k + 1u < CH_ITEMS) {
            k++;
            int m = urbsim_host_take_more(h->w, &h->item_bridge[k], &more, h->items[k], CH_ITEM_BYTES);
            if (m < 0) {
                h->errors++;
                return false;
            }
            h->item_len[k] = (uint32_t)m;
        }
        if (more) {
            h->errors++;
        }
        for (uint32_t i = 0; i <= k; i++) {
            receive(h, h->item_bridge[i], h->items[i], h->item_len[i]);
        }
        return true;
    }
    if (t_py <= target) {
        uint64_t now = urbsim_now(h->w);
        while (h->n_ev && h->heap[0].when <= now) {
            ev_t e = ev_pop(h);
            h->timer_runs++;
            if (e.kind == EV_TIMER) {
                on_timer(h, e.bridge, e.arg);
            } else if (e.kind == EV_FRAME) {
                frame_tick(h, e.bridge);
            } else {
                loop_run(h);
            }
        }
        return true;
    }
    return false;
}

/* ---------------------------------------------------------------- API */


urbsim_chost_t *urbsim_chost_new(urbsim_world_t *w)
{
    if (!w || urbsim_host_timer(w, 0) == 0u) {
        return NULL; /* urbsim_host_timer is 0 only for a world not started */
    }
    urbsim_chost_t *h = calloc(1, sizeof *h);
    if (!h) {
        return NULL;
    }
    h->w = w;
    return h;
}

void urbsim_chost_free(urbsim_chost_t *h)
{
    if (!h) {
        return;
    }
    chost_pd_free(h);
    for (uint32_t i = 0; i < h->n_blocks; i++) {
        free(h->blocks[i]);
    }
    free(h->heap);
    free(h->rec);
    free(h->cb);
    free(h);
}

int urbsim_chost_bridge(urbsim_chost_t *h, int bridge, int usb, int window, int next_seq, int frame)
{
    if (!h || bridge < 0 || bridge >= CH_MAX_BRIDGES || h->b[bridge].on || next_seq < 0 || next_seq > 15 ||
        frame < 1 || frame > 65535) {
        return -1;
    }
    if (isnan(urbsim_stat(h->w, "bridge.ppm", bridge))) {
        return -1; /* the world has no such bridge */
    }
    ch_bridge_t *br = &h->b[bridge];
    urb_link_kind_t kind = usb ? URB_LINK_USB : URB_LINK_RS232;
    urb_core_config_t cfg;
    urb_core_default_config(&cfg, kind);
    if (urb_core_init(&br->core, kind, &cfg) != URB_HOST_OK || urb_core_set_window(&br->core, (uint8_t)window) != URB_HOST_OK) {
        return -1;
    }
    /* The taken-over process's position: the bridge echoes sequence numbers and frame counters,
     * so a new core must go on from where the old one stopped (a fresh one would start at 1). */
    br->core.next_seq = (uint8_t)next_seq;
    br->core.frame = (uint16_t)frame;
    br->usb = usb != 0;
    br->on = true;
    return 0;
}

int urbsim_chost_pending(urbsim_chost_t *h, int bridge, int frame, int64_t deadline_ns, uint64_t t_v)
{
    if (!h || bridge < 0 || bridge >= CH_MAX_BRIDGES || !h->b[bridge].on || t_v < urbsim_now(h->w)) {
        return -1;
    }
    ch_bridge_t *br = &h->b[bridge];
    if (frame) {
        if (br->ticking || !br->usb) {
            return -1;
        }
        br->ticking = true;
    } else {
        if (br->n_timers == CH_TIMERS) {
            return -1;
        }
        br->timer_at[br->n_timers++] = deadline_ns;
    }
    if (!chost_grow((void **)&h->heap, &h->cap_ev, h->n_ev + 1u, sizeof(ev_t))) {
        return -1;
    }
    ev_push(h, (ev_t){t_v, h->seq++, deadline_ns, bridge, (uint8_t)(frame ? EV_FRAME : EV_TIMER)});
    return 0;
}

int urbsim_chost_loop(urbsim_chost_t *h, int64_t period_ns, uint32_t count, int64_t t0_ns)
{
    if (!h || period_ns <= 0 || h->period != 0) {
        return -1;
    }
    h->period = period_ns;
    h->left = count;
    h->t0 = t0_ns;
    h->next = (urbsim_host_local(h->w) / period_ns + 1) * period_ns;
    call_at(h, h->next, EV_LOOP, -1, 0);
    return 0;
}

int urbsim_chost_stop(urbsim_chost_t *h)
{
    if (!h || h->period == 0) {
        return -1;
    }
    h->left = 0u;
    return 0;
}

int urbsim_chost_advance_to(urbsim_chost_t *h, uint64_t t_v)
{
    if (!h) {
        return -1;
    }
    while (h->errors == 0u && step(h, t_v)) {
    }
    return h->errors ? -1 : 0;
}

int urbsim_chost_requests(urbsim_chost_t *h, uint32_t from, uint32_t *what, int64_t *submitted, int64_t *done,
                          uint32_t *flags, uint32_t cap)
{
    if (!h || !what || !submitted || !done || !flags) {
        return -1;
    }
    uint32_t n = 0;
    for (; n < cap && from + n < h->n_rec; n++) {
        const ch_rec_t *r = &h->rec[from + n];
        what[n] = r->what;
        submitted[n] = r->submitted;
        done[n] = r->done;
        flags[n] = r->flags;
    }
    return (int)n;
}

int urbsim_chost_callbacks(urbsim_chost_t *h, uint32_t from, uint32_t *rec, uint64_t *t_v, uint32_t cap)
{
    if (!h || !rec || !t_v) {
        return -1;
    }
    uint32_t n = 0;
    for (; n < cap && from + n < h->n_cb; n++) {
        rec[n] = h->cb[from + n].rec;
        t_v[n] = h->cb[from + n].t_v;
    }
    return (int)n;
}

int urbsim_chost_responses(urbsim_chost_t *h, uint32_t from, int8_t *status, uint8_t *len, uint8_t *data, uint32_t cap)
{
    if (!h || !status || !len || !data) {
        return -1;
    }
    uint32_t n = 0;
    for (; n < cap && from + n < h->n_rec; n++) {
        const ch_rec_t *r = &h->rec[from + n];
        status[n] = r->status;
        len[n] = r->len;
        memcpy(&data[n * URB_HOST_MAILBOX_MAX], r->data, URB_HOST_MAILBOX_MAX);
    }
    return (int)n;
}

double urbsim_chost_stat(urbsim_chost_t *h, const char *name)
{
    if (!h || !name) {
        return NAN;
    }
    static const struct {
        const char *name;
        size_t offset;
    } counters[] = {
        {"submitted", offsetof(urbsim_chost_t, submitted)},   {"completed", offsetof(urbsim_chost_t, completed)},
        {"duplicates", offsetof(urbsim_chost_t, duplicates)}, {"errors", offsetof(urbsim_chost_t, errors)},
        {"wakeups", offsetof(urbsim_chost_t, wakeups)},       {"timer_runs", offsetof(urbsim_chost_t, timer_runs)},
        {"loop_runs", offsetof(urbsim_chost_t, loop_runs)},   {"plain_fails", offsetof(urbsim_chost_t, plain_fails)},
    };
    for (size_t i = 0; i < sizeof counters / sizeof counters[0]; i++) {
        if (strcmp(name, counters[i].name) == 0) {
            uint64_t v;
            memcpy(&v, (const char *)h + counters[i].offset, sizeof v);
            return (double)v;
        }
    }
    if (strncmp(name, "stray_bytes:", 12) == 0) {
        int b = atoi(name + 12);
        return b >= 0 && b < CH_MAX_BRIDGES && h->b[b].on ? (double)h->b[b].core.m.stray_bytes : NAN;
    }
    if (strncmp(name, "fails:", 6) == 0) {
        int axis = atoi(name + 6);
        return axis >= 0 && axis < h->n_axes ? (double)h->axis[axis].fails : NAN;
    }
    return NAN;
}
