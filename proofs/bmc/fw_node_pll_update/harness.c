/*
 * Proof: the heartbeat PLL update (urb_pll_sync in firmware/node/urb_pll.c: eq. 1 period
 * estimate, eq. 2 next period, Q8 fixed point), run by the I2C interrupt on a SYNC's counter byte;
 * and on another path the heartbeat timer interrupt (urb_node_timer_event: a pending
 * SYNC_CONFIG request, the free-running period, lost-sync detection).
 *
 * An inductive proof: the PLL state is ARBITRARY within the invariant below (so every state any
 * sequence of SYNCs, heartbeats and requests can reach is covered, not only short sequences),
 * one entry point runs on ARBITRARY inputs, and the invariant must hold again afterwards.
 *
 * Inputs (the full range the HAL and the bus can give):
 *   t_d, counter       any 32-bit capture tick, any 8-bit SYNC counter
 *   hal->now()         any 32-bit tick at every call (the timer may have wrapped, stalled, jumped)
 *   configuration      whatever urb_node_init accepts (config_valid): ticks_per_us 1..1000,
 *                      heartbeat 64 .. 2^21 - 1 ticks, every gain, threshold and count
 *   requests           any SYNC_CONFIG fields (period_us, lead_us, enable), any measured t_acq
 *
 * Invariant (the documented ranges; assumed before, asserted after):
 *   nominal_q8   = T << 8 with T in 64 .. 2^21 - 1 ticks (URB_PLL_MIN_TICKS .. URB_PLL_MAX_TICKS)
 *   period_q8    <= 2^21 - 1 ticks in Q8: the estimate That_d never leaves the range in which
 *                every Q8 sum fits int32. It has no lower bound but 0: SYNC intervals that each
 *                pass the outlier window can walk it down (reported, not a UB: nothing divides by it)
 *   lead_prev    <= period / 4 of some valid period (the lead clamp), so < 2^19 ticks
 *   expect_q8    |expect_q8| <= max |phase_q8| + max |step_q8|: the error the last correction left
 *   gear         <= 8; fixed_lead <= 65535 us * ticks_per_us
 * At the period limit of HEAD (2^23 ticks) this proof found signed overflows (t_n - t_d plus the
 * lead; phase error minus lead step minus the expected error); urb_pll.c now limits periods to 2^21
 * ticks (43 ms at 48 MHz) and adds the lead to t_n in modular tick arithmetic (mutant phase-sum-overflow).
 * Properties (besides bounds, pointers, signed overflow, shifts and division on every step):
 *   eq. 1        a period update moves That_d toward the measured T_d, never past it (full tier:
 *                the oracle's own 32-bit division doubles the solver time)
 *   compare      every set_compare is at least 1 us (ticks_per_us ticks) after the now() it read
 *   cost         one SYNC update within FW_PLL_SYNC_BUDGET, one timer event within
 *                FW_TIMER_EVENT_BUDGET (cycles at 48 MHz, HAL calls FW_HAL_CALL_CYCLES each,
 *                the software division FW_UDIV_CYCLES: views.json)
 * Cover points (URB_COVER, checked by the reach run): a SYNC that updates the period, one that
 * arms a compare, a first SYNC, one whose interval is not used; a heartbeat that applies a
 * pending request, one that makes an update due, one that reports a lost sync.
 */
#include "urb_verify.h"

#include "urb_node_internal.h"

#include "../stubs/fw_budgets.h"

#define FW_COST_BUDGET FW_PLL_SYNC_BUDGET

#define FW_MAX_TICKS 0x1FFFFFu /* URB_PLL_MAX_TICKS */
#define FW_MIN_TICKS 64u       /* URB_PLL_MIN_TICKS */
/* |expect_q8| <= |phase_q8 - step_q8| <= (MAX * 256 + 255) + (MAX / 4) * 256 */
#define FW_EXPECT_MAX ((int64_t)FW_MAX_TICKS * 256 + 255 + (int64_t)(FW_MAX_TICKS >> 2) * 256)

URB_PROOF_COST_STORAGE;

/* The view in views.json charges the software division through this (see FW_UDIV_CYCLES). */
const uint32_t fw_udiv_cycles = FW_UDIV_CYCLES;

static urb_node_t node;
static urb_node_config_t cfg;
static urb_node_hal_t hal;
static uint32_t last_now;    /* the latest now() the library read */
static uint8_t compares;     /* set_compare calls */
static uint8_t faults_lost;  /* LOST_SYNC faults counted */

static uint32_t hal_now(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    last_now = URB_NONDET_U32();
    return last_now;
}

static void hal_set_compare(void *ctx, uint32_t at)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    /* signed tick difference at - now >= 1 us, computed here (urb_tick_diff would add its cost) */
    uint32_t const ahead = at - last_now;
    URB_ASSERT((ahead >= cfg.ticks_per_us) && (ahead < 0x80000000u), "compare: at least 1 us ahead of now()");
    compares++;
}

static void hal_mark(void *ctx, urb_node_mark_t mark)
{
    (void)ctx;
    (void)mark;
    URB_COST(FW_HAL_CALL_CYCLES);
}

/* urb_node.c's fault counter (the interrupt side's only call out of urb_pll.c). */
void urb_isr_fault(urb_node_t *n, urb_node_fault_t code)
{
    URB_COST(24u);
    URB_ASSERT(code == URB_NODE_FAULT_LOST_SYNC, "the PLL reports LOST_SYNC only");
    n->isr_faults[2] = (uint8_t)(n->isr_faults[2] + 1u);
    faults_lost++;
}

/* A configuration urb_node_init accepts (config_valid). */
static void arbitrary_config(void)
{
    cfg.ticks_per_us = URB_NONDET_U16();
    URB_ASSUME((cfg.ticks_per_us >= 1u) && (cfg.ticks_per_us <= 1000u));
    cfg.heartbeat_us = URB_NONDET_U16();
    uint32_t const ticks = (uint32_t)cfg.heartbeat_us * cfg.ticks_per_us;
    URB_ASSUME((ticks >= FW_MIN_TICKS) && (ticks <= FW_MAX_TICKS));
    cfg.update_divider = URB_NONDET_U8();
    URB_ASSUME(cfg.update_divider >= 1u);
    cfg.lost_sync_beats = URB_NONDET_U8();
    URB_ASSUME(cfg.lost_sync_beats >= 2u);
    cfg.kd_q8 = URB_NONDET_U8();
    cfg.kn_q8 = URB_NONDET_U8();
    cfg.lock_count = URB_NONDET_U8();
    cfg.max_outliers = URB_NONDET_U8();
    cfg.max_gap = URB_NONDET_U8();
}

/* The invariant over the PLL state (see the top comment). */
static bool invariant(urb_node_pll_t const *pll)
{
    uint32_t const nominal = pll->nominal_q8 >> 8;
    return ((pll->nominal_q8 & 0xFFu) == 0u) && (nominal >= FW_MIN_TICKS) && (nominal <= FW_MAX_TICKS) &&
           (pll->period_q8 <= (FW_MAX_TICKS << 8)) && (pll->lead_prev <= (FW_MAX_TICKS >> 2)) &&
           ((int64_t)pll->expect_q8 <= FW_EXPECT_MAX) && ((int64_t)pll->expect_q8 >= -FW_EXPECT_MAX) && (pll->gear <= 8u) &&
           (pll->state <= (uint8_t)URB_NODE_SYNC_LOCKED) && (pll->fixed_lead <= 65535u * (uint32_t)cfg.ticks_per_us);
}

/* An arbitrary PLL state within the invariant. */
static void arbitrary_pll(void)
{
    urb_node_pll_t *pll = &node.pll;
    pll->period_q8 = URB_NONDET_U32();
    pll->nominal_q8 = URB_NONDET_U32();
    pll->next_beat = URB_NONDET_U32();
    pll->last_beat = URB_NONDET_U32();
    pll->prev_sync = URB_NONDET_U32();
    pll->phase_q8 = URB_NONDET_I32();
    pll->expect_q8 = URB_NONDET_I32();
    pll->fixed_lead = URB_NONDET_U32();
    pll->lead_prev = URB_NONDET_U32();
    pll->lock_ticks = URB_NONDET_U16();
    pll->outlier_ticks = URB_NONDET_U16();
    pll->syncs = URB_NONDET_U16();
    pll->rejected = URB_NONDET_U16();
    pll->next_frac = URB_NONDET_U8();
    pll->last_frac = URB_NONDET_U8();
    pll->state = URB_NONDET_U8();
    pll->gear = URB_NONDET_U8();
    pll->good = URB_NONDET_U8();
    pll->outliers = URB_NONDET_U8();
    pll->quiet = URB_NONDET_U8();
    pll->prev_counter = URB_NONDET_U8();
    pll->have_prev = URB_NONDET_BOOL() ? 1u : 0u;
    pll->req_ack = URB_NONDET_U8();
    URB_ASSUME(invariant(pll));
    node.acq_ticks = URB_NONDET_U32(); /* the main loop's measurement: any value (the lead clamps it) */
}

#if !defined(URB_TIER_FAST)
static uint32_t abs_diff(uint32_t a, uint32_t b)
{
    return (a > b) ? (a - b) : (b - a);
}
#endif

static void part_sync(void)
{
    urb_node_pll_t const *pll = &node.pll;
    uint32_t const t_d = URB_NONDET_U32();
    uint8_t const counter = URB_NONDET_U8();
    uint32_t const old_period = pll->period_q8;
    uint32_t const prev_sync = pll->prev_sync;
    uint8_t const gap = (uint8_t)(counter - pll->prev_counter);
    bool const had_prev = pll->have_prev != 0u;
    uint8_t const gear = pll->gear;

    URB_COST_BEGIN();
    urb_pll_sync(&node, t_d, counter);
    URB_COST_END(FW_COST_BUDGET);

    URB_ASSERT(invariant(pll), "invariant kept by a SYNC");
    URB_ASSERT(compares <= 1u, "at most one compare per SYNC");
    if (pll->period_q8 != old_period) {
        /* eq. 1 ran: T_d = (t_d - prev_sync) / gap ticks, That_d moved toward it, never past it */
        URB_ASSERT(had_prev && (gap >= 1u) && (gap <= cfg.max_gap), "eq. 1 only with a usable SYNC interval");
        uint32_t const delta = t_d - prev_sync;
        URB_ASSERT(delta <= 0xFFFFFFu, "eq. 1 only over a representable interval");
#if !defined(URB_TIER_FAST) /* the solver's second 32-bit division: full tier only (+90 s) */
        uint32_t const td_q8 = (delta << 8) / gap;
        URB_ASSERT(abs_diff(td_q8, pll->period_q8) < abs_diff(td_q8, old_period), "eq. 1: toward T_d");
        URB_ASSERT((pll->period_q8 >= old_period) == (td_q8 >= old_period), "eq. 1: never past T_d");
#endif
        URB_ASSERT((pll->gear == ((gear < 8u) ? (uint8_t)(gear + 1u) : 8u)) || (pll->gear == 0u),
                   "gear shifting: one step per update (0: the phase test then re-acquired)");
        URB_COVER("sync-updates-the-period");
    } else if (had_prev) {
        URB_COVER("sync-interval-not-used");
    }
    if (compares == 1u) {
        URB_COVER("sync-arms-a-compare");
    }
    if (!had_prev) {
        URB_COVER("first-sync");
    }
}

static void part_timer(void)
{
    urb_node_pll_t const *pll = &node.pll;
    node.req_seq = URB_NONDET_U8();
    node.req_period_us = URB_NONDET_U16();
    node.req_lead_us = URB_NONDET_U16();
    node.req_enable = URB_NONDET_U8();
    node.div = URB_NONDET_U8();
    node.update_due = URB_NONDET_U8();
    uint8_t const due = node.update_due;
    uint8_t const acked = pll->req_ack;

    URB_COST_BEGIN();
    urb_node_timer_event(&node);
    URB_COST_END(FW_TIMER_EVENT_BUDGET);

    URB_ASSERT(invariant(pll), "invariant kept by a heartbeat");
    URB_ASSERT(compares == 1u, "a heartbeat arms the next one");
    URB_ASSERT(pll->req_ack == node.req_seq, "a pending request is applied at the heartbeat");
    URB_ASSERT((uint8_t)(node.update_due - due) <= 1u, "at most one update per heartbeat");
    if (acked != node.req_seq) {
        URB_COVER("heartbeat-applies-a-pending-request");
    }
    if (node.update_due != due) {
        URB_COVER("heartbeat-makes-an-update-due");
    }
    if (faults_lost != 0u) {
        URB_COVER("heartbeat-reports-a-lost-sync");
    }
}

void harness(void)
{
    arbitrary_config();
    hal.now = hal_now;
    hal.set_compare = hal_set_compare;
    hal.mark = URB_NONDET_BOOL() ? hal_mark : NULL;
    hal.ctx = NULL;
    node.hal = &hal;
    node.cfg = &cfg;
    node.started = 1u;
    arbitrary_pll();
#if defined(URB_PART_TIMER)
    part_timer();
#elif defined(URB_PART_SYNC)
    part_sync();
#else
    if (URB_NONDET_BOOL()) {
        part_sync();
    } else {
        part_timer();
    }
#endif
}
