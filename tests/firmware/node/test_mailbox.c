/*
 * Node API: initialisation, configuration checks, setup, and every argument/state error of the
 * mailbox calls. The algorithms' interleavings are in test_interleave.c.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "node_fixture.h"
#include "urb_core.h"

static fixture_t fx;

static int setup(void **state)
{
    fx_defaults(&fx);
    assert_int_equal(fx_start(&fx), URB_NODE_OK);
    *state = &fx;
    return 0;
}

static void init_arguments(void **state)
{
    (void)state;
    fixture_t f;
    fx_defaults(&f);
    assert_int_equal(urb_node_init(NULL, &f.port.hal, &f.hooks, &f, &f.cfg, f.storage, 8u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_init(&f.node, NULL, &f.hooks, &f, &f.cfg, f.storage, 8u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_init(&f.node, &f.port.hal, &f.hooks, &f, NULL, f.storage, 8u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_init(&f.node, &f.port.hal, &f.hooks, &f, &f.cfg, NULL, 8u), URB_NODE_ERR_ARG);
    /* a HAL without its required functions */
    urb_hal_hosted_t bad;
    urb_hal_hosted_init(&bad, 0u, false);
    bad.hal.now = NULL;
    assert_int_equal(urb_node_init(&f.node, &bad.hal, &f.hooks, &f, &f.cfg, f.storage, 8u), URB_NODE_ERR_CONFIG);
    urb_hal_hosted_init(&bad, 0u, false);
    bad.hal.set_compare = NULL;
    assert_int_equal(urb_node_init(&f.node, &bad.hal, &f.hooks, &f, &f.cfg, f.storage, 8u), URB_NODE_ERR_CONFIG);
    urb_hal_hosted_init(&bad, 0u, false);
    bad.hal.set_address = NULL;
    assert_int_equal(urb_node_init(&f.node, &bad.hal, &f.hooks, &f, &f.cfg, f.storage, 8u), URB_NODE_ERR_CONFIG);
    assert_int_equal(f.bootups, 0u); /* nothing ran */
    assert_int_equal(urb_node_init(&f.node, &f.port.hal, NULL, &f, &f.cfg, f.storage, 8u), URB_NODE_ERR_ARG);
    /* empty hooks are fine, and so is no storage when bootup sets up nothing */
    static const urb_node_hooks_t none = {NULL, NULL, NULL, NULL, NULL, NULL, NULL};
    assert_int_equal(urb_node_init(&f.node, &f.port.hal, &none, NULL, &f.cfg, NULL, 0u), URB_NODE_OK);
    (void)urb_hal_hosted_advance(&f.port, &f.node, 48000u);
    assert_true((urb_node_poll(&f.node) & URB_NODE_POLL_UPDATE) != 0u);
    assert_int_equal(fx_command(&f.node, 2u, 1u, 0u, 0u), FX_ALL_ACKED); /* SIGNAL: no hook */
    assert_true((urb_node_poll(&f.node) & URB_NODE_POLL_COMMAND) != 0u);
    (void)urb_node_i2c_event(&f.node, URB_I2C_STUCK, 0u);               /* fault: no hook */
    assert_true((urb_node_poll(&f.node) & URB_NODE_POLL_FAULT) != 0u);
    assert_int_equal(fx_command(&f.node, 1u, 0u, 0u, 0u), FX_ALL_ACKED); /* RESET: no hook */
    assert_true((urb_node_poll(&f.node) & URB_NODE_POLL_COMMAND) != 0u);
    assert_int_equal(urb_node_poll(&f.node), 0u);
    urb_node_timer_event(&f.node);
}

static void init_config_checks(void **state)
{
    (void)state;
    static const struct {
        size_t offset;
        size_t size;
        uint32_t value;
    } bad[] = {
        {offsetof(urb_node_config_t, i2c_address), 1u, 0u},
        {offsetof(urb_node_config_t, i2c_address), 1u, 128u},
        {offsetof(urb_node_config_t, ticks_per_us), 2u, 0u},
        {offsetof(urb_node_config_t, ticks_per_us), 2u, 1001u},
        {offsetof(urb_node_config_t, heartbeat_us), 2u, 1u},      /* 48 ticks: too short */
        {offsetof(urb_node_config_t, heartbeat_us), 2u, 43000u},  /* 2.064 M ticks < 2^21 ok... */
        {offsetof(urb_node_config_t, update_divider), 1u, 0u},
        {offsetof(urb_node_config_t, lost_sync_beats), 1u, 1u},
    };
    for (size_t i = 0u; i < sizeof bad / sizeof bad[0]; i++) {
        fixture_t f;
        fx_defaults(&f);
        uint8_t *p = (uint8_t *)&f.cfg + bad[i].offset;
        if (bad[i].size == 1u) {
            *p = (uint8_t)bad[i].value;
        } else {
            uint16_t const v = (uint16_t)bad[i].value;
            memcpy(p, &v, 2u);
        }
        int const expect = (i == 5u) ? URB_NODE_OK : URB_NODE_ERR_CONFIG;
        assert_int_equal(fx_start(&f), expect);
    }
    /* a period of 2^21 ticks or more could overflow the PLL's Q8 sums (urb_pll.c) */
    fixture_t f;
    fx_defaults(&f);
    f.cfg.ticks_per_us = 200u;
    f.cfg.heartbeat_us = 60000u; /* 12 M ticks */
    assert_int_equal(fx_start(&f), URB_NODE_ERR_CONFIG);
    fx_defaults(&f);
    f.cfg.heartbeat_us = 43691u; /* 48 x 43691 = 2^21 + 16 ticks: just beyond the limit */
    assert_int_equal(fx_start(&f), URB_NODE_ERR_CONFIG);
    urb_node_config_default(NULL); /* harmless */
}

/* lobster-trace: urb.MBX_012 */
static void init_runs_hooks_and_starts(void **state)
{
    fixture_t *f = *state;
    assert_int_equal(f->bootups, 1u);
    assert_int_equal(f->inits, 1u);
    assert_int_equal(f->bootup_rc, URB_NODE_OK);
    assert_int_equal(f->port.address, 0x21u);
    assert_true(f->port.armed != 0u);
    assert_int_equal(f->port.compare, 1000u + 48000u); /* first heartbeat one nominal period on */
    assert_int_equal(urb_node_inbox_size(&f->node, 0u), 6u);
    assert_int_equal(urb_node_outbox_size(&f->node, 0u), 25u);
    assert_int_equal(urb_node_inbox_size(&f->node, 2u), 20u);
    assert_int_equal(urb_node_outbox_size(&f->node, 1u), 6u);
    assert_int_equal(urb_node_outbox_size(&f->node, 3u), 0u);
    assert_int_equal(urb_node_inbox_size(&f->node, 8u), 0u);
    assert_int_equal(urb_node_outbox_size(NULL, 1u), 0u);
    assert_int_equal(urb_node_inbox_size(NULL, 1u), 0u);
    assert_int_equal(f->node.storage_used, 2u * (2u + 20u + 6u + 20u));
}

/* lobster-trace: urb.PKT_003 */
static void setup_errors(void **state)
{
    (void)state;
    fixture_t f;
    fx_defaults(&f);
    urb_node_t *node = &f.node;
    /* before start: exercise the calls directly on a node in bootup state */
    memset(node, 0, sizeof *node);
    node->storage = f.storage;
    node->storage_len = 10u;
    urb_mailbox_reset(node);
    assert_int_equal(urb_node_setup_inbox(NULL, 1u, 2u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_setup_inbox(node, 0u, 2u), URB_NODE_ERR_ARG); /* library-owned */
    assert_int_equal(urb_node_setup_inbox(node, 8u, 2u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_setup_inbox(node, 1u, 0u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_setup_inbox(node, 1u, 33u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_setup_outbox(node, 0u, 2u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_setup_outbox(node, 1u, 33u), URB_NODE_ERR_ARG);
    assert_int_equal(node->setup_err, URB_NODE_ERR_ARG); /* the first error is kept */
    assert_int_equal(urb_node_setup_inbox(node, 1u, 5u), URB_NODE_OK);
    assert_int_equal(urb_node_setup_inbox(node, 1u, 5u), URB_NODE_ERR_SETUP);
    assert_int_equal(urb_node_setup_outbox(node, 1u, 1u), URB_NODE_ERR_NOMEM); /* 10 - 10 = 0 left */
    node->storage = NULL;
    assert_int_equal(urb_node_setup_outbox(node, 2u, 1u), URB_NODE_ERR_NOMEM);
    assert_int_equal(urb_node_set_class(NULL, 1u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_set_index(NULL, 1u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_set_index(node, 64u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_set_fingerprint(NULL, 1u), URB_NODE_ERR_ARG);
    /* init returns bootup's first error and keeps the node off the bus */
    fx_defaults(&f);
    f.out_sizes[4] = 0u;
    f.index = 70u;
    assert_int_equal(fx_start(&f), URB_NODE_ERR_ARG);
    assert_int_equal(f.inits, 0u);
    fx_defaults(&f);
    f.in_sizes[3] = 32u;
    f.in_sizes[4] = 32u;
    f.in_sizes[5] = 32u;
    f.in_sizes[6] = 32u;
    f.in_sizes[7] = 32u;
    f.out_sizes[3] = 32u;
    f.out_sizes[4] = 32u;
    assert_int_equal(fx_start(&f), URB_NODE_ERR_NOMEM); /* 512 bytes are not enough for this */
}

static void setup_after_start_refused(void **state)
{
    urb_node_t *node = &((fixture_t *)*state)->node;
    assert_int_equal(urb_node_setup_inbox(node, 3u, 2u), URB_NODE_ERR_STATE);
    assert_int_equal(urb_node_setup_outbox(node, 3u, 2u), URB_NODE_ERR_STATE);
    assert_int_equal(urb_node_set_class(node, 1u), URB_NODE_ERR_STATE);
    assert_int_equal(urb_node_set_index(node, 1u), URB_NODE_ERR_STATE);
    assert_int_equal(urb_node_set_fingerprint(node, 1u), URB_NODE_ERR_STATE);
    assert_int_equal(node->setup_err, 0); /* not recorded after start */
}

static void outbox_errors(void **state)
{
    urb_node_t *node = &((fixture_t *)*state)->node;
    uint8_t *buf = NULL;
    assert_int_equal(urb_node_lock_outbox(NULL, 1u, &buf), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_lock_outbox(node, 1u, NULL), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_lock_outbox(node, 0u, &buf), URB_NODE_ERR_ARG); /* library-owned */
    assert_int_equal(urb_node_lock_outbox(node, 8u, &buf), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_lock_outbox(node, 3u, &buf), URB_NODE_ERR_SETUP);
    assert_int_equal(urb_node_release_outbox(NULL, 1u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_release_outbox(node, 0u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_release_outbox(node, 8u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_release_outbox(node, 3u), URB_NODE_ERR_SETUP);
    assert_int_equal(urb_node_release_outbox(node, 1u), URB_NODE_ERR_STATE); /* not locked */
    assert_int_equal(urb_node_lock_outbox(node, 1u, &buf), URB_NODE_OK);
    uint8_t *again = NULL;
    assert_int_equal(urb_node_lock_outbox(node, 1u, &again), URB_NODE_ERR_STATE); /* double lock */
    assert_null(again);
    assert_int_equal(urb_node_release_outbox(node, 1u), URB_NODE_OK);
    assert_int_equal(urb_node_release_outbox(node, 1u), URB_NODE_ERR_STATE);
    /* the locked buffer is never the published one: alternate buffers */
    uint8_t *b1 = NULL, *b2 = NULL;
    assert_int_equal(urb_node_lock_outbox(node, 2u, &b1), URB_NODE_OK);
    assert_int_equal(urb_node_release_outbox(node, 2u), URB_NODE_OK);
    assert_int_equal(urb_node_lock_outbox(node, 2u, &b2), URB_NODE_OK);
    assert_ptr_not_equal(b1, b2);
    assert_int_equal(urb_node_release_outbox(node, 2u), URB_NODE_OK);
}

static void inbox_errors(void **state)
{
    urb_node_t *node = &((fixture_t *)*state)->node;
    const uint8_t *data = NULL;
    assert_int_equal(urb_node_lock_inbox(NULL, 1u, &data), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_lock_inbox(node, 1u, NULL), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_lock_inbox(node, 0u, &data), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_lock_inbox(node, 8u, &data), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_lock_inbox(node, 3u, &data), URB_NODE_ERR_SETUP);
    assert_int_equal(urb_node_release_inbox(NULL, 1u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_release_inbox(node, 0u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_release_inbox(node, 8u), URB_NODE_ERR_ARG);
    assert_int_equal(urb_node_release_inbox(node, 3u), URB_NODE_ERR_SETUP);
    assert_int_equal(urb_node_release_inbox(node, 1u), URB_NODE_ERR_STATE);
    /* the setup value: zeros, not new */
    assert_int_equal(urb_node_lock_inbox(node, 1u, &data), URB_NODE_OK);
    assert_int_equal(data[0], 0u);
    const uint8_t *again = NULL;
    assert_int_equal(urb_node_lock_inbox(node, 1u, &again), URB_NODE_ERR_STATE);
    assert_int_equal(urb_node_release_inbox(node, 1u), URB_NODE_OK);
    assert_int_equal(urb_node_release_inbox(node, 1u), URB_NODE_ERR_STATE);
}

/* Step hook: commits a fresh bus write at every AppLockLoadFront, so each attempt's
 * AppLockCheckFront fails: after MaxRetry retries the lock returns BUSY. */
static void commit_at_load(urb_node_t *node, uint8_t step, void *ctx)
{
    unsigned *count = ctx;
    if (step == URB_STEP_IN_LOAD_FRONT) {
        uint8_t const data[2] = {(uint8_t)(*count + 1u), 0u};
        assert_int_equal(fx_write(node, 1u, data, 2u), FX_ALL_ACKED);
        (*count)++;
    }
}

/* lobster-trace: urb.MBX_010 */
static void inbox_busy_after_retries(void **state)
{
    urb_node_t *node = &((fixture_t *)*state)->node;
    unsigned count = 0u;
    fx_step_hook = commit_at_load;
    fx_step_ctx = &count;
    const uint8_t *data = NULL;
    int const rc = urb_node_lock_inbox(node, 1u, &data);
    fx_step_hook = NULL;
    assert_int_equal(rc, URB_NODE_ERR_BUSY);
    assert_int_equal(count, 3u); /* 1 + MaxRetry attempts */
    assert_int_equal(node->inbox[1].app_idx, URB_NONE);
    /* without interference the next lock gets the latest commit */
    assert_int_equal(urb_node_lock_inbox(node, 1u, &data), URB_NODE_NEW);
    assert_int_equal(data[0], 3u);
    assert_int_equal(urb_node_release_inbox(node, 1u), URB_NODE_OK);
}

static void status_and_synced(void **state)
{
    urb_node_t *node = &((fixture_t *)*state)->node;
    urb_node_sync_status_t st;
    urb_node_sync_status(node, &st);
    assert_int_equal(st.state, URB_NODE_SYNC_FREE);
    assert_int_equal(st.period_q8, 48000u * 256u);
    assert_false(urb_node_synced(node));
    assert_false(urb_node_synced(NULL));
    urb_node_sync_status(NULL, &st);
    urb_node_sync_status(node, NULL);
    urb_node_mark_acquired(NULL);
    urb_node_mark_acquired(node); /* outside app_update: no effect */
    assert_int_equal(node->acq_ticks, 0u);
    assert_false(urb_node_has_work(NULL));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(init_arguments),
        cmocka_unit_test(init_config_checks),
        cmocka_unit_test_setup(init_runs_hooks_and_starts, setup),
        cmocka_unit_test(setup_errors),
        cmocka_unit_test_setup(setup_after_start_refused, setup),
        cmocka_unit_test_setup(outbox_errors, setup),
        cmocka_unit_test_setup(inbox_errors, setup),
        cmocka_unit_test_setup(inbox_busy_after_retries, setup),
        cmocka_unit_test_setup(status_and_synced, setup),
    };
    return cmocka_run_group_tests_name("node_mailbox", tests, NULL, NULL);
}
