/*
 * Node lifecycle and main loop: initialisation, the round-robin poll (inbox 0 commands, app_update,
 * faults, outbox 0 identification, app_idle), acquisition-time measurement.
 *
 * Everything here runs at thread level. It talks to the interrupt side only through
 *   - the mailbox algorithms (inbox 0 and outbox 0 are ordinary mailboxes),
 *   - counters with one writer each (update_due, isr_faults, id_reads/id_done),
 *   - one 32-bit value the SYNC interrupt reads (acq_ticks: aligned word stores are atomic on
 *     every supported core), and a request (req_*) the timer interrupt applies.
 *
 * Seeded bug for the mutant check: URB_MUTANT_ACQ_NO_DECAY (t_acq never forgets a sample).
 */
#include "urb_node_internal.h"

#include "urb_core.h"

/* ===== Configuration ======================================================================== */

void urb_node_config_default(urb_node_config_t *cfg)
{
    if (cfg == NULL) {
        return;
    }
    /* one struct copy from a constant: smaller on Cortex-M0+ than member stores */
    *cfg = (urb_node_config_t){
        .i2c_address = 0u, /* must be set: no default address is safe on a shared bus */
        .ticks_per_us = 48u, /* 48 MHz timer */
        .heartbeat_us = 1000u,
        .update_divider = 1u,
        .sync_enabled = 1u,
        .lead_us = 0u, /* the measured acquisition time */
        /* PLL defaults, tuned with tests/firmware/pll (see firmware/node/README.md) */
        .kd_q8 = 32u, /* K_d = 1/8 */
        .kn_q8 = 64u, /* K_n = 1/4 */
        .lock_ns = 1000u,
        .lock_count = 4u,
        .outlier_ns = 2000u,
        .max_outliers = 4u,
        .max_gap = 8u,
        .lost_sync_beats = 10u,
        .acq_window = 16u, /* an inflated t_acq is forgotten within 32 updates */
        .acq_guard_us = 1u,
    };
}

static bool config_valid(const urb_node_config_t *cfg)
{
    uint32_t const ticks = (uint32_t)cfg->heartbeat_us * cfg->ticks_per_us;
    /* the PLL's Q8 arithmetic needs periods of 64 .. 2^21 - 1 ticks (urb_pll.c); gains, lock_count and
     * max_gap of 0 are legal (they switch the feature off) */
    return (cfg->i2c_address >= 1u) && (cfg->i2c_address <= 127u) && (cfg->ticks_per_us >= 1u) &&
           (cfg->ticks_per_us <= 1000u) && (ticks >= 64u) && (ticks <= 0x1FFFFFu) && (cfg->update_divider >= 1u) &&
           (cfg->lost_sync_beats >= 2u);
}

void urb_setup_error(urb_node_t *node, int rc)
{
    if ((node != NULL) && (node->started == 0u) && (node->setup_err == 0)) {
        node->setup_err = (int8_t)rc;
    }
}

void urb_isr_fault(urb_node_t *node, urb_node_fault_t code)
{
    uint8_t const i = (uint8_t)((uint8_t)code - 1u);
    node->isr_faults[i] = (uint8_t)(node->isr_faults[i] + 1u); /* single writer: the interrupts */
}

/* ===== Identification (outbox 0) ============================================================ */

/* Publishes Identification when anything in it changed; returns URB_NODE_POLL_IDENT if it did. */
/* lobster-trace: urb.MBX_011 */
static uint8_t refresh_identification(urb_node_t *node)
{
    uint8_t const synced = (node->pll.state == URB_NODE_SYNC_LOCKED) ? URB_F_ID_SYNCED : 0u;
    uint8_t flags = node->flags;
    /* the phase lead in use: configured, or the measured acquisition time */
    uint32_t const acq = ((node->pll.fixed_lead != 0u) ? node->pll.fixed_lead : node->acq_ticks) / node->cfg->ticks_per_us;
    uint16_t const acq_us = (acq > 0xFFFFu) ? 0xFFFFu : (uint16_t)acq;
    /* the fault flag clears once a read that began after we published it has completed */
    /* id_done - id_fault_after in 1..127 (modulo 256): a read begun after it has completed */
    if (((flags & URB_F_ID_FAULT) != 0u) && ((uint8_t)(node->id_done - node->id_fault_after - 1u) < 0x7Fu)) {
        flags &= (uint8_t)~URB_F_FAULT;
    }
    uint8_t const fault = ((flags & URB_F_FAULT) != 0u) ? URB_F_ID_FAULT : 0u;
    node->flags = flags;
    if (((flags & URB_F_ID_DIRTY) == 0u) && (synced == (flags & URB_F_ID_SYNCED)) && (acq_us == node->id_acq_us) &&
        (fault == (flags & URB_F_ID_FAULT))) {
        return 0u;
    }
    urb_identification_t id;
    id.class_id = node->class_id;
    id.index = node->index;
    id.fingerprint = node->fingerprint;
    id.fw_major = node->cfg->fw_major;
    id.fw_minor = node->cfg->fw_minor;
    id.fw_patch = node->cfg->fw_patch;
    /* bound: URB_NODE_MAILBOXES = 8 */
    for (uint8_t n = 0u; n < URB_NODE_MAILBOXES; n++) {
        id.inbox_sizes[n] = node->inbox[n].size;
        id.outbox_sizes[n] = node->outbox[n].size;
    }
    id.synced = synced != 0u;
    id.fault = fault != 0u;
    id.acq_time = acq_us;
    uint8_t *buf = NULL;
    if (urb_lock_outbox_any(node, 0u, &buf) != URB_NODE_OK) {
        return 0u; /* the bridge still reads the other buffer: next iteration */
    }
    (void)urb_identification_encode(&id, buf, URB_NODE_OUTBOX0_SIZE); /* cannot fail: sizes <= 32, index <= 63 */
    (void)urb_release_outbox_any(node, 0u);
    node->flags = (uint8_t)((flags & (uint8_t) ~(URB_F_ID_DIRTY | URB_F_ID_SYNCED | URB_F_ID_FAULT)) | synced | fault);
    node->id_acq_us = acq_us;
    node->id_fault_after = node->id_reads; /* reads begun up to here may hold the previous version */
    return URB_NODE_POLL_IDENT;
}

/* ===== Faults =============================================================================== */

static void deliver_fault(urb_node_t *node, urb_node_fault_t code)
{
    node->flags |= URB_F_FAULT;
    /* the flag clears only after a read begun from here on: a read completed before this fault
     * (even after the flag's last publication) did not report it */
    node->id_fault_after = node->id_reads;
    if (node->hooks->fault != NULL) {
        node->hooks->fault(node, node->user, code);
    }
}

/* Delivers the faults counted since the last poll (by the interrupts, and a missed heartbeat by
 * run_update): once per code per poll. */
/* lobster-trace: urb.ERR_005 */
static uint8_t deliver_isr_faults(urb_node_t *node)
{
    uint8_t delivered = 0u;
    /* bound: URB_NODE_FAULT_CODES = 4 */
    for (uint8_t i = 0u; i < URB_NODE_FAULT_CODES; i++) {
        uint8_t const count = node->isr_faults[i];
        if (count != node->seen_faults[i]) {
            node->seen_faults[i] = count;
            deliver_fault(node, (urb_node_fault_t)(i + 1u));
            delivered = URB_NODE_POLL_FAULT;
        }
    }
    return delivered;
}

/* ===== Inbox 0 commands ===================================================================== */

static void reset_application(urb_node_t *node)
{
    node->flags = (uint8_t)((node->flags & (uint8_t)~URB_F_FAULT) | URB_F_ID_DIRTY);
    node->acq_ticks = 0u;                  /* re-measure t_acq: the application restarts */
    node->acq_win = 0u;
    node->acq_count = 0u;
    node->update_done = node->update_due;  /* drop an update due before the reset */
    if (node->hooks->reset != NULL) {
        node->hooks->reset(node, node->user);
    }
}

/* Executes a new inbox-0 command, if any. Runs in the main loop, never in the interrupt. */
/* lobster-trace: urb.MBX_011, urb.WCET_003 */
static uint8_t run_command(urb_node_t *node)
{
    if (node->req_seq != node->pll.req_ack) {
        return 0u; /* a SYNC_CONFIG is still to be applied: the next command waits in inbox 0 */
    }
    const uint8_t *data = NULL;
    int const rc = urb_lock_inbox_any(node, 0u, &data);
    if (rc < 0) {
        return 0u; /* BUSY: bridge writes are landing right now; next iteration */
    }
    urb_command_t cmd;
    int32_t const decoded = (rc == URB_NODE_NEW) ? urb_command_decode(&cmd, data, URB_NODE_INBOX0_SIZE) : -1;
    (void)urb_release_inbox_any(node, 0u);
    if (decoded < 0) {
        return 0u; /* nothing new, or an unknown opcode: ignored */
    }
    switch (cmd.opcode) {
    case URB_COMMAND_CODE_RESET:
        reset_application(node);
        break;
    case URB_COMMAND_CODE_SIGNAL:
        if (node->hooks->signal != NULL) {
            node->hooks->signal(node, node->user, cmd.arg);
        }
        break;
    case URB_COMMAND_CODE_IDENTIFY:
        node->flags |= URB_F_ID_DIRTY;
        if (node->hal->identify != NULL) {
            node->hal->identify(node->hal->ctx, cmd.arg);
        }
        break;
    case URB_COMMAND_CODE_SYNC_CONFIG:
        /* posted to the timer interrupt, which applies it at the next heartbeat */
        node->req_period_us = cmd.period_us;
        node->req_lead_us = cmd.lead_us;
        node->req_enable = (uint8_t)(cmd.arg & 1u);
        URB_NODE_BARRIER(); /* the request is complete before the interrupt can see it */
        node->req_seq = (uint8_t)(node->req_seq + 1u);
        node->flags |= URB_F_ID_DIRTY;
        break;
    default: /* NOP */
        break;
    }
    return URB_NODE_POLL_COMMAND;
}

/* ===== Periodic update ====================================================================== */

static uint8_t run_update(urb_node_t *node)
{
    uint8_t const due = node->update_due; /* read before the beat: the beat is then this one or newer */
    uint8_t const pending = (uint8_t)(due - node->update_done);
    if (pending == 0u) {
        return 0u;
    }
    /* on time: exactly one update due, and no heartbeat since `due` was read */
    uint8_t const valid = ((pending == 1u) && (node->update_due == due)) ? URB_F_ACQ_VALID : 0u;
    node->update_done = due;
    uint8_t const ov = node->seen_faults[URB_NODE_FAULT_OVERRUN - 1u];
    if ((pending > 1u) && (ov == node->isr_faults[URB_NODE_FAULT_OVERRUN - 1u])) {
        /* app_update missed at least one heartbeat: one OVERRUN for deliver_isr_faults, later in
         * this poll; when a refused write's is pending, that one delivery covers both (once per
         * code per poll) */
        node->seen_faults[URB_NODE_FAULT_OVERRUN - 1u] = (uint8_t)(ov - 1u);
    }
    node->flags = (uint8_t)((node->flags & (uint8_t) ~(URB_F_ACQ_MARKED | URB_F_ACQ_VALID)) | URB_F_IN_UPDATE | valid);
    if (node->hooks->update != NULL) {
        node->hooks->update(node, node->user);
    }
    node->flags &= (uint8_t)~URB_F_IN_UPDATE;
    return URB_NODE_POLL_UPDATE;
}

/* t_acq is a windowed maximum over two halves: the largest sample of the window in progress and of
 * the complete window before it. A longer acquisition is tracked at its first sample; a sample
 * inflated once (an interrupt during the acquisition, e.g. the bridge's start-up scan) is forgotten
 * after at most 2 x acq_window - 1 more samples, when the window after its own one completes.
 * Samples carry the guard: without it the lead would settle where the acquisition ends on the
 * SYNC, whose interrupt then lengthens some samples, and the window would make the lead oscillate
 * by an interrupt's length (firmware/node/README.md). */
/* lobster-trace: urb.SYN_004 */
static void acq_sample(urb_node_t *node, uint32_t sample)
{
    if (sample > node->acq_ticks) {
        node->acq_ticks = sample;
    }
    if (sample > node->acq_win) {
        node->acq_win = sample;
    }
    node->acq_count++;
#if defined(URB_MUTANT_ACQ_NO_DECAY)
    node->acq_count = 0u; /* mutant: the window never completes, t_acq only grows */
#endif
    if (node->acq_count >= node->cfg->acq_window) {
        node->acq_ticks = node->acq_win; /* the window before the completed one is dropped */
        node->acq_win = 0u;
        node->acq_count = 0u;
    }
}

void urb_node_mark_acquired(urb_node_t *node)
{
    if ((node == NULL) || ((node->flags & (URB_F_IN_UPDATE | URB_F_ACQ_MARKED)) != URB_F_IN_UPDATE)) {
        return; /* outside app_update, or already marked */
    }
    node->flags |= URB_F_ACQ_MARKED;
    urb_node_hal_t const *hal = node->hal;
    if (hal->mark != NULL) {
        hal->mark(hal->ctx, URB_NODE_MARK_ACQ_END);
    }
    if ((node->flags & URB_F_ACQ_VALID) == 0u) {
        return; /* a late update would inflate t_acq */
    }
    /* from this update's heartbeat (a newer one would only make the sample smaller) */
    uint32_t const elapsed = hal->now(hal->ctx) - node->update_beat;
    if (elapsed < (node->pll.period_q8 >> 8)) {
        acq_sample(node, elapsed + ((uint32_t)node->cfg->acq_guard_us * node->cfg->ticks_per_us));
    }
}

/* ===== Lifecycle ============================================================================ */

/* The mailbox positions and the I2C slave's start state, on a node start_node has just zeroed.
 * ACSL for Frama-C WP (proofs/framac/node_init/): the requires are what the zeroing gives (every
 * integer field 0, the storage block valid and apart from the node: urb_node_init's caller), and
 * the ensures are the conjuncts of the I2C slave invariant urb_i2c_ok (urb_i2c.c), which
 * node_init proves from them: the base case of the induction over slave events. */
/*@ requires \valid(node) && node->storage_used == 0;
    requires \valid(node->storage + (0 .. node->storage_len - 1));
    requires \separated(node, node->storage + (0 .. node->storage_len - 1));
    requires \forall integer n; 0 <= n < URB_NODE_MAILBOXES ==>
               node->outbox[n].front == 0 && node->inbox[n].front == 0 &&
               node->outbox[n].offset == 0 && node->outbox[n].size == 0 &&
               node->inbox[n].offset == 0 && node->inbox[n].size == 0;
    requires node->i2c.mailbox == 0 && node->i2c.crc16 == 0;
    assigns node->outbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx, node->outbox[0 .. URB_NODE_MAILBOXES - 1].held,
            node->inbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx, node->inbox[0 .. URB_NODE_MAILBOXES - 1].app_idx,
            node->outbox[0].size, node->inbox[0].offset, node->inbox[0].size,
            node->i2c.state, node->i2c.selected;
    ensures start_layout: urb_mb_layout(node);
    ensures start_i2c: node->i2c.state == URB_I2C_ST_IDLE && node->i2c.mailbox == 0 &&
                       node->i2c.selected == 0 && node->i2c.crc16 == 0; */
static void start_slave(urb_node_t *node)
{
    urb_mailbox_reset(node);
    node->i2c.state = URB_I2C_ST_IDLE;
    node->i2c.selected = 0u; /* reads return outbox 0 until the first select */
}

/* ACSL for Frama-C WP (proofs/framac/node_init/), no code. WP models the zeroing below as "the
 * struct value *node equals the zero literal", the mailbox arrays element by element (outbox[0] ..
 * outbox[7]); start_slave's requires read the fields in memory (node->outbox[n].size). z3 and cvc4
 * do not link the two for an arbitrary n on their own: they time out, even on one field of one box
 * next to the literal's facts. urb_mb_number splits a mailbox number into its 8 values, each of
 * which the literal names; zero_fields, a ghost function (nothing compiled), turns the value's
 * fields into the memory's away from the literal's facts, its postcondition naming both so that
 * the provers can match them. The value's zero fields are named predicates, not spelled out under
 * a \let: Eva evaluates those (and leaves the \let form Unknown). A change of URB_NODE_MAILBOXES
 * fails this proof until urb_mb_number follows. */
/*@ predicate urb_mb_number(integer n) = n == 0 || n == 1 || n == 2 || n == 3 || n == 4 || n == 5 || n == 6 || n == 7; */
/*@ predicate urb_zero_box(urb_node_t s, integer n) =
      s.outbox[n].front == 0 && s.outbox[n].offset == 0 && s.outbox[n].size == 0 &&
      s.inbox[n].front == 0 && s.inbox[n].offset == 0 && s.inbox[n].size == 0;
    predicate urb_zero_start(urb_node_t s) =
      s.storage_used == 0 && s.i2c.mailbox == 0 && s.i2c.crc16 == 0 &&
      \forall integer n; 0 <= n < URB_NODE_MAILBOXES ==> urb_mb_number(n) ==> urb_zero_box(s, n); */
/*@ ghost
  /@ requires urb_zero_start(*node);
     assigns \nothing;
     ensures zero_storage: node->storage_used == 0;
     ensures zero_i2c: node->i2c.mailbox == 0 && node->i2c.crc16 == 0;
     ensures zero_boxes: \forall integer n; 0 <= n < URB_NODE_MAILBOXES ==> urb_zero_box(*node, n) &&
       node->outbox[n].front == 0 && node->outbox[n].offset == 0 && node->outbox[n].size == 0 &&
       node->inbox[n].front == 0 && node->inbox[n].offset == 0 && node->inbox[n].size == 0; @/
  static void zero_fields(urb_node_t *node) { }
*/

/* urb_node_init's steps before the bootup hook: zero the node (a re-init, a node reset, starts
 * from scratch; the port keeps the node's interrupts off until set_address), keep the arguments,
 * start the slave. The zeroing is a struct assignment, not a byte loop through an unsigned char
 * pointer, because WP's typed memory model does not relate byte stores to the integer fields.
 * arm-none-eabi-gcc -Os and x86 gcc -O2 emit one memset of sizeof(urb_node_t) bytes for it, as
 * for the loop, with no copy of the literal on the stack (clang 14 builds the literal on the stack
 * and copies it, for the volatile members: host builds only).
 * ACSL: the storage block (storage_len valid bytes, apart from the node) is urb_node_init's
 * caller's obligation; node_init proves this contract and start_slave's requires at its call. */
/*@ requires \valid(node);
    requires \valid(storage + (0 .. storage_len - 1));
    requires \separated(node, storage + (0 .. storage_len - 1));
    assigns *node;
    ensures fresh_args: node->hal == hal && node->hooks == hooks && node->user == user &&
                        node->cfg == cfg && node->storage == storage && node->storage_len == storage_len;
    ensures fresh_layout: urb_mb_layout(node);
    ensures fresh_i2c: node->i2c.state == URB_I2C_ST_IDLE && node->i2c.mailbox == 0 &&
                       node->i2c.selected == 0 && node->i2c.crc16 == 0; */
static void start_node(urb_node_t *node, const urb_node_hal_t *hal, const urb_node_hooks_t *hooks, void *user,
                       const urb_node_config_t *cfg, uint8_t *storage, uint16_t storage_len)
{
    /* For WP: the guards of the stores below, stated before the zeroing; after it the provers
     * time out on them among the literal's facts, and Qed reuses these. */
    /*@ assert fields_valid: \valid(&node->hal) && \valid(&node->hooks) && \valid(&node->user) &&
          \valid(&node->cfg) && \valid(&node->storage) && \valid(&node->storage_len); */
    *node = (urb_node_t){0};
    /*@ assert zero_value: urb_zero_start(*node); */
    /*@ ghost zero_fields(node); */
    node->hal = hal;
    node->hooks = hooks;
    node->user = user;
    node->cfg = cfg;
    node->storage = storage;
    node->storage_len = storage_len;
    start_slave(node);
}

/* ACSL: the caller's obligation (urb_node.h: storage_len bytes of storage, referenced, not copied),
 * from which start_node's requires follow at its call; not proved here (no WP unit holds
 * urb_node_init: it calls the hooks and the HAL through pointers). */
/*@ requires node == \null || \valid(node);
    requires storage == \null || \valid(storage + (0 .. storage_len - 1));
    requires \separated(node, storage + (0 .. storage_len - 1)); */
/* lobster-trace: urb.MBX_012 */
int urb_node_init(urb_node_t *node, const urb_node_hal_t *hal, const urb_node_hooks_t *hooks, void *user,
                  const urb_node_config_t *cfg, uint8_t *storage, uint16_t storage_len)
{
    if ((node == NULL) || (hal == NULL) || (hooks == NULL) || (cfg == NULL) || ((storage == NULL) && (storage_len != 0u))) {
        return URB_NODE_ERR_ARG;
    }
    if ((hal->now == NULL) || (hal->set_compare == NULL) || (hal->set_address == NULL) || !config_valid(cfg)) {
        return URB_NODE_ERR_CONFIG;
    }
    start_node(node, hal, hooks, user, cfg, storage, storage_len);
    if (hooks->bootup != NULL) {
        hooks->bootup(node, user);
    }
    if (node->setup_err != 0) {
        return node->setup_err; /* stays off the bus */
    }
    node->flags = URB_F_ID_DIRTY;
    (void)refresh_identification(node); /* no interrupt yet: the lock cannot fail */
    node->started = 1u;
    urb_pll_start(node);
    hal->set_address(hal->ctx, cfg->i2c_address);
    if (hooks->init != NULL) {
        hooks->init(node, user);
    }
    return URB_NODE_OK;
}

/* lobster-trace: urb.WCET_003 */
uint8_t urb_node_poll(urb_node_t *node)
{
    if ((node == NULL) || (node->started == 0u)) {
        return 0u;
    }
    /* faults after the update: it starts sooner after its heartbeat, and a missed heartbeat's
     * OVERRUN joins the interrupts' in one delivery */
    uint8_t done = run_command(node);
    done |= run_update(node);
    done |= deliver_isr_faults(node);
    done |= refresh_identification(node);
    if (node->hooks->idle != NULL) {
        node->hooks->idle(node, node->user);
    }
    return done;
}

bool urb_node_has_work(const urb_node_t *node)
{
    if ((node == NULL) || (node->started == 0u)) {
        return false;
    }
    if ((node->update_due != node->update_done) || ((node->flags & URB_F_ID_DIRTY) != 0u)) {
        return true;
    }
    /* bound: URB_NODE_FAULT_CODES = 4 */
    for (uint8_t i = 0u; i < URB_NODE_FAULT_CODES; i++) {
        if (node->isr_faults[i] != node->seen_faults[i]) {
            return true;
        }
    }
    uint8_t const front = node->inbox[0].front; /* a command committed and not yet taken */
    return node->inbox[0].fresh[front] != 0u;
}

/* ===== Setup ================================================================================ */

/* Setup calls are allowed on a node that is not on the bus yet. */
static int setup_allowed(const urb_node_t *node)
{
    if (node == NULL) {
        return URB_NODE_ERR_ARG;
    }
    return (node->started != 0u) ? URB_NODE_ERR_STATE : URB_NODE_OK;
}

/* lobster-trace: urb.MBX_012 */
int urb_node_set_class(urb_node_t *node, uint8_t class_id)
{
    int const rc = setup_allowed(node);
    if (rc == URB_NODE_OK) {
        node->class_id = class_id;
    }
    return rc;
}

/* lobster-trace: urb.MBX_012 */
int urb_node_set_index(urb_node_t *node, uint8_t index)
{
    int rc = setup_allowed(node);
    if ((rc == URB_NODE_OK) && (index > 63u)) {
        rc = URB_NODE_ERR_ARG;
        urb_setup_error(node, rc);
    }
    if (rc == URB_NODE_OK) {
        node->index = index;
    }
    return rc;
}

/* lobster-trace: urb.MBX_011 */
int urb_node_set_fingerprint(urb_node_t *node, uint32_t fingerprint)
{
    int const rc = setup_allowed(node);
    if (rc == URB_NODE_OK) {
        node->fingerprint = fingerprint;
    }
    return rc;
}
