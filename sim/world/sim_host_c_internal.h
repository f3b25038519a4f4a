/*
 * sim_host_c_internal.h: what the C host's driver (sim_host_c.c: SimHost's event loop and
 * SimManager's steps over one urb_core_t per bridge) and its applications share; not part of the
 * API (sim_host_c.h). The applications: sim_host_pd.c (the PD and gait axes of control.py and
 * gait.py) and sim_host_plain.c (plain periodic and one-off requests).
 */
#ifndef URBSIM_SIM_HOST_C_INTERNAL_H
#define URBSIM_SIM_HOST_C_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "sim_host_c.h"

#include "urb_host_core.h"

#define CH_MAX_BRIDGES 8
#define CH_MAX_AXES 16
#define CH_MAX_READS 32
#define CH_BLOCK 256         /* transfers allocated at a time (a loop that outruns its link queues without end) */
#define CH_MAX_BLOCKS 4096
#define CH_TIMERS 64         /* armed timers per bridge (SimManager._timer_at) */
#define CH_ITEM_BYTES 1024   /* as World._buf: the largest item a take hands over */
#define CH_ITEMS 256
#define NS_PER_MS 1000000LL

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
    bool read, counter; /* counter: a write's every byte is the period number's low byte */
    uint8_t data[URB_HOST_MAILBOX_MAX]; /* a write's payload */
    uint32_t every, first; /* due at periods first, first + every, ... */
} ch_read_t;

typedef struct {
    uint32_t what, flags;
    int64_t submitted, done;
    int8_t status;   /* the bridge's status byte, -1: no response reached the host */
    uint8_t len;     /* an OK read's data: data[0 .. len - 1] */
    uint8_t data[URB_HOST_MAILBOX_MAX];
} ch_rec_t;

typedef struct {
    uint32_t rec; /* the request record the callback was for */
    uint64_t t_v; /* the virtual instant it ran at */
} ch_callback_t;

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
    ch_callback_t *cb; /* every dispatch, in order: the application's callbacks */
    uint32_t n_cb, cap_cb;
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

/* ---------------------------------------------------------------- the driver, for the applications */

/** Make room for `need` elements of `size` bytes in *p (capacity *cap), doubling; false: out of memory. */
bool chost_grow(void **p, uint32_t *cap, uint32_t need, size_t size);
/** A free transfer (counted in errors and NULL when none is left). */
xfer_t *chost_xfer_get(urbsim_chost_t *h);
/** Give transfer `x` back to the pool. */
void chost_xfer_put(urbsim_chost_t *h, xfer_t *x);
/** SimManager.submit: record `x` (its transfer filled in, its axis set), give it to bridge `b`'s core,
 *  then run the manager's step; a refusal counts in errors and frees `x`. */
void chost_submit(urbsim_chost_t *h, xfer_t *x, int b);

/* ---------------------------------------------------------------- the applications, for the driver */

/** One loop period of the PD and gait axes: sample every PD axis's truth, then submit every axis's
 *  feedback read; false when the driver failed (counted in errors). */
bool chost_pd_tick(urbsim_chost_t *h);
/** The completion of a feedback read of axis x->axis (control.py's and gait.py's callbacks). */
void chost_pd_done(urbsim_chost_t *h, xfer_t *x);
/** Free the axes' arrays. */
void chost_pd_free(urbsim_chost_t *h);
/** One loop period of the plain requests: submit those due, in the order they were added. */
void chost_plain_tick(urbsim_chost_t *h);

#endif /* URBSIM_SIM_HOST_C_INTERNAL_H */
