/* kernel.c: the event queue, ordered by (time, insertion sequence). See kernel.h.
 *
 * Why two queues: the simulation keeps ~60 events pending, but nearly every event it runs was
 * scheduled a few microseconds earlier, and those arrive almost in time order. In one binary heap
 * each of them was sifted through ~6 levels of long-term entries on the way in and on the way out,
 * a third of the run time. Both queues use the same strict total order and the earlier head runs
 * first, so the run order is exactly that of a single queue. */
#include "kernel.h"

#include <stdlib.h>
#include <string.h>

/* True when a must run before b. Sequence numbers are unique, so this is a strict total order and
 * the run order never depends on the queues' internal layout. */
static inline bool before(const urbsim_event_key_t *a, const urbsim_event_key_t *b)
{
    return a->t < b->t || (a->t == b->t && a->seq < b->seq);
}

static bool heap_init(urbsim_heap_t *q, size_t cap)
{
    q->len = 0;
    q->cap = cap;
    q->key = malloc(cap * sizeof *q->key);
    q->item = malloc(cap * sizeof *q->item);
    q->owner = malloc(cap * sizeof *q->owner);
    return q->key != NULL && q->item != NULL && q->owner != NULL;
}

static void heap_free(urbsim_heap_t *q)
{
    free(q->key);
    free(q->item);
    free(q->owner);
    q->key = NULL;
    q->item = NULL;
    q->owner = NULL;
    q->len = q->cap = 0;
}

/* Double the arrays (a heap stays a heap). */
static bool heap_grow(urbsim_heap_t *q)
{
    size_t cap = q->cap * 2u;
    urbsim_event_key_t *key = realloc(q->key, cap * sizeof *key);
    if (key == NULL) {
        return false;
    }
    q->key = key;
    urbsim_event_t *item = realloc(q->item, cap * sizeof *item);
    if (item == NULL) {
        return false;
    }
    q->item = item;
    urbsim_handle_t **owner = realloc(q->owner, cap * sizeof *owner);
    if (owner == NULL) {
        return false;
    }
    q->owner = owner;
    q->cap = cap;
    return true;
}

/*
 * The helpers below take an event as separate scalars, never as a struct by value: GCC passes
 * such a struct through the stack with 8-byte stores and reads it back with 16-byte loads, a
 * store-forwarding stall that cost more than all of the queue's own work (7 % of a SensoRHex run).
 */

/* Near queue: insert into the sorted ring (the caller checked there is room). The new event has
 * the largest sequence number of all, so it goes after every event due at or before its time: an
 * event due no earlier than all others (a byte's completion after the interrupts it raised) is
 * appended and one due before all others (an interrupt handler right after the bus event that
 * raised it) goes in front, both in O(1); the others are placed from the back. */
static void ring_push(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg)
{
    const uint32_t m = URBSIM_KERNEL_NEAR_MAX - 1u;
    urbsim_near_entry_t *e = k->near;
    uint32_t i;
    if (t >= k->near_last) {
        i = (k->near_head + k->near_len) & m;
        k->near_last = t;
    } else if (t < e[k->near_head].key.t) {
        k->near_head = (k->near_head - 1u) & m;
        i = k->near_head;
    } else {
        i = k->near_head + k->near_len;
#ifdef URBSIM_MUTANT_RING_TIES /* seeded bug (mk/sim.mk): a new event overtakes its ties */
        while (i != k->near_head && t <= e[(i - 1u) & m].key.t) {
#else
        while (i != k->near_head && t < e[(i - 1u) & m].key.t) {
#endif
            e[i & m] = e[(i - 1u) & m];
            i--;
        }
        i &= m;
    }
    k->near_len++;
    e[i].key.t = t;
    e[i].key.seq = k->next_seq++;
    e[i].item.fn = fn;
    e[i].item.ctx = ctx;
    e[i].item.arg = arg;
}

/* Far queue: binary heap, whose entries may have an owner handle that follows them around. */

/* Tell the owner of the entry in slot i, if any, where it is now. */
static inline void heap_track(urbsim_heap_t *q, size_t i)
{
#ifndef URBSIM_MUTANT_CANCEL_SLOT /* seeded bug (mk/sim.mk): a handle loses track of its moved event */
    if (q->owner[i] != NULL) {
        q->owner[i]->slot = i;
    }
#else
    (void)q;
    (void)i;
#endif
}

/* Put an event into slot i. */
static inline void heap_place(urbsim_heap_t *q, size_t i, urbsim_ns_t t, uint64_t seq, urbsim_event_fn fn, void *ctx,
                              uint64_t arg, urbsim_handle_t *owner)
{
    q->key[i].t = t;
    q->key[i].seq = seq;
    q->item[i].fn = fn;
    q->item[i].ctx = ctx;
    q->item[i].arg = arg;
    q->owner[i] = owner;
    heap_track(q, i);
}

/* Move the entry in slot i into the hole at slot j. */
static inline void heap_move(urbsim_heap_t *q, size_t j, size_t i)
{
    q->key[j] = q->key[i];
    q->item[j] = q->item[i];
    q->owner[j] = q->owner[i];
    heap_track(q, j);
}

/* Put an event into the hole at slot i, sifting it up towards the root. */
static void heap_sift_up(urbsim_heap_t *q, size_t i, urbsim_ns_t t, uint64_t seq, urbsim_event_fn fn, void *ctx,
                         uint64_t arg, urbsim_handle_t *owner)
{
    const urbsim_event_key_t key = {t, seq};
    while (i > 0) {
        size_t parent = (i - 1u) / 2u;
        if (!before(&key, &q->key[parent])) {
            break;
        }
        heap_move(q, i, parent);
        i = parent;
    }
    heap_place(q, i, t, seq, fn, ctx, arg, owner);
}

/* Put an event into the hole at slot i of a heap of n entries, sifting it down. */
static void heap_sift_down(urbsim_heap_t *q, size_t i, size_t n, urbsim_ns_t t, uint64_t seq, urbsim_event_fn fn,
                           void *ctx, uint64_t arg, urbsim_handle_t *owner)
{
    const urbsim_event_key_t key = {t, seq};
    for (;;) {
        size_t c = 2u * i + 1u;
        if (c >= n) {
            break;
        }
        if (c + 1u < n && before(&q->key[c + 1u], &q->key[c])) {
            c++;
        }
        if (!before(&q->key[c], &key)) {
            break;
        }
        heap_move(q, i, c);
        i = c;
    }
    heap_place(q, i, t, seq, fn, ctx, arg, owner);
}

/* Remove the entry at slot i (q->len > i), copying its payload to *gone, and restore the heap
 * property with the last entry. */
static void heap_remove(urbsim_heap_t *q, size_t i, urbsim_event_t *gone)
{
    if (gone != NULL) {
        *gone = q->item[i];
    }
    if (q->owner[i] != NULL) {
        q->owner[i]->armed = false;
    }
    size_t n = --q->len;
    if (i == n) {
        return;
    }
    const urbsim_event_key_t *last = &q->key[n];
    const urbsim_event_t *li = &q->item[n];
    if (i > 0 && before(last, &q->key[(i - 1u) / 2u])) {
        heap_sift_up(q, i, last->t, last->seq, li->fn, li->ctx, li->arg, q->owner[n]);
    } else {
        heap_sift_down(q, i, n, last->t, last->seq, li->fn, li->ctx, li->arg, q->owner[n]);
    }
}

bool urbsim_kernel_init(urbsim_kernel_t *k)
{
    k->now = 0;
    k->next_seq = 0;
    k->executed = 0;
    k->stop = false;
    k->near_head = 0;
    k->near_len = 0;
    k->near_last = 0;
    if (!heap_init(&k->far, 256)) {
        heap_free(&k->far);
        return false;
    }
    return true;
}

void urbsim_kernel_free(urbsim_kernel_t *k)
{
    heap_free(&k->far);
    k->near_len = 0;
}

size_t urbsim_kernel_pending(const urbsim_kernel_t *k)
{
    return k->near_len + k->far.len;
}

size_t urbsim_kernel_capacity(const urbsim_kernel_t *k)
{
    return URBSIM_KERNEL_NEAR_MAX + k->far.cap;
}

void urbsim_handle_init(urbsim_handle_t *h)
{
    h->slot = 0;
    h->armed = false;
}

/* Where an event due at t (>= now) goes: the near ring if it is due soon and there is room. */
static inline bool goes_near(const urbsim_kernel_t *k, urbsim_ns_t t)
{
    return t - k->now <= URBSIM_KERNEL_NEAR_NS && k->near_len < URBSIM_KERNEL_NEAR_MAX;
}

static bool far_push(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg,
                     urbsim_handle_t *h)
{
    urbsim_heap_t *q = &k->far;
    if (q->len == q->cap && !heap_grow(q)) {
        return false;
    }
    if (h != NULL) {
        h->armed = true;
    }
    heap_sift_up(q, q->len++, t, k->next_seq++, fn, ctx, arg, h);
    return true;
}

/* Queue an event due at t (clamped to now), with its handle if it goes to the far queue. */
static bool schedule(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg,
                     urbsim_handle_t *h)
{
    if (t < k->now) {
        t = k->now;
    }
    if (goes_near(k, t)) {
        ring_push(k, t, fn, ctx, arg);
        return true;
    }
    return far_push(k, t, fn, ctx, arg, h);
}

bool urbsim_kernel_at(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg)
{
    return schedule(k, t, fn, ctx, arg, NULL);
}

bool urbsim_kernel_at_handle(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg,
                             urbsim_handle_t *h)
{
    if (h != NULL) {
        urbsim_kernel_cancel(k, h); /* a handle holds one event: the one it held is superseded */
    }
    return schedule(k, t, fn, ctx, arg, h);
}

void urbsim_kernel_cancel(urbsim_kernel_t *k, urbsim_handle_t *h)
{
    if (!h->armed) {
        return;
    }
    heap_remove(&k->far, h->slot, NULL);
}

bool urbsim_kernel_after(urbsim_kernel_t *k, urbsim_ns_t delay, urbsim_event_fn fn, void *ctx, uint64_t arg)
{
    return urbsim_kernel_at(k, k->now + delay, fn, ctx, arg);
}

urbsim_ns_t urbsim_kernel_next_time(const urbsim_kernel_t *k)
{
    urbsim_ns_t a = k->near_len ? k->near[k->near_head].key.t : URBSIM_NEVER;
    urbsim_ns_t b = k->far.len ? k->far.key[0].t : URBSIM_NEVER;
    return a < b ? a : b;
}

bool urbsim_kernel_run_until(urbsim_kernel_t *k, urbsim_ns_t limit)
{
    k->stop = false;
    for (;;) {
        urbsim_event_t ev;
        urbsim_ns_t t;
        const urbsim_near_entry_t *head = &k->near[k->near_head];
        bool near;
        if (k->near_len == 0u) {
            if (k->far.len == 0u) {
                break;
            }
            near = false;
        } else {
#ifdef URBSIM_MUTANT_QUEUE_TIES /* seeded bug (mk/sim.mk): a tie between the queues goes to the near one */
            near = k->far.len == 0u || head->key.t <= k->far.key[0].t;
#else
            near = k->far.len == 0u || before(&head->key, &k->far.key[0]);
#endif
        }
        if (near) {
            t = head->key.t;
            if (t > limit) {
                break;
            }
            ev = head->item;
            k->near_head = (k->near_head + 1u) & (URBSIM_KERNEL_NEAR_MAX - 1u);
            k->near_len--;
        } else {
            t = k->far.key[0].t;
            if (t > limit) {
                break;
            }
            heap_remove(&k->far, 0, &ev);
        }
        k->now = t;
        k->executed++;
        ev.fn(ev.ctx, ev.arg, t);
        if (k->stop) {
            k->stop = false;
            return true;
        }
    }
    if (limit > k->now) {
        k->now = limit;
    }
    return false;
}

void urbsim_kernel_stop(urbsim_kernel_t *k)
{
    k->stop = true;
}
