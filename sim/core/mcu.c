/* mcu.c: interrupt serialisation and main-loop occupancy of a simulated MCU. See mcu.h. */
#include "mcu.h"

#include <string.h>

void urbsim_mcu_init(urbsim_mcu_t *m, const urbsim_clock_cfg_t *cfg, const urbsim_rng_t *rng)
{
    urbsim_clock_init(&m->clk, cfg, rng);
    m->isr_free_at = 0;
    m->thread_from = m->thread_until = 0;
    memset(m->win, 0, sizeof m->win);
    m->win_next = 0;
    m->irqs = 0;
    m->isr_ns = 0;
    m->masked = 0;
}

void urbsim_mcu_reset(urbsim_mcu_t *m, urbsim_ns_t now)
{
    urbsim_clock_reset(&m->clk, now);
    m->isr_free_at = now;
    m->thread_from = m->thread_until = now;
    memset(m->win, 0, sizeof m->win); /* empty windows [0, 0) contain no instant */
}

/* When the handler of an interrupt raised at t_irq starts, with entry latency `lat`, on a core in its
 * idle path: neither a handler nor main-loop work is in progress at t_irq. The main loop ran
 * idle_cycles after the latest of them ended, then masks interrupts (PRIMASK) for mask_cycles: an
 * interrupt raised there is taken when the section ends (WFI returns at once with one pending);
 * after it the core sleeps in WFI and first wakes up. */
static urbsim_ns_t idle_start(urbsim_mcu_t *m, urbsim_ns_t t_irq, urbsim_ns_t lat)
{
    const urbsim_clock_cfg_t *cfg = &m->clk.cfg;
    urbsim_ns_t last = m->isr_free_at > m->thread_until ? m->isr_free_at : m->thread_until;
    urbsim_ns_t masked_from = last + urbsim_clock_cycles_ns(&m->clk, last, cfg->idle_cycles);
    urbsim_ns_t masked_until = masked_from + urbsim_clock_cycles_ns(&m->clk, masked_from, cfg->mask_cycles);
    if (t_irq < masked_from) {
        return t_irq + lat;
    }
    if (t_irq < masked_until) {
        m->masked++;
#ifdef URBSIM_MUTANT_MASK_IGNORED /* seeded bug (mk/sim.mk): PRIMASK does not hold the interrupt back */
        return t_irq + lat;
#else
        return masked_until + lat;
#endif
    }
    return t_irq + urbsim_clock_cycles_ns(&m->clk, t_irq, cfg->wfi_wake_cycles) + lat;
}

urbsim_ns_t urbsim_mcu_isr(urbsim_mcu_t *m, urbsim_ns_t t_irq, double cycles, urbsim_ns_t *end)
{
    urbsim_ns_t lat = urbsim_clock_irq_latency(&m->clk, t_irq);
    urbsim_ns_t start = t_irq + lat;
    const urbsim_clock_cfg_t *cfg = &m->clk.cfg;
    bool idle_path = cfg->idle_cycles > 0.0 || cfg->mask_cycles > 0.0 || cfg->wfi_wake_cycles > 0.0;
    if (idle_path && t_irq >= m->isr_free_at && !(t_irq >= m->thread_from && t_irq < m->thread_until)) {
        start = idle_start(m, t_irq, lat);
    }
    if (start < m->isr_free_at) {
        start = m->isr_free_at; /* tail-chained behind the handler still running */
    }
    urbsim_ns_t dur = urbsim_clock_cycles_ns(&m->clk, start, cycles);
    m->isr_free_at = start + dur;
    m->irqs++;
    m->isr_ns += dur;
    if (start >= m->thread_from && start < m->thread_until) {
        m->thread_until += dur; /* the handler preempted the main loop */
    }
    m->win[m->win_next].start = start;
    m->win[m->win_next].end = start + dur;
    m->win_next = (m->win_next + 1u) % URBSIM_MCU_WINDOWS;
    *end = start + dur;
    return start;
}

/* Handlers are reserved in order and never overlap (each starts no earlier than the previous one
 * returned), so the windows in the ring are sorted, oldest at win_next. */
urbsim_ns_t urbsim_mcu_thread_free(const urbsim_mcu_t *m, urbsim_ns_t now)
{
#ifdef URBSIM_MUTANT_THREAD_OVER_ISR /* seeded bug (mk/sim.mk): the main loop runs over a handler */
    (void)m;
    return now;
#else
    if (now >= m->isr_free_at) {
        return now; /* every reserved handler has returned: the common case */
    }
    urbsim_ns_t t = now;
    for (uint32_t i = 0; i < URBSIM_MCU_WINDOWS; i++) {
        const urbsim_mcu_window_t *w = &m->win[(m->win_next + i) % URBSIM_MCU_WINDOWS];
        if (w->start <= t && t < w->end) {
            t = w->end; /* and on through the handlers chained behind it */
        }
    }
    return t;
#endif
}

urbsim_ns_t urbsim_mcu_thread_busy(urbsim_mcu_t *m, urbsim_ns_t now, urbsim_ns_t dur)
{
    urbsim_ns_t until = now + dur;
#ifndef URBSIM_MUTANT_THREAD_OVER_ISR
    /* The windows are sorted: when the newest started before `now`, none starts inside the work
     * (the common case, on every main-loop iteration). */
    if (m->win[(m->win_next + URBSIM_MCU_WINDOWS - 1u) % URBSIM_MCU_WINDOWS].start >= now) {
        for (uint32_t i = 0; i < URBSIM_MCU_WINDOWS; i++) {
            const urbsim_mcu_window_t *w = &m->win[(m->win_next + i) % URBSIM_MCU_WINDOWS];
            if (w->start >= now && w->start < until) {
                until += w->end - w->start; /* reserved before this work began, runs inside it */
            }
        }
    }
#endif
    m->thread_from = now;
    m->thread_until = until;
    return until;
}
