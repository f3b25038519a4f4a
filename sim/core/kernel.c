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

static bool queue_init(urbsim_queue_t *q, size_t cap, bool owners)
{
    q->len = 0;
    q->head = 0;
    q->cap = cap;
    q->key = malloc(cap * sizeof *q->key);
    q->item = malloc(cap * sizeof *q->item);
    q->owner = owners ? malloc(cap * sizeof *q->owner) : NULL;
    return q->key != NULL && q->item != NULL && (!owners || q->owner != NULL);
}

static void queue_free(urbsim_queue_t *q)
{
    free(q->key);
    free(q->item);
    free(q->owner);
    q->key = NULL;
    q->item = NULL;
    q->owner = NULL;
    q->len = q->cap = q->head = 0;
}

/* Double the arrays, moving the entries to indices 0..len-1 in their order (a heap stays a heap,
 * the ring is unwrapped). */
static bool queue_grow(urbsim_queue_t *q)
{
    size_t cap = q->cap * 2u;
    if (q->owner != NULL) {
        /* the heap (the only queue with owners) always starts at index 0: no unwrapping */
        urbsim_handle_t **owner = realloc(q->owner, cap * sizeof *owner);
        if (owner == NULL) {
            return false;
        }
        q->owner = owner;
    }
    urbsim_event_key_t *key = malloc(cap * sizeof *key);
    urbsim_event_t *item = malloc(cap * sizeof *item);
    if (key == NULL || item == NULL) {
        free(key);
        free(item);
        return false;
    }
    size_t first = q->cap - q->head < q->len ? q->cap - q->head : q->len; /* entries before the wrap */
    memcpy(key, q->key + q->head, first * sizeof *key);
    memcpy(key + first, q->key, (q->len - first) * sizeof *key);
    memcpy(item, q->item + q->head, first * sizeof *item);
    memcpy(item + first, q->item, (q->len - first) * sizeof *item);
    free(q->key);
    free(q->item);
    q->key = key;
    q->item = item;
    q->cap = cap;
    q->head = 0;
    return true;
}

/* Near queue: insert into the sorted ring. An event due before all others (an interrupt handler
 * right after the bus event that raised it) goes in front in O(1); the others are placed from the
 * back. */
static void ring_push(urbsim_queue_t *q, urbsim_event_key_t key, urbsim_event_t item)
{
    size_t m = q->cap - 1u;
    if (q->len > 0u && before(&key, &q->key[q->head])) {
        q->head = (q->head - 1u) & m;
        q->key[q->head] = key;
        q->item[q->head] = item;
        q->len++;
        return;
    }
    size_t i = q->head + q->len++;
#ifdef URBSIM_MUTANT_RING_TIES /* seeded bug (mk/sim.mk): a new event overtakes its ties */
    while (i > q->head && key.t <= q->key[(i - 1u) & m].t) {
#else
    while (i > q->head && before(&key, &q->key[(i - 1u) & m])) {
#endif
        q->key[i & m] = q->key[(i - 1u) & m];
        q->item[i & m] = q->item[(i - 1u) & m];
        i--;
    }
    q->key[i & m] = key;
    q->item[i & m] = item;
}

static urbsim_event_t ring_pop(urbsim_queue_t *q)
{
    urbsim_event_t top = q->item[q->head];
    q->head = (q->head + 1u) & (q->cap - 1u);
    q->len--;
    return top;
}

/* Far queue: binary heap, whose entries may have an owner handle that follows them around. */
static inline void heap_place(urbsim_queue_t *q, size_t i, urbsim_event_key_t key, urbsim_event_t item,
                              urbsim_handle_t *owner)
{
    q->key[i] = key;
    q->item[i] = item;
    q->owner[i] = owner;
#ifndef URBSIM_MUTANT_CANCEL_SLOT /* seeded bug (mk/sim.mk): a handle loses track of its moved event */
    if (owner != NULL) {
        owner->slot = i;
    }
#endif
}

/* Move an entry from slot i into the hole at slot j. */
static inline void heap_move(urbsim_queue_t *q, size_t j, size_t i)
{
    heap_place(q, j, q->key[i], q->item[i], q->owner[i]);
}

/* Put (key, item) into the hole at slot i, sifting it up towards the root. */
static void heap_sift_up(urbsim_queue_t *q, size_t i, urbsim_event_key_t key, urbsim_event_t item,
                         urbsim_handle_t *owner)
{
    while (i > 0) {
        size_t parent = (i - 1u) / 2u;
        if (!before(&key, &q->key[parent])) {
            break;
        }
        heap_move(q, i, parent);
        i = parent;
    }
    heap_place(q, i, key, item, owner);
}

/* Put (key, item) into the hole at slot i of a heap of n entries, sifting it down. */
static void heap_sift_down(urbsim_queue_t *q, size_t i, size_t n, urbsim_event_key_t key, urbsim_event_t item,
                           urbsim_handle_t *owner)
{
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
    heap_place(q, i, key, item, owner);
}

static void heap_push(urbsim_queue_t *q, urbsim_event_key_t key, urbsim_event_t item, urbsim_handle_t *owner)
{
    heap_sift_up(q, q->len++, key, item, owner);
}

/* Remove the entry at slot i (q->len > i) and restore the heap property with the last entry. */
static urbsim_event_t heap_remove(urbsim_queue_t *q, size_t i)
{
    urbsim_event_t gone = q->item[i];
    if (q->owner[i] != NULL) {
        q->owner[i]->armed = false;
    }
    size_t n = --q->len;
    if (i == n) {
        return gone;
    }
    urbsim_event_key_t last = q->key[n];
    if (i > 0 && before(&last, &q->key[(i - 1u) / 2u])) {
        heap_sift_up(q, i, last, q->item[n], q->owner[n]);
    } else {
        heap_sift_down(q, i, n, last, q->item[n], q->owner[n]);
    }
    return gone;
}

bool urbsim_kernel_init(urbsim_kernel_t *k)
{
    k->now = 0;
    k->next_seq = 0;
    k->executed = 0;
    k->stop = false;
    bool ok = queue_init(&k->near, 64, false);
    ok = queue_init(&k->far, 256, true) && ok;
    if (!ok) {
        urbsim_kernel_free(k);
    }
    k->len = 0;
    k->cap = k->near.cap + k->far.cap;
    return ok;
}

void urbsim_kernel_free(urbsim_kernel_t *k)
{
    queue_free(&k->near);
    queue_free(&k->far);
    k->len = k->cap = 0;
}

void urbsim_handle_init(urbsim_handle_t *h)
{
    h->slot = 0;
    h->armed = false;
}

bool urbsim_kernel_at(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg)
{
    return urbsim_kernel_at_handle(k, t, fn, ctx, arg, NULL);
}

bool urbsim_kernel_at_handle(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg,
                             urbsim_handle_t *h)
{
    if (h != NULL) {
        urbsim_kernel_cancel(k, h); /* a handle holds one event: the one it held is superseded */
    }
    if (t < k->now) {
        t = k->now;
    }
    bool near = t - k->now <= URBSIM_KERNEL_NEAR_NS && k->near.len < URBSIM_KERNEL_NEAR_MAX;
    urbsim_queue_t *q = near ? &k->near : &k->far;
    if (q->len == q->cap) {
        if (!queue_grow(q)) {
            return false;
        }
        k->cap = k->near.cap + k->far.cap;
    }
    urbsim_event_key_t key = {t, k->next_seq++};
    urbsim_event_t item = {fn, ctx, arg};
    if (near) {
        ring_push(q, key, item);
    } else {
        if (h != NULL) {
            h->armed = true;
        }
        heap_push(q, key, item, h);
    }
    k->len++;
    return true;
}

void urbsim_kernel_cancel(urbsim_kernel_t *k, urbsim_handle_t *h)
{
    if (!h->armed) {
        return;
    }
    (void)heap_remove(&k->far, h->slot);
    k->len--;
}

bool urbsim_kernel_after(urbsim_kernel_t *k, urbsim_ns_t delay, urbsim_event_fn fn, void *ctx, uint64_t arg)
{
    return urbsim_kernel_at(k, k->now + delay, fn, ctx, arg);
}

urbsim_ns_t urbsim_kernel_next_time(const urbsim_kernel_t *k)
{
    urbsim_ns_t a = k->near.len ? k->near.key[k->near.head].t : URBSIM_NEVER;
    urbsim_ns_t b = k->far.len ? k->far.key[0].t : URBSIM_NEVER;
    return a < b ? a : b;
}

bool urbsim_kernel_run_until(urbsim_kernel_t *k, urbsim_ns_t limit)
{
    k->stop = false;
    for (;;) {
        bool near;
        if (k->near.len == 0) {
            if (k->far.len == 0) {
                break;
            }
            near = false;
        } else {
#ifdef URBSIM_MUTANT_QUEUE_TIES /* seeded bug (mk/sim.mk): a tie between the queues goes to the near one */
            near = k->far.len == 0 || k->near.key[k->near.head].t <= k->far.key[0].t;
#else
            near = k->far.len == 0 || before(&k->near.key[k->near.head], &k->far.key[0]);
#endif
        }
        urbsim_ns_t t = near ? k->near.key[k->near.head].t : k->far.key[0].t;
        if (t > limit) {
            break;
        }
        urbsim_event_t ev = near ? ring_pop(&k->near) : heap_remove(&k->far, 0);
        k->len--;
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
