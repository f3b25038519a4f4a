/*
 * sim_host_c.h: the C host library (host/c/core, unchanged) driving a simulated world's bridges on
 * its simulated host CPU, with no Python in the loop (issue #38).
 *
 * It is the thin port of the sans-IO core: one urb_core_t per bridge, fed the uplink byte streams
 * and USB batches that the Python SimHost reads (urbsim_run_take), its frames written with
 * urbsim_host_send, its timers and the application's periodic thread woken by the simulated OS
 * tick (urbsim_host_timer), all in the host CPU's clock (urbsim_host_local). The scheduling is
 * SimManager's (host/urb/managers/sim.py) and SimHost's (sim/urb_sim/host.py) step for step: the
 * same instants, the same order, one timer per bridge at its earliest deadline, a USB frame tick
 * while the core is busy, callbacks never nested. So a run handed over from the Python host library
 * (urbsim_chost_bridge with its sequence position) is the run the Python library would have made.
 *
 * The application on top: the SensoRHex PD loop of sim/urb_sim/experiments/control.py (_control):
 * each period the thread samples every axis's true shaft angle, then submits a MotorFeedback read
 * per axis; the read's completion unwraps the encoder, computes u = Kp e + Kd de/dt (clamped,
 * de/dt over the reads' submission instants) against A sin(omega t) and submits the MotorCommand
 * write. Periodic plain reads (the 100-Hz sensors) can run beside it. Every request completes
 * exactly once through the core; the driver records each one's outcome.
 *
 * Every function returns a negative value (or NULL) on a bad argument; nothing aborts.
 */
#ifndef URBSIM_SIM_HOST_C_H
#define URBSIM_SIM_HOST_C_H

#include <stdint.h>

#include "urbsim.h"

typedef struct urbsim_chost urbsim_chost_t;

/** A C host for started world `w` (driving none of its bridges yet); NULL when w is NULL or not started. */
urbsim_chost_t *urbsim_chost_new(urbsim_world_t *w);
/** Free it (the world stays). */
void urbsim_chost_free(urbsim_chost_t *h);
/** Drive `bridge` (usb: its uplink is USB) with a core of `window` requests in flight whose next
 *  request carries sequence number `next_seq` (0..15) and, on USB, whose next OUT transfer carries
 *  frame counter `frame` (1..65535): the position of the Python core it takes over. 0, or -1 (also
 *  for a bridge the world does not have, or one already driven). */
int urbsim_chost_bridge(urbsim_chost_t *h, int bridge, int usb, int window, int next_seq, int frame);
/** An event the taken-over host had pending for `bridge` at virtual time `t_v` (>= now): a USB frame
 *  tick (frame != 0: SimManager._frame_tick while _ticking) or the timer armed for host time
 *  `deadline_ns` (SimManager._timer_at). Give them in the Python host's order (its heap sorted):
 *  events at one instant run in the order given. 0, or -1. */
int urbsim_chost_pending(urbsim_chost_t *h, int bridge, int frame, int64_t deadline_ns, uint64_t t_v);
/** A PD axis: the motor driver at `address` on `bridge`, its plant node `node`, gains kp (V/rad),
 *  kd (V s/rad), output limit (V); reference amp sin(omega t) with the true angle sampled every
 *  period (control.py) when leg < 0, else gait.py's leg_reference for `leg` (0..5) with a row logged
 *  per feedback (urbsim_chost_log). Returns its index, or -1. */
int urbsim_chost_axis(urbsim_chost_t *h, int bridge, int node, int address, double kp, double kd, double limit,
                      double amp, double omega, int leg);
/** A plain read of `length` bytes of outbox `mailbox` at `address` on `bridge`, at every `every`-th
 *  loop period (the every-th, the 2 every-th, ...; after the axes' reads). Returns its index, or -1. */
int urbsim_chost_read(urbsim_chost_t *h, int bridge, int address, int mailbox, int length, int every);
/** A plain write of data[0 .. length - 1] to inbox `mailbox` at `address` on `bridge`, at every
 *  `every`-th period; data NULL makes it urbsim_chost_read. Plain requests go out in the order they
 *  were added. Returns its index, or -1. */
int urbsim_chost_write(urbsim_chost_t *h, int bridge, int address, int mailbox, const uint8_t *data, int length,
                       int every);
/** Submit one request now, outside the loop (a write of data[0 .. length - 1], or a read of `length`
 *  bytes when data is NULL), as the application's set-up does. 0, or -1. */
int urbsim_chost_submit(urbsim_chost_t *h, int bridge, int address, int mailbox, const uint8_t *data, int length);
/** Start the application's thread: `count` periods of `period_ns` (host clock), the first at the
 *  next multiple of period_ns; `t0_ns` is the reference's time zero (host clock). 0, or -1. */
int urbsim_chost_loop(urbsim_chost_t *h, int64_t period_ns, uint32_t count, int64_t t0_ns);
/** Run the world and the host up to virtual time `t_v`. 0; -1 on a bad call or when the driver
 *  failed (out of memory, a pool exhausted, a core refusing a valid request: urbsim_chost_stat
 *  "errors" > 0). */
int urbsim_chost_advance_to(urbsim_chost_t *h, uint64_t t_v);
/** Copy samples [from, from + cap) of axis `axis`: t (host clock - t0), true shaft angle, reference.
 *  Returns how many were copied (-1 bad call). */
int urbsim_chost_samples(urbsim_chost_t *h, int axis, uint32_t from, int64_t *t, double *pos, double *ref, uint32_t cap);
/** Copy the commands (mV, in the order computed) [from, from + cap) of `axis`. */
int urbsim_chost_commands(urbsim_chost_t *h, int axis, uint32_t from, int32_t *mv, uint32_t cap);
/** Copy rows [from, from + cap) of gait axis `axis`'s log, 6 doubles each: t (s since t0), reference,
 *  true shaft angle, measured voltage (V), measured current (A), true current (A). */
int urbsim_chost_log(urbsim_chost_t *h, int axis, uint32_t from, double *rows, uint32_t cap);
/** Copy the request records [from, from + cap) in submission order: what (bridge << 24 | address
 *  << 16 | mailbox << 8 | read), submitted_ns, completed_ns (URB_NO_TIME: never
 *  dispatched), flags. */
int urbsim_chost_requests(urbsim_chost_t *h, uint32_t from, uint32_t *what, int64_t *submitted, int64_t *done,
                          uint32_t *flags, uint32_t cap);
/** A counter: "submitted", "completed", "duplicates" (completions of a request already complete),
 *  "errors", "wakeups", "timer_runs", "loop_runs", "fails:<axis>", "plain_fails"; NaN when unknown. */
double urbsim_chost_stat(urbsim_chost_t *h, const char *name);

#endif /* URBSIM_SIM_HOST_C_H */
