/*
 * Heartbeat PLL (firmware/node/urb_pll.c): lock, period estimate under crystal error, missed and
 * duplicate SYNCs, outliers, re-acquisition, lost sync and free-running, disabled sync, fixed
 * lead; then the two-node model (tests/firmware/pll) against the paper's Table I.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "node_fixture.h"
#include "pll_model.h"

#define PERIOD 48000u
#define DELAY 2200u /* ticks from the address match to the counter byte's interrupt */

static fixture_t fx;

static int setup(void **state)
{
    fx_defaults(&fx);
    fx.update_work = 960u; /* t_acq = 20 us */
    assert_int_equal(fx_start(&fx), URB_NODE_OK);
    *state = &fx;
    return 0;
}

/* Advances to absolute tick t (firing heartbeats and polling after each), like a sleeping main loop. */
static void run_to(fixture_t *f, uint32_t t)
{
    /* bound: one heartbeat per call step */
    for (int guard = 0; guard < 100000; guard++) {
        uint32_t const left = t - f->port.now;
        if (left == 0u || left > 0x80000000u) {
            return;
        }
        uint32_t const to_beat = f->port.compare - f->port.now;
        uint32_t const step = (to_beat != 0u && to_beat < left) ? to_beat : left;
        if (urb_hal_hosted_advance(&f->port, &f->node, step) != 0u) {
            (void)urb_node_poll(&f->node);
        }
    }
}

/* One SYNC whose address match is at tick t, counter c. */
static void sync_at(fixture_t *f, uint32_t t, uint8_t c)
{
    run_to(f, t);
    f->port.capture = t;
    run_to(f, t + DELAY);
    fx_sync(&f->node, c);
    (void)urb_node_poll(&f->node);
}

/* n SYNCs of period p starting at t0 (counter from c0); returns the tick after the last. */
static uint32_t syncs(fixture_t *f, uint32_t t0, uint32_t p, unsigned n, uint8_t c0)
{
    for (unsigned k = 0u; k < n; k++) {
        sync_at(f, t0 + k * p, (uint8_t)(c0 + k));
    }
    return t0 + n * p;
}

/* Phase of the latest heartbeat + lead relative to the latest SYNC, in ticks. */
static double phase_ticks(fixture_t *f)
{
    urb_node_sync_status_t st;
    urb_node_sync_status(&f->node, &st);
    return (double)st.phase_q8 / 256.0;
}

/* lobster-trace: urb.SYN_001 */
static void locks_and_measures_period(void **state)
{
    fixture_t *f = *state;
    uint32_t t = syncs(f, 30000u, PERIOD + 5u, 30u, 1u); /* the bridge runs 104 ppm slow */
    urb_node_sync_status_t st;
    urb_node_sync_status(&f->node, &st);
    assert_int_equal(st.state, URB_NODE_SYNC_LOCKED);
    assert_true(urb_node_synced(&f->node));
    assert_true(fabs((double)st.period_q8 / 256.0 - (PERIOD + 5u)) < 0.5);
    assert_true(fabs(phase_ticks(f)) < 2.0);
    assert_int_equal(st.acq_ticks, 960u + 48u); /* t_acq + the 1-us guard */
    assert_int_equal(st.lead_ticks, 960u + 48u);
    /* heartbeat = SYNC - lead: the acquisition ends one guard before the SYNC */
    assert_true(abs((int)(st.last_beat + 960u + 48u - (t - PERIOD - 5u))) <= 2);
    (void)t;
}

/* lobster-trace: urb.SYN_006 */
static void missed_and_duplicate_syncs(void **state)
{
    fixture_t *f = *state;
    uint32_t t = syncs(f, 30000u, PERIOD - 7u, 20u, 1u);
    uint16_t const used = f->node.pll.syncs;
    /* every third SYNC only (counter gap 3): the period is still measured */
    for (unsigned k = 0u; k < 10u; k++) {
        sync_at(f, t + 3u * k * (PERIOD - 7u), (uint8_t)(20u + 1u + 3u * k));
    }
    assert_int_equal(f->node.pll.syncs, used + 10u);
    assert_true(fabs((double)f->node.pll.period_q8 / 256.0 - (PERIOD - 7u)) < 0.5);
    assert_true(urb_node_synced(&f->node));
    t += 30u * (PERIOD - 7u);
    /* the same counter twice: rejected */
    uint16_t const rej = f->node.pll.rejected;
    sync_at(f, t, 51u);
    fx_sync(&f->node, 51u);
    assert_int_equal(f->node.pll.rejected, rej + 1u);
    /* a gap beyond max_gap: phase kept, period not measured */
    uint32_t const before = f->node.pll.period_q8;
    sync_at(f, t + 20u * (PERIOD - 7u), 71u);
    assert_int_equal(f->node.pll.period_q8, before);
    assert_true(fabs(phase_ticks(f)) < 40.0);
}

/* lobster-trace: urb.SYN_006 */
static void outliers_rejected_then_reacquired(void **state)
{
    fixture_t *f = *state;
    uint32_t t = syncs(f, 30000u, PERIOD, 20u, 1u);
    assert_true(urb_node_synced(&f->node));
    uint16_t const rej = f->node.pll.rejected;
    /* one SYNC 10 us late (bus busy): ignored, still locked, phase unchanged */
    sync_at(f, t + 480u, 21u);
    assert_true(f->node.pll.rejected > rej); /* its period sample and its phase */
    assert_true(urb_node_synced(&f->node));
    t = syncs(f, t + PERIOD, PERIOD, 5u, 22u);
    assert_true(fabs(phase_ticks(f)) < 2.0);
    /* the bus phase really moves by 100 us: after max_outliers the node re-acquires and re-locks */
    t = syncs(f, t + 4800u, PERIOD, 15u, 27u);
    assert_true(urb_node_synced(&f->node));
    assert_true(fabs(phase_ticks(f)) < 2.0);
}

/* lobster-trace: urb.SYN_006 */
static void lost_sync_free_runs(void **state)
{
    fixture_t *f = *state;
    uint32_t t = syncs(f, 30000u, PERIOD + 3u, 30u, 1u);
    assert_true(urb_node_synced(&f->node));
    uint32_t const estimate = f->node.pll.period_q8;
    /* SYNC stops: after lost_sync_beats heartbeats LOST_SYNC, free-running at the estimate */
    run_to(f, t + 8u * PERIOD); /* the last SYNC was at t - PERIOD: 9 quiet heartbeats */
    assert_int_equal(f->faults[URB_NODE_FAULT_LOST_SYNC], 0u);
    run_to(f, t + 10u * PERIOD);
    assert_int_equal(f->faults[URB_NODE_FAULT_LOST_SYNC], 1u);
    assert_false(urb_node_synced(&f->node));
    assert_int_equal(f->node.pll.state, URB_NODE_SYNC_FREE);
    assert_int_equal(f->node.pll.period_q8, estimate);
    uint32_t const b0 = f->port.compare;
    run_to(f, b0 + 1u);
    assert_true(abs((int)(f->port.compare - b0) - (int)(estimate >> 8)) <= 1);
    /* still one fault, however long it lasts; the identification says not synced */
    run_to(f, t + 40u * PERIOD);
    assert_int_equal(f->faults[URB_NODE_FAULT_LOST_SYNC], 1u);
    uint8_t id[25];
    assert_true(fx_read_checked(&f->node, 0u, 25u, id));
    assert_int_equal(id[22] & 1u, 0u); /* Identification.synced, bit 176 */
    /* SYNC returns: re-locked within a few periods */
    (void)syncs(f, t + 41u * (PERIOD + 3u), PERIOD + 3u, 8u, 100u);
    assert_true(urb_node_synced(&f->node));
    assert_true(fx_read_checked(&f->node, 0u, 25u, id));
    assert_int_equal(id[22] & 1u, 1u);
}

static void disabled_and_fixed_lead(void **state)
{
    (void)state;
    fixture_t f;
    fx_defaults(&f);
    f.cfg.sync_enabled = 0u;
    assert_int_equal(fx_start(&f), URB_NODE_OK);
    (void)syncs(&f, 30000u, PERIOD + 50u, 10u, 1u);
    assert_int_equal(f.node.pll.state, URB_NODE_SYNC_OFF);
    assert_int_equal(f.node.pll.period_q8, PERIOD * 256u); /* nominal, untouched */
    /* a configured lead replaces the measured acquisition time */
    fx_defaults(&f);
    f.cfg.lead_us = 50u;
    f.update_work = 100u;
    assert_int_equal(fx_start(&f), URB_NODE_OK);
    uint32_t const t = syncs(&f, 30000u, PERIOD, 20u, 1u);
    urb_node_sync_status_t st;
    urb_node_sync_status(&f.node, &st);
    assert_int_equal(st.lead_ticks, 50u * 48u);
    assert_true(urb_node_synced(&f.node));
    assert_true(abs((int)(st.last_beat + 2400u - (t - PERIOD))) <= 2);
}

static void timer_stall_is_harmless(void **state)
{
    fixture_t *f = *state;
    /* the timer interrupt was blocked for several periods: the next compare is re-armed ahead */
    f->port.now += 5u * PERIOD;
    urb_node_timer_event(&f->node);
    assert_true((int32_t)(f->port.compare - f->port.now) > 0);
    /* a SYNC with the last heartbeat long gone: the phase error is clamped, no overflow */
    f->port.capture = f->port.now;
    fx_sync(&f->node, 1u);
    f->port.now += 200u * PERIOD;
    f->port.capture = f->port.now;
    fx_sync(&f->node, 2u); /* rejected (period and phase far off), no overflow (UBSan) */
    urb_node_timer_event(&f->node); /* the compare flag set during the stall fires late */
    assert_true((int32_t)(f->port.compare - f->port.now) > 0);
}

/* SYNCs after a silence longer than the period measurement can represent (2^24 ticks) and captures
 * from far behind the latest heartbeat: the period estimate is kept, the phase error is clamped to
 * one period, nothing overflows (UBSan), and the heartbeat stays armed ahead. */
static void silence_too_long_to_measure(void **state)
{
    fixture_t *f = *state;
    (void)syncs(f, PERIOD, PERIOD, 12u, 0u);
    urb_node_sync_status_t before;
    urb_node_sync_status(&f->node, &before);
    assert_true(urb_node_synced(&f->node));
    f->port.now += 400u * PERIOD; /* 19.2 M ticks > 2^24 without a heartbeat interrupt */
    f->port.capture = f->port.now;
    fx_sync(&f->node, 12u); /* the next counter: one SYNC period, but 19.2 M ticks measured */
    urb_node_sync_status_t after;
    urb_node_sync_status(&f->node, &after);
    assert_int_equal(after.period_q8, before.period_q8);
    urb_node_timer_event(&f->node);
    assert_true((int32_t)(f->port.compare - f->port.now) > 0);
    /* a capture three periods before the latest heartbeat: phase > period, clamped */
    f->port.capture = after.last_beat - 3u * PERIOD;
    fx_sync(&f->node, 13u);
    urb_node_sync_status(&f->node, &after);
    assert_int_equal(after.phase_q8, (int32_t)(after.period_q8 & ~0xFFu)); /* +1 period, its fraction dropped */
    assert_true(after.phase_q8 <= (int32_t)(PERIOD * 256u) && after.phase_q8 >= -(int32_t)(PERIOD * 256u));
}

/* Two nodes on the model clock: the paper's Table I, beaten on every seed. */
/* lobster-trace: urb.SYN_002, urb.SYN_003 */
static void two_nodes_beat_table1(void **state)
{
    (void)state;
    double conv = 0.0, diff = 0.0, jit = 0.0;
    unsigned const seeds = 8u;
    for (unsigned s = 1u; s <= seeds; s++) {
        pll_scenario_t sc;
        pll_default_scenario(&sc, s);
        pll_result_t r;
        assert_int_equal(pll_run(&sc, &r), 0);
        assert_true(r.converged);
        assert_true(r.all_synced_at_end);
        assert_true(r.converge_ns < 78.4e6);
        assert_true(r.diff_mean_ns < 190.0);
        assert_true(r.diff_max_ns < 560.0);
        assert_true(r.jitter_sd_ns < 920.0);
        assert_int_equal(r.overruns, 0u);
        conv += r.converge_ns / seeds;
        diff += r.diff_mean_ns / seeds;
        jit += r.jitter_sd_ns / seeds;
    }
    printf("two nodes, %u seeds: convergence %.1f ms, inter-node %.3f us, jitter sd %.3f us\n", seeds, conv / 1e6,
           diff / 1e3, jit / 1e3);
}

/* lobster-trace: urb.SYN_006 */
static void two_nodes_outage(void **state)
{
    (void)state;
    pll_scenario_t sc;
    pll_default_scenario(&sc, 3u);
    sc.duration_ns = 1.2e9;
    sc.outage_start_ns = 0.6e9;
    sc.outage_len_ns = 30e6;
    sc.drop_prob = 0.02;
    pll_result_t r;
    assert_int_equal(pll_run(&sc, &r), 0);
    assert_true(r.converged);
    assert_int_equal(r.lost_sync_faults, 2u); /* one per node */
    assert_true(r.relock_ns < 20e6);
    assert_true(r.freerun_drift_ns < 5000.0);
    assert_true(r.all_synced_at_end);
}

/* Mutation score (tests/mutation/README.md): seeded bugs the tests above let through. */

/* `synced` after exactly lock_count in-lock SYNCs in a row (the acquisition's first tracked SYNC
 * still carries the lead's step, so the count starts after it), not one earlier. */
static void locks_after_exactly_lock_count_syncs(void **state)
{
    fixture_t *f = *state;
    unsigned const n = f->node.cfg->lock_count;
    assert_true(n >= 2u);
    uint32_t t = 30000u;
    uint8_t c = 1u;
    while (f->node.pll.good < n - 1u) {
        assert_true(c < 20u);
        t = syncs(f, t, PERIOD, 1u, c++);
    }
    assert_false(urb_node_synced(&f->node));
    (void)syncs(f, t, PERIOD, 1u, c);
    assert_true(urb_node_synced(&f->node));
}

/* A heartbeat interrupt so late that the following beat is one tick short of 1 us away moves that
 * beat to exactly 1 us from now (at least 1 us ahead, never less). */
static void late_interrupt_rearms_a_full_microsecond_ahead(void **state)
{
    fixture_t *f = *state;
    uint32_t const margin = f->node.cfg->ticks_per_us;
    f->node.pll.period_q8 = (PERIOD << 8) + 128u; /* a period estimate with half a tick: beats carry a fraction */
    f->port.now = f->port.compare + PERIOD - (margin - 1u);
    urb_node_timer_event(&f->node);
    assert_int_equal(f->port.compare, f->port.now + margin);
    assert_int_equal(f->node.pll.next_frac, 0u); /* the re-armed beat is a whole tick: its fraction goes */
    /* a full microsecond away is left as it is */
    f->port.now = f->port.compare + PERIOD - margin;
    uint32_t const next = f->port.compare + PERIOD;
    urb_node_timer_event(&f->node);
    assert_int_equal(f->port.compare, next);
}

/* ===== One step of the PLL against a reference model ==========================================
 * The model restates urb_pll.c's contract (the header comment: eq. 1 with gear shifting and the
 * outlier window, eq. 2 with the lead step applied at once, acquisition's phase jump, lock with 2x
 * hysteresis, the heartbeat at least 1 us ahead, lost sync, the update divider) in int64 arithmetic
 * with plain division, none of the firmware's Q8 helpers. Each step starts from a random state
 * whose inputs are drawn around the boundaries the code compares against (a window, the lock and
 * outlier limits, the phase clamp, the lead's quarter period, the 1-us margin, the period range of
 * a request), then compares every PLL field, the armed compare and the LOST_SYNC count. */

static uint64_t rng_state;

static uint32_t rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (uint32_t)(rng_state >> 16);
}

/* uniform in lo..hi (inclusive) */
static int64_t pick(int64_t lo, int64_t hi)
{
    return lo + (int64_t)(rnd() % (uint32_t)(hi - lo + 1));
}

/* `base` exactly, one off either way, or anywhere in lo..hi: boundaries come up often */
static int64_t near(int64_t base, int64_t lo, int64_t hi)
{
    return (rnd() % 2u == 0u) ? base + pick(-1, 1) : pick(lo, hi);
}

static int64_t ref_diff(uint32_t a, uint32_t b)
{
    uint32_t const d = a - b;
    return (d < 0x80000000u) ? (int64_t)d : (int64_t)d - 4294967296LL;
}

static int64_t ref_floor256(int64_t x)
{
    return (x >= 0) ? x / 256 : -((-x + 255) / 256);
}

static int64_t ref_abs(int64_t x)
{
    return (x < 0) ? -x : x;
}

/* x * k / 256 rounded half away from zero; a gain of 256 or more is 1 */
static int64_t ref_gain(int64_t x, int64_t k)
{
    if (k >= 256) {
        return x;
    }
    int64_t const r = (ref_abs(x) * k + 128) / 256;
    return (x < 0) ? -r : r;
}

typedef struct {
    urb_node_pll_t p;
    uint32_t compare;
    uint32_t candidate; /* the heartbeat before the 1-us margin and the skip were applied */
    uint8_t lost_sync;
    uint8_t div, update_due;
    uint32_t update_beat;
} ref_t;

static void ref_reacquire(urb_node_pll_t *p, uint8_t state)
{
    p->state = state;
    p->have_prev = 0u;
    p->gear = 0u;
    p->good = 0u;
    p->outliers = 0u;
    p->expect_q8 = 0;
}

static void ref_schedule(ref_t *r, const urb_node_config_t *cfg, uint32_t now, uint32_t ref, uint8_t frac, int64_t off,
                         bool skip)
{
    int64_t total = (int64_t)frac + off;
    r->candidate = ref + (uint32_t)ref_floor256(total);
    if (skip && ref_diff(r->candidate, now) < (int64_t)cfg->ticks_per_us) {
        total += r->p.period_q8; /* already past: one period on */
    }
    int64_t const whole = ref_floor256(total);
    r->p.next_beat = ref + (uint32_t)whole;
    r->p.next_frac = (uint8_t)(total - whole * 256);
    if (ref_diff(r->p.next_beat, now) < (int64_t)cfg->ticks_per_us) {
        r->p.next_beat = now + cfg->ticks_per_us;
        r->p.next_frac = 0u;
    }
    r->compare = r->p.next_beat;
}

/* eq. 1: the period sample of a SYNC `gap` counts after the previous one */
static void ref_period(urb_node_pll_t *p, const urb_node_config_t *cfg, uint32_t t_d, uint8_t gap)
{
    uint32_t const delta = t_d - p->prev_sync;
    if (gap > cfg->max_gap || delta > 0xFFFFFFu) {
        return;
    }
    int64_t const td_q8 = (int64_t)delta * 256 / gap;
    if (td_q8 > 0x1FFFFFLL * 256) {
        return;
    }
    int64_t const err = td_q8 - (int64_t)p->period_q8;
    int64_t const window = (p->gear == 0u) ? (int64_t)(p->nominal_q8 / 8u) : (int64_t)p->outlier_ticks * 256;
    if (ref_abs(err) > window) {
        p->rejected++;
        return;
    }
    int64_t const shifted = 256 >> p->gear;
    int64_t const kd = (shifted > cfg->kd_q8) ? shifted : cfg->kd_q8;
    p->period_q8 = (uint32_t)((int64_t)p->period_q8 + ref_gain(err, kd));
    if (p->gear < 8u) {
        p->gear++;
    }
}

/* the lead a SYNC uses: configured, else t_acq, at most a quarter of the (updated) period */
static int64_t ref_lead(const urb_node_pll_t *p, uint32_t acq_ticks)
{
    int64_t const lead = (p->fixed_lead != 0u) ? p->fixed_lead : acq_ticks;
    int64_t const quarter = (int64_t)(p->period_q8 / 256u) / 4;
    return (lead > quarter) ? quarter : lead;
}

static void ref_sync(ref_t *r, const urb_node_config_t *cfg, uint32_t acq_ticks, uint32_t now, uint32_t t_d,
                     uint8_t counter)
{
    urb_node_pll_t *p = &r->p;
    if (p->state == URB_NODE_SYNC_OFF) {
        return;
    }
    if (p->have_prev != 0u) {
        uint8_t const gap = (uint8_t)(counter - p->prev_counter);
        if (gap == 0u) {
            p->rejected++;
            return;
        }
        ref_period(p, cfg, t_d, gap);
    }
    p->prev_sync = t_d;
    p->prev_counter = counter;
    p->have_prev = 1u;
    p->quiet = 0u;
    int64_t const period = p->period_q8 / 256u;
    int64_t const lead = ref_lead(p, acq_ticks);
    int64_t phase = ref_diff(p->last_beat + (uint32_t)lead, t_d);
    phase = (phase > period) ? period : ((phase < -period) ? -period : phase);
    int64_t const phase_q8 = phase * 256 + p->last_frac;
    int64_t const step_q8 = (lead - (int64_t)p->lead_prev) * 256;
    p->phase_q8 = (int32_t)phase_q8;
    if (p->state == URB_NODE_SYNC_FREE) {
        p->state = URB_NODE_SYNC_TRACK;
        p->good = 0u;
        p->expect_q8 = 0;
        p->lead_prev = (uint32_t)lead;
        p->syncs++;
        ref_schedule(r, cfg, now, t_d, 0u, (int64_t)p->period_q8 - lead * 256, true);
        return;
    }
    if (ref_abs(ref_floor256(phase_q8 - step_q8 - p->expect_q8)) > p->outlier_ticks) {
        p->rejected++;
        p->outliers++;
        if (p->outliers > cfg->max_outliers) {
            ref_reacquire(p, URB_NODE_SYNC_FREE);
        }
        return;
    }
    if (ref_abs(phase) <= p->lock_ticks) {
        if (p->good < cfg->lock_count) {
            p->good++;
        }
        if (p->good >= cfg->lock_count) {
            p->state = URB_NODE_SYNC_LOCKED;
        }
    } else {
        p->good = 0u;
        if (ref_abs(phase) > 2 * (int64_t)p->lock_ticks) {
            p->state = URB_NODE_SYNC_TRACK;
        }
    }
    p->outliers = 0u;
    p->lead_prev = (uint32_t)lead;
    p->syncs++;
    int64_t const corr_q8 = ref_gain(phase_q8 - step_q8, cfg->kn_q8) + step_q8;
    p->expect_q8 = (int32_t)(phase_q8 - corr_q8);
    ref_schedule(r, cfg, now, p->last_beat, p->last_frac, (int64_t)p->period_q8 - corr_q8, true);
}

static void ref_timer(ref_t *r, const urb_node_config_t *cfg, uint32_t now, uint16_t req_period_us,
                      uint16_t req_lead_us, uint8_t req_enable, uint8_t req_seq)
{
    urb_node_pll_t *p = &r->p;
    if (req_seq != p->req_ack) {
        uint32_t const ticks = (uint32_t)req_period_us * cfg->ticks_per_us;
        if (ticks >= 64u && ticks <= 0x1FFFFFu) {
            p->nominal_q8 = ticks * 256u;
        }
        p->period_q8 = p->nominal_q8;
        p->fixed_lead = (uint32_t)req_lead_us * cfg->ticks_per_us;
        p->lead_prev = 0u;
        ref_reacquire(p, (req_enable != 0u) ? URB_NODE_SYNC_FREE : URB_NODE_SYNC_OFF);
        p->req_ack = req_seq;
    }
    uint32_t const t_n = p->next_beat;
    p->last_beat = t_n;
    p->last_frac = p->next_frac;
    ref_schedule(r, cfg, now, t_n, p->last_frac, (int64_t)p->period_q8, false);
    if (p->quiet < 255u) {
        p->quiet++;
    }
    if (p->state >= URB_NODE_SYNC_TRACK && p->quiet >= cfg->lost_sync_beats) {
        ref_reacquire(p, URB_NODE_SYNC_FREE);
        p->gear = 8u;
        r->lost_sync++;
    }
    r->div++;
    if (r->div >= cfg->update_divider) {
        r->div = 0u;
        r->update_beat = t_n;
        r->update_due++;
    }
}

/* A started node with a random (consistent) PLL state and configuration. */
static void random_pll(fixture_t *f)
{
    fx_defaults(f);
    f->cfg.ticks_per_us = (uint16_t)((rnd() % 2u == 0u) ? 48 : pick(1, 100));
    f->cfg.heartbeat_us = (uint16_t)(PERIOD / 48u);
    assert_int_equal(fx_start(f), URB_NODE_OK);
    urb_node_config_t *c = &f->cfg;
    c->kd_q8 = (uint8_t)pick(0, 255);
    c->kn_q8 = (uint8_t)pick(0, 255);
    c->lock_count = (uint8_t)pick(0, 6);
    c->max_outliers = (uint8_t)pick(0, 6);
    c->max_gap = (uint8_t)pick(0, 10);
    c->lost_sync_beats = (uint8_t)pick(1, 12);
    c->update_divider = (uint8_t)pick(1, 4);
    urb_node_pll_t *p = &f->node.pll;
    p->nominal_q8 = (uint32_t)pick(2000, 200000) * 256u + (uint32_t)pick(0, 255);
    p->period_q8 = (uint32_t)((int64_t)p->nominal_q8 + pick(-(int64_t)p->nominal_q8 / 8, (int64_t)p->nominal_q8 / 8));
    int64_t const period = p->period_q8 / 256u;
    p->gear = (uint8_t)pick(0, 8);
    p->state = (uint8_t)pick(0, 3);
    p->good = (uint8_t)pick(0, 7);
    p->outliers = (uint8_t)pick(0, 7);
    p->quiet = (uint8_t)pick(0, 255);
    p->have_prev = (uint8_t)pick(0, 1);
    p->prev_counter = (uint8_t)rnd();
    p->lock_ticks = (uint16_t)pick(0, 300);
    p->outlier_ticks = (uint16_t)pick(0, 3000);
    p->fixed_lead = (rnd() % 2u == 0u) ? 0u : (uint32_t)pick(1, period / 2);
    f->node.acq_ticks = (uint32_t)pick(0, period / 2);
    p->lead_prev = (uint32_t)pick(0, period / 4);
    p->last_beat = rnd();
    p->last_frac = (uint8_t)rnd();
    p->next_beat = p->last_beat + (uint32_t)period;
    p->next_frac = (uint8_t)rnd();
    p->expect_q8 = (int32_t)pick(-(int64_t)p->period_q8 / 4, (int64_t)p->period_q8 / 4);
    p->syncs = (uint16_t)rnd();
    p->rejected = (uint16_t)rnd();
    p->req_ack = f->node.req_seq;
    f->node.div = (uint8_t)pick(0, 4);
}

static ref_t ref_of(const fixture_t *f)
{
    ref_t r;
    memset(&r, 0, sizeof r);
    r.p = f->node.pll;
    r.compare = f->port.compare;
    r.lost_sync = f->node.isr_faults[URB_NODE_FAULT_LOST_SYNC - 1u];
    r.div = f->node.div;
    r.update_due = f->node.update_due;
    r.update_beat = f->node.update_beat;
    return r;
}

static void assert_matches(const fixture_t *f, const ref_t *r)
{
    urb_node_pll_t const *p = &f->node.pll;
    assert_int_equal(p->period_q8, r->p.period_q8);
    assert_int_equal(p->nominal_q8, r->p.nominal_q8);
    assert_int_equal(p->next_beat, r->p.next_beat);
    assert_int_equal(p->next_frac, r->p.next_frac);
    assert_int_equal(p->last_beat, r->p.last_beat);
    assert_int_equal(p->last_frac, r->p.last_frac);
    assert_int_equal(p->prev_sync, r->p.prev_sync);
    assert_int_equal(p->prev_counter, r->p.prev_counter);
    assert_int_equal(p->have_prev, r->p.have_prev);
    assert_int_equal(p->phase_q8, r->p.phase_q8);
    assert_int_equal(p->expect_q8, r->p.expect_q8);
    assert_int_equal(p->fixed_lead, r->p.fixed_lead);
    assert_int_equal(p->lead_prev, r->p.lead_prev);
    assert_int_equal(p->lock_ticks, r->p.lock_ticks);
    assert_int_equal(p->outlier_ticks, r->p.outlier_ticks);
    assert_int_equal(p->syncs, r->p.syncs);
    assert_int_equal(p->rejected, r->p.rejected);
    assert_int_equal(p->state, r->p.state);
    assert_int_equal(p->gear, r->p.gear);
    assert_int_equal(p->good, r->p.good);
    assert_int_equal(p->outliers, r->p.outliers);
    assert_int_equal(p->quiet, r->p.quiet);
    assert_int_equal(p->req_ack, r->p.req_ack);
    assert_int_equal(f->port.compare, r->compare);
    assert_int_equal(f->node.isr_faults[URB_NODE_FAULT_LOST_SYNC - 1u], r->lost_sync);
    assert_int_equal(f->node.div, r->div);
    assert_int_equal(f->node.update_due, r->update_due);
    assert_int_equal(f->node.update_beat, r->update_beat);
    /* the status the application reads is the state itself */
    urb_node_sync_status_t st;
    urb_node_sync_status(&f->node, &st);
    assert_int_equal(st.state, p->state);
    assert_int_equal(st.period_q8, p->period_q8);
    assert_int_equal(st.phase_q8, p->phase_q8);
    assert_int_equal(st.lead_ticks, p->lead_prev);
    assert_int_equal(st.acq_ticks, f->node.acq_ticks);
    assert_int_equal(st.last_beat, p->last_beat);
    assert_int_equal(st.syncs, p->syncs);
    assert_int_equal(st.rejected, p->rejected);
    assert_int_equal(urb_node_synced(&f->node), p->state == URB_NODE_SYNC_LOCKED);
}

#define REF_STEPS 20000u

/* lobster-trace: urb.SYN_001, urb.SYN_003, urb.SYN_005, urb.SYN_006 */
static void sync_step_matches_reference_model(void **state)
{
    (void)state;
    rng_state = 0x9E3779B97F4A7C15u;
    static fixture_t f;
    unsigned reached[4] = {0u, 0u, 0u, 0u}; /* acquisitions, outliers, in lock, corrections */
    for (unsigned n = 0u; n < REF_STEPS; n++) {
        random_pll(&f);
        urb_node_pll_t *p = &f.node.pll;
        urb_node_config_t const *c = &f.cfg;
        /* the period sample: gap and interval around the window (gear 0: nominal / 8, then outlier_ticks) */
        uint8_t const gap = (uint8_t)((rnd() % 4u == 0u) ? near(c->max_gap, 0, 12) : pick(1, 2));
        uint8_t const counter = (uint8_t)(p->prev_counter + gap);
        int64_t const window = (p->gear == 0u) ? (int64_t)(p->nominal_q8 / 8u) : (int64_t)p->outlier_ticks * 256;
        int64_t err = (rnd() % 2u == 0u) ? (rnd() % 2u == 0u ? 1 : -1) * near(window, 0, window + 512)
                                         : pick(-window - 512, window + 512);
        if (rnd() % 8u == 0u) {
            err = pick(-2, 2); /* the rounding of a gain around zero */
        }
        int64_t delta = ((int64_t)p->period_q8 + err) * (gap == 0u ? 1 : gap) / 256;
        if (rnd() % 16u == 0u) {
            delta = near(0xFFFFFF, 0, 0x1FFFFFF); /* the longest interval measured */
        }
        if (rnd() % 16u == 0u && gap > 0u) {
            delta = near(0x1FFFFFLL * gap, 0, 0xFFFFFF); /* the longest period accepted */
        }
        /* the lead around a quarter of the period this SYNC leaves */
        ref_t probe = ref_of(&f);
        if (p->have_prev != 0u && gap != 0u) {
            ref_period(&probe.p, c, p->prev_sync + (uint32_t)delta, gap);
        }
        int64_t const quarter = (int64_t)(probe.p.period_q8 / 256u) / 4;
        if (rnd() % 2u == 0u) {
            if (p->fixed_lead != 0u) {
                p->fixed_lead = (uint32_t)near(quarter, 1, quarter + 2);
            } else {
                f.node.acq_ticks = (uint32_t)near(quarter, 0, quarter + 2);
            }
        }
        int64_t const lead = ref_lead(&probe.p, f.node.acq_ticks);
        /* the phase error around the lock limits and the clamp to one period */
        int64_t const period = probe.p.period_q8 / 256u;
        int64_t const sign = (rnd() % 2u == 0u) ? 1 : -1;
        int64_t phase;
        switch (rnd() % 5u) {
        case 0u: phase = sign * near(p->lock_ticks, 0, 3 * (int64_t)p->lock_ticks + 2); break;
        case 1u: phase = sign * near(2 * (int64_t)p->lock_ticks, 0, 3 * (int64_t)p->lock_ticks + 2); break;
        case 2u: phase = sign * near(period, period - 3, period + 3); break;
        case 3u: phase = pick(-period - 10, period + 10); break;
        default: /* an error of -1/256 .. 1/256 tick, no lead step: the gain's rounding around zero */
            phase = pick(-1, 1);
            p->last_frac = (uint8_t)((rnd() % 2u == 0u) ? 255u : pick(0, 2));
            p->lead_prev = (uint32_t)lead;
            break;
        }
        uint32_t const t_d = p->last_beat + (uint32_t)lead - (uint32_t)phase;
        p->prev_sync = t_d - (uint32_t)delta;
        /* the expected error around the outlier limit */
        int64_t const clamped = (phase > period) ? period : ((phase < -period) ? -period : phase);
        int64_t const step_q8 = (lead - (int64_t)p->lead_prev) * 256;
        int64_t off = sign * near((int64_t)p->outlier_ticks * 256 + pick(0, 255), 0, 2 * (int64_t)p->outlier_ticks * 256);
        if (rnd() % 8u == 0u) {
            off = pick(-2, 2); /* floor(x / 256) around zero */
        }
        p->expect_q8 = (int32_t)(clamped * 256 + p->last_frac - step_q8 - off);
        /* now: around the point where the next heartbeat would be less than 1 us ahead */
        ref_t dry = ref_of(&f);
        ref_sync(&dry, c, f.node.acq_ticks, 0u, t_d, counter);
        f.port.now = (rnd() % 2u == 0u) ? dry.candidate - c->ticks_per_us + (uint32_t)pick(-1, 1)
                                         : t_d + (uint32_t)pick(0, 2 * period);
        f.port.now_offset = 0u;
        ref_t r = ref_of(&f);
        ref_sync(&r, c, f.node.acq_ticks, f.port.now, t_d, counter);
        uint8_t const before = p->state;
        uint8_t const outliers = p->outliers;
        urb_pll_sync(&f.node, t_d, counter);
        assert_matches(&f, &r);
        reached[0] += (before == URB_NODE_SYNC_FREE) ? 1u : 0u;
        reached[1] += (p->outliers > outliers) ? 1u : 0u;
        reached[2] += (p->state == URB_NODE_SYNC_LOCKED && before != URB_NODE_SYNC_FREE) ? 1u : 0u;
        reached[3] += (p->outliers == 0u && before >= URB_NODE_SYNC_TRACK) ? 1u : 0u;
    }
    /* every path was taken many times */
    for (unsigned k = 0u; k < 4u; k++) {
        assert_true(reached[k] > REF_STEPS / 50u);
    }
}

/* lobster-trace: urb.SYN_006 */
static void timer_step_matches_reference_model(void **state)
{
    (void)state;
    rng_state = 0xD1B54A32D192ED03u;
    static fixture_t f;
    unsigned requests = 0u, lost = 0u, updates = 0u;
    for (unsigned n = 0u; n < REF_STEPS; n++) {
        random_pll(&f);
        urb_node_pll_t *p = &f.node.pll;
        urb_node_config_t *c = &f.cfg;
        p->quiet = (uint8_t)((rnd() % 4u == 0u) ? near(254, 250, 255) : near(c->lost_sync_beats - 1, 0, 14));
        f.node.div = (uint8_t)near(c->update_divider - 1, 0, 5);
        if (rnd() % 4u == 0u) {
            /* a request with a period around the accepted range (64 .. 2^21 - 1 ticks) */
            static const struct { uint16_t tpu, us; } edges[] = {{1u, 63u}, {1u, 64u}, {1u, 65u}, {50u, 41943u},
                                                                  {49u, 42799u}, {64u, 32768u}, {48u, 0u}, {48u, 1000u}};
            unsigned const e = rnd() % (sizeof edges / sizeof edges[0]);
            c->ticks_per_us = edges[e].tpu;
            f.node.req_period_us = edges[e].us;
            f.node.req_lead_us = (uint16_t)pick(0, 100);
            f.node.req_enable = (uint8_t)pick(0, 1);
            f.node.req_seq = (uint8_t)(p->req_ack + pick(1, 255));
        }
        /* now: around the point where the next heartbeat would be less than 1 us ahead */
        ref_t dry = ref_of(&f);
        ref_timer(&dry, c, 0u, f.node.req_period_us, f.node.req_lead_us, f.node.req_enable, f.node.req_seq);
        f.port.now = (rnd() % 2u == 0u) ? dry.candidate - c->ticks_per_us + (uint32_t)pick(-1, 1)
                                         : p->next_beat + (uint32_t)pick(0, 100);
        f.port.now_offset = 0u;
        ref_t r = ref_of(&f);
        uint8_t const lost_before = r.lost_sync;
        ref_timer(&r, c, f.port.now, f.node.req_period_us, f.node.req_lead_us, f.node.req_enable, f.node.req_seq);
        requests += (f.node.req_seq != p->req_ack) ? 1u : 0u;
        uint32_t const beats = f.port.mark_count[URB_NODE_MARK_BEAT];
        urb_node_timer_event(&f.node);
        assert_matches(&f, &r);
        assert_int_equal(f.port.mark_count[URB_NODE_MARK_BEAT], beats + 1u); /* the logic analyser's probe */
        lost += (r.lost_sync != lost_before) ? 1u : 0u;
        updates += (r.div == 0u) ? 1u : 0u;
    }
    assert_true(requests > REF_STEPS / 8u);
    assert_true(lost > REF_STEPS / 50u);
    assert_true(updates > REF_STEPS / 8u);
}

/* Start: the thresholds in ticks, the configuration as the first request, and the first heartbeat
 * one nominal period after start; with sync disabled the PLL stays off. Distinct lock and outlier
 * limits and a configured lead tell every field apart. */
static void start_applies_the_configuration(void **state)
{
    (void)state;
    static fixture_t f;
    for (uint8_t enabled = 0u; enabled <= 1u; enabled++) {
        fx_defaults(&f);
        f.cfg.ticks_per_us = 40u;
        f.cfg.heartbeat_us = 1500u;
        f.cfg.lock_ns = 1500u;
        f.cfg.outlier_ns = 2600u;
        f.cfg.lead_us = 7u;
        f.cfg.sync_enabled = enabled;
        uint32_t const t0 = f.port.now;
        assert_int_equal(fx_start(&f), URB_NODE_OK);
        urb_node_pll_t const *p = &f.node.pll;
        assert_int_equal(p->lock_ticks, 60u);     /* 1500 ns at 40 ticks/us */
        assert_int_equal(p->outlier_ticks, 104u); /* 2600 ns */
        assert_int_equal(f.node.req_period_us, 1500u);
        assert_int_equal(f.node.req_lead_us, 7u);
        assert_int_equal(f.node.req_enable, enabled);
        assert_int_equal(p->req_ack, f.node.req_seq);
        assert_int_equal(p->nominal_q8, 60000u * 256u);
        assert_int_equal(p->period_q8, 60000u * 256u);
        assert_int_equal(p->fixed_lead, 7u * 40u);
        assert_int_equal(p->state, enabled ? URB_NODE_SYNC_FREE : URB_NODE_SYNC_OFF);
        urb_node_sync_status_t st;
        urb_node_sync_status(&f.node, &st);
        assert_int_equal(st.last_beat, t0);
        assert_int_equal(f.port.compare, t0 + 60000u);
        assert_int_equal(p->next_frac, 0u);
    }
}

/* The signed tick distance at and around the wrap: half the counter range either way. */
static void tick_diff_at_the_wrap(void **state)
{
    (void)state;
    assert_int_equal(urb_tick_diff(5u, 5u), 0);
    assert_int_equal(urb_tick_diff(0u, 1u), -1);
    assert_int_equal(urb_tick_diff(1u, 0xFFFFFFFFu), 2);
    assert_int_equal(urb_tick_diff(0x7FFFFFFFu, 0u), INT32_MAX);
    assert_int_equal(urb_tick_diff(0x80000000u, 0u), INT32_MIN);
    assert_int_equal(urb_tick_diff(0u, 0x7FFFFFFFu), -INT32_MAX);
    assert_int_equal(urb_tick_diff(0u, 0x80000001u), INT32_MAX);
}

/* Marks the acquisition end `elapsed` ticks after the update's heartbeat, as app_update would. */
static void mark_after(fixture_t *f, uint32_t elapsed)
{
    f->node.flags = (uint8_t)(f->node.flags | URB_F_IN_UPDATE | URB_F_ACQ_VALID);
    f->node.flags = (uint8_t)(f->node.flags & (uint8_t)~URB_F_ACQ_MARKED);
    f->node.update_beat = 7000u;
    f->port.now = 7000u + elapsed;
    urb_node_mark_acquired(&f->node);
}

/* t_acq's sample limits: an acquisition ending one tick before the next heartbeat is measured, one
 * ending on it is not; a sample one tick above the window's maximum raises it. */
/* lobster-trace: urb.SYN_004 */
static void acquisition_sample_limits(void **state)
{
    fixture_t *f = *state;
    uint32_t const guard = f->node.cfg->acq_guard_us * f->node.cfg->ticks_per_us;
    assert_int_equal(f->node.pll.period_q8 >> 8, PERIOD);
    mark_after(f, PERIOD);
    assert_int_equal(f->node.acq_ticks, 0u);
    assert_int_equal(f->node.acq_count, 0u);
    mark_after(f, PERIOD - 1u);
    assert_int_equal(f->node.acq_ticks, PERIOD - 1u + guard);
    assert_int_equal(f->node.acq_win, PERIOD - 1u + guard);
    assert_int_equal(f->node.acq_count, 1u);
    f->node.acq_ticks = 100u;
    f->node.acq_win = 100u;
    mark_after(f, 101u - guard);
    assert_int_equal(f->node.acq_ticks, 101u);
    assert_int_equal(f->node.acq_win, 101u);
    assert_int_equal(f->node.acq_count, 2u);
    assert_int_equal(f->port.mark_count[URB_NODE_MARK_ACQ_END], 3u);
    assert_true((f->node.flags & URB_F_ACQ_MARKED) != 0u);
    urb_node_mark_acquired(&f->node); /* marked already: nothing more */
    assert_int_equal(f->node.acq_count, 2u);
    assert_int_equal(f->port.mark_count[URB_NODE_MARK_ACQ_END], 3u);
    /* the limit is the period estimate, not the nominal period */
    f->node.pll.period_q8 = (PERIOD + 10u) << 8;
    mark_after(f, PERIOD + 5u);
    assert_int_equal(f->node.acq_ticks, PERIOD + 5u + guard);
    assert_int_equal(f->node.acq_count, 3u);
}

static void update_without_mark(fixture_t *f)
{
    (void)f; /* an application that does not mark its acquisition end */
}

/* After app_update the update's flag is cleared: a mark from outside it does nothing. Two updates
 * due (a missed heartbeat) while the interrupt has counted 255 OVERRUNs not yet delivered: one
 * OVERRUN is delivered in that poll, and the count is caught up. */
static void update_flag_and_overrun_delivery(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    f->on_update = update_without_mark;
    node->update_due = (uint8_t)(node->update_done + 1u);
    (void)urb_node_poll(node);
    assert_int_equal(f->updates, 1u);
    urb_node_mark_acquired(node);
    assert_int_equal(f->port.mark_count[URB_NODE_MARK_ACQ_END], 0u);
    assert_int_equal(node->acq_count, 0u);
    uint8_t const i = URB_NODE_FAULT_OVERRUN - 1u;
    node->isr_faults[i] = (uint8_t)(node->seen_faults[i] + 255u);
    node->update_due = (uint8_t)(node->update_done + 2u);
    unsigned const before = f->faults[URB_NODE_FAULT_OVERRUN];
    (void)urb_node_poll(node);
    assert_int_equal(f->updates, 2u);
    assert_int_equal(f->faults[URB_NODE_FAULT_OVERRUN], before + 1u);
    assert_int_equal(node->seen_faults[i], node->isr_faults[i]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(locks_and_measures_period, setup),
        cmocka_unit_test_setup(missed_and_duplicate_syncs, setup),
        cmocka_unit_test_setup(outliers_rejected_then_reacquired, setup),
        cmocka_unit_test_setup(lost_sync_free_runs, setup),
        cmocka_unit_test(disabled_and_fixed_lead),
        cmocka_unit_test_setup(timer_stall_is_harmless, setup),
        cmocka_unit_test_setup(silence_too_long_to_measure, setup),
        cmocka_unit_test(two_nodes_beat_table1),
        cmocka_unit_test(two_nodes_outage),
        cmocka_unit_test_setup(locks_after_exactly_lock_count_syncs, setup),
        cmocka_unit_test_setup(late_interrupt_rearms_a_full_microsecond_ahead, setup),
        cmocka_unit_test(sync_step_matches_reference_model),
        cmocka_unit_test(timer_step_matches_reference_model),
        cmocka_unit_test(start_applies_the_configuration),
        cmocka_unit_test(tick_diff_at_the_wrap),
        cmocka_unit_test_setup(acquisition_sample_limits, setup),
        cmocka_unit_test_setup(update_flag_and_overrun_delivery, setup),
    };
    return cmocka_run_group_tests_name("node_pll", tests, NULL, NULL);
}
