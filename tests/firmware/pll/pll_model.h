/*
 * Deterministic host model for tuning and checking the heartbeat PLL (firmware/node/urb_pll.c):
 * a bridge broadcasting SYNC every period and N nodes running the REAL node library, each on its
 * own clock, all in one process in virtual time (no real time, no threads).
 *
 * Clock model (the one sim/core/clock.h documents for the simulation, simplified to what matters
 * here): local time runs at rate 1 + e(t), e = ppm0 + ramp * t + w(t), w an Ornstein-Uhlenbeck
 * wander held constant over 100-ms segments; the timer counts floor(local seconds * 48 MHz); an
 * interrupt starts irq_base + U(0..irq_jitter) core cycles after its cause. A compare at tick C
 * fires when the counter reaches C. The SYNC's general-call address match happens at a bus instant
 * t_hw common to all nodes (the bridge's own latency and the 9 bit times of the address byte are
 * common-mode); with `capture` the node's t_d is the tick latched at t_hw, without it the tick at
 * its interrupt. The main loop sleeps between interrupts (urb_node_has_work + WFI), so app_update
 * starts main_latency_ns + U(0..main_jitter) cycles after the heartbeat; acquisition takes
 * acq_ns + U(0..acq_jitter) cycles and ends with the release of outbox 1 (t_acq_end).
 *
 * Metrics, as in the paper's Table I (Sec. VI-C), on t_acq_end:
 *   convergence: from the last node's power-on to the first SYNC after which the inter-node
 *                difference of t_acq_end stays below 1 us until the end of the run (or the
 *                outage) and every node is within 1 us of its steady phase;
 *   inter-node:  |t_acq_end(node i) - t_acq_end(node j)| per SYNC, steady state (mean and max);
 *   jitter:      deviation of one node's t_acq_end period from its mean, steady state (sd, max).
 */
#ifndef PLL_MODEL_H
#define PLL_MODEL_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_node.h"

#define PLL_MAX_NODES 8u

typedef struct {
    double ppm0;              /* static crystal error */
    double ramp_ppm_per_s;    /* deterministic drift */
    double wander_ppm;        /* OU wander sd */
    double start_ns;          /* power-on time */
    unsigned irq_base_cycles; /* interrupt entry */
    unsigned irq_jitter_cycles;
    double main_latency_ns;   /* heartbeat -> app_update start (timer ISR + wake-up) */
    unsigned main_jitter_cycles;
    double acq_ns;            /* acquisition time */
    unsigned acq_jitter_cycles;
    bool capture;             /* hardware capture of the SYNC address match */
} pll_node_params_t;

typedef struct {
    unsigned nodes;
    double duration_ns;
    double sync_period_ns;    /* bridge heartbeat, nominal */
    double bridge_ppm;        /* bridge crystal error */
    unsigned bridge_jitter_cycles; /* bridge timer-interrupt jitter (common to all nodes) */
    double drop_prob;         /* a SYNC is lost (corrupted address byte) */
    double late_prob;         /* a SYNC comes late (bus busy) ... */
    double late_max_ns;       /* ... by up to this */
    double outage_start_ns;   /* no SYNC in [start, start + len) (0 len: none) */
    double outage_len_ns;
    uint64_t seed;
    urb_node_config_t cfg;    /* node configuration (PLL gains) */
    pll_node_params_t node[PLL_MAX_NODES];
} pll_scenario_t;

typedef struct {
    bool converged;
    double converge_ns;       /* see above */
    double diff_mean_ns;      /* inter-node, steady state */
    double diff_max_ns;
    double jitter_sd_ns;      /* worst node */
    double jitter_max_ns;     /* worst node: max |period - mean| */
    double relock_ns;         /* after the outage: SYNC back -> synced again (0: no outage) */
    double freerun_drift_ns;  /* during the outage: largest |phase drift| of a node */
    unsigned lost_sync_faults;/* LOST_SYNC faults delivered, all nodes */
    unsigned overruns;        /* OVERRUN faults delivered, all nodes */
    unsigned syncs_sent;
    bool all_synced_at_end;
} pll_result_t;

/* A scenario with the defaults: 2 nodes +-100 ppm class errors from the seed, 1 kHz SYNC, capture. */
void pll_default_scenario(pll_scenario_t *sc, uint64_t seed);

/* Runs the scenario; returns 0 on success (-1: bad scenario). */
int pll_run(const pll_scenario_t *sc, pll_result_t *out);

#endif /* PLL_MODEL_H */
