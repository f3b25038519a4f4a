/*
 * kernel.h: the discrete-event kernel of the URB simulation.
 *
 * Virtual time is a uint64_t count of nanoseconds since the start of the run (584 years of range).
 * Events are (time, callback, context, argument) records kept in a priority queue ordered by time,
 * with ties broken by insertion order: two events scheduled for the same instant run in the order
 * they were scheduled. Nothing else (pointer values, hash order, wall-clock time) influences the
 * order, so a run is a pure function of its inputs and seed.
 *
 * State lives in a caller-owned urbsim_kernel_t; there are no globals, so any number of kernels
 * (simulated worlds) can live in one process. The queue arrays grow on the heap (the simulation is
 * host code; only the firmware under test is heap-free).
 *
 * A component that may change its mind (a timer compare moved by the PLL, a main-loop iteration
 * brought forward) schedules its events with a generation number in `arg` and ignores stale ones.
 * Stale events far in the future would pile up in the heap and be sifted through on every
 * operation, so such an event can be scheduled with a handle (urbsim_kernel_at_handle) and
 * withdrawn once it is known stale (urbsim_kernel_cancel). Cancelling only ever removes an event
 * that would have run as a no-op, so it changes no run order: every remaining event keeps its time
 * and its place among ties.
 */
#ifndef URBSIM_KERNEL_H
#define URBSIM_KERNEL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/** Virtual time in nanoseconds. */
typedef uint64_t urbsim_ns_t;

#define URBSIM_NS_PER_US 1000ull
#define URBSIM_NS_PER_MS 1000000ull
#define URBSIM_NS_PER_S 1000000000ull
#define URBSIM_NEVER UINT64_MAX

/** An event callback. `now` equals the event's time; `arg` is what was passed to schedule. */
typedef void (*urbsim_event_fn)(void *ctx, uint64_t arg, urbsim_ns_t now);

/** Ordering key of a pending event: time, then insertion sequence (unique, so the order is total). */
typedef struct {
    urbsim_ns_t t;   /**< when the event fires */
    uint64_t seq;    /**< insertion sequence number: the tie-breaker */
} urbsim_event_key_t;

/** A handle on a scheduled event, owned by the component that scheduled it: while the event waits
 *  in the far queue the kernel keeps `slot` (its heap index) up to date so it can be cancelled. */
typedef struct {
    size_t slot;     /**< index in the far queue while `armed` */
    bool armed;      /**< the event waits in the far queue and can be cancelled */
} urbsim_handle_t;

/** What a pending event runs. */
typedef struct {
    urbsim_event_fn fn;
    void *ctx;
    uint64_t arg;
} urbsim_event_t;

/** The far queue: a binary min-heap (key[0] is the earliest) with keys and payloads in parallel
 *  arrays, so that the sifting loops read only the 16-byte keys and touch a payload only when
 *  they move it. */
typedef struct {
    urbsim_event_key_t *key;
    urbsim_event_t *item;
    urbsim_handle_t **owner; /**< the handle of each entry, or NULL */
    size_t len;
    size_t cap;
} urbsim_heap_t;

/** A near-queue entry: key and payload side by side, because the ring moves them together. */
typedef struct {
    urbsim_event_key_t key;
    urbsim_event_t item;
} urbsim_near_entry_t;

/** Events scheduled at most this far ahead go to the near queue while it holds fewer than
 *  URBSIM_KERNEL_NEAR_MAX (speed knobs: any values give the same run). The cap bounds the sorted
 *  insertion when many interrupts are raised at once (a general call to 20 nodes); the overflow
 *  goes to the heap. It is also the size of the ring, so it must be a power of two. */
#define URBSIM_KERNEL_NEAR_NS (60u * URBSIM_NS_PER_US)
#define URBSIM_KERNEL_NEAR_MAX 32u

/*
 * Two queues: events due within URBSIM_KERNEL_NEAR_NS of the time they are scheduled (bus bytes,
 * interrupt handlers, most main-loop polls: the bulk of the traffic) and the rest (timer compares,
 * USB frames, OS ticks, the stale events of replaced timers). The next event is the earlier of the
 * two heads, so the split changes nothing about the order. The near queue holds a handful of
 * entries (about 6 in the SensoRHex scenario), so a sorted ring of fixed size inside the kernel
 * takes a new one in a few comparisons and gives the earliest back in one; the ~50 long-term
 * entries stay out of their way in the heap.
 */
typedef struct {
    urbsim_near_entry_t near[URBSIM_KERNEL_NEAR_MAX]; /**< sorted ring; near[near_head] is the earliest */
    uint32_t near_head;
    uint32_t near_len;
    urbsim_ns_t near_last; /**< time of the ring's last entry; at most `now` when the ring is empty */
    urbsim_heap_t far;
    urbsim_ns_t now;      /**< time of the event being run, or the last run_until limit */
    uint64_t next_seq;
    uint64_t executed;    /**< events run so far (for the speed benchmark) */
    bool stop;            /**< set by urbsim_kernel_stop() from inside a callback */
} urbsim_kernel_t;

/** Initialise an empty kernel at time 0. Returns false when the initial allocation fails. */
bool urbsim_kernel_init(urbsim_kernel_t *k);

/** Free the queues. The kernel may be initialised again afterwards. */
void urbsim_kernel_free(urbsim_kernel_t *k);

/**
 * Schedule fn(ctx, arg, t) at virtual time t. A time in the past (t < now) is clamped to now: an
 * event can never run before the one that scheduled it. Returns false only when the queue cannot
 * grow (out of memory); the event is then not scheduled. O(log n) for far events, O(near queue
 * length) for near ones, O(1) for a near event due after all others.
 */
bool urbsim_kernel_at(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg);

/**
 * urbsim_kernel_at, keeping `h` (owned by the caller, cleared with urbsim_handle_init) as a handle
 * on the event so that urbsim_kernel_cancel can withdraw it. A handle holds one event: the event it
 * held, if still in the far queue, is withdrawn first (the caller knows it is superseded).
 */
bool urbsim_kernel_at_handle(urbsim_kernel_t *k, urbsim_ns_t t, urbsim_event_fn fn, void *ctx, uint64_t arg,
                             urbsim_handle_t *h);

/** Withdraw the event scheduled with `h` if it still waits in the far queue; the caller must know it
 *  is stale (its generation was superseded), because an event in the near queue cannot be withdrawn
 *  and will still run. O(log n). */
void urbsim_kernel_cancel(urbsim_kernel_t *k, urbsim_handle_t *h);

/** A handle that holds no event. */
void urbsim_handle_init(urbsim_handle_t *h);

/** Schedule relative to now: urbsim_kernel_at(k, now + delay, ...). */
bool urbsim_kernel_after(urbsim_kernel_t *k, urbsim_ns_t delay, urbsim_event_fn fn, void *ctx, uint64_t arg);

/** Events pending (both queues). */
size_t urbsim_kernel_pending(const urbsim_kernel_t *k);

/** Events the queues hold before the far queue must grow (both queues). */
size_t urbsim_kernel_capacity(const urbsim_kernel_t *k);

/** Time of the earliest pending event, or URBSIM_NEVER when none is pending. O(1). */
urbsim_ns_t urbsim_kernel_next_time(const urbsim_kernel_t *k);

/**
 * Run every event with time <= limit, in (time, sequence) order, then set now = limit. Returns
 * early, with now at the stopping event's time, when a callback calls urbsim_kernel_stop(); the
 * return value is then true. Events scheduled by callbacks for times <= limit run in the same call.
 */
bool urbsim_kernel_run_until(urbsim_kernel_t *k, urbsim_ns_t limit);

/** Ask run_until to return after the current callback (used for host wake-ups). */
void urbsim_kernel_stop(urbsim_kernel_t *k);

#endif /* URBSIM_KERNEL_H */
