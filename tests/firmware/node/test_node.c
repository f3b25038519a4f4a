/*
 * Main loop: app_update scheduling, deadline overruns, acquisition-time measurement, every inbox 0
 * command, fault delivery, outbox 0 refresh, has_work.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "node_fixture.h"
#include "urb_core.h"
#include "urb_runtime.h"

static fixture_t fx;

static int setup(void **state)
{
    fx_defaults(&fx);
    assert_int_equal(fx_start(&fx), URB_NODE_OK);
    *state = &fx;
    return 0;
}

#define PERIOD 48000u

static urb_identification_t read_id(urb_node_t *node)
{
    uint8_t data[25];
    assert_true(fx_read_checked(node, 0u, 25u, data));
    urb_identification_t id;
    assert_int_equal(urb_identification_decode(&id, data, 25u), 25);
    return id;
}

/* lobster-trace: urb.MBX_012 */
static void update_once_per_heartbeat(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    assert_false(urb_node_has_work(node));
    assert_false(urb_node_update_due(node));
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_UPDATE, 0u);
    assert_int_equal(f->idles, 1u);
    assert_int_equal(urb_hal_hosted_advance(&f->port, node, PERIOD), 1u);
    assert_true(urb_node_has_work(node));
    assert_true(urb_node_update_due(node));
    assert_int_equal(f->port.mark_count[URB_NODE_MARK_BEAT], 1u);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_UPDATE) != 0u);
    assert_false(urb_node_update_due(node));
    assert_false(urb_node_update_due(NULL));
    assert_int_equal(f->updates, 1u);
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_UPDATE, 0u);
    assert_int_equal(f->updates, 1u);
    assert_int_equal(f->idles, 3u);
    assert_int_equal(f->faults[URB_NODE_FAULT_OVERRUN], 0u);
    /* free-running at the nominal period without SYNC */
    assert_int_equal(urb_hal_hosted_advance(&f->port, node, 10u * PERIOD), 10u);
    assert_int_equal(f->port.compare, 1000u + 12u * PERIOD);
}

static void missed_deadline_overrun(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    assert_int_equal(urb_hal_hosted_advance(&f->port, node, 2u * PERIOD), 2u);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_UPDATE) != 0u);
    assert_int_equal(f->updates, 1u); /* one catch-up update, not two */
    assert_int_equal(f->faults[URB_NODE_FAULT_OVERRUN], 1u);
    assert_int_equal(node->acq_ticks, 0u); /* a late update is not measured */
}

static void update_divider(void **state)
{
    (void)state;
    fixture_t f;
    fx_defaults(&f);
    f.cfg.update_divider = 10u; /* 100 Hz */
    assert_int_equal(fx_start(&f), URB_NODE_OK);
    for (unsigned i = 0u; i < 25u; i++) {
        (void)urb_hal_hosted_advance(&f.port, &f.node, PERIOD);
        (void)urb_node_poll(&f.node);
    }
    assert_int_equal(f.updates, 2u);
    assert_int_equal(f.faults[URB_NODE_FAULT_OVERRUN], 0u);
}

static void one_update(fixture_t *f, uint32_t work)
{
    f->update_work = work;
    (void)urb_hal_hosted_advance(&f->port, &f->node, PERIOD);
    (void)urb_node_poll(&f->node);
}

static void acquisition_time(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    f->cfg.acq_guard_us = 0u; /* the configuration is referenced: this node measures without a guard */
    f->update_work = 480u; /* 10 us from heartbeat to the release of outbox 1 */
    (void)urb_hal_hosted_advance(&f->port, node, PERIOD);
    (void)urb_node_poll(node);
    assert_int_equal(node->acq_ticks, 480u);
    assert_int_equal(f->port.mark_count[URB_NODE_MARK_ACQ_END], 1u);
    f->update_work = 240u; /* shorter: the max is kept */
    (void)urb_hal_hosted_advance(&f->port, node, PERIOD);
    (void)urb_node_poll(node);
    assert_int_equal(node->acq_ticks, 480u);
    f->update_work = 960u;
    (void)urb_hal_hosted_advance(&f->port, node, PERIOD);
    (void)urb_node_poll(node);
    assert_int_equal(node->acq_ticks, 960u);
    urb_identification_t const id = read_id(node);
    assert_int_equal(id.acq_time, 20u); /* us */
    urb_node_sync_status_t st;
    urb_node_sync_status(node, &st);
    assert_int_equal(st.acq_ticks, 960u);
    /* with the default 1-us guard every sample is 48 ticks longer, and so is the lead */
    f->cfg.acq_guard_us = 1u;
    one_update(f, 960u);
    assert_int_equal(node->acq_ticks, 960u + 48u);
    assert_int_equal(read_id(node).acq_time, 21u);
}

/* The default window (16 samples): an outlier in the first sample of a window is forgotten after
 * 2 x 16 - 1 more samples (31 updates = 31 SYNCs at update_divider 1), never earlier than 16; a
 * longer acquisition is tracked at once and kept. */
static void acquisition_time_window(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    f->cfg.acq_guard_us = 0u;
    assert_int_equal(f->cfg.acq_window, 16u);
    one_update(f, 4800u); /* 100 us: an acquisition an interrupt preempted */
    assert_int_equal(node->acq_ticks, 4800u);
    for (unsigned k = 1u; k < 31u; k++) {
        one_update(f, 480u);
        assert_int_equal(node->acq_ticks, 4800u);
    }
    one_update(f, 480u);
    assert_int_equal(node->acq_ticks, 480u);
    urb_node_sync_status_t st;
    urb_node_sync_status(node, &st);
    assert_int_equal(st.acq_ticks, 480u);
    assert_int_equal(read_id(node).acq_time, 10u);
    /* genuinely longer from now on: tracked at its first sample, then kept window after window */
    one_update(f, 960u);
    assert_int_equal(node->acq_ticks, 960u);
    for (unsigned k = 0u; k < 64u; k++) {
        one_update(f, 960u - (k & 7u)); /* jitter below the largest sample */
        assert_int_equal(node->acq_ticks, 960u);
    }
    /* an outlier in the last sample of a window is held through the next window only */
    while (node->acq_count != 15u) {
        one_update(f, 900u);
    }
    one_update(f, 4800u);
    assert_int_equal(node->acq_ticks, 4800u);
    for (unsigned k = 1u; k < 16u; k++) {
        one_update(f, 900u);
        assert_int_equal(node->acq_ticks, 4800u);
    }
    one_update(f, 900u);
    assert_int_equal(node->acq_ticks, 900u);
}

/* acq_window 0 acts as 1: t_acq is the latest sample. */
static void acquisition_time_window_one(void **state)
{
    (void)state;
    fixture_t f;
    fx_defaults(&f);
    f.cfg.acq_window = 0u;
    f.cfg.acq_guard_us = 0u;
    assert_int_equal(fx_start(&f), URB_NODE_OK);
    one_update(&f, 4800u);
    assert_int_equal(f.node.acq_ticks, 4800u);
    one_update(&f, 480u);
    assert_int_equal(f.node.acq_ticks, 480u);
}

static void explicit_mark_wins(fixture_t *f)
{
    urb_node_t *node = &f->node;
    f->port.now_offset = 100u;
    urb_node_mark_acquired(node);
    f->port.now_offset = 900u;
    uint8_t *buf = NULL;
    assert_int_equal(urb_node_lock_outbox(node, 1u, &buf), URB_NODE_OK);
    memset(buf, 1, 6u);
    assert_int_equal(urb_node_release_outbox(node, 1u), URB_NODE_OK); /* already marked */
    f->port.now_offset = 0u;
}

static void explicit_mark(void **state)
{
    fixture_t *f = *state;
    f->cfg.acq_guard_us = 0u;
    f->on_update = explicit_mark_wins;
    (void)urb_hal_hosted_advance(&f->port, &f->node, PERIOD);
    (void)urb_node_poll(&f->node);
    assert_int_equal(f->node.acq_ticks, 100u);
    assert_int_equal(f->port.mark_count[URB_NODE_MARK_ACQ_END], 1u);
}

static void command_nop_and_unknown(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_NOP, 0u, 0u, 0u), FX_ALL_ACKED);
    assert_true(urb_node_has_work(node));
    assert_true((urb_node_poll(node) & URB_NODE_POLL_COMMAND) != 0u);
    /* executed once only */
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_COMMAND, 0u);
    /* an unknown opcode passes the link check but not the decoder: ignored */
    uint8_t const raw[6] = {9u, 0u, 0u, 0u, 0u, 0u};
    assert_int_equal(fx_write(node, 0u, raw, 6u), FX_ALL_ACKED);
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_COMMAND, 0u);
    assert_int_equal(f->resets + f->signals, 0u);
}

/* Step hook: the bridge writes inbox 0 again right after each AppLockClaim of the command lock, so
 * each attempt fails its front check: the main loop's lock of inbox 0 returns BUSY. */
static void command_lands_at_claim(urb_node_t *node, uint8_t step, void *ctx)
{
    unsigned *writes = ctx;
    if ((step == URB_STEP_IN_CLAIM) && (node->inbox[0].app_idx != URB_NONE)) {
        uint8_t buf[URB_COMMAND_SIZE];
        urb_command_t const cmd = {URB_COMMAND_CODE_SIGNAL, (uint8_t)(10u + *writes), 0u, 0u};
        assert_int_equal(urb_command_encode(&cmd, buf, sizeof buf), (int)sizeof buf);
        assert_int_equal(fx_write(node, 0u, buf, sizeof buf), FX_ALL_ACKED);
        (*writes)++;
    }
}

/* A command lock that finds bridge writes landing on every attempt (BUSY) leaves inbox 0 alone; the
 * next poll runs the newest command, once. */
static void command_busy_waits_for_the_next_poll(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_SIGNAL, 1u, 0u, 0u), FX_ALL_ACKED);
    unsigned writes = 0u;
    fx_step_hook = command_lands_at_claim;
    fx_step_ctx = &writes;
    uint8_t const result = urb_node_poll(node);
    fx_step_hook = NULL;
    assert_int_equal(writes, 3u); /* 1 + MaxRetry attempts, each overtaken by a write */
    assert_int_equal(result & URB_NODE_POLL_COMMAND, 0u);
    assert_int_equal(f->signals, 0u);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_COMMAND) != 0u);
    assert_int_equal(f->signals, 1u);
    assert_int_equal(f->last_signal, 12u); /* the last write won */
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_COMMAND, 0u);
}

/* lobster-trace: urb.MBX_011 */
static void command_reset(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    f->cfg.acq_guard_us = 0u;
    f->update_work = 480u;
    (void)urb_hal_hosted_advance(&f->port, node, PERIOD);
    (void)urb_node_poll(node);
    assert_int_equal(node->acq_ticks, 480u);
    /* a fault sets the identification flag; RESET clears it and re-measures t_acq */
    uint8_t frame[8];
    uint8_t const d[2] = {0u, 0u};
    (void)fx_write_raw(node, frame, fx_frame(frame, 1u, d, 2u, 1u), true);
    (void)urb_node_poll(node);
    assert_true(read_id(node).fault);
    (void)urb_hal_hosted_advance(&f->port, node, PERIOD); /* an update due before the reset is dropped */
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_RESET, 0u, 0u, 0u), FX_ALL_ACKED);
    unsigned const updates = f->updates;
    assert_true((urb_node_poll(node) & URB_NODE_POLL_COMMAND) != 0u);
    assert_int_equal(f->resets, 1u);
    assert_int_equal(f->updates, updates);
    assert_int_equal(node->acq_ticks, 0u);
    assert_false(read_id(node).fault);
}

/* lobster-trace: urb.MBX_011 */
static void command_signal(void **state)
{
    fixture_t *f = *state;
    assert_int_equal(fx_command(&f->node, URB_COMMAND_CODE_SIGNAL, 7u, 0u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(&f->node);
    assert_int_equal(f->signals, 1u);
    assert_int_equal(f->last_signal, 7u);
    /* the same signal sent twice is delivered twice (two commits) */
    assert_int_equal(fx_command(&f->node, URB_COMMAND_CODE_SIGNAL, 7u, 0u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(&f->node);
    assert_int_equal(f->signals, 2u);
}

/* lobster-trace: urb.MBX_011 */
static void command_identify(void **state)
{
    fixture_t *f = *state;
    assert_int_equal(fx_command(&f->node, URB_COMMAND_CODE_IDENTIFY, 3u, 0u, 0u), FX_ALL_ACKED);
    uint8_t const done = urb_node_poll(&f->node);
    assert_true((done & URB_NODE_POLL_COMMAND) != 0u);
    assert_true((done & URB_NODE_POLL_IDENT) != 0u); /* outbox 0 refreshed */
    assert_int_equal(f->port.identify_calls, 1u);
    assert_int_equal(f->port.identify_seconds, 3u);
    /* a port without an LED */
    f->port.hal.identify = NULL;
    assert_int_equal(fx_command(&f->node, URB_COMMAND_CODE_IDENTIFY, 1u, 0u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(&f->node);
    assert_int_equal(f->port.identify_calls, 1u);
}

/* lobster-trace: urb.MBX_011 */
static void command_sync_config(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    urb_node_sync_status_t st;
    /* disable: applied by the next heartbeat */
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_SYNC_CONFIG, 0u, 0u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(node);
    assert_int_equal(node->pll.state, URB_NODE_SYNC_FREE);
    (void)urb_hal_hosted_advance(&f->port, node, PERIOD);
    urb_node_sync_status(node, &st);
    assert_int_equal(st.state, URB_NODE_SYNC_OFF);
    fx_sync(node, 1u); /* ignored */
    assert_int_equal(node->pll.syncs, 0u);
    /* enable with a 2 ms period and a fixed 30 us lead */
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_SYNC_CONFIG, 1u, 2000u, 30u), FX_ALL_ACKED);
    (void)urb_node_poll(node);
    (void)urb_hal_hosted_advance(&f->port, node, PERIOD);
    urb_node_sync_status(node, &st);
    assert_int_equal(st.state, URB_NODE_SYNC_FREE);
    assert_int_equal(st.period_q8, 2u * PERIOD * 256u);
    assert_int_equal(node->pll.fixed_lead, 30u * 48u);
    /* two SYNC_CONFIGs before a heartbeat: the second waits, then wins */
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_SYNC_CONFIG, 1u, 1000u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(node);
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_SYNC_CONFIG, 1u, 1500u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(node);
    assert_true(urb_node_has_work(node)); /* one request still to post */
    (void)urb_hal_hosted_advance(&f->port, node, 2u * PERIOD);
    assert_int_equal(node->pll.period_q8, PERIOD * 256u);
    (void)urb_node_poll(node);
    (void)urb_hal_hosted_advance(&f->port, node, 2u * PERIOD);
    assert_int_equal(node->pll.period_q8, 72000u * 256u);
    assert_int_equal(node->pll.fixed_lead, 0u);
    /* a period out of range keeps the current one */
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_SYNC_CONFIG, 1u, 1u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(node);
    (void)urb_hal_hosted_advance(&f->port, node, 2u * PERIOD);
    assert_int_equal(node->pll.period_q8, 72000u * 256u);
}

/* lobster-trace: urb.ERR_005 */
static void faults_delivered_in_poll(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u);
    assert_int_equal(f->faults[URB_NODE_FAULT_STUCK_BUS], 0u); /* never from the interrupt */
    assert_true(urb_node_has_work(node));
    assert_true((urb_node_poll(node) & URB_NODE_POLL_FAULT) != 0u);
    assert_int_equal(f->faults[URB_NODE_FAULT_STUCK_BUS], 1u); /* once per code per poll */
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_FAULT, 0u);
    assert_true(read_id(node).fault);
}

/* A fault delivered after a complete identification read, while the published flag is still set,
 * must show in the next read ("a fault was reported to the application since the last
 * identification read"), then clear after a read that reported it. Before the fix the poll cleared
 * the flag for the earlier read and the second fault was never published (review F3). */
static void fault_after_identification_read_is_published(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u); /* fault #1 */
    (void)urb_node_poll(node);                          /* delivered and published */
    assert_true(read_id(node).fault);                   /* complete read: the host saw fault #1 */
    /* fault #2, a write with a bad check, before the next main-loop iteration */
    uint8_t frame[8];
    uint8_t const d[2] = {0u, 0u};
    (void)fx_write_raw(node, frame, fx_frame(frame, 1u, d, 2u, 1u), true);
    (void)urb_node_poll(node);
    assert_int_equal(f->faults[URB_NODE_FAULT_CHECKSUM], 1u);
    assert_true(read_id(node).fault); /* fault #2 is reported */
    (void)urb_node_poll(node);
    assert_false(read_id(node).fault); /* that read reported it: cleared */
    /* the same with the missed heartbeat's OVERRUN, delivered by the update */
    (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u);
    (void)urb_node_poll(node);
    assert_true(read_id(node).fault);
    assert_int_equal(urb_hal_hosted_advance(&f->port, node, 2u * PERIOD), 2u);
    (void)urb_node_poll(node);
    assert_int_equal(f->faults[URB_NODE_FAULT_OVERRUN], 1u);
    assert_true(read_id(node).fault);
    (void)urb_node_poll(node);
    assert_false(read_id(node).fault);
}

/* A refused write's OVERRUN and a missed heartbeat's OVERRUN in the same poll: one delivery
 * (README: "at most once per code per poll"; before the fix: two, review F7). */
/* lobster-trace: urb.ERR_005 */
static void overrun_once_per_poll(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    const uint8_t *data = NULL;
    assert_true(urb_node_lock_inbox(node, 1u, &data) >= 0); /* the application holds inbox 1 */
    uint8_t const d[2] = {1u, 2u};
    assert_int_equal(fx_write(node, 1u, d, 2u), FX_ALL_ACKED); /* into the other buffer */
    assert_int_equal(fx_write(node, 1u, d, 2u), 1);            /* refused: NACK, OVERRUN counted */
    assert_int_equal(urb_node_release_inbox(node, 1u), URB_NODE_OK);
    assert_int_equal(urb_hal_hosted_advance(&f->port, node, 2u * PERIOD), 2u); /* and a missed heartbeat */
    uint8_t const done = urb_node_poll(node);
    assert_true((done & URB_NODE_POLL_FAULT) != 0u);
    assert_true((done & URB_NODE_POLL_UPDATE) != 0u);
    assert_int_equal(f->faults[URB_NODE_FAULT_OVERRUN], 1u);
    assert_false(urb_node_has_work(node)); /* nothing left over for a later poll either */
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_FAULT, 0u);
    assert_int_equal(f->faults[URB_NODE_FAULT_OVERRUN], 1u);
    /* the next missed heartbeat alone is an OVERRUN again, in the poll that finds it */
    assert_int_equal(urb_hal_hosted_advance(&f->port, node, 2u * PERIOD), 2u);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_FAULT) != 0u);
    assert_int_equal(f->faults[URB_NODE_FAULT_OVERRUN], 2u);
}

/* lobster-trace: urb.MBX_011 */
static void identification_refreshes(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_IDENT, 0u); /* nothing changed */
    /* a bridge read in progress: the first refresh takes the other buffer, the second must wait */
    (void)fx_select(node, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    node->flags |= URB_F_ID_DIRTY;
    assert_true((urb_node_poll(node) & URB_NODE_POLL_IDENT) != 0u); /* first refresh: other buffer */
    node->flags |= URB_F_ID_DIRTY;
    assert_int_equal(urb_node_poll(node) & URB_NODE_POLL_IDENT, 0u); /* the next one is being read */
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_IDENT) != 0u);
}

/* Mutation score (tests/mutation/README.md): RESET itself clears the fault flag and republishes
 * the identification (no identification read in between, which would clear the flag anyway), and
 * the command after it still runs. */
static void command_reset_republishes_and_the_next_command_runs(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u); /* a fault */
    (void)urb_node_poll(node);                          /* delivered and published, never read */
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_RESET, 0u, 0u, 0u), FX_ALL_ACKED);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_COMMAND) != 0u);
    assert_false(read_id(node).fault);
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_SIGNAL, 5u, 0u, 0u), FX_ALL_ACKED);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_COMMAND) != 0u);
    assert_int_equal(f->signals, 1u);
    assert_int_equal(f->last_signal, 5u);
}

/* Mutation score: the window keeps its largest sample even when it is one tick larger than the
 * one before it (the window's end then drops t_acq to that largest sample, not to the earlier one). */
static void acquisition_window_keeps_a_max_one_tick_larger(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    f->cfg.acq_guard_us = 0u;
    one_update(f, 480u);
    one_update(f, 481u);
    assert_int_equal(node->acq_ticks, 481u);
    while (node->acq_count != 0u) {
        one_update(f, 400u);
    }
    assert_int_equal(node->acq_ticks, 481u);
}

/* A heartbeat during the application's reset hook: the update it makes due is run, not dropped
 * with the ones due before the reset (those are dropped before the hook runs). */
static void reset_with_a_heartbeat(urb_node_t *node, void *user)
{
    fixture_t *f = user;
    f->resets++;
    (void)urb_hal_hosted_advance(&f->port, node, PERIOD);
}

static void update_due_during_the_reset_hook_runs(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    f->hooks.reset = reset_with_a_heartbeat;
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_RESET, 0u, 0u, 0u), FX_ALL_ACKED);
    unsigned const updates = f->updates;
    uint8_t const done = urb_node_poll(node);
    assert_true((done & URB_NODE_POLL_COMMAND) != 0u);
    assert_int_equal(f->resets, 1u);
    assert_true((done & URB_NODE_POLL_UPDATE) != 0u);
    assert_int_equal(f->updates, updates + 1u);
}

/* Two bus writes to inbox 0 land right after the command's inbox is released (interrupts at that
 * step): the command run is the one that was locked, read before the release, not a later one
 * that the second write put into the same buffer. */
static void two_writes_at_release(urb_node_t *node, uint8_t step, void *ctx)
{
    unsigned *writes = ctx;
    if ((step == URB_STEP_IN_RELEASE) && (*writes == 0u)) {
        *writes = 2u;
        assert_int_equal(fx_command(node, URB_COMMAND_CODE_SIGNAL, 2u, 0u, 0u), FX_ALL_ACKED);
        assert_int_equal(fx_command(node, URB_COMMAND_CODE_SIGNAL, 3u, 0u, 0u), FX_ALL_ACKED);
    }
}

static void command_read_before_its_inbox_is_released(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_SIGNAL, 1u, 0u, 0u), FX_ALL_ACKED);
    unsigned writes = 0u;
    fx_step_hook = two_writes_at_release;
    fx_step_ctx = &writes;
    uint8_t const done = urb_node_poll(node);
    fx_step_hook = NULL;
    assert_int_equal(writes, 2u);
    assert_true((done & URB_NODE_POLL_COMMAND) != 0u);
    assert_int_equal(f->signals, 1u);
    assert_int_equal(f->last_signal, 1u);
    assert_true((urb_node_poll(node) & URB_NODE_POLL_COMMAND) != 0u); /* then the latest one */
    assert_int_equal(f->last_signal, 3u);
}

/* RESET restarts the t_acq measurement (firmware/node/README.md, "RESET still restarts the
 * measurement"): after it, the same samples give the node the same t_acq, sample by sample, as a
 * node that has just started, whatever the window held before; and the identification still names
 * the node (class, index, fingerprint). */
static void reset_measures_t_acq_like_a_fresh_start(void **state)
{
    fixture_t *f = *state;
    static fixture_t fresh;
    fx_defaults(&fresh);
    assert_int_equal(fx_start(&fresh), URB_NODE_OK);
    f->cfg.acq_guard_us = 0u;
    f->cfg.acq_window = 4u;
    fresh.cfg.acq_guard_us = 0u;
    fresh.cfg.acq_window = 4u;
    /* before the reset: a long acquisition, three samples into a window */
    for (unsigned i = 0u; i < 3u; i++) {
        one_update(f, 2000u);
    }
    assert_int_equal(f->node.acq_ticks, 2000u);
    assert_int_equal(fx_command(&f->node, URB_COMMAND_CODE_RESET, 0u, 0u, 0u), FX_ALL_ACKED);
    assert_true((urb_node_poll(&f->node) & URB_NODE_POLL_COMMAND) != 0u);
    /* one inflated sample, then short ones: two windows complete */
    static const uint32_t samples[] = {96u, 288u, 96u, 96u, 96u, 96u, 96u, 96u, 96u, 96u};
    for (size_t i = 0u; i < sizeof samples / sizeof samples[0]; i++) {
        one_update(f, samples[i]);
        one_update(&fresh, samples[i]);
        assert_int_equal(f->node.acq_ticks, fresh.node.acq_ticks);
        urb_identification_t const got = read_id(&f->node);
        urb_identification_t const want = read_id(&fresh.node);
        assert_int_equal(got.acq_time, want.acq_time);
        assert_int_equal(got.class_id, want.class_id);
        assert_int_equal(got.index, want.index);
        assert_int_equal(got.fingerprint, want.fingerprint);
    }
    assert_int_equal(fresh.node.acq_ticks, 96u); /* the inflated sample is forgotten after two windows */
    assert_int_equal(f->resets, 1u);
}

/* What the poll that runs each command reports (URB_NODE_POLL_*): COMMAND for every command; the
 * commands that change what Identification describes or ask for it (IDENTIFY; RESET: the fault
 * flag and t_acq restart; SYNC_CONFIG: the synchronisation it reports is reconfigured) also
 * republish outbox 0 in that same poll (IDENT); NOP and SIGNAL leave outbox 0 alone. */
static void command_poll_reports(void **state)
{
    fixture_t *f = *state;
    urb_node_t *node = &f->node;
    static const struct {
        uint8_t opcode;
        uint8_t done;
    } cases[] = {
        {URB_COMMAND_CODE_NOP, URB_NODE_POLL_COMMAND},
        {URB_COMMAND_CODE_SIGNAL, URB_NODE_POLL_COMMAND},
        {URB_COMMAND_CODE_IDENTIFY, URB_NODE_POLL_COMMAND | URB_NODE_POLL_IDENT},
        {URB_COMMAND_CODE_RESET, URB_NODE_POLL_COMMAND | URB_NODE_POLL_IDENT},
        {URB_COMMAND_CODE_SIGNAL, URB_NODE_POLL_COMMAND},
        {URB_COMMAND_CODE_SYNC_CONFIG, URB_NODE_POLL_COMMAND | URB_NODE_POLL_IDENT},
    };
    assert_int_equal(urb_node_poll(node), 0u);
    for (size_t i = 0u; i < sizeof cases / sizeof cases[0]; i++) {
        /* SYNC_CONFIG: enabled, period and lead kept (0): nothing it reports changes */
        assert_int_equal(fx_command(node, cases[i].opcode, 1u, 0u, 0u), FX_ALL_ACKED);
        assert_int_equal(urb_node_poll(node), cases[i].done);
        assert_int_equal(urb_node_poll(node), 0u);
        assert_false(urb_node_has_work(node));
    }
    assert_int_equal(f->signals, 2u);
    assert_int_equal(f->resets, 1u);
    assert_int_equal(f->port.identify_calls, 1u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(update_once_per_heartbeat, setup),
        cmocka_unit_test_setup(missed_deadline_overrun, setup),
        cmocka_unit_test(update_divider),
        cmocka_unit_test_setup(acquisition_time, setup),
        cmocka_unit_test_setup(acquisition_time_window, setup),
        cmocka_unit_test(acquisition_time_window_one),
        cmocka_unit_test_setup(explicit_mark, setup),
        cmocka_unit_test_setup(command_nop_and_unknown, setup),
        cmocka_unit_test_setup(command_reset, setup),
        cmocka_unit_test_setup(command_busy_waits_for_the_next_poll, setup),
        cmocka_unit_test_setup(command_signal, setup),
        cmocka_unit_test_setup(command_identify, setup),
        cmocka_unit_test_setup(command_sync_config, setup),
        cmocka_unit_test_setup(faults_delivered_in_poll, setup),
        cmocka_unit_test_setup(identification_refreshes, setup),
        cmocka_unit_test_setup(fault_after_identification_read_is_published, setup),
        cmocka_unit_test_setup(overrun_once_per_poll, setup),
        cmocka_unit_test_setup(command_reset_republishes_and_the_next_command_runs, setup),
        cmocka_unit_test_setup(acquisition_window_keeps_a_max_one_tick_larger, setup),
        cmocka_unit_test_setup(update_due_during_the_reset_hook_runs, setup),
        cmocka_unit_test_setup(command_read_before_its_inbox_is_released, setup),
        cmocka_unit_test_setup(reset_measures_t_acq_like_a_fresh_start, setup),
        cmocka_unit_test_setup(command_poll_reports, setup),
    };
    return cmocka_run_group_tests_name("node_main_loop", tests, NULL, NULL);
}
