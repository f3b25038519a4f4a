/*
 * clock.h: the local clock of one simulated device (node, bridge, host CPU, USB host controller).
 *
 * CLOCK MODEL (documented for users in sim/README.md; the Table I comparison is only meaningful
 * under it):
 *
 *   local time runs at rate 1 + e(t) against virtual (true) time, where
 *     e(t) = ppm0 * 1e-6                       static crystal error, drawn per device and seed
 *          + ramp * 1e-6 * t[s]                slow deterministic drift (warm-up), ppm/s, with t
 *                                              counted from the last power-on (urbsim_clock_reset)
 *          + w(t)                              slow random wander: an Ornstein-Uhlenbeck process
 *                                              with stationary sd `wander_ppm` and time constant
 *                                              `wander_tau_s`, sampled every `segment_ns`
 *   e(t) is held constant over segments of `segment_ns` (piecewise-linear local time), which makes
 *   conversions exact and invertible in both directions.
 *
 *   The device's timer counts ticks of timer_hz (its resolution, e.g. 48 MHz for a Cortex-M0+
 *   running its timer from the core clock). A timer compare at tick C fires at the first virtual
 *   instant where the counter has reached C. The interrupt then takes irq_base_cycles plus a
 *   uniform 0..irq_jitter_cycles extra cycles of the cpu_hz core clock (exception entry, and the
 *   instruction being completed when the interrupt arrived) before the handler's first line runs.
 *
 * The clock starts at local time 0 when the device is powered (urbsim_clock_reset). Segments are
 * generated lazily, in order, from the device's own random stream, so they do not depend on when
 * or how often the clock is queried. A ring keeps the most recent URBSIM_CLOCK_SEGMENTS segments;
 * queries older than that (more than segments * segment_ns in the past) are clamped to the oldest.
 */
#ifndef URBSIM_CLOCK_H
#define URBSIM_CLOCK_H

#include "kernel.h"
#include "rng.h"

#define URBSIM_CLOCK_SEGMENTS 64u

typedef struct {
    double cpu_hz;          /**< core clock: interrupt latency is counted in its cycles */
    double timer_hz;        /**< timer tick rate: the timer's resolution is 1 / timer_hz */
    double ppm0;            /**< static frequency error in ppm (positive: the clock runs fast) */
    double ramp_ppm_per_s;  /**< deterministic drift of the error, ppm per second */
    double wander_ppm;      /**< stationary sd of the random wander, ppm */
    double wander_tau_s;    /**< time constant of the wander, seconds */
    uint32_t irq_base_cycles;   /**< fixed interrupt entry latency, core cycles */
    uint32_t irq_jitter_cycles; /**< extra latency, uniform in 0..this, core cycles */
    urbsim_ns_t segment_ns; /**< rate update period (0 means 100 ms) */
    /* The core's idle path (mcu.h): after a handler returns or main-loop work ends the main loop
     * runs idle_cycles, then a PRIMASK section of mask_cycles (interrupts raised in it start at its
     * end), then sleeps in WFI (an interrupt first takes wfi_wake_cycles). All 0: the core is
     * always ready, the model before hardware profiles. */
    double idle_cycles;
    double mask_cycles;
    double wfi_wake_cycles;
} urbsim_clock_cfg_t;

typedef struct {
    urbsim_ns_t t0;     /**< virtual start time of the segment */
    double local0;      /**< local time (ns) at t0 */
    double rate;        /**< local ns per virtual ns in the segment: 1 + e */
    double ns_per_cycle;/**< virtual ns per core cycle in the segment (cached: 1e9 / cpu_hz / rate) */
} urbsim_clock_seg_t;

typedef struct {
    /* What every interrupt reads, first and together: the newest segment, where nearly every
     * query falls, with its virtual span [cur_t0, cur_t1), kept by grow() and reset() so the
     * common lookup is two comparisons. */
    urbsim_ns_t origin;      /**< virtual time of the last reset (power-on) */
    urbsim_ns_t cur_t0, cur_t1;
    uint32_t cur;            /**< ring index of the newest segment */
    urbsim_rng_t jitter;     /**< interrupt-latency draws: a separate stream so the wander
                                  never depends on how many interrupts happened */
    urbsim_clock_cfg_t cfg;
    urbsim_rng_t rng;        /**< wander draws (one per segment, in order) */
    double wander;           /**< current OU state (fraction, not ppm) */
    uint32_t first;          /**< ring index of the oldest segment kept */
    uint32_t count;          /**< segments in the ring */
    uint64_t generated;      /**< segments generated since reset (numbering for the ramp) */
    urbsim_clock_seg_t seg[URBSIM_CLOCK_SEGMENTS];
} urbsim_clock_t;

/** Default configuration: a 48 MHz Cortex-M0+ with its timer on the core clock, no error. */
urbsim_clock_cfg_t urbsim_clock_default_cfg(void);

/** Set up a clock; `rng` is the device's own stream (copied). Starts at local 0 at virtual 0. */
void urbsim_clock_init(urbsim_clock_t *c, const urbsim_clock_cfg_t *cfg, const urbsim_rng_t *rng);

/** Power-on at virtual time `now`: local time restarts at 0. The wander state is kept (it is a
 *  property of the crystal and its temperature, not of the firmware). */
void urbsim_clock_reset(urbsim_clock_t *c, urbsim_ns_t now);

/** Local time in ns (not rounded) at virtual time t (t >= the last reset). */
double urbsim_clock_local_ns(urbsim_clock_t *c, urbsim_ns_t t);

/** Earliest virtual time at which local time is >= local_ns (rounded up to whole ns). */
urbsim_ns_t urbsim_clock_virtual_at(urbsim_clock_t *c, double local_ns);

/** The timer counter at virtual time t: floor(local seconds * timer_hz), 64 bits wide. */
uint64_t urbsim_clock_ticks(urbsim_clock_t *c, urbsim_ns_t t);

/** Earliest virtual time at which the timer counter has reached `ticks`. */
urbsim_ns_t urbsim_clock_virtual_at_tick(urbsim_clock_t *c, uint64_t ticks);

/** Draw one interrupt latency in virtual ns (base + uniform jitter cycles of the core clock, at
 *  the clock's current rate near virtual time t). */
urbsim_ns_t urbsim_clock_irq_latency(urbsim_clock_t *c, urbsim_ns_t t);

/** Virtual duration of `cycles` core cycles near virtual time t (rounded to nearest ns). */
urbsim_ns_t urbsim_clock_cycles_ns(urbsim_clock_t *c, urbsim_ns_t t, double cycles);

/** The clock's current frequency error e(t) in ppm (for traces and reports). */
double urbsim_clock_error_ppm(urbsim_clock_t *c, urbsim_ns_t t);

#endif /* URBSIM_CLOCK_H */
