/*
 * Proof: the inbox-0 command handler (run_command in firmware/node/urb_node.c), the main loop's
 * reaction to a Command the bridge wrote into inbox 0 (spec/schema core.urbs, Command).
 *
 * Inputs, all arbitrary: the six bytes of both inbox-0 buffers, which buffer is front, both new
 * flags, a write of the interrupt in progress into the other buffer (or none), the node's flags,
 * the update counters, the measured t_acq, a pending SYNC_CONFIG request (req_seq != req_ack) and
 * its fields, and which application hooks and HAL functions exist (each may be NULL).
 *
 * Properties (besides bounds, pointers, overflow and shifts on every access):
 *   wait for SYNC_CONFIG  while the timer interrupt has not applied the previous SYNC_CONFIG, no
 *                         command is taken: inbox 0, its new flag and every request field stay
 *   once                  only a NEW message runs (the lock's URB_NODE_NEW); its new flag is
 *                         cleared, a second look finds nothing
 *   dispatch              opcode 0..4 reaches exactly its effect and no other: NOP nothing, RESET
 *                         the reset hook once (fault flag cleared, ID_DIRTY, t_acq re-measured, a
 *                         due update dropped), SIGNAL the signal hook once with arg, IDENTIFY the
 *                         HAL once with arg and ID_DIRTY, SYNC_CONFIG the request fields (period,
 *                         lead, enable = arg bit 0), req_seq + 1 and ID_DIRTY
 *   malformed             an opcode above 4 is ignored (the documented "unknown opcode: ignored"):
 *                         consumed, no hook, no state change, result 0
 *   mailbox               inbox 0 is released afterwards; no mailbox byte is written (the
 *                         interrupt's buffer in particular)
 *   has_work              urb_node_has_work reports a committed, untaken command
 *   cost                  the path costs at most FW_COMMAND_BUDGET cycles (hooks excluded)
 *
 * Not here: the interrupt preempting the lock (fw_mailbox_inbox proves the same lock code against
 * every interleaving) and the bytes' way into inbox 0 (fw_node_i2c_slave).
 *
 * The harness includes the prepared (instrumented, possibly mutated) urb_node.c itself, because
 * run_command is static.
 *
 * Cover points (URB_COVER, checked by the reach run): listed at the end of harness().
 */
#include "urb_verify.h"

#include "urb_node.c"

#include "../stubs/fw_budgets.h"

#define FW_COST_BUDGET FW_COMMAND_BUDGET

URB_PROOF_COST_STORAGE;

static urb_node_t node;
static uint8_t user_token; /* the `user` pointer the hooks must get back */
static urb_node_hal_t hal;
static urb_node_hooks_t hooks;

static uint8_t reset_calls;
static uint8_t signal_calls;
static uint8_t signal_arg;
static uint8_t identify_calls;
static uint8_t identify_arg;
static uint8_t other_calls; /* hooks a command must never run */

static void hook_reset(urb_node_t *n, void *user)
{
    URB_ASSERT((n == &node) && (user == &user_token), "reset hook: the node and its user pointer");
    reset_calls++;
}

static void hook_signal(urb_node_t *n, void *user, uint8_t signal)
{
    URB_ASSERT((n == &node) && (user == &user_token), "signal hook: the node and its user pointer");
    signal_calls++;
    signal_arg = signal;
}

static void hook_other(urb_node_t *n, void *user)
{
    (void)n;
    (void)user;
    other_calls++;
}

static void hook_fault(urb_node_t *n, void *user, urb_node_fault_t fault)
{
    (void)n;
    (void)user;
    (void)fault;
    other_calls++;
}

static void hal_identify(void *ctx, uint8_t seconds)
{
    URB_ASSERT(ctx == &user_token, "identify: the port's context");
    URB_COST(FW_HAL_CALL_CYCLES);
    identify_calls++;
    identify_arg = seconds;
}

/* Inbox 0 as urb_mailbox_reset leaves it (buffers in node.mb0 after outbox 0), with an arbitrary
 * history: which buffer is front, new flags, an interrupt write in progress into the other one. */
static void arbitrary_inbox0(void)
{
    urb_node_inbox_t *ib = &node.inbox[0];
    ib->offset = 2u * URB_NODE_OUTBOX0_SIZE;
    ib->size = URB_NODE_INBOX0_SIZE;
    uint8_t const front = URB_NONDET_U8();
    URB_ASSUME(front < 2u);
    ib->front = front;
    ib->fresh[0] = URB_NONDET_BOOL() ? 1u : 0u;
    ib->fresh[1] = URB_NONDET_BOOL() ? 1u : 0u;
    /* MailboxInbox.tla: a write in progress always targets 1 - front; the main loop holds nothing */
    ib->isr_idx = URB_NONDET_BOOL() ? (uint8_t)(1u - front) : URB_NONE;
    ib->app_idx = URB_NONE;
    for (uint8_t k = 0u; k < 2u * URB_NODE_INBOX0_SIZE; k++) {
        node.mb0[(2u * URB_NODE_OUTBOX0_SIZE) + k] = URB_NONDET_U8();
    }
}

void harness(void)
{
    hal.ctx = &user_token;
    hal.identify = URB_NONDET_BOOL() ? hal_identify : NULL;
    hooks.reset = URB_NONDET_BOOL() ? hook_reset : NULL;
    hooks.signal = URB_NONDET_BOOL() ? hook_signal : NULL;
    hooks.bootup = hook_other;
    hooks.init = hook_other;
    hooks.idle = hook_other;
    hooks.update = hook_other;
    hooks.fault = hook_fault;
    node.hal = &hal;
    node.hooks = &hooks;
    node.user = &user_token;
    node.started = 1u;
    arbitrary_inbox0();

    node.flags = URB_NONDET_U8();
    node.update_due = URB_NONDET_U8();
    node.update_done = URB_NONDET_U8();
    node.acq_ticks = URB_NONDET_U32();
    node.req_seq = URB_NONDET_U8();
    node.pll.req_ack = URB_NONDET_U8();
    node.req_period_us = URB_NONDET_U16();
    node.req_lead_us = URB_NONDET_U16();
    node.req_enable = URB_NONDET_U8();

    /* what the command handler may look at, before */
    urb_node_inbox_t const *ib = &node.inbox[0];
    uint8_t const front = ib->front;
    uint8_t const other_fresh = ib->fresh[1u - front];
    bool const is_new = ib->fresh[front] != 0u;
    uint8_t mb0_before[2u * URB_NODE_INBOX0_SIZE];
    for (uint8_t k = 0u; k < 2u * URB_NODE_INBOX0_SIZE; k++) {
        mb0_before[k] = node.mb0[(2u * URB_NODE_OUTBOX0_SIZE) + k];
    }
    uint8_t const *cmd = &mb0_before[front * URB_NODE_INBOX0_SIZE];
    bool const pending = node.req_seq != node.pll.req_ack;
    uint8_t const flags = node.flags;
    uint8_t const due = node.update_due;
    uint8_t const done_before = node.update_done;
    uint32_t const acq = node.acq_ticks;
    uint8_t const seq = node.req_seq;
    uint16_t const period = node.req_period_us;
    uint16_t const lead = node.req_lead_us;
    uint8_t const enable = node.req_enable;

    if (is_new) {
        URB_ASSERT(urb_node_has_work(&node), "has_work: a committed command not yet taken is work");
    }

    URB_COST_BEGIN();
    uint8_t const rc = run_command(&node);
    URB_COST_END(FW_COST_BUDGET);

    URB_ASSERT(other_calls == 0u, "a command never runs another hook");
    URB_ASSERT(ib->app_idx == URB_NONE, "inbox 0 released");
    URB_ASSERT(ib->front == front, "the main loop never moves front");
    URB_ASSERT(ib->fresh[1u - front] == other_fresh, "the other buffer's new flag is the interrupt's");
    for (uint8_t k = 0u; k < 2u * URB_NODE_INBOX0_SIZE; k++) {
        URB_ASSERT(node.mb0[(2u * URB_NODE_OUTBOX0_SIZE) + k] == mb0_before[k], "no mailbox byte is written");
    }

    bool const taken = !pending && is_new;
    bool const runs = taken && (cmd[0] <= (uint8_t)URB_COMMAND_CODE_SYNC_CONFIG);
    URB_ASSERT((ib->fresh[front] == 0u) == (taken || !is_new), "a taken command is no longer new; others stay");
    URB_ASSERT(rc == (runs ? URB_NODE_POLL_COMMAND : 0u), "result: POLL_COMMAND exactly when a command ran");

    uint8_t const op = runs ? cmd[0] : 0xFFu; /* 0xFF: nothing runs */
    bool const do_reset = op == (uint8_t)URB_COMMAND_CODE_RESET;
    bool const do_signal = op == (uint8_t)URB_COMMAND_CODE_SIGNAL;
    bool const do_identify = op == (uint8_t)URB_COMMAND_CODE_IDENTIFY;
    bool const do_sync = op == (uint8_t)URB_COMMAND_CODE_SYNC_CONFIG;

    URB_ASSERT(reset_calls == ((do_reset && (hooks.reset != NULL)) ? 1u : 0u), "RESET: the reset hook, once");
    URB_ASSERT(signal_calls == ((do_signal && (hooks.signal != NULL)) ? 1u : 0u), "SIGNAL: the signal hook, once");
    URB_ASSERT(identify_calls == ((do_identify && (hal.identify != NULL)) ? 1u : 0u), "IDENTIFY: the HAL, once");
    if (signal_calls != 0u) {
        URB_ASSERT(signal_arg == cmd[1], "SIGNAL: the hook gets arg");
    }
    if (identify_calls != 0u) {
        URB_ASSERT(identify_arg == cmd[1], "IDENTIFY: the HAL gets arg (seconds)");
    }

    uint8_t expect_flags = flags;
    if (do_reset) {
        expect_flags = (uint8_t)((flags & (uint8_t)~URB_F_FAULT) | URB_F_ID_DIRTY);
    } else if (do_identify || do_sync) {
        expect_flags = (uint8_t)(flags | URB_F_ID_DIRTY);
    }
    URB_ASSERT(node.flags == expect_flags, "flags: only the command's own change");
    URB_ASSERT(node.acq_ticks == (do_reset ? 0u : acq), "t_acq: re-measured after RESET only");
    URB_ASSERT(node.update_due == due, "update_due is the timer interrupt's");
    URB_ASSERT(node.update_done == (do_reset ? due : done_before), "RESET drops a due update, nothing else does");

    if (do_sync) {
        URB_ASSERT(node.req_period_us == (uint16_t)(cmd[2] | ((uint16_t)cmd[3] << 8)), "SYNC_CONFIG: period_us");
        URB_ASSERT(node.req_lead_us == (uint16_t)(cmd[4] | ((uint16_t)cmd[5] << 8)), "SYNC_CONFIG: lead_us");
        URB_ASSERT(node.req_enable == (cmd[1] & 1u), "SYNC_CONFIG: enable = arg bit 0");
        URB_ASSERT(node.req_seq == (uint8_t)(seq + 1u), "SYNC_CONFIG: posted once to the timer interrupt");
    } else {
        URB_ASSERT((node.req_period_us == period) && (node.req_lead_us == lead) && (node.req_enable == enable) &&
                       (node.req_seq == seq),
                   "no request unless SYNC_CONFIG");
    }

    /* once: the same message is not executed again */
    if (taken) {
        URB_ASSERT(run_command(&node) == 0u, "once: a taken command does not run twice");
    }

    /* cover points: every command runs (with and without its hook), an unknown opcode is taken and
     * dropped, a command waits while a SYNC_CONFIG is pending, an old command is not taken */
    if (do_reset && (reset_calls != 0u)) {
        URB_COVER("reset-runs-its-hook");
    }
    if (do_signal && (signal_calls != 0u)) {
        URB_COVER("signal-runs-its-hook");
    }
    if (do_identify && (identify_calls != 0u)) {
        URB_COVER("identify-calls-the-hal");
    }
    if (do_identify && (hal.identify == NULL)) {
        URB_COVER("identify-without-a-hal-hook");
    }
    if (do_sync) {
        URB_COVER("sync-config-posted");
    }
    if (taken && !runs) {
        URB_COVER("unknown-opcode-dropped");
    }
    if (pending && is_new) {
        URB_COVER("a-command-waits-for-a-pending-sync-config");
    }
    if (!is_new) {
        URB_COVER("an-old-command-is-not-taken");
    }
}
