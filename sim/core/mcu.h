/*
 * mcu.h: timing of one simulated microcontroller (a node or a bridge): its clock, its interrupts
 * and its main loop.
 *
 * Interrupts share one priority level (the node library and the bridge require it): an interrupt
 * raised at t_irq starts after the entry latency (clock.h) and not before the previous handler
 * has returned (tail-chaining), then runs for its handler time. The firmware's C code runs in zero
 * host time; its cost in virtual time is this handler time, given per interrupt source in core
 * cycles.
 *
 * The main loop (thread level) runs at an instant and is then busy for its cost; interrupts that
 * land inside a busy window lengthen it by their handler time (they preempt it), whether they were
 * raised before the main loop's work began or during it. The main loop cannot begin work while a
 * handler runs: an iteration due then waits for the handler (and any tail-chained to it) to return. *
 * IDLE PATH (hardware profiles; clock.h idle_cycles, mask_cycles, wfi_wake_cycles, all 0 by
 * default): when neither a handler nor main-loop work is in progress, the core runs the main loop's
 * last pass (idle_cycles after the latest ended), then the sleep idiom's PRIMASK section (cpsid i;
 * check for work; wfi; cpsie i: mask_cycles), then sleeps. An interrupt raised inside the section
 * starts at its end plus the entry latency; one raised while the core sleeps first wakes it
 * (wfi_wake_cycles).
 */
#ifndef URBSIM_MCU_H
#define URBSIM_MCU_H

#include "clock.h"

/** Handlers remembered for the main loop's questions (urbsim_mcu_thread_free, _thread_busy): more
 *  than are ever raised within one entry latency of each other. */
#define URBSIM_MCU_WINDOWS 8u

/** One reserved handler: it runs in [start, end). */
typedef struct {
    urbsim_ns_t start;
    urbsim_ns_t end;
} urbsim_mcu_window_t;

typedef struct {
    urbsim_clock_t clk;
    urbsim_ns_t isr_free_at;     /**< the running handler returns here */
    urbsim_ns_t thread_from;     /**< main-loop work in progress: [thread_from, thread_until) */
    urbsim_ns_t thread_until;
    urbsim_mcu_window_t win[URBSIM_MCU_WINDOWS]; /**< the latest handlers, oldest at win[win_next] */
    uint32_t win_next;
    uint64_t irqs;               /**< interrupts taken */
    urbsim_ns_t isr_ns;          /**< total handler time (CPU load) */
    uint64_t masked;             /**< interrupts raised inside the idle path's PRIMASK section */
} urbsim_mcu_t;

/** Set up with a clock configuration and the device's random stream. */
void urbsim_mcu_init(urbsim_mcu_t *m, const urbsim_clock_cfg_t *cfg, const urbsim_rng_t *rng);

/**
 * Reserve the handler of an interrupt raised at t_irq that runs `cycles` core cycles. Returns the
 * instant the handler starts (its first line runs, what the firmware's now() sees) and stores in
 * *end when it returns. A main-loop busy window that contains the handler is lengthened by it.
 */
urbsim_ns_t urbsim_mcu_isr(urbsim_mcu_t *m, urbsim_ns_t t_irq, double cycles, urbsim_ns_t *end);

/** The earliest instant at or after `now` at which the main loop can run: `now`, unless a reserved
 *  handler has started by `now` and not returned; then the return of the last handler chained to it. */
urbsim_ns_t urbsim_mcu_thread_free(const urbsim_mcu_t *m, urbsim_ns_t now);

/** The main loop works from `now` for `dur`: it is busy until now + dur, lengthened by every
 *  handler already reserved to start in that window (urbsim_mcu_isr lengthens it for later ones).
 *  Returns the end of the busy window. */
urbsim_ns_t urbsim_mcu_thread_busy(urbsim_mcu_t *m, urbsim_ns_t now, urbsim_ns_t dur);

/** Power-on reset at `now`: clock restarts at 0, no handler or main-loop work in progress. */
void urbsim_mcu_reset(urbsim_mcu_t *m, urbsim_ns_t now);

#endif /* URBSIM_MCU_H */
