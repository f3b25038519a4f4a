/*
 * sim_host_c.c: the C host library on the simulated host CPU (see sim_host_c.h). The core
 * (host/c/core) is untouched; this file is its port: SimHost's event loop and SimManager's
 * _after_step, _on_timer and _frame_tick, in C, over the world's public API (urbsim.h).
 */
#include "sim_host_c.h"

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "urb_host_core.h"
#include "urb_sensorhex.h"

#define CH_MAX_BRIDGES 8
#define CH_MAX_AXES 16
#define CH_MAX_READS 32
#define CH_BLOCK 256         /* transfers allocated at a time (a loop that outruns its link queues without end) */
#define CH_MAX_BLOCKS 4096
#define CH_TIMERS 64         /* armed timers per bridge (SimManager._timer_at) */
#define CH_ITEM_BYTES 1024   /* as World._buf: the largest item a take hands over */
#define CH_ITEMS 256
#define NS_PER_MS 1000000LL
#define PI 3.141592653589793 /* Python's math.pi, so that the two hosts compute the same positions */
#define FEEDBACK_MAILBOX 1u
#define COMMAND_MAILBOX 1u

typedef enum { EV_TIMER, EV_FRAME, EV_LOOP } ev_kind_t;

typedef struct {
    uint64_t when, seq;
    int64_t arg;
    int bridge;
    uint8_t kind;
} ev_t;

typedef struct xfer xfer_t;
struct xfer {
    urb_transfer_t t;
    xfer_t *next;     /* free list, or the bridge's completions waiting for dispatch */
    uint32_t rec;     /* its request record */
    int axis;         /* the PD axis of a feedback read, else -1 */
    int bridge;
};

typedef struct {
    bool on, usb, ticking, dispatching;
    urb_core_t core;
    xfer_t *pend_head, *pend_tail;
    int64_t timer_at[CH_TIMERS];
    uint32_t n_timers;
} ch_bridge_t;

typedef struct {
    int bridge, node, leg; /* leg >= 0: the gait's reference for that leg, logged per feedback */
    uint8_t address;
    double kp, kd, limit, amp, omega;
    bool has_prev, has_raw;
    double prev_e;
    int64_t prev_t;
    uint16_t raw;
    int64_t pos;
    uint64_t fails;
    /* truth samples and commands, grown as needed */
    int64_t *st;
    double *spos, *sref;
    uint32_t n_s, cap_s;
    int32_t *mv;
    uint32_t n_mv, cap_mv;
    /* gait axes: one row per successful feedback (gait.py run_gait's legs and truth_current) */
    double *log;   /* CH_LOG_COLS per row */
    uint32_t n_log, cap_log;
} ch_axis_t;

#define CH_LOG_COLS 6u /* t s, reference, true shaft, measured V, measured I, true current */

typedef struct {
    int bridge;
    uint8_t address, mailbox, length;
    bool read;
    uint8_t data[URB_HOST_MAILBOX_MAX]; /* a write's payload */
    uint32_t every;
} ch_read_t;

typedef struct {
    uint32_t what, flags;
    int64_t submitted, done;
} ch_rec_t;

struct urbsim_chost {
    urbsim_world_t *w;
    ch_bridge_t b[CH_MAX_BRIDGES];
    ch_axis_t axis[CH_MAX_AXES];
    int n_axes;
    ch_read_t read[CH_MAX_READS];
    int n_reads;
    xfer_t *blocks[CH_MAX_BLOCKS]; /* the transfers: the cores hold pointers to them, so they never move */
    uint32_t n_blocks;
    xfer_t *free_list;
    ev_t *heap;
    uint32_t n_ev, cap_ev;
    uint64_t seq;
    /* the loop */
    int64_t period, next, t0;
    uint32_t left;
    uint64_t loop_runs;
    /* records */
    ch_rec_t *rec;
    uint32_t n_rec, cap_rec;
    /* counters */
    uint64_t submitted, completed, duplicates, errors, wakeups, timer_runs, plain_fails;
#ifdef URBSIM_MUTANT_CHOST_DROP_COMPLETION
    uint64_t taken;
#endif
    /* a wake-up's items, taken all before any is delivered (as World.run_take) */
    uint8_t items[CH_ITEMS][CH_ITEM_BYTES];
    uint32_t item_len[CH_ITEMS];
    int item_bridge[CH_ITEMS];
};

/* ---------------------------------------------------------------- growable arrays */

static bool grow(void **p, uint32_t *cap, uint32_t need, size_t size)
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
    if (!grow((void **)&h->heap, &h->cap_ev, h->n_ev + 1u, sizeof(ev_t))) {
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

static void xfer_put(urbsim_chost_t *h, xfer_t *x);

static xfer_t *xfer_get(urbsim_chost_t *h)
{
    if (!h->free_list && h->n_blocks < CH_MAX_BLOCKS) {
        xfer_t *block = calloc(CH_BLOCK, sizeof *block);
        if (block) {
            h->blocks[h->n_blocks++] = block;
            for (int i = CH_BLOCK - 1; i >= 0; i--) {
                xfer_put(h, &block[i]);
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

static void xfer_put(urbsim_chost_t *h, xfer_t *x)
{
    x->next = h->free_list;
    h->free_list = x;
}

static void after_step(urbsim_chost_t *h, int b);

/* SimManager.submit: the core takes it, then _after_step. */
static void submit(urbsim_chost_t *h, xfer_t *x, int b)
{
    if (!grow((void **)&h->rec, &h->cap_rec, h->n_rec + 1u, sizeof(ch_rec_t))) {
        h->errors++;
        xfer_put(h, x);
        return;
    }
    urb_transfer_t *t = &x->t;
    x->bridge = b;
    x->rec = h->n_rec++;
    h->rec[x->rec] = (ch_rec_t){(uint32_t)b << 24 | (uint32_t)t->address << 16 | (uint32_t)t->mailbox << 8 | (t->read ? 1u : 0u),
                                0u, urbsim_host_local(h->w), URB_NO_TIME};
    t->user = x;
    if (urb_core_submit(&h->b[b].core, t, h->rec[x->rec].submitted) != URB_HOST_OK) {
        h->errors++;
        xfer_put(h, x);
        return;
    }
    h->submitted++;
    after_step(h, b);
}

/* ---------------------------------------------------------------- the application */

static void push_sample(urbsim_chost_t *h, ch_axis_t *a, int64_t t, double pos, double ref)
{
    /* three arrays of one length: each grows from the same capacity to the same capacity */
    uint32_t cap_t = a->cap_s, cap_p = a->cap_s, cap_r = a->cap_s;
    bool ok = grow((void **)&a->st, &cap_t, a->n_s + 1u, sizeof *a->st);
    ok = grow((void **)&a->spos, &cap_p, a->n_s + 1u, sizeof *a->spos) && ok;
    ok = grow((void **)&a->sref, &cap_r, a->n_s + 1u, sizeof *a->sref) && ok;
    if (!ok || cap_t != cap_p || cap_t != cap_r) {
        h->errors++;
        return;
    }
    a->cap_s = cap_t;
    a->st[a->n_s] = t;
    a->spos[a->n_s] = pos;
    a->sref[a->n_s] = ref;
    a->n_s++;
}

/* The Pd of control.py: u = Kp e + Kd de/dt, de/dt over the reads' submission instants. */
static double pd(ch_axis_t *a, double e, int64_t t_ns)
{
    double de = 0.0;
    if (a->has_prev) {
        double dt = (double)(t_ns - a->prev_t) * 1e-9;
        de = (e - a->prev_e) / (dt > 1e-6 ? dt : 1e-6);
    }
    a->has_prev = true;
    a->prev_e = e;
    a->prev_t = t_ns;
    double u = a->kp * e + a->kd * de;
#ifdef URBSIM_MUTANT_CHOST_WRONG_GAIN
    u = 1.25 * a->kp * e + a->kd * de; /* seeded bug: the proportional gain 25 % high */
#endif
    return u > a->limit ? a->limit : (u < -a->limit ? -a->limit : u);
}

/* Axis.update: the encoder wraps modulo 65536 (Python's % is never negative). */
static double unwrap(ch_axis_t *a, uint16_t raw)
{
    if (a->has_raw) {
        int64_t d = ((int64_t)raw - (int64_t)a->raw + 32768) % 65536;
        a->pos += (d < 0 ? d + 65536 : d) - 32768;
    }
    a->raw = raw;
    a->has_raw = true;
    return (double)a->pos / (2000.0 / (2.0 * PI));
}

/* Submit the MotorCommand for drive u (V), as int(round(u * 1000)) mV; false when it failed. */
static bool command(urbsim_chost_t *h, ch_axis_t *a, double u)
{
    double mv = rint(u * 1000.0); /* Python's round(): halves to even, the default rounding mode */
    if (!grow((void **)&a->mv, &a->cap_mv, a->n_mv + 1u, sizeof *a->mv)) {
        h->errors++;
        return false;
    }
    urb_motor_command_t cmd = {(int16_t)mv};
    uint8_t data[URB_MOTOR_COMMAND_SIZE];
    xfer_t *w = xfer_get(h);
    if (!w || urb_motor_command_encode(&cmd, data, sizeof data) != (int32_t)sizeof data ||
        urb_transfer_write(&w->t, a->address, COMMAND_MAILBOX, data, (uint8_t)sizeof data) != URB_HOST_OK) {
        h->errors++;
        if (w) {
            xfer_put(h, w);
        }
        return false;
    }
    w->axis = -1;
    submit(h, w, a->bridge);
    a->mv[a->n_mv++] = (int32_t)mv;
    return true;
}

/* gait.py's Buehler clock, gait clock and leg reference, operation for operation. */
#define GEAR 33.0
#define PERIOD_S 0.8
#define STANCE_SWEEP 1.0
#define DUTY 0.5

static double buehler(double phase_s)
{
    double k = floor(phase_s / PERIOD_S);
    double t = phase_s - k * PERIOD_S;
    double a;
    if (t < DUTY * PERIOD_S) {
        a = -STANCE_SWEEP / 2 + STANCE_SWEEP * t / (DUTY * PERIOD_S);
    } else {
        a = STANCE_SWEEP / 2 + (2 * PI - STANCE_SWEEP) * (t - DUTY * PERIOD_S) / ((1 - DUTY) * PERIOD_S);
    }
    return a + 2 * PI * k + STANCE_SWEEP / 2;
}

static double gait_clock(double t_s)
{
    if (t_s < PERIOD_S) {
        return t_s;
    }
    double back = 2 * PERIOD_S - t_s;
    return back > 0.0 ? back : 0.0;
}

static double leg_reference(int leg, double t_s)
{
    double offset = (leg == 0 || leg == 2 || leg == 4) ? 0.0 : PERIOD_S / 2;
    return GEAR * (buehler(gait_clock(t_s) + offset) - buehler(offset));
}

/* The feedback callback of gait.py's run_gait. */
static void gait_feedback(urbsim_chost_t *h, ch_axis_t *a, const urb_motor_feedback_t *fb, int64_t submitted)
{
    int64_t now = urbsim_host_local(h->w);
    int64_t t = now - h->t0;
    double pos = unwrap(a, fb->encoder);
    double ts = (double)t * 1e-9;
    double ref = leg_reference(a->leg, ts > 0.0 ? ts : 0.0);
    double u = pd(a, ref - pos, submitted ? submitted : now);
    if (!command(h, a, u)) {
        return;
    }
    double plant[6];
    if (urbsim_node_plant(h->w, a->node, plant) != 0 ||
        !grow((void **)&a->log, &a->cap_log, (a->n_log + 1u) * CH_LOG_COLS, sizeof *a->log)) {
        h->errors++;
        return;
    }
    double *row = &a->log[a->n_log++ * CH_LOG_COLS];
    row[0] = (double)t * 1e-9;
    row[1] = ref;
    row[2] = plant[0];
    row[3] = fb->voltage / 1000.0;
    row[4] = fb->current / 1000.0;
    row[5] = plant[2];
}

/* The feedback callback of control.py's _control (or gait.py's run_gait for a gait axis). */
static void feedback_done(urbsim_chost_t *h, xfer_t *x)
{
    ch_axis_t *a = &h->axis[x->axis];
    urb_motor_feedback_t fb;
    if (x->t.flags != URB_FLAG_NONE ||
        urb_motor_feedback_decode(&fb, x->t.response, x->t.response_len) != (int32_t)URB_MOTOR_FEEDBACK_SIZE) {
        a->fails++;
        return;
    }
    if (a->leg >= 0) {
        gait_feedback(h, a, &fb, x->t.submitted_ns);
        return;
    }
    int64_t t = urbsim_host_local(h->w);
    double pos = unwrap(a, fb.encoder);
    double r = a->amp * sin(a->omega * (double)(t - h->t0) * 1e-9);
    (void)command(h, a, pd(a, r - pos, x->t.submitted_ns ? x->t.submitted_ns : t));
}

/* One period of the application's thread (control.py's tick, then the plain reads due). */
static void loop_tick(urbsim_chost_t *h)
{
    int64_t t = urbsim_host_local(h->w) - h->t0;
    for (int i = 0; i < h->n_axes; i++) {
        ch_axis_t *a = &h->axis[i];
        if (a->leg >= 0) {
            continue; /* a gait axis logs at its feedback, not at the tick */
        }
        double plant[6];
        if (urbsim_node_plant(h->w, a->node, plant) != 0) {
            h->errors++;
            return;
        }
        push_sample(h, a, t, plant[0], a->amp * sin(a->omega * (double)t * 1e-9));
    }
    for (int i = 0; i < h->n_axes; i++) {
        xfer_t *x = xfer_get(h);
        if (!x) {
            return;
        }
        urb_transfer_read(&x->t, h->axis[i].address, FEEDBACK_MAILBOX, URB_MOTOR_FEEDBACK_SIZE);
        x->axis = i;
        submit(h, x, h->axis[i].bridge);
    }
    for (int i = 0; i < h->n_reads; i++) {
        ch_read_t *r = &h->read[i];
        if (h->loop_runs % r->every != 0u) {
            continue;
        }
        xfer_t *x = xfer_get(h);
        if (!x) {
            return;
        }
        if (r->read) {
            urb_transfer_read(&x->t, r->address, r->mailbox, r->length);
        } else {
            urb_transfer_write(&x->t, r->address, r->mailbox, r->data, r->length);
        }
        x->axis = -1;
        submit(h, x, r->bridge);
    }
}

/* A completion handed back by the core, dispatched: record it once, run its application part. */
static void dispatch(urbsim_chost_t *h, xfer_t *x)
{
    ch_rec_t *r = &h->rec[x->rec];
    if (r->done != URB_NO_TIME) {
        h->duplicates++;
        return;
    }
    r->done = x->t.completed_ns;
    r->flags = x->t.flags;
    h->completed++;
    if (x->axis >= 0) {
        feedback_done(h, x);
    } else if (x->t.read && x->t.flags != URB_FLAG_NONE) {
        h->plain_fails++;
    }
    xfer_put(h, x);
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
    loop_tick(h);
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
    for (int i = 0; i < h->n_axes; i++) {
        free(h->axis[i].st);
        free(h->axis[i].spos);
        free(h->axis[i].sref);
        free(h->axis[i].mv);
        free(h->axis[i].log);
    }
    for (uint32_t i = 0; i < h->n_blocks; i++) {
        free(h->blocks[i]);
    }
    free(h->heap);
    free(h->rec);
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
    if (!grow((void **)&h->heap, &h->cap_ev, h->n_ev + 1u, sizeof(ev_t))) {
        return -1;
    }
    ev_push(h, (ev_t){t_v, h->seq++, deadline_ns, bridge, (uint8_t)(frame ? EV_FRAME : EV_TIMER)});
    return 0;
}

int urbsim_chost_axis(urbsim_chost_t *h, int bridge, int node, int address, double kp, double kd, double limit,
                      double amp, double omega, int leg)
{
    if (!h || h->n_axes == CH_MAX_AXES || leg > 5 || bridge < 0 || bridge >= CH_MAX_BRIDGES || !h->b[bridge].on || address < 1 ||
        address > 127 || !(limit > 0.0)) {
        return -1;
    }
    double plant[6];
    if (urbsim_node_plant(h->w, node, plant) != 0) {
        return -1;
    }
    ch_axis_t *a = &h->axis[h->n_axes];
    memset(a, 0, sizeof *a);
    *a = (ch_axis_t){.bridge = bridge, .node = node, .leg = leg < 0 ? -1 : leg, .address = (uint8_t)address, .kp = kp,
                     .kd = kd, .limit = limit, .amp = amp, .omega = omega};
    return h->n_axes++;
}

int urbsim_chost_read(urbsim_chost_t *h, int bridge, int address, int mailbox, int length, int every)
{
    return urbsim_chost_write(h, bridge, address, mailbox, NULL, length, every);
}

int urbsim_chost_write(urbsim_chost_t *h, int bridge, int address, int mailbox, const uint8_t *data, int length,
                       int every)
{
    if (!h || h->n_reads == CH_MAX_READS || bridge < 0 || bridge >= CH_MAX_BRIDGES || !h->b[bridge].on || address < 1 ||
        address > 127 || mailbox < 0 || mailbox > 7 || length < 1 || length > 32 || every < 1) {
        return -1;
    }
    ch_read_t *r = &h->read[h->n_reads];
    *r = (ch_read_t){.bridge = bridge, .address = (uint8_t)address, .mailbox = (uint8_t)mailbox,
                     .length = (uint8_t)length, .read = data == NULL, .every = (uint32_t)every};
    if (data) {
        memcpy(r->data, data, (size_t)length);
    }
    return h->n_reads++;
}

int urbsim_chost_submit(urbsim_chost_t *h, int bridge, int address, int mailbox, const uint8_t *data, int length)
{
    if (!h || bridge < 0 || bridge >= CH_MAX_BRIDGES || !h->b[bridge].on || address < 1 || address > 127 || mailbox < 0 ||
        mailbox > 7 || length < 1 || length > 32) {
        return -1;
    }
    xfer_t *x = xfer_get(h);
    if (!x) {
        return -1;
    }
    int32_t rc = data ? urb_transfer_write(&x->t, (uint8_t)address, (uint8_t)mailbox, data, (uint8_t)length)
                      : urb_transfer_read(&x->t, (uint8_t)address, (uint8_t)mailbox, (uint8_t)length);
    if (rc != URB_HOST_OK) {
        xfer_put(h, x);
        return -1;
    }
    x->axis = -1;
    uint64_t errors = h->errors;
    submit(h, x, bridge);
    return h->errors == errors ? 0 : -1;
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

int urbsim_chost_advance_to(urbsim_chost_t *h, uint64_t t_v)
{
    if (!h) {
        return -1;
    }
    while (h->errors == 0u && step(h, t_v)) {
    }
    return h->errors ? -1 : 0;
}

int urbsim_chost_samples(urbsim_chost_t *h, int axis, uint32_t from, int64_t *t, double *pos, double *ref, uint32_t cap)
{
    if (!h || axis < 0 || axis >= h->n_axes || !t || !pos || !ref) {
        return -1;
    }
    const ch_axis_t *a = &h->axis[axis];
    uint32_t n = 0;
    for (; n < cap && from + n < a->n_s; n++) {
        t[n] = a->st[from + n];
        pos[n] = a->spos[from + n];
        ref[n] = a->sref[from + n];
    }
    return (int)n;
}

int urbsim_chost_commands(urbsim_chost_t *h, int axis, uint32_t from, int32_t *mv, uint32_t cap)
{
    if (!h || axis < 0 || axis >= h->n_axes || !mv) {
        return -1;
    }
    const ch_axis_t *a = &h->axis[axis];
    uint32_t n = 0;
    for (; n < cap && from + n < a->n_mv; n++) {
        mv[n] = a->mv[from + n];
    }
    return (int)n;
}

int urbsim_chost_log(urbsim_chost_t *h, int axis, uint32_t from, double *rows, uint32_t cap)
{
    if (!h || axis < 0 || axis >= h->n_axes || !rows) {
        return -1;
    }
    const ch_axis_t *a = &h->axis[axis];
    uint32_t n = 0;
    for (; n < cap && from + n < a->n_log; n++) {
        memcpy(&rows[n * CH_LOG_COLS], &a->log[(from + n) * CH_LOG_COLS], CH_LOG_COLS * sizeof *rows);
    }
    return (int)n;
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
    if (strncmp(name, "fails:", 6) == 0) {
        int axis = atoi(name + 6);
        return axis >= 0 && axis < h->n_axes ? (double)h->axis[axis].fails : NAN;
    }
    return NAN;
}
