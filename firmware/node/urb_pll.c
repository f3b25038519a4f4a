/*
 * Heartbeat timer locked to the downlink SYNC: the paper's PLL (Sec. V-E, Fig. 10).
 *
 *   eq. 1   That_d[k+1] = That_d[k] - K_d (That_d[k] - T_d)         period estimate
 *   eq. 2   T[k+1]      = That_d[k+1] - K_n (t_n - t_d + dt_adj)     next node period
 *
 * t_d is the tick of the SYNC's general-call address match, T_d the measured SYNC period (the
 * counter turns a gap of m SYNCs into T_d = (t_d - t_d_prev) / m), t_n the latest node heartbeat,
 * dt_adj the phase lead (the measured acquisition time t_acq unless configured), so that the
 * END of acquisition lands on the SYNC. T[k+1] replaces the period in progress: the SYNC comes
 * dt_adj after t_n, so the pending compare is simply moved to t_n + T[k+1].
 *
 * Fixed point, no float (Cortex-M0+ has no FPU): periods and phases are ticks * 256 (Q8) in 32
 * bits, gains are Q8 (K = k_q8 / 256). The heartbeat compare is an integer tick; the fraction
 * is carried to the next period so the average period keeps the 1/256-tick resolution.
 * Valid for periods below 2^21 ticks (43 ms at 48 MHz), checked by urb_node_init: then a phase
 * error, a lead step and the error the last correction left add up within int32 (at 2^23 ticks
 * they overflowed; proofs/bmc/fw_node_pll_update proves the bound by induction).
 *
 * Beyond the paper (all configurable, urb_node_config_t):
 *   - acquisition: the first SYNC (after start or a loss) jumps the phase (K_n = 1 once), and the
 *     period filter starts with K_d = 1 and halves it per SYNC down to K_d ("gear shifting"), so
 *     the estimate is the running mean while it has few samples;
 *   - missed SYNCs: the counter gap m divides the measured interval (up to max_gap);
 *   - outliers: a period sample or phase error beyond outlier_ns is ignored while tracking;
 *     max_outliers in a row mean the bus phase really moved: re-acquire;
 *   - lost sync: lost_sync_beats heartbeats without SYNC: free-run at the last period estimate,
 *     fault LOST_SYNC, Identification.synced cleared.
 *
 * Both entry points run in interrupts of equal priority (urb_node_hal.h): the timer compare
 * (urb_node_timer_event) and the SYNC's counter byte (urb_pll_sync, from the I2C event).
 * The main loop only posts requests (req_*), applied by the timer interrupt.
 *
 * Seeded bugs for the mutant check: URB_MUTANT_PLL_NO_PHASE (K_n = 0: frequency lock only),
 * URB_MUTANT_NO_LOST_SYNC (never declares a lost sync).
 */
#include "urb_node_internal.h"

#define URB_PLL_ONE 256u       /* 1.0 in Q8 */
#define URB_PLL_MAX_GEAR 8u    /* 256 >> 8 = 1: below any kd_q8 */
#define URB_PLL_MAX_TICKS 0x1FFFFFu /* periods below 2^21 ticks keep every Q8 sum in int32 */
#define URB_PLL_MIN_TICKS 64u       /* shortest period accepted (config, SYNC_CONFIG) */

int32_t urb_tick_diff(uint32_t a, uint32_t b)
{
    uint32_t const d = a - b;
    if (d <= 0x7FFFFFFFu) {
        return (int32_t)d;
    }
    return -(int32_t)(~d) - 1; /* d - 2^32 without an implementation-defined conversion */
}

static uint32_t abs32(int32_t x)
{
    return (x < 0) ? ((uint32_t)(-(x + 1)) + 1u) : (uint32_t)x;
}

/* round(x * k / 256) for k <= 256, rounding half away from zero (no bias either way); no overflow
 * for any int32 x. */
static int32_t mul_q8(int32_t x, uint16_t k)
{
    if (k >= URB_PLL_ONE) {
        return x;
    }
    uint32_t const mag = abs32(x);
    uint32_t const r = ((mag >> 8) * k) + ((((mag & 0xFFu) * k) + 128u) >> 8);
    return (x < 0) ? -(int32_t)r : (int32_t)r;
}

/* floor(x / 256) without the implementation-defined right shift of a negative number. */
static int32_t floor_q8(int32_t x)
{
    if (x >= 0) {
        return (int32_t)((uint32_t)x >> 8);
    }
    return -(int32_t)((uint32_t)(-(x + 1)) >> 8) - 1;
}

/* Arms the pending heartbeat, at least 1 us from now (an interrupt delayed past it fires at once). */
static void arm(urb_node_t *node)
{
    urb_node_hal_t const *hal = node->hal;
    urb_node_pll_t *pll = &node->pll;
    uint32_t const now = hal->now(hal->ctx);
    uint32_t const margin = node->cfg->ticks_per_us;
    if (urb_tick_diff(pll->next_beat, now) < (int32_t)margin) {
        pll->next_beat = now + margin;
        pll->next_frac = 0u;
    }
    hal->set_compare(hal->ctx, pll->next_beat);
}

/* Moves the pending heartbeat to ref + off_q8 / 256 (ref: an integer tick with fraction ref_frac).
 * With `skip`, a time already past (a phase jump backwards during acquisition) moves one period
 * on instead: the heartbeat keeps the right phase and skips a beat rather than firing late. */
static void schedule(urb_node_t *node, uint32_t ref, uint8_t ref_frac, int32_t off_q8, bool skip)
{
    urb_node_pll_t *pll = &node->pll;
    int32_t total = (int32_t)ref_frac + off_q8;
    if (skip) {
        urb_node_hal_t const *hal = node->hal;
        int32_t const ahead = urb_tick_diff(ref + (uint32_t)floor_q8(total), hal->now(hal->ctx));
        if (ahead < (int32_t)node->cfg->ticks_per_us) {
            total += (int32_t)pll->period_q8;
        }
    }
    int32_t const whole = floor_q8(total);
    pll->next_beat = ref + (uint32_t)whole; /* modular: a negative whole moves back */
    pll->next_frac = (uint8_t)((uint32_t)total & 0xFFu);
    arm(node);
}

/* Restarts acquisition: the next SYNC jumps the phase, the period filter restarts in gear 0. */
/* lobster-trace: urb.SYN_006 */
static void reacquire(urb_node_pll_t *pll, uint8_t state)
{
    pll->state = state;
    pll->have_prev = 0u;
    pll->gear = 0u;
    pll->good = 0u;
    pll->outliers = 0u;
    pll->expect_q8 = 0;
}

/* The period of `gap` SYNCs over `delta` ticks, Q8, or false when the interval is too long to
 * represent (2^24 ticks: 8 missed SYNCs of 2 M ticks). */
static bool measure(uint32_t delta, uint8_t gap, uint32_t *td_q8)
{
    if (delta > 0xFFFFFFu) {
        return false;
    }
    /* missed SYNCs: one division (software on Cortex-M0+, bounded); one SYNC: a shift */
    *td_q8 = (gap > 1u) ? ((delta << 8) / gap) : (delta << 8);
    return *td_q8 <= (URB_PLL_MAX_TICKS << 8);
}

/* eq. 1 with gear shifting and outlier rejection. */
/* lobster-trace: urb.SYN_003, urb.SYN_005 */
static void update_period(urb_node_t *node, uint32_t t_d, uint8_t gap)
{
    urb_node_pll_t *pll = &node->pll;
    uint32_t td_q8 = 0u;
    if ((gap > node->cfg->max_gap) || !measure(t_d - pll->prev_sync, gap, &td_q8)) {
        return; /* too many SYNCs missed to trust the interval: phase only */
    }
    int32_t const err = (int32_t)td_q8 - (int32_t)pll->period_q8; /* T_d - That_d */
    /* In gear 0 the estimate is only the nominal period: accept +-12.5 % (crystal, bridge setting). */
    uint32_t const window = (pll->gear == 0u) ? (pll->nominal_q8 >> 3) : ((uint32_t)pll->outlier_ticks << 8);
    if (abs32(err) > window) {
        pll->rejected++;
        return;
    }
    uint16_t const shifted = (uint16_t)(URB_PLL_ONE >> pll->gear);
    uint16_t const kd = (shifted > node->cfg->kd_q8) ? shifted : node->cfg->kd_q8;
    /* eq. 1: That_d[k+1] = That_d[k] - K_d (That_d[k] - T_d) */
    pll->period_q8 = (uint32_t)((int32_t)pll->period_q8 + mul_q8(err, kd));
    if (pll->gear < URB_PLL_MAX_GEAR) {
        pll->gear++;
    }
}

/* t_n - t_d + dt_adj in ticks, clamped to +-period (a stalled timer cannot overflow phase * 256).
 * The lead is added to t_n in modular tick arithmetic, so no capture, however bogus (a timer that
 * jumped: t_n - t_d near 2^31), can overflow the sum (fw_node_pll_update found that overflow). */
static int32_t phase_of(uint32_t t_n, uint32_t t_d, uint32_t lead, int32_t period)
{
    int32_t const phase = urb_tick_diff(t_n + lead, t_d);
    return (phase > period) ? period : ((phase < -period) ? -period : phase);
}

/* lobster-trace: urb.SYN_001, urb.SYN_002, urb.SYN_005, urb.WCET_002 */
void urb_pll_sync(urb_node_t *node, uint32_t t_d, uint8_t counter)
{
    urb_node_pll_t *pll = &node->pll;
    urb_node_config_t const *cfg = node->cfg;
    if (pll->state == URB_NODE_SYNC_OFF) {
        return;
    }
    if (pll->have_prev != 0u) {
        uint8_t const gap = (uint8_t)(counter - pll->prev_counter);
        if (gap == 0u) {
            pll->rejected++; /* the same SYNC twice */
            return;
        }
        update_period(node, t_d, gap);
    }
    pll->prev_sync = t_d;
    pll->prev_counter = counter;
    pll->have_prev = 1u;
    pll->quiet = 0u;

    /* dt_adj: configured lead, else the measured acquisition time; at most a quarter period */
    int32_t const period = (int32_t)(pll->period_q8 >> 8);
    uint32_t lead = (pll->fixed_lead != 0u) ? pll->fixed_lead : node->acq_ticks;
    if (lead > ((uint32_t)period >> 2)) {
        lead = (uint32_t)period >> 2; /* keeps the acquisition jump and every phase in range */
    }
    int32_t const lead_step = (int32_t)lead - (int32_t)pll->lead_prev;

    /* phase error of t_n, the latest heartbeat: t_n - t_d + dt_adj (Q8, with t_n's fraction) */
    int32_t const phase = phase_of(pll->last_beat, t_d, lead, period);
    int32_t const phase_q8 = (phase * 256) + (int32_t)pll->last_frac;
    int32_t const step_q8 = lead_step * 256; /* the part of the error a lead change explains */
    pll->phase_q8 = phase_q8;
    if (pll->state == URB_NODE_SYNC_FREE) {
        /* acquisition: one phase jump, the next heartbeat straight to t_d - dt_adj + That_d
         * (a period later when that is already past: a skipped beat, never a short one) */
        pll->state = URB_NODE_SYNC_TRACK;
        pll->good = 0u;
        pll->expect_q8 = 0;
        pll->lead_prev = lead;
        pll->syncs++;
#if defined(URB_MUTANT_PLL_NO_PHASE)
        schedule(node, pll->last_beat, pll->last_frac, (int32_t)pll->period_q8, true);
#else
        schedule(node, t_d, 0u, (int32_t)pll->period_q8 - (int32_t)(lead << 8), true);
#endif
        return;
    }
    if (abs32(floor_q8(phase_q8 - step_q8 - pll->expect_q8)) > pll->outlier_ticks) {
        /* the error is not what the last correction left: a late or early SYNC, ignored */
        pll->rejected++;
        pll->outliers++;
        if (pll->outliers > cfg->max_outliers) {
            reacquire(pll, URB_NODE_SYNC_FREE); /* the bus phase really moved */
        }
        return;
    }
    /* lock detection with 2x hysteresis */
    uint32_t const err = abs32(phase);
    if (err <= pll->lock_ticks) {
        if (pll->good < cfg->lock_count) {
            pll->good++;
        }
        if (pll->good >= cfg->lock_count) {
            pll->state = URB_NODE_SYNC_LOCKED;
        }
    } else {
        pll->good = 0u;
        if (err > ((uint32_t)pll->lock_ticks << 1)) {
            pll->state = URB_NODE_SYNC_TRACK;
        }
    }
    pll->outliers = 0u;
    pll->lead_prev = lead;
    pll->syncs++;
    uint16_t kn = cfg->kn_q8;
#if defined(URB_MUTANT_PLL_NO_PHASE)
    kn = 0u;
#endif
    /* K_n on the measured error; a change of dt_adj itself is applied at once (the paper keeps
     * dt_adj constant; ours follows the measured t_acq, whose steps are deliberate, not noise) */
    int32_t const corr_q8 = mul_q8(phase_q8 - step_q8, kn) + step_q8;
    pll->expect_q8 = phase_q8 - corr_q8; /* the error this correction leaves for the next SYNC */
    /* eq. 2: T[k+1] = That_d[k+1] - K_n (t_n - t_d + dt_adj), the period following t_n */
    schedule(node, pll->last_beat, pll->last_frac, (int32_t)pll->period_q8 - corr_q8, true);
}

/* Applies a configuration request posted by the main loop (SYNC_CONFIG). */
static void apply_request(urb_node_t *node)
{
    urb_node_pll_t *pll = &node->pll;
    uint32_t const tpu = node->cfg->ticks_per_us;
    uint32_t const ticks = (uint32_t)node->req_period_us * tpu;
    if ((ticks >= URB_PLL_MIN_TICKS) && (ticks <= URB_PLL_MAX_TICKS)) {
        pll->nominal_q8 = ticks << 8; /* 0 or out of range: keep the current nominal period */
    }
    pll->period_q8 = pll->nominal_q8;
    pll->fixed_lead = (uint32_t)node->req_lead_us * tpu;
    pll->lead_prev = 0u;
    reacquire(pll, (node->req_enable != 0u) ? URB_NODE_SYNC_FREE : URB_NODE_SYNC_OFF);
    pll->req_ack = node->req_seq;
}

/* lobster-trace: urb.SYN_006, urb.WCET_002 */
void urb_node_timer_event(urb_node_t *node)
{
    if ((node == NULL) || (node->started == 0u)) {
        return;
    }
    urb_node_pll_t *pll = &node->pll;
    urb_node_hal_t const *hal = node->hal;
    if (node->req_seq != pll->req_ack) {
        apply_request(node);
    }
    uint32_t const t_n = pll->next_beat; /* the compare that fired: exact, no latency */
    pll->last_beat = t_n;
    pll->last_frac = pll->next_frac;
    /* free-run one period (That_d); the next SYNC moves it by eq. 2 */
    schedule(node, t_n, pll->last_frac, (int32_t)pll->period_q8, false);
    if (hal->mark != NULL) {
        hal->mark(hal->ctx, URB_NODE_MARK_BEAT);
    }
    if (pll->quiet < 0xFFu) {
        pll->quiet++;
    }
#if !defined(URB_MUTANT_NO_LOST_SYNC)
    if ((pll->state >= URB_NODE_SYNC_TRACK) && (pll->quiet >= node->cfg->lost_sync_beats)) {
        reacquire(pll, URB_NODE_SYNC_FREE); /* free-run at the last period estimate, keep it */
        pll->gear = URB_PLL_MAX_GEAR;       /* ...and keep filtering it at K_d when SYNC returns */
        urb_isr_fault(node, URB_NODE_FAULT_LOST_SYNC);
    }
#endif
    node->div++;
    if (node->div >= node->cfg->update_divider) {
        node->div = 0u;
        node->update_beat = t_n;
        node->update_due = (uint8_t)(node->update_due + 1u);
    }
}

void urb_pll_start(urb_node_t *node)
{
    urb_node_pll_t *pll = &node->pll;
    urb_node_config_t const *cfg = node->cfg;
    pll->lock_ticks = (uint16_t)(((uint32_t)cfg->lock_ns * cfg->ticks_per_us) / 1000u); /* <= 65535 */
    pll->outlier_ticks = (uint16_t)(((uint32_t)cfg->outlier_ns * cfg->ticks_per_us) / 1000u);
    /* the configuration is the first request (urb_node_init checked the period) */
    node->req_period_us = cfg->heartbeat_us;
    node->req_lead_us = cfg->lead_us;
    node->req_enable = cfg->sync_enabled;
    apply_request(node);
    urb_node_hal_t const *hal = node->hal;
    uint32_t const now = hal->now(hal->ctx);
    pll->last_beat = now;
    schedule(node, now, 0u, (int32_t)pll->period_q8, false); /* first heartbeat one period after start */
}

void urb_node_sync_status(const urb_node_t *node, urb_node_sync_status_t *out)
{
    if ((node == NULL) || (out == NULL)) {
        return;
    }
    urb_node_pll_t const *pll = &node->pll;
    out->state = (urb_node_sync_t)pll->state;
    out->period_q8 = pll->period_q8;
    out->phase_q8 = pll->phase_q8;
    out->lead_ticks = pll->lead_prev;
    out->acq_ticks = node->acq_ticks;
    out->last_beat = pll->last_beat;
    out->syncs = pll->syncs;
    out->rejected = pll->rejected;
}

bool urb_node_synced(const urb_node_t *node)
{
    return (node != NULL) && (node->pll.state == URB_NODE_SYNC_LOCKED);
}
