/* clock.c: piecewise-linear local clocks with crystal error, drift and wander. See clock.h. */
#include "clock.h"

#include <math.h>

urbsim_clock_cfg_t urbsim_clock_default_cfg(void)
{
    urbsim_clock_cfg_t cfg = {
        .cpu_hz = 48e6,
        .timer_hz = 48e6,
        .ppm0 = 0.0,
        .ramp_ppm_per_s = 0.0,
        .wander_ppm = 0.0,
        .wander_tau_s = 10.0,
        .irq_base_cycles = 15, /* Cortex-M0+ exception entry, zero wait states */
        .irq_jitter_cycles = 0,
        .segment_ns = 100 * URBSIM_NS_PER_MS,
        .idle_cycles = 0.0,
        .mask_cycles = 0.0,
        .wfi_wake_cycles = 0.0,
    };
    return cfg;
}

static urbsim_ns_t seg_len(const urbsim_clock_t *c)
{
    return c->cfg.segment_ns ? c->cfg.segment_ns : 100 * URBSIM_NS_PER_MS;
}

/* Rate of segment number n (counted from the last reset): the sum of the three error terms. The
 * OU wander advances one step per generated segment, from this clock's own stream. */
static double next_rate(urbsim_clock_t *c, uint64_t n)
{
    double len_s = (double)seg_len(c) * 1e-9;
    if (c->cfg.wander_ppm > 0.0 && c->cfg.wander_tau_s > 0.0) {
        double a = exp(-len_s / c->cfg.wander_tau_s);
        double sd = c->cfg.wander_ppm * 1e-6 * sqrt(1.0 - a * a);
        c->wander = a * c->wander + urbsim_rng_normal(&c->rng, 0.0, sd);
    }
    double t_s = (double)n * len_s;
    double e = c->cfg.ppm0 * 1e-6 + c->cfg.ramp_ppm_per_s * 1e-6 * t_s + c->wander;
    return 1.0 + e;
}

static urbsim_clock_seg_t *seg_at(urbsim_clock_t *c, uint32_t i)
{
    return &c->seg[(c->first + i) % URBSIM_CLOCK_SEGMENTS];
}

/* Append the segment following the newest one, dropping the oldest when the ring is full. */
static void grow(urbsim_clock_t *c)
{
    urbsim_clock_seg_t *last = seg_at(c, c->count - 1u);
    urbsim_clock_seg_t next;
    next.t0 = last->t0 + seg_len(c);
    next.local0 = last->local0 + (double)seg_len(c) * last->rate;
    next.rate = next_rate(c, c->generated++);
    next.ns_per_cycle = 1e9 / c->cfg.cpu_hz / next.rate;
    if (c->count == URBSIM_CLOCK_SEGMENTS) {
        c->first = (c->first + 1u) % URBSIM_CLOCK_SEGMENTS;
        c->count--;
    }
    *seg_at(c, c->count) = next;
    c->count++;
    c->cur = (c->first + c->count - 1u) % URBSIM_CLOCK_SEGMENTS;
    c->cur_t0 = next.t0;
#ifdef URBSIM_MUTANT_CLOCK_SPAN /* seeded bug (mk/sim.mk): the newest segment is believed 1 ms longer */
    c->cur_t1 = next.t0 + seg_len(c) + URBSIM_NS_PER_MS;
#else
    c->cur_t1 = next.t0 + seg_len(c);
#endif
}

void urbsim_clock_init(urbsim_clock_t *c, const urbsim_clock_cfg_t *cfg, const urbsim_rng_t *rng)
{
    c->cfg = *cfg;
    c->rng = *rng;
    urbsim_rng_seed(&c->jitter, urbsim_rng_u64(&c->rng) ^ 0x6A09E667F3BCC909ull);
    if (c->cfg.wander_ppm > 0.0) {
        /* Start the wander in its stationary distribution, not at zero. */
        c->wander = urbsim_rng_normal(&c->rng, 0.0, c->cfg.wander_ppm * 1e-6);
    } else {
        c->wander = 0.0;
    }
    urbsim_clock_reset(c, 0);
}

void urbsim_clock_reset(urbsim_clock_t *c, urbsim_ns_t now)
{
    c->origin = now;
    c->first = 0;
    c->count = 1;
    c->generated = 0;
    c->seg[0].t0 = now;
    c->seg[0].local0 = 0.0;
    c->seg[0].rate = next_rate(c, c->generated++);
    c->seg[0].ns_per_cycle = 1e9 / c->cfg.cpu_hz / c->seg[0].rate;
    c->cur = 0;
    c->cur_t0 = now;
    c->cur_t1 = now + seg_len(c);
}

/* The segment containing virtual time t, generating forward as needed. */
static urbsim_clock_seg_t *find_virtual_slow(urbsim_clock_t *c, urbsim_ns_t t)
{
    urbsim_ns_t len = seg_len(c);
    while (t >= seg_at(c, c->count - 1u)->t0 + len) {
        grow(c);
    }
    uint32_t i = c->count - 1u;
    while (i > 0 && seg_at(c, i)->t0 > t) {
        i--;
    }
    return seg_at(c, i);
}

/* Nearly every query falls in the newest segment: that case costs two comparisons. */
static inline urbsim_clock_seg_t *find_virtual(urbsim_clock_t *c, urbsim_ns_t t)
{
    if (t >= c->cur_t0 && t < c->cur_t1) {
        return &c->seg[c->cur];
    }
    return find_virtual_slow(c, t);
}

double urbsim_clock_local_ns(urbsim_clock_t *c, urbsim_ns_t t)
{
    if (t < c->origin) {
        t = c->origin;
    }
    urbsim_clock_seg_t *s = find_virtual(c, t);
    double dt = t >= s->t0 ? (double)(t - s->t0) : 0.0;
    return s->local0 + dt * s->rate;
}

urbsim_ns_t urbsim_clock_virtual_at(urbsim_clock_t *c, double local_ns)
{
    if (local_ns <= 0.0) {
        return c->origin;
    }
    /* Generate forward until the newest segment ends after local_ns. */
    for (;;) {
        urbsim_clock_seg_t *last = seg_at(c, c->count - 1u);
        if (last->local0 + (double)seg_len(c) * last->rate > local_ns) {
            break;
        }
        grow(c);
    }
    uint32_t i = c->count - 1u;
    while (i > 0 && seg_at(c, i)->local0 > local_ns) {
        i--;
    }
    urbsim_clock_seg_t *s = seg_at(c, i);
    double dt = (local_ns - s->local0) / s->rate;
    if (dt < 0.0) {
        dt = 0.0;
    }
    urbsim_ns_t t = s->t0 + (urbsim_ns_t)ceil(dt);
    /* Rounding of the division may leave us one ns off either way (up: local_ns(t) * rate / rate
     * can exceed the whole number of ns it came from); step until t is the earliest instant. */
    while (t > s->t0 && urbsim_clock_local_ns(c, t - 1u) >= local_ns) {
        t--;
    }
    while (urbsim_clock_local_ns(c, t) < local_ns) {
        t++;
    }
    return t;
}

uint64_t urbsim_clock_ticks(urbsim_clock_t *c, urbsim_ns_t t)
{
    double ticks = urbsim_clock_local_ns(c, t) * 1e-9 * c->cfg.timer_hz + 1e-9;
    /* floor() without the libm call: for ticks >= 1 truncation is floor; below 1 floor is <= 0. */
    return ticks < 1.0 ? 0u : (uint64_t)ticks;
}

urbsim_ns_t urbsim_clock_virtual_at_tick(urbsim_clock_t *c, uint64_t ticks)
{
    double local_ns = (double)ticks * 1e9 / c->cfg.timer_hz;
    urbsim_ns_t t = urbsim_clock_virtual_at(c, local_ns - 1e-6);
    while (urbsim_clock_ticks(c, t) < ticks) {
        t++;
    }
    return t;
}

urbsim_ns_t urbsim_clock_cycles_ns(urbsim_clock_t *c, urbsim_ns_t t, double cycles)
{
    if (t < c->origin) {
        t = c->origin;
    }
    /* >= 0, so round half up (cheaper than llround), and through int64_t: one instruction, where
     * a double to uint64_t conversion needs a range test (same value below 2^63 ns). */
    return (urbsim_ns_t)(int64_t)(cycles * find_virtual(c, t)->ns_per_cycle + 0.5);
}

urbsim_ns_t urbsim_clock_irq_latency(urbsim_clock_t *c, urbsim_ns_t t)
{
#ifdef URBSIM_MUTANT_SHARED_JITTER /* seeded bug (tests/sim/test_determinism.py): one latency stream for
                                     * every clock of the process, whose state outlives the world */
    static urbsim_rng_t shared;
    static bool seeded;
    if (!seeded) {
        urbsim_rng_seed(&shared, 1u);
        seeded = true;
    }
    uint64_t extra = urbsim_rng_below(&shared, (uint64_t)c->cfg.irq_jitter_cycles + 1u);
#else
    uint64_t extra = urbsim_rng_below(&c->jitter, (uint64_t)c->cfg.irq_jitter_cycles + 1u);
#endif
    return urbsim_clock_cycles_ns(c, t, (double)c->cfg.irq_base_cycles + (double)extra);
}

double urbsim_clock_error_ppm(urbsim_clock_t *c, urbsim_ns_t t)
{
    urbsim_clock_seg_t *s = find_virtual(c, t < c->origin ? c->origin : t);
    return (s->rate - 1.0) * 1e6;
}
