/*
 * Host model of SYNC + N nodes running the real node library (see pll_model.h). Test code: it
 * uses doubles, malloc and a PRNG freely; the library under test does not.
 */
#include "pll_model.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TICK_HZ 48e6
#define CPU_HZ 48e6
#define SEG_NS 100e6
#define MAX_SEGS 512u
#define T_BIT_NS 2500.0 /* 400 kb/s */

typedef struct {
    double t0, local0, rate;
} seg_t;

typedef struct {
    uint64_t s;
} rng_t;

static uint64_t rng_next(rng_t *r)
{
    /* splitmix64: tiny, deterministic, good enough for jitter draws */
    uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double rng_unit(rng_t *r)
{
    return (double)(rng_next(r) >> 11) * (1.0 / 9007199254740992.0);
}

static unsigned rng_upto(rng_t *r, unsigned n) /* uniform 0..n */
{
    return (unsigned)(rng_next(r) % ((uint64_t)n + 1u));
}

static double rng_gauss(rng_t *r)
{
    double const u1 = rng_unit(r) + 1e-300;
    double const u2 = rng_unit(r);
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

typedef struct mnode {
    const pll_node_params_t *p;
    seg_t seg[MAX_SEGS];
    unsigned nseg;
    urb_node_t node;
    urb_node_hal_t hal;
    urb_node_hooks_t hooks;
    uint8_t storage[16];
    rng_t rng;
    double now;       /* virtual time the firmware currently runs at */
    double hw_sync;   /* bus instant of the last general-call address match */
    bool powered;
    bool armed;
    uint64_t compare; /* armed compare, 64-bit */
    double beat_t;    /* virtual time the compare fires */
    double poll_t;    /* next main-loop wake-up, INFINITY if none */
    int sync_step;    /* next SYNC byte to deliver: 0 none, 1 address, 2 magic, 3 counter, 4 stop */
    double sync_base; /* t_hw of the SYNC being delivered */
    uint8_t sync_counter;
    double *acq_end;  /* t_acq_end records */
    size_t n_acq, cap_acq;
    unsigned lost, overruns;
} mnode_t;

static double local_ns(const mnode_t *m, double t)
{
    double const rel = t - m->p->start_ns;
    if (rel <= 0.0) {
        return 0.0;
    }
    unsigned j = (unsigned)(rel / SEG_NS);
    if (j >= m->nseg) {
        j = m->nseg - 1u;
    }
    return m->seg[j].local0 + (rel - m->seg[j].t0) * m->seg[j].rate;
}

static uint64_t ticks_at(const mnode_t *m, double t)
{
    return (uint64_t)floor(local_ns(m, t) * (TICK_HZ / 1e9));
}

static double virtual_at_tick(const mnode_t *m, uint64_t c)
{
    double const target = (double)c / (TICK_HZ / 1e9);
    unsigned j = 0u;
    while (j + 1u < m->nseg && m->seg[j + 1u].local0 <= target) {
        j++;
    }
    double const rel = m->seg[j].t0 + (target - m->seg[j].local0) / m->seg[j].rate;
    return m->p->start_ns + rel + 1e-6;
}

static double cycles_ns(unsigned cycles)
{
    return (double)cycles * (1e9 / CPU_HZ);
}

static double irq_latency(mnode_t *m)
{
    return cycles_ns(m->p->irq_base_cycles + rng_upto(&m->rng, m->p->irq_jitter_cycles));
}

/* ----- HAL ----- */

static uint32_t h_now(void *ctx)
{
    mnode_t *m = ctx;
    return (uint32_t)ticks_at(m, m->now);
}

static void h_set_compare(void *ctx, uint32_t at)
{
    mnode_t *m = ctx;
    uint64_t const cur = ticks_at(m, m->now);
    uint64_t full = (cur & ~(uint64_t)0xFFFFFFFFu) | at;
    if (full + 0x80000000ull < cur) {
        full += 0x100000000ull;
    } else if (full > cur + 0x80000000ull) {
        full -= 0x100000000ull;
    }
    m->compare = full;
    m->armed = true;
    m->beat_t = virtual_at_tick(m, full);
    if (m->beat_t < m->now) {
        m->beat_t = m->now;
    }
}

static uint32_t h_capture(void *ctx)
{
    mnode_t *m = ctx;
    return (uint32_t)ticks_at(m, m->hw_sync);
}

static void h_set_address(void *ctx, uint8_t address)
{
    (void)ctx;
    (void)address;
}

/* ----- application ----- */

static void a_bootup(urb_node_t *node, void *user)
{
    (void)user;
    (void)urb_node_set_class(node, 0x7Fu);
    (void)urb_node_setup_outbox(node, 1u, 4u);
}

static void a_update(urb_node_t *node, void *user)
{
    mnode_t *m = user;
    m->now += m->p->acq_ns + cycles_ns(rng_upto(&m->rng, m->p->acq_jitter_cycles));
    uint8_t *buf = NULL;
    if (urb_node_lock_outbox(node, 1u, &buf) == URB_NODE_OK) {
        memset(buf, 0, 4u);
        (void)urb_node_release_outbox(node, 1u); /* marks the end of acquisition */
        if (m->n_acq < m->cap_acq) {
            m->acq_end[m->n_acq++] = m->now;
        }
    }
}

static void a_fault(urb_node_t *node, void *user, urb_node_fault_t fault)
{
    (void)node;
    mnode_t *m = user;
    if (fault == URB_NODE_FAULT_LOST_SYNC) {
        m->lost++;
    } else if (fault == URB_NODE_FAULT_OVERRUN) {
        m->overruns++;
    }
}

static void build_clock(mnode_t *m, double duration_ns, rng_t *r)
{
    double const steps = duration_ns / SEG_NS + 2.0;
    m->nseg = (steps > (double)MAX_SEGS) ? MAX_SEGS : (unsigned)steps;
    double w = m->p->wander_ppm * rng_gauss(r);
    double const a = exp(-SEG_NS / 10e9); /* tau 10 s */
    double local = 0.0;
    for (unsigned j = 0u; j < m->nseg; j++) {
        double const t0 = (double)j * SEG_NS;
        double const e = m->p->ppm0 + m->p->ramp_ppm_per_s * (t0 / 1e9) + w;
        m->seg[j] = (seg_t){t0, local, 1.0 + e * 1e-6};
        local += SEG_NS * m->seg[j].rate;
        w = w * a + m->p->wander_ppm * sqrt(1.0 - a * a) * rng_gauss(r);
    }
}

/* Wake the main loop if the firmware has work (it sleeps otherwise). */
static void maybe_wake(mnode_t *m)
{
    if (isinf(m->poll_t) && urb_node_has_work(&m->node)) {
        m->poll_t = m->now + m->p->main_latency_ns + cycles_ns(rng_upto(&m->rng, m->p->main_jitter_cycles));
    }
}

void pll_default_scenario(pll_scenario_t *sc, uint64_t seed)
{
    memset(sc, 0, sizeof *sc);
    rng_t r = {seed * 7919u + 17u};
    sc->nodes = 2u;
    sc->duration_ns = 1.5e9;
    sc->sync_period_ns = 1e6;
    sc->bridge_ppm = (rng_unit(&r) * 200.0) - 100.0;
    sc->bridge_jitter_cycles = 8u;
    sc->seed = seed;
    urb_node_config_default(&sc->cfg);
    sc->cfg.i2c_address = 0x10u;
    for (unsigned i = 0u; i < PLL_MAX_NODES; i++) {
        pll_node_params_t *p = &sc->node[i];
        p->ppm0 = (rng_unit(&r) * 200.0) - 100.0;
        p->ramp_ppm_per_s = (rng_unit(&r) * 0.2) - 0.1;
        p->wander_ppm = 0.05;
        p->start_ns = rng_unit(&r) * 5e6; /* power-on within the first 5 ms */
        p->irq_base_cycles = 15u;
        p->irq_jitter_cycles = 8u;
        p->main_latency_ns = 6000.0; /* timer ISR (~200 cycles) + wake-up from WFI */
        p->main_jitter_cycles = 8u;
        p->acq_ns = 20000.0;
        p->acq_jitter_cycles = 4u;
        p->capture = true;
    }
}

/* Nearest record to t in a sorted array (two-pointer cursor). */
static double nearest(const double *v, size_t n, size_t *cur, double t)
{
    while (*cur + 1u < n && fabs(v[*cur + 1u] - t) <= fabs(v[*cur] - t)) {
        (*cur)++;
    }
    return (n == 0u) ? INFINITY : v[*cur];
}

int pll_run(const pll_scenario_t *sc, pll_result_t *out)
{
    if (sc->nodes == 0u || sc->nodes > PLL_MAX_NODES || sc->duration_ns > 40e9) {
        return -1;
    }
    memset(out, 0, sizeof *out);
    rng_t world = {sc->seed ^ 0xA5A5A5A5u};
    mnode_t *nodes = calloc(sc->nodes, sizeof *nodes);
    size_t const n_sync_max = (size_t)(sc->duration_ns / sc->sync_period_ns) + 4u;
    double *sync_hw = calloc(n_sync_max, sizeof *sync_hw);
    unsigned char *synced = calloc(n_sync_max * sc->nodes, 1u);
    if (nodes == NULL || sync_hw == NULL || synced == NULL) {
        free(nodes);
        free(sync_hw);
        free(synced);
        return -1;
    }
    for (unsigned i = 0u; i < sc->nodes; i++) {
        mnode_t *m = &nodes[i];
        m->p = &sc->node[i];
        m->rng.s = sc->seed * 1000003u + i;
        build_clock(m, sc->duration_ns + 1e8, &m->rng);
        m->hal = (urb_node_hal_t){m, h_now, h_set_compare, m->p->capture ? h_capture : NULL, h_set_address, NULL, NULL};
        m->hooks = (urb_node_hooks_t){a_bootup, NULL, NULL, NULL, a_update, NULL, a_fault};
        m->poll_t = INFINITY;
        m->cap_acq = (size_t)(sc->duration_ns / 1e5) + 16u; /* >= 10 per SYNC period */
        m->acq_end = calloc(m->cap_acq, sizeof(double));
    }
    double const bridge_rate = 1.0 + sc->bridge_ppm * 1e-6;
    size_t k = 0u;           /* next SYNC number */
    size_t n_sync = 0u;
    for (;;) {
        /* next bridge SYNC: its address match on the bus */
        double const t_sync = ((double)(k + 1u) * sc->sync_period_ns) / bridge_rate + 2.5 * T_BIT_NS + 9.0 * T_BIT_NS;
        double t_next = t_sync;
        int who = -1;
        int what = 0; /* 1 power, 2 beat, 3 poll, 4 sync step */
        for (unsigned i = 0u; i < sc->nodes; i++) {
            mnode_t *m = &nodes[i];
            double const cand[4] = {m->powered ? INFINITY : m->p->start_ns,
                                    (m->powered && m->armed) ? m->beat_t : INFINITY, m->poll_t,
                                    m->sync_step != 0 ? m->sync_base + (double)(m->sync_step - 1) * 9.0 * T_BIT_NS : INFINITY};
            for (int c = 0; c < 4; c++) {
                if (cand[c] < t_next) {
                    t_next = cand[c];
                    who = (int)i;
                    what = c + 1;
                }
            }
        }
        if (t_next > sc->duration_ns) {
            break;
        }
        if (who < 0) {
            /* the bridge sends SYNC k + 1 (counter wraps at 256) */
            double t_hw = t_sync + cycles_ns(rng_upto(&world, sc->bridge_jitter_cycles));
            double const t_on_time = t_hw; /* metrics use the bridge's heartbeat, not a late message */
            bool deliver = rng_unit(&world) >= sc->drop_prob;
            if (rng_unit(&world) < sc->late_prob) {
                t_hw += rng_unit(&world) * sc->late_max_ns;
            }
            if (sc->outage_len_ns > 0.0 && t_hw >= sc->outage_start_ns && t_hw < sc->outage_start_ns + sc->outage_len_ns) {
                deliver = false;
            }
            if (n_sync < n_sync_max) {
                sync_hw[n_sync] = t_on_time;
                for (unsigned i = 0u; i < sc->nodes; i++) {
                    synced[n_sync * sc->nodes + i] = urb_node_synced(&nodes[i].node) ? 1u : 0u;
                }
                n_sync++;
            }
            out->syncs_sent++;
            for (unsigned i = 0u; deliver && i < sc->nodes; i++) {
                mnode_t *m = &nodes[i];
                if (m->powered) {
                    m->sync_step = 1;
                    m->sync_base = t_hw;
                    m->sync_counter = (uint8_t)((k + 1u) & 0xFFu);
                }
            }
            k++;
            continue;
        }
        mnode_t *m = &nodes[who];
        switch (what) {
        case 1: /* power-on */
            m->now = t_next;
            m->powered = true;
            (void)urb_node_init(&m->node, &m->hal, &m->hooks, m, &sc->cfg, m->storage, (uint16_t)sizeof m->storage);
            break;
        case 2: /* heartbeat compare */
            m->armed = false;
            m->now = t_next + irq_latency(m);
            urb_node_timer_event(&m->node);
            m->now = t_next;
            maybe_wake(m);
            break;
        case 3: /* main loop */
            m->now = t_next;
            m->poll_t = INFINITY;
            (void)urb_node_poll(&m->node);
            maybe_wake(m);
            break;
        default: { /* a SYNC byte reaches this node's interrupt */
            double const t_irq = t_next + irq_latency(m);
            m->now = t_irq;
            if (m->sync_step == 1) {
                m->hw_sync = t_next;
                (void)urb_node_i2c_event(&m->node, URB_I2C_GENERAL_CALL, 0u);
            } else if (m->sync_step == 2) {
                (void)urb_node_i2c_event(&m->node, URB_I2C_RX_BYTE, 0xA5u);
            } else if (m->sync_step == 3) {
                (void)urb_node_i2c_event(&m->node, URB_I2C_RX_BYTE, m->sync_counter);
            } else {
                (void)urb_node_i2c_event(&m->node, URB_I2C_STOP, 0u);
            }
            m->sync_step = (m->sync_step >= 4) ? 0 : m->sync_step + 1;
            maybe_wake(m);
            break;
        }
        }
    }

    /* ----- metrics ----- */
    double latest_start = 0.0;
    for (unsigned i = 0u; i < sc->nodes; i++) {
        latest_start = fmax(latest_start, sc->node[i].start_ns);
        out->lost_sync_faults += nodes[i].lost;
        out->overruns += nodes[i].overruns;
    }
    double *e = calloc(n_sync * sc->nodes + 1u, sizeof(double)); /* e[k][i] = t_acq_end - t_hw */
    size_t *cur = calloc(sc->nodes, sizeof(size_t));
    for (size_t s = 0u; s < n_sync; s++) {
        for (unsigned i = 0u; i < sc->nodes; i++) {
            e[s * sc->nodes + i] = nearest(nodes[i].acq_end, nodes[i].n_acq, &cur[i], sync_hw[s]) - sync_hw[s];
        }
    }
    double const out_a = sc->outage_start_ns;
    double const out_b = sc->outage_start_ns + sc->outage_len_ns;
    bool const has_outage = sc->outage_len_ns > 0.0;
    /* steady phase per node: median-free estimate, the mean over the last 100 SYNCs */
    double ref[PLL_MAX_NODES] = {0};
    size_t const tail = (n_sync > 100u) ? 100u : n_sync;
    for (unsigned i = 0u; i < sc->nodes; i++) {
        for (size_t s = n_sync - tail; s < n_sync; s++) {
            ref[i] += e[s * sc->nodes + i] / (double)tail;
        }
    }
    /* convergence: the first SYNC after which every later one (before any outage) is in */
    size_t const conv_end = n_sync;
    size_t last_bad = SIZE_MAX;
    for (size_t s = 0u; s < conv_end; s++) {
        if (sync_hw[s] < latest_start) {
            last_bad = s;
            continue;
        }
        if (has_outage && sync_hw[s] >= out_a) {
            break;
        }
        double lo = INFINITY, hi = -INFINITY;
        for (unsigned i = 0u; i < sc->nodes; i++) {
            double const v = e[s * sc->nodes + i];
            lo = fmin(lo, v);
            hi = fmax(hi, v);
        }
        if (!((hi - lo) < 1000.0)) {
            last_bad = s;
        }
    }
    size_t first_good = (last_bad == SIZE_MAX) ? 0u : last_bad + 1u;
    /* ...and at which every node is also within 1 us of its own steady phase */
    for (; first_good < n_sync; first_good++) {
        bool ok = true;
        for (unsigned i = 0u; i < sc->nodes; i++) {
            ok = ok && fabs(e[first_good * sc->nodes + i] - ref[i]) < 1000.0;
        }
        if (ok) {
            break;
        }
    }
    out->converged = first_good < n_sync && !(has_outage && sync_hw[first_good] >= out_a);
    out->converge_ns = out->converged ? sync_hw[first_good] - latest_start : INFINITY;
    /* steady state: from convergence + 100 ms, outside [outage start, outage end + 300 ms) */
    double const steady_from = out->converged ? sync_hw[first_good] + 100e6 : INFINITY;
    double sum = 0.0;
    size_t cnt = 0u;
    for (size_t s = 0u; s < n_sync; s++) {
        double const t = sync_hw[s];
        if (t < steady_from || (has_outage && t >= out_a && t < out_b + 300e6)) {
            continue;
        }
        for (unsigned i = 0u; i < sc->nodes; i++) {
            for (unsigned j = i + 1u; j < sc->nodes; j++) {
                double const d = fabs(e[s * sc->nodes + i] - e[s * sc->nodes + j]);
                sum += d;
                cnt++;
                out->diff_max_ns = fmax(out->diff_max_ns, d);
            }
        }
    }
    out->diff_mean_ns = (cnt != 0u) ? sum / (double)cnt : INFINITY;
    for (unsigned i = 0u; i < sc->nodes; i++) {
        mnode_t const *m = &nodes[i];
        double ps = 0.0, pss = 0.0;
        size_t pn = 0u;
        for (int pass = 0; pass < 2; pass++) {
            double const mean = (pn != 0u) ? ps / (double)pn : 0.0;
            for (size_t a = 1u; a < m->n_acq; a++) {
                double const t = m->acq_end[a - 1u];
                if (t < steady_from || (has_outage && m->acq_end[a] >= out_a && t < out_b + 300e6)) {
                    continue;
                }
                double const per = m->acq_end[a] - t;
                if (pass == 0) {
                    ps += per;
                    pn++;
                } else {
                    pss += (per - mean) * (per - mean);
                    out->jitter_max_ns = fmax(out->jitter_max_ns, fabs(per - mean));
                }
            }
        }
        if (pn > 1u) {
            out->jitter_sd_ns = fmax(out->jitter_sd_ns, sqrt(pss / (double)(pn - 1u)));
        }
    }
    /* outage: free-run drift and re-lock */
    if (has_outage) {
        size_t before = 0u;
        for (size_t s = 0u; s < n_sync && sync_hw[s] < out_a; s++) {
            before = s;
        }
        for (size_t s = before; s < n_sync && sync_hw[s] < out_b; s++) {
            for (unsigned i = 0u; i < sc->nodes; i++) {
                out->freerun_drift_ns = fmax(out->freerun_drift_ns, fabs(e[s * sc->nodes + i] - e[before * sc->nodes + i]));
            }
        }
        out->relock_ns = INFINITY;
        bool seen_unlocked = false;
        for (size_t s = 0u; s < n_sync; s++) {
            if (sync_hw[s] < out_b) {
                continue;
            }
            bool all = true;
            for (unsigned i = 0u; i < sc->nodes; i++) {
                all = all && synced[s * sc->nodes + i] != 0u;
            }
            if (!all) {
                seen_unlocked = true;
            } else if (seen_unlocked || s > 0u) {
                out->relock_ns = sync_hw[s] - out_b;
                break;
            }
        }
    }
    out->all_synced_at_end = true;
    for (unsigned i = 0u; i < sc->nodes; i++) {
        out->all_synced_at_end = out->all_synced_at_end && urb_node_synced(&nodes[i].node);
        free(nodes[i].acq_end);
    }
    free(e);
    free(cur);
    free(nodes);
    free(sync_hw);
    free(synced);
    return 0;
}
