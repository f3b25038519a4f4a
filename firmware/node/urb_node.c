/*
 * Node lifecycle and main loop: initialisation, the round-robin poll (faults, inbox 0 commands,
 * app_update, outbox 0 identification, app_idle), acquisition-time measurement.
 *
 * Everything here runs at thread level. It talks to the interrupt side only through
 *   - the mailbox algorithms (inbox 0 and outbox 0 are ordinary mailboxes),
 *   - counters with one writer each (update_due, isr_faults, id_reads/id_done),
 *   - one 32-bit value the SYNC interrupt reads (acq_ticks: aligned word stores are atomic on
 *     every supported core), and a request (req_*) the timer interrupt applies.
 */
#include "urb_node_internal.h"

#include "urb_core.h"

/* ===== Configuration ======================================================================== */

void urb_node_config_default(urb_node_config_t *cfg)
{
    if (cfg == NULL) {
        return;
    }
    cfg->i2c_address = 0u; /* must be set: no default address is safe on a shared bus */
    cfg->fw_major = 0u;
    cfg->fw_minor = 0u;
    cfg->fw_patch = 0u;
    cfg->ticks_per_us = 48u; /* 48 MHz timer */
    cfg->heartbeat_us = 1000u;
    cfg->update_divider = 1u;
    cfg->sync_enabled = 1u;
    cfg->lead_us = 0u;
    /* PLL defaults, tuned with tests/firmware/pll (see firmware/node/README.md) */
    cfg->kd_q8 = 32u;  /* K_d = 1/8 */
    cfg->kn_q8 = 64u;  /* K_n = 1/4 */
    cfg->lock_ns = 1000u;
    cfg->lock_count = 4u;
    cfg->outlier_ns = 2000u;
    cfg->max_outliers = 4u;
    cfg->max_gap = 8u;
    cfg->lost_sync_beats = 10u;
}

static bool config_valid(const urb_node_config_t *cfg)
{
    uint32_t const ticks = (uint32_t)cfg->heartbeat_us * cfg->ticks_per_us;
    return (cfg->i2c_address >= 1u) && (cfg->i2c_address <= 127u) && (cfg->ticks_per_us >= 1u) &&
           (cfg->ticks_per_us <= 1000u) && (ticks >= 64u) && (ticks <= 0x7FFFFFu) && (cfg->update_divider >= 1u) &&
           (cfg->kd_q8 >= 1u) && (cfg->kn_q8 >= 1u) && (cfg->lock_count >= 1u) && (cfg->max_gap >= 1u) &&
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

static uint32_t lead_in_use(const urb_node_t *node)
{
    uint32_t const lead = (node->pll.fixed_lead != 0u) ? node->pll.fixed_lead : node->acq_ticks;
    uint32_t const limit = (node->pll.period_q8 >> 8) >> 2; /* the PLL's quarter-period limit */
    return (lead > limit) ? limit : lead;
}

/* Publishes Identification when anything in it changed; returns URB_NODE_POLL_IDENT if it did. */
static uint8_t refresh_identification(urb_node_t *node)
{
    uint8_t const synced = (node->pll.state == URB_NODE_SYNC_LOCKED) ? 1u : 0u;
    uint32_t const acq = lead_in_use(node) / node->cfg.ticks_per_us;
    uint16_t const acq_us = (acq > 0xFFFFu) ? 0xFFFFu : (uint16_t)acq;
    /* the fault flag clears once a read that began after we published it has completed */
    if ((node->fault_flag != 0u) && (node->id_fault != 0u) && (node->id_done != node->id_fault_after) &&
        ((uint8_t)(node->id_done - node->id_fault_after) < 0x80u)) {
        node->fault_flag = 0u;
    }
    if ((node->id_dirty == 0u) && (synced == node->id_synced) && (acq_us == node->id_acq_us) &&
        (node->fault_flag == node->id_fault)) {
        return 0u;
    }
    urb_identification_t id;
    id.class_id = node->class_id;
    id.index = node->index;
    id.fingerprint = node->fingerprint;
    id.fw_major = node->cfg.fw_major;
    id.fw_minor = node->cfg.fw_minor;
    id.fw_patch = node->cfg.fw_patch;
    /* bound: URB_NODE_MAILBOXES = 8 */
    for (uint8_t n = 0u; n < URB_NODE_MAILBOXES; n++) {
        id.inbox_sizes[n] = node->inbox[n].size;
        id.outbox_sizes[n] = node->outbox[n].size;
    }
    id.synced = synced != 0u;
    id.fault = node->fault_flag != 0u;
    id.acq_time = acq_us;
    uint8_t *buf = NULL;
    if (urb_lock_outbox_any(node, 0u, &buf) != URB_NODE_OK) {
        return 0u; /* the bridge still reads the other buffer: next iteration */
    }
    (void)urb_identification_encode(&id, buf, URB_NODE_OUTBOX0_SIZE); /* cannot fail: sizes <= 32, index <= 63 */
    (void)urb_release_outbox_any(node, 0u);
    node->id_dirty = 0u;
    node->id_synced = synced;
    node->id_acq_us = acq_us;
    node->id_fault = node->fault_flag;
    node->id_fault_after = node->id_reads; /* reads begun up to here may hold the previous version */
    return URB_NODE_POLL_IDENT;
}

/* ===== Faults =============================================================================== */

static void deliver_fault(urb_node_t *node, urb_node_fault_t code)
{
    node->fault_flag = 1u;
    if ((node->hooks != NULL) && (node->hooks->fault != NULL)) {
        node->hooks->fault(node, node->user, code);
    }
}

/* Delivers the faults the interrupts counted since the last poll: once per code per poll. */
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

/* Posts a SYNC_CONFIG to the timer interrupt once the previous request has been applied. */
static void post_sync_config(urb_node_t *node)
{
    if ((node->cmd_pending == 0u) || (node->req_seq != node->pll.req_ack)) {
        return; /* nothing to post, or the previous request is not applied yet */
    }
    uint32_t nominal = node->pll.nominal_q8;
    if (node->cmd_period_us != 0u) {
        uint32_t const ticks = (uint32_t)node->cmd_period_us * node->cfg.ticks_per_us;
        if ((ticks >= 64u) && (ticks <= 0x7FFFFFu)) {
            nominal = ticks << 8;
        }
    }
    node->req_nominal_q8 = nominal;
    node->req_lead_ticks = (uint32_t)node->cmd_lead_us * node->cfg.ticks_per_us;
    node->req_enable = (uint8_t)(node->cmd_arg & 1u);
    node->cmd_pending = 0u;
    URB_NODE_BARRIER(); /* the request is complete before the interrupt can see it */
    node->req_seq = (uint8_t)(node->req_seq + 1u);
    node->id_dirty = 1u;
}

static void reset_application(urb_node_t *node)
{
    node->fault_flag = 0u;
    node->acq_ticks = 0u;                  /* re-measure t_acq: the application restarts */
    node->update_done = node->update_due;  /* drop an update due before the reset */
    node->id_dirty = 1u;
    if ((node->hooks != NULL) && (node->hooks->reset != NULL)) {
        node->hooks->reset(node, node->user);
    }
}

/* Executes a new inbox-0 command, if any. Runs in the main loop, never in the interrupt. */
static uint8_t run_command(urb_node_t *node)
{
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
        if ((node->hooks != NULL) && (node->hooks->signal != NULL)) {
            node->hooks->signal(node, node->user, cmd.arg);
        }
        break;
    case URB_COMMAND_CODE_IDENTIFY:
        node->id_dirty = 1u;
        if (node->hal->identify != NULL) {
            node->hal->identify(node->hal->ctx, cmd.arg);
        }
        break;
    case URB_COMMAND_CODE_SYNC_CONFIG:
        node->cmd_pending = 1u; /* a newer SYNC_CONFIG replaces one not yet posted */
        node->cmd_arg = cmd.arg;
        node->cmd_period_us = cmd.period_us;
        node->cmd_lead_us = cmd.lead_us;
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
    node->cur_beat = node->update_beat;
    node->acq_valid = ((pending == 1u) && (node->update_due == due)) ? 1u : 0u;
    node->update_done = due;
    if (pending > 1u) {
        deliver_fault(node, URB_NODE_FAULT_OVERRUN); /* app_update missed at least one heartbeat */
    }
    node->in_update = 1u;
    node->acq_marked = 0u;
    if ((node->hooks != NULL) && (node->hooks->update != NULL)) {
        node->hooks->update(node, node->user);
    }
    node->in_update = 0u;
    return URB_NODE_POLL_UPDATE;
}

void urb_node_mark_acquired(urb_node_t *node)
{
    if ((node == NULL) || (node->in_update == 0u) || (node->acq_marked != 0u)) {
        return;
    }
    node->acq_marked = 1u;
    urb_node_hal_t const *hal = node->hal;
    if (hal->mark != NULL) {
        hal->mark(hal->ctx, URB_NODE_MARK_ACQ_END);
    }
    if (node->acq_valid == 0u) {
        return; /* a late update would inflate t_acq */
    }
    uint32_t const elapsed = hal->now(hal->ctx) - node->cur_beat;
    if ((elapsed > node->acq_ticks) && (elapsed < (node->pll.period_q8 >> 8))) {
        node->acq_ticks = elapsed; /* t_acq: the largest time from heartbeat to end of acquisition */
    }
}

/* ===== Lifecycle ============================================================================ */

int urb_node_init(urb_node_t *node, const urb_node_hal_t *hal, const urb_node_hooks_t *hooks, void *user,
                  const urb_node_config_t *cfg, uint8_t *storage, uint16_t storage_len)
{
    if ((node == NULL) || (hal == NULL) || (cfg == NULL) || ((storage == NULL) && (storage_len != 0u))) {
        return URB_NODE_ERR_ARG;
    }
    if ((hal->now == NULL) || (hal->set_compare == NULL) || (hal->set_address == NULL) || !config_valid(cfg)) {
        return URB_NODE_ERR_CONFIG;
    }
    /* Zero everything: a re-init (node reset) starts from scratch; the port keeps the node's
     * interrupts off until set_address below. bound: sizeof(urb_node_t) */
    unsigned char *raw = (unsigned char *)node;
    for (size_t k = 0u; k < sizeof *node; k++) {
        raw[k] = 0u;
    }
    node->hal = hal;
    node->hooks = hooks;
    node->user = user;
    node->cfg = *cfg;
    node->storage = storage;
    node->storage_len = storage_len;
    urb_mailbox_reset(node);
    node->i2c.state = URB_I2C_ST_IDLE;
    node->i2c.selected = 0u; /* reads return outbox 0 until the first select */
    if ((hooks != NULL) && (hooks->bootup != NULL)) {
        hooks->bootup(node, user);
    }
    if (node->setup_err != 0) {
        return node->setup_err; /* stays off the bus */
    }
    node->id_dirty = 1u;
    (void)refresh_identification(node); /* no interrupt yet: the lock cannot fail */
    node->started = 1u;
    urb_pll_start(node);
    hal->set_address(hal->ctx, cfg->i2c_address);
    if ((hooks != NULL) && (hooks->init != NULL)) {
        hooks->init(node, user);
    }
    return URB_NODE_OK;
}

uint8_t urb_node_poll(urb_node_t *node)
{
    if ((node == NULL) || (node->started == 0u)) {
        return 0u;
    }
    uint8_t done = deliver_isr_faults(node);
    done |= run_command(node);
    post_sync_config(node);
    done |= run_update(node);
    done |= refresh_identification(node);
    if ((node->hooks != NULL) && (node->hooks->idle != NULL)) {
        node->hooks->idle(node, node->user);
    }
    return done;
}

bool urb_node_has_work(const urb_node_t *node)
{
    if ((node == NULL) || (node->started == 0u)) {
        return false;
    }
    if ((node->update_due != node->update_done) || (node->cmd_pending != 0u) || (node->id_dirty != 0u)) {
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

int urb_node_set_class(urb_node_t *node, uint8_t class_id)
{
    if (node == NULL) {
        return URB_NODE_ERR_ARG;
    }
    if (node->started != 0u) {
        return URB_NODE_ERR_STATE;
    }
    node->class_id = class_id;
    return URB_NODE_OK;
}

int urb_node_set_index(urb_node_t *node, uint8_t index)
{
    if (node == NULL) {
        return URB_NODE_ERR_ARG;
    }
    if (index > 63u) {
        urb_setup_error(node, URB_NODE_ERR_ARG);
        return URB_NODE_ERR_ARG;
    }
    if (node->started != 0u) {
        return URB_NODE_ERR_STATE;
    }
    node->index = index;
    return URB_NODE_OK;
}

int urb_node_set_fingerprint(urb_node_t *node, uint32_t fingerprint)
{
    if (node == NULL) {
        return URB_NODE_ERR_ARG;
    }
    if (node->started != 0u) {
        return URB_NODE_ERR_STATE;
    }
    node->fingerprint = fingerprint;
    return URB_NODE_OK;
}
