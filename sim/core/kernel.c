/* kernel.c: binary min-heap of events keyed by (time, insertion sequence). See kernel.h. */
#include "kernel.h"

#include <stdlib.h>


/* True when a must run before b. Sequence numbers are unique, so this is a strict total order and
 * the run order never depends on the heap's internal layout. */
static bool before(const urbsim_event_t *a, const urbsim_event_t *b)
{
    return a->t < b->t || (a->t == b->t && a->seq < b->seq);
}

bool urbsim_kernel_init(urbsim_kernel_t *k)
{
    k->len = 0;
    k->cap = 256;
    k->now = 0;
    k->next_seq = 0;
    k->executed = 0;
    k->stop = false;
    k->heap = malloc(k->cap * sizeof *k->heap);
    return k->heap != NULL;
}

void urbsim_kernel_free(urbsim_kernel_t *k)
{

    free(k->heap);
    k->heap = NULL;
    k->len = k->cap = 0;
}

bool urbsim_kernel_at(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg)
{
    if (k->len == k->cap) {
        size_t cap = k->cap * 2u;
        urbsim_event_t *grown = realloc(k->heap, cap * sizeof *grown);
        if (grown == NULL) {
            return false;
        }
        k->heap = grown;
        k->cap = cap;
    }
    urbsim_event_t ev = {t < k->now ? k->now : t, k->next_seq++, fn, ctx, arg};
    /* Sift up: move parents down until ev's slot is found (one write per level). */
    size_t i = k->len++;
    while (i > 0) {
        size_t parent = (i - 1u) / 2u;
        if (!before(&ev, &k->heap[parent])) {
            break;
        }
        k->heap[i] = k->heap[parent];
        i = parent;
    }
    k->heap[i] = ev;
    return true;
}

bool urbsim_kernel_after(urbsim_kernel_t *k, urbsim_ns_t delay, urbsim_event_fn fn, void *ctx, uint64_t arg)
{
    return urbsim_kernel_at(k, k->now + delay, fn, ctx, arg);
}

urbsim_ns_t urbsim_kernel_next_time(const urbsim_kernel_t *k)
{
    return k->len ? k->heap[0].t : URBSIM_NEVER;
}

/* Remove the root and restore the heap property (sift the last element down). */
static urbsim_event_t pop(urbsim_kernel_t *k)
{
    urbsim_event_t top = k->heap[0];
    urbsim_event_t last = k->heap[--k->len];
    size_t n = k->len;
    size_t i = 0;
    for (;;) {
        size_t c = 2u * i + 1u;
        if (c >= n) {
            break;
        }
        if (c + 1u < n && before(&k->heap[c + 1u], &k->heap[c])) {
            c++;
        }
        if (!before(&k->heap[c], &last)) {
            break;
        }
        k->heap[i] = k->heap[c];
        i = c;
    }
    if (n > 0) {
        k->heap[i] = last;
    }
    return top;
}

bool urbsim_kernel_run_until(urbsim_kernel_t *k, urbsim_ns_t limit)
{
    k->stop = false;
    while (k->len && k->heap[0].t <= limit) {
        urbsim_event_t ev = pop(k);
        k->now = ev.t;
        k->executed++;
        ev.fn(ev.ctx, ev.arg, ev.t);
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
