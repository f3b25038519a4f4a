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
    };
    return cmocka_run_group_tests_name("node_pll", tests, NULL, NULL);
}
