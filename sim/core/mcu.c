/* mcu.c: interrupt serialisation and main-loop occupancy of a simulated MCU. See mcu.h. */
#include "mcu.h"

void urbsim_mcu_init(urbsim_mcu_t *m, const urbsim_clock_cfg_t *cfg, const urbsim_rng_t *rng)
{
    urbsim_clock_init(&m->clk, cfg, rng);
    m->isr_free_at = 0;
    m->thread_from = m->thread_until = 0;
    m->irqs = 0;
    m->isr_ns = 0;
}

void urbsim_mcu_reset(urbsim_mcu_t *m, urbsim_ns_t now)
{
    urbsim_clock_reset(&m->clk, now);
    m->isr_free_at = now;
    m->thread_from = m->thread_until = now;
}

urbsim_ns_t urbsim_mcu_isr(urbsim_mcu_t *m, urbsim_ns_t t_irq, double cycles, urbsim_ns_t *end)
{
    urbsim_ns_t start = t_irq + urbsim_clock_irq_latency(&m->clk, t_irq);
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
    *end = start + dur;
    return start;
}
