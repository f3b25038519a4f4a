/*
 * PLL harness: runs the two-node model (pll_model.h) over 20 seeds per scenario with the
 * library's default configuration and prints the paper's Table I metrics next to the paper's
 * numbers. `pll_harness --tune` sweeps K_n and K_d (how the defaults were chosen).
 *
 *   build/firmware/node/pll_harness            (make pll-harness)
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pll_model.h"

#define SEEDS 20u

typedef struct {
    const char *name;
    void (*tweak)(pll_scenario_t *sc);
} scenario_t;

static void s_clean(pll_scenario_t *sc)
{
    (void)sc;
}

static void s_faulty(pll_scenario_t *sc)
{
    sc->drop_prob = 0.05;   /* 5 % of SYNCs lost */
    sc->late_prob = 0.02;   /* 2 % late by up to 30 us (bus busy) */
    sc->late_max_ns = 30000.0;
}

static void s_outage(pll_scenario_t *sc)
{
    sc->duration_ns = 2.0e9;
    sc->outage_start_ns = 0.8e9; /* 50 ms without SYNC */
    sc->outage_len_ns = 50e6;
}

static void s_no_capture(pll_scenario_t *sc)
{
    for (unsigned i = 0u; i < PLL_MAX_NODES; i++) {
        sc->node[i].capture = false; /* t_d read in the ISR: + irq latency jitter */
    }
}

static void s_extreme(pll_scenario_t *sc)
{
    sc->bridge_ppm = 100.0;
    sc->node[0].ppm0 = -100.0;
    sc->node[1].ppm0 = 100.0;
    for (unsigned i = 0u; i < PLL_MAX_NODES; i++) {
        sc->node[i].ramp_ppm_per_s = 1.0;
        sc->node[i].wander_ppm = 0.5;
    }
}

static void s_six(pll_scenario_t *sc)
{
    sc->nodes = 6u; /* a SensoRHex bus: several motor nodes */
}

static const scenario_t scenarios[] = {
    {"clean (2 nodes, +-100 ppm, capture)", s_clean},
    {"5% SYNC lost, 2% late <= 30 us", s_faulty},
    {"50 ms SYNC outage at 0.8 s", s_outage},
    {"no hardware capture (t_d in ISR)", s_no_capture},
    {"+-100 ppm extremes, 1 ppm/s ramp", s_extreme},
    {"6 nodes", s_six},
};

typedef struct {
    double conv_sum, conv_max, diff_sum, diff_max, jit_sum, jit_max, jpk_max, relock_max, drift_max;
    unsigned failures, lost, overruns;
} agg_t;

static void run_set(const urb_node_config_t *cfg, void (*tweak)(pll_scenario_t *), agg_t *a, unsigned seeds)
{
    memset(a, 0, sizeof *a);
    for (unsigned s = 1u; s <= seeds; s++) {
        pll_scenario_t sc;
        pll_default_scenario(&sc, s);
        if (cfg != NULL) {
            uint8_t const addr = sc.cfg.i2c_address;
            sc.cfg = *cfg;
            sc.cfg.i2c_address = addr;
        }
        tweak(&sc);
        pll_result_t r;
        if (pll_run(&sc, &r) != 0 || !r.converged || !r.all_synced_at_end) {
            a->failures++;
            continue;
        }
        a->conv_sum += r.converge_ns;
        a->conv_max = fmax(a->conv_max, r.converge_ns);
        a->diff_sum += r.diff_mean_ns;
        a->diff_max = fmax(a->diff_max, r.diff_max_ns);
        a->jit_sum += r.jitter_sd_ns;
        a->jit_max = fmax(a->jit_max, r.jitter_sd_ns);
        a->jpk_max = fmax(a->jpk_max, r.jitter_max_ns);
        a->relock_max = fmax(a->relock_max, r.relock_ns);
        a->drift_max = fmax(a->drift_max, r.freerun_drift_ns);
        a->lost += r.lost_sync_faults;
        a->overruns += r.overruns;
    }
}

static void tune(void)
{
    static const uint8_t kns[] = {32u, 64u, 96u, 128u, 160u, 192u, 224u};
    static const uint8_t kds[] = {8u, 16u, 32u, 64u, 128u};
    printf("| K_n | K_d | conv avg ms (clean) | conv max ms | diff avg ns | jitter sd avg ns | conv avg ms (faulty) | diff avg ns (faulty) | fail |\n");
    printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (size_t i = 0u; i < sizeof kns; i++) {
        for (size_t j = 0u; j < sizeof kds; j++) {
            urb_node_config_t cfg;
            urb_node_config_default(&cfg);
            cfg.kn_q8 = kns[i];
            cfg.kd_q8 = kds[j];
            agg_t c, f;
            run_set(&cfg, s_clean, &c, 10u);
            run_set(&cfg, s_faulty, &f, 10u);
            unsigned const nc = 10u - c.failures, nf = 10u - f.failures;
            printf("| %u/256 | %u/256 | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %u |\n", kns[i], kds[j],
                   nc ? c.conv_sum / nc / 1e6 : -1.0, c.conv_max / 1e6, nc ? c.diff_sum / nc : -1.0,
                   nc ? c.jit_sum / nc : -1.0, nf ? f.conv_sum / nf / 1e6 : -1.0, nf ? f.diff_sum / nf : -1.0,
                   c.failures + f.failures);
        }
    }
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "--tune") == 0) {
        tune();
        return 0;
    }
    urb_node_config_t cfg;
    urb_node_config_default(&cfg);
    printf("PLL harness: %u seeds per scenario, defaults K_n = %u/256, K_d = %u/256, lock %u ns x %u, "
           "outliers %u ns x %u, lost after %u beats\n\n",
           SEEDS, cfg.kn_q8, cfg.kd_q8, cfg.lock_ns, cfg.lock_count, cfg.outlier_ns, cfg.max_outliers,
           cfg.lost_sync_beats);
    printf("| scenario | convergence avg / max (ms) | inter-node avg / max (us) | jitter sd avg / max (us) | "
           "jitter peak (us) | re-lock max (ms) | free-run drift (us) | LOST_SYNC | OVERRUN | fail |\n");
    printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    printf("| paper, Table I (2 nodes, oscilloscope) | 78.4 / 88.4 | 0.19 / 0.56 | 0.92 / 1.33 | | | | | | |\n");
    int status = 0;
    for (size_t i = 0u; i < sizeof scenarios / sizeof scenarios[0]; i++) {
        agg_t a;
        run_set(NULL, scenarios[i].tweak, &a, SEEDS);
        unsigned const n = SEEDS - a.failures;
        if (n == 0u) {
            printf("| %s | all %u runs failed |\n", scenarios[i].name, SEEDS);
            status = 1;
            continue;
        }
        printf("| %s | %.1f / %.1f | %.3f / %.3f | %.3f / %.3f | %.3f | %.1f | %.2f | %u | %u | %u |\n",
               scenarios[i].name, a.conv_sum / n / 1e6, a.conv_max / 1e6, a.diff_sum / n / 1e3, a.diff_max / 1e3,
               a.jit_sum / n / 1e3, a.jit_max / 1e3, a.jpk_max / 1e3, a.relock_max / 1e6, a.drift_max / 1e3, a.lost,
               a.overruns, a.failures);
        if (a.failures != 0u) {
            status = 1;
        }
    }
    printf("\nInter-node: |t_acq_end(i) - t_acq_end(j)| per SYNC; jitter: sd of one node's t_acq_end period "
           "(peak: largest |period - mean|); both in steady state (from convergence + 100 ms).\n");
    return status;
}
