/*
 * Proof: one main-loop step of the node (urb_node_poll, firmware/node/urb_node.c): deferred
 * interrupt faults, an inbox-0 command, the periodic update, the identification refresh, the idle
 * hook; the application's hooks are bounded stubs (their time is the application's, not counted).
 *
 * Inputs: an arbitrary valid node state after urb_node_init: arbitrary flags, fault counters of
 * the interrupts and their main-loop copies, update counters, SYNC_CONFIG request and
 * acknowledgement, measured t_acq, PLL state and fixed lead, identification counters; inbox 0 with
 * arbitrary contents in both buffers, front and new flags, a bridge write in progress into the back
 * buffer or none; outbox 0 with either buffer being read by the bridge or none; application
 * mailbox sizes 0..32, class, index 0..63, fingerprint and firmware version arbitrary; any
 * configuration urb_node_init accepts (ticks_per_us 1..1000); each hook and HAL callback present or
 * NULL.
 *
 * Properties (besides bounds, pointers, overflow and shifts, and every loop within --unwind with
 * unwinding assertions on):
 *   faults   each fault code the interrupts counted since the last poll reaches the fault hook
 *            exactly once (the main-loop copy catches up), the fault flag is set, and no other
 *            fault is delivered except OVERRUN for a missed update
 *   command  a pending NEW command (no SYNC_CONFIG waiting) is taken exactly once: its new flag is
 *            cleared, POLL_COMMAND is reported exactly for the opcodes 0..4, SIGNAL reaches the
 *            signal hook once; without one, no command runs (fw_node_inbox0_command proves each
 *            opcode's effect)
 *   update   the update hook runs exactly when an update is due, once, and the update counters
 *            catch up; OVERRUN is delivered exactly when more than one was due
 *   idle     the idle hook runs once per poll
 *   result   the returned mask is exactly the steps that ran
 *   cost     one poll, hooks excluded, within FW_POLL_BUDGET = 4800 cycles, a tenth of the 1-ms
 *            cycle at 48 MHz (fw_budgets.h): the rest of the cycle is the application's update
 *            and idle time and the interrupts. Worst case (COST): 3472 cycles = 72 us, 72% of the
 *            budget, 7.2% of the cycle; 2457 of them are the identification encoder's proved worst
 *            case, charged whenever outbox 0 is refreshed
 *
 * The harness includes the prepared urb_node.c (as fw_node_inbox0_command does). The
 * identification encoder is its proved contract (stubs/fw_node_ident_stub.c: preconditions
 * asserted, its recorded worst-case cost charged). The interrupt
 * preempting the poll is not modelled here: fw_mailbox_inbox / fw_mailbox_outbox prove the lock
 * code against every interleaving, and the counters the interrupts share are single-writer.
 * Cover points (URB_COVER, checked by the reach run): listed at the end of harness().
 */
#include "urb_verify.h"

#include "urb_node.c"

#include "fw_budgets.h"

#define FW_COST_BUDGET FW_POLL_BUDGET

URB_PROOF_COST_STORAGE;

static urb_node_t node;
static uint8_t user_token; /* the `user` pointer the hooks must get back */
static urb_node_hal_t hal;
static urb_node_hooks_t hooks;
static urb_node_config_t cfg;

static uint8_t update_calls;
static uint8_t idle_calls;
static uint8_t signal_calls;
static uint8_t fault_calls[URB_NODE_FAULT_CODES];
static uint8_t fault_other;

/* ----- application hooks: bounded stubs that record their calls ----- */

static void hook_update(urb_node_t *n, void *user)
{
    URB_ASSERT((n == &node) && (user == &user_token), "update hook: the node and its user pointer");
    URB_ASSERT((node.flags & URB_F_IN_UPDATE) != 0u, "update hook: runs inside the update");
    update_calls++;
}

static void hook_idle(urb_node_t *n, void *user)
{
    URB_ASSERT((n == &node) && (user == &user_token), "idle hook: the node and its user pointer");
    idle_calls++;
}

static void hook_signal(urb_node_t *n, void *user, uint8_t signal)
{
    (void)n;
    (void)user;
    (void)signal;
    signal_calls++;
}

static void hook_reset(urb_node_t *n, void *user)
{
    (void)n;
    (void)user;
}

static void hook_fault(urb_node_t *n, void *user, urb_node_fault_t fault)
{
    URB_ASSERT((n == &node) && (user == &user_token), "fault hook: the node and its user pointer");
    uint8_t const i = (uint8_t)((uint8_t)fault - 1u);
    if (i < URB_NODE_FAULT_CODES) {
        fault_calls[i]++;
    } else {
        fault_other++;
    }
}

static uint32_t hal_now(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    return URB_NONDET_U32();
}

static void hal_identify(void *ctx, uint8_t seconds)
{
    (void)ctx;
    (void)seconds;
    URB_COST(FW_HAL_CALL_CYCLES);
}

static uint8_t arbitrary_index(void)
{
    uint8_t const b = URB_NONDET_U8();
    URB_ASSUME(b <= 1u);
    return b;
}

/* ----- an arbitrary valid node state after urb_node_init ----- */

static void setup_node(void)
{
    hal.ctx = &user_token;
    hal.now = hal_now;
    hal.identify = URB_NONDET_BOOL() ? hal_identify : NULL;
    hooks.update = URB_NONDET_BOOL() ? hook_update : NULL;
    hooks.idle = URB_NONDET_BOOL() ? hook_idle : NULL;
    hooks.signal = URB_NONDET_BOOL() ? hook_signal : NULL;
    hooks.reset = URB_NONDET_BOOL() ? hook_reset : NULL;
    hooks.fault = URB_NONDET_BOOL() ? hook_fault : NULL;
    cfg.ticks_per_us = URB_NONDET_U16();
    URB_ASSUME((cfg.ticks_per_us >= 1u) && (cfg.ticks_per_us <= 1000u)); /* config_valid */
    cfg.fw_major = URB_NONDET_U8();
    cfg.fw_minor = URB_NONDET_U8();
    cfg.fw_patch = URB_NONDET_U8();
    node.hal = &hal;
    node.hooks = &hooks;
    node.user = &user_token;
    node.cfg = &cfg;
    node.started = 1u;
    node.class_id = URB_NONDET_U8();
    node.index = URB_NONDET_U8();
    URB_ASSUME(node.index <= 63u); /* urb_node_set_index */
    node.fingerprint = URB_NONDET_U32();
    node.flags = URB_NONDET_U8();
    URB_ASSUME((node.flags & URB_F_IN_UPDATE) == 0u); /* set only inside run_update, and poll is not re-entered */
    node.update_due = URB_NONDET_U8();
    node.update_done = URB_NONDET_U8();
    node.req_seq = URB_NONDET_U8();
    node.pll.req_ack = URB_NONDET_U8();
    node.id_reads = URB_NONDET_U8();
    node.id_done = URB_NONDET_U8();
    node.id_fault_after = URB_NONDET_U8();
    /* id_done is a value id_reads had (the interrupt copies it when a read completes), and the
     * library's window on these 8-bit counters is 128: fewer than 128 identification reads begun
     * and cut short since the last complete one */
    URB_ASSUME((uint8_t)(node.id_reads - node.id_done) < 0x80u);
    node.id_acq_us = URB_NONDET_U16();
    node.acq_ticks = URB_NONDET_U32();
    node.pll.fixed_lead = URB_NONDET_U32();
    node.pll.state = URB_NONDET_U8();
    for (uint8_t i = 0u; i < URB_NODE_FAULT_CODES; i++) {
        node.isr_faults[i] = URB_NONDET_U8();
        node.seen_faults[i] = URB_NONDET_U8();
    }
    /* mailboxes as urb_mailbox_reset and the setup calls leave them (sizes 0..32), then an
     * arbitrary history of inbox 0 and outbox 0 */
    for (uint8_t n = 0u; n < URB_NODE_MAILBOXES; n++) {
        node.outbox[n].isr_idx = URB_NONE;
        node.outbox[n].held = URB_NONE;
        node.inbox[n].isr_idx = URB_NONE;
        node.inbox[n].app_idx = URB_NONE;
        uint8_t const si = URB_NONDET_U8();
        uint8_t const so = URB_NONDET_U8();
        URB_ASSUME((si <= URB_NODE_MAX_SIZE) && (so <= URB_NODE_MAX_SIZE));
        node.inbox[n].size = si;
        node.outbox[n].size = so;
    }
    node.outbox[0].size = URB_NODE_OUTBOX0_SIZE;
    node.inbox[0].offset = 2u * URB_NODE_OUTBOX0_SIZE;
    node.inbox[0].size = URB_NODE_INBOX0_SIZE;
    uint8_t const in_front = arbitrary_index();
    node.inbox[0].front = in_front;
    node.inbox[0].fresh[0] = arbitrary_index();
    node.inbox[0].fresh[1] = arbitrary_index();
    node.inbox[0].isr_idx = URB_NONDET_BOOL() ? (uint8_t)(1u - in_front) : URB_NONE; /* a write in progress */
    node.outbox[0].front = arbitrary_index();
    uint8_t const reading = URB_NONDET_U8();
    URB_ASSUME(reading <= URB_NONE);
    node.outbox[0].isr_idx = reading; /* the bridge reads either buffer (latched earlier), or none */
}

void harness(void)
{
    setup_node();
    for (uint8_t k = 0u; k < 2u * URB_NODE_INBOX0_SIZE; k++) {
        node.mb0[(2u * URB_NODE_OUTBOX0_SIZE) + k] = URB_NONDET_U8(); /* both inbox-0 buffers */
    }
    urb_node_inbox_t const *ib = &node.inbox[0];
    uint8_t const front = ib->front;
    bool const is_new = ib->fresh[front] != 0u;
    bool const waiting = node.req_seq != node.pll.req_ack;
    uint8_t const opcode = node.mb0[(2u * URB_NODE_OUTBOX0_SIZE) + (front * URB_NODE_INBOX0_SIZE)];
    bool const taken = is_new && !waiting;
    bool const runs = taken && (opcode <= (uint8_t)URB_COMMAND_CODE_SYNC_CONFIG);
    uint8_t const pending = (uint8_t)(node.update_due - node.update_done);
    uint8_t const due = node.update_due;
    uint8_t isr[URB_NODE_FAULT_CODES];
    uint8_t seen[URB_NODE_FAULT_CODES];
    for (uint8_t i = 0u; i < URB_NODE_FAULT_CODES; i++) {
        isr[i] = node.isr_faults[i];
        seen[i] = node.seen_faults[i];
    }

    URB_COST_BEGIN();
    uint8_t const done = urb_node_poll(&node);
    URB_COST_END(FW_COST_BUDGET);

    bool const reset = runs && (opcode == (uint8_t)URB_COMMAND_CODE_RESET);
    bool any_fault = false;
    for (uint8_t i = 0u; i < URB_NODE_FAULT_CODES; i++) {
        bool counted = isr[i] != seen[i];
        if ((i == (uint8_t)(URB_NODE_FAULT_OVERRUN - 1u)) && (pending > 1u) && !reset) {
            counted = true; /* the missed update is an OVERRUN too, delivered with a refused write's */
        }
        any_fault = any_fault || counted;
        URB_ASSERT(node.seen_faults[i] == isr[i], "faults: the main-loop copy catches up with the interrupts");
        URB_ASSERT(fault_calls[i] == (((hooks.fault != NULL) && counted) ? 1u : 0u),
                   "faults: each counted code exactly once per poll, no other");
    }
    URB_ASSERT(fault_other == 0u, "faults: only the four codes");
    URB_ASSERT(((done & URB_NODE_POLL_FAULT) != 0u) == any_fault, "result: POLL_FAULT exactly when a fault was delivered");
    URB_ASSERT(!any_fault || ((node.flags & URB_F_FAULT) != 0u),
               "identification: a fault delivered by this poll is not cleared by its refresh");

    if (taken) {
        URB_ASSERT(ib->fresh[front] == 0u, "command: taken exactly once (no longer new)");
    } else {
        URB_ASSERT(ib->fresh[front] == (is_new ? 1u : 0u), "command: a waiting command stays new");
    }
    URB_ASSERT(((done & URB_NODE_POLL_COMMAND) != 0u) == runs, "result: POLL_COMMAND exactly when a command ran");
    URB_ASSERT(signal_calls == ((runs && (opcode == (uint8_t)URB_COMMAND_CODE_SIGNAL) && (hooks.signal != NULL)) ? 1u : 0u),
               "command: SIGNAL reaches the hook once");
    URB_ASSERT(ib->app_idx == URB_NONE, "command: inbox 0 released");

    bool const update = (pending != 0u) && !reset; /* RESET drops an update due before it */
    URB_ASSERT(update_calls == ((update && (hooks.update != NULL)) ? 1u : 0u), "update: the hook exactly when an update was due, once");
    URB_ASSERT(((done & URB_NODE_POLL_UPDATE) != 0u) == update, "result: POLL_UPDATE exactly when an update was due");
    URB_ASSERT(node.update_done == due, "update: the counters catch up");
    URB_ASSERT((node.flags & URB_F_IN_UPDATE) == 0u, "update: no longer inside the update");
    URB_ASSERT(idle_calls == ((hooks.idle != NULL) ? 1u : 0u), "idle: the hook once per poll");
    URB_ASSERT(node.outbox[0].held == URB_NONE, "identification: outbox 0 released");
    URB_ASSERT((done & (uint8_t)~(URB_NODE_POLL_COMMAND | URB_NODE_POLL_UPDATE | URB_NODE_POLL_IDENT | URB_NODE_POLL_FAULT)) == 0u,
               "result: only the documented bits");

    /* cover points: a fault delivered, a missed update counted as OVERRUN, a command run, a RESET
     * dropping a due update, an update, the identification refreshed, a quiet poll */
    if (any_fault) {
        URB_COVER("a-fault-delivered");
    }
    if ((pending > 1u) && !reset) {
        URB_COVER("a-missed-update-is-an-overrun");
    }
    if (runs) {
        URB_COVER("a-command-runs");
    }
    if (reset && (pending != 0u)) {
        URB_COVER("reset-drops-a-due-update");
    }
    if (update) {
        URB_COVER("an-update-runs");
    }
    if ((done & URB_NODE_POLL_IDENT) != 0u) {
        URB_COVER("identification-refreshed");
    }
    if (done == 0u) {
        URB_COVER("a-quiet-poll");
    }
}
