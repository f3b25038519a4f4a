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

/* Queries and entry points called with NULL, an out-of-range mailbox or a node that never started
 * answer their neutral value and change nothing. */
static void api_edges(void **state)
{
    urb_node_t *node = &((fixture_t *)*state)->node;
    assert_int_equal(urb_node_outbox_size(node, 1u), 6u);
    assert_int_equal(urb_node_outbox_size(node, 8u), 0u);
    assert_int_equal(urb_node_outbox_size(NULL, 1u), 0u);
    urb_node_buffers_t b;
    assert_false(urb_node_inbox_buffers(node, 1u, NULL));
    assert_true(urb_node_inbox_buffers(node, 1u, &b));
    assert_int_equal(b.isr, URB_NODE_NO_BUFFER);
    assert_int_equal(urb_node_poll(NULL), 0u);
    uint32_t const compare = ((fixture_t *)*state)->port.compare;
    urb_node_timer_event(NULL);
    assert_int_equal(((fixture_t *)*state)->port.compare, compare);
    static urb_node_t never_started; /* zeroed: urb_node_init never ran */
    assert_false(urb_node_has_work(&never_started));
    assert_int_equal(urb_node_poll(&never_started), 0u);
    urb_node_timer_event(&never_started);
    assert_int_equal(never_started.update_due, 0u);
}

/* The interrupt-side mailbox steps when no transfer is in progress (isr_idx == NONE): their ACSL
 * `idle` behaviours. The I2C state machine never calls them then (a read or store only follows a
 * begin, proofs/bmc/fw_node_i2c_slave); these are the defensive answers: a read gives 0xFF, a store
 * and a commit change nothing. */
static void isr_steps_without_a_transfer(void **state)
{
    urb_node_t *node = &((fixture_t *)*state)->node;
    assert_int_equal(node->outbox[1].isr_idx, URB_NONE);
    assert_int_equal(urb_isr_read_byte(node, 1u, 0u), 0xFFu);
    assert_int_equal(node->inbox[1].isr_idx, URB_NONE);
    uint8_t before[FX_STORAGE];
    memcpy(before, ((fixture_t *)*state)->storage, sizeof before);
    uint8_t const front = node->inbox[1].front;
    urb_isr_write_byte(node, 1u, 0u, 0xABu);
    urb_isr_write_commit(node, 1u);
    assert_memory_equal(before, ((fixture_t *)*state)->storage, sizeof before);
    assert_int_equal(node->inbox[1].front, front);
    assert_int_equal(node->inbox[1].fresh[0] | node->inbox[1].fresh[1], 0u);
    const uint8_t *data = NULL;
    assert_int_equal(urb_node_lock_inbox(node, 1u, &data), URB_NODE_OK); /* still the setup value: not NEW */
    assert_int_equal(urb_node_release_inbox(node, 1u), URB_NODE_OK);
}

/* Mutation score (tests/mutation/README.md): seeded bugs the tests above let through. */

/* The interrupt's commit with no write begun (a refused write, a select alone) publishes nothing:
 * without its guard it would store fresh[NONE] and make NONE the front buffer. */
static void commit_without_a_write_publishes_nothing(void **state)
{
    urb_node_t *node = &((fixture_t *)*state)->node;
    urb_node_buffers_t before, after;
    assert_true(urb_node_inbox_buffers(node, 1u, &before));
    urb_isr_write_commit(node, 1u);
    assert_true(urb_node_inbox_buffers(node, 1u, &after));
    assert_int_equal(after.front, before.front);
    assert_int_equal(after.isr, URB_NODE_NO_BUFFER);
    const uint8_t *data = NULL;
    assert_int_equal(urb_node_lock_inbox(node, 1u, &data), URB_NODE_OK); /* not NEW: nothing arrived */
    assert_int_equal(urb_node_release_inbox(node, 1u), URB_NODE_OK);
}

/* The interrupt's byte store with no write begun changes no storage byte: without its guard it
 * would store into "buffer NONE", past the inbox's two buffers. */
static void byte_without_a_write_stores_nothing(void **state)
{
    fixture_t *f = (fixture_t *)*state;
    uint8_t before[FX_STORAGE];
    memcpy(before, f->storage, sizeof before);
    urb_isr_write_byte(&f->node, 1u, 0u, 0x77u);
    assert_memory_equal(f->storage, before, sizeof before);
}

/* Mailbox 7 is the last one: the size queries answer it, and answer 0 from 8 on; its lock and
 * release work like any other's. */
static void mailbox_7_is_usable_and_8_is_not(void **state)
{
    fixture_t *f = (fixture_t *)*state;
    fx_defaults(f);
    f->in_sizes[7] = 3u;
    f->out_sizes[7] = 4u;
    assert_int_equal(fx_start(f), URB_NODE_OK);
    urb_node_t *node = &f->node;
    assert_int_equal(urb_node_inbox_size(node, 7u), 3u);
    assert_int_equal(urb_node_outbox_size(node, 7u), 4u);
    assert_int_equal(urb_node_inbox_size(node, 8u), 0u);
    assert_int_equal(urb_node_outbox_size(node, 8u), 0u); /* outbox[8] would be inbox 0, size != 0 */
    uint8_t *out = NULL;
    assert_int_equal(urb_node_lock_outbox(node, 7u, &out), URB_NODE_OK);
    assert_int_equal(urb_node_release_outbox(node, 7u), URB_NODE_OK);
    const uint8_t *in = NULL;
    assert_int_equal(urb_node_lock_inbox(node, 7u, &in), URB_NODE_OK);
    assert_int_equal(urb_node_release_inbox(node, 7u), URB_NODE_OK);
}

/* Setup carves 2 x size bytes of the caller's storage block and zero-fills exactly those
 * (urb_node.h: "zero-filled"; the block itself need not be zeroed), never a byte past storage_len;
 * a box that needs one byte more than is left is refused. */
static void setup_zero_fills_exactly_its_bytes(void **state)
{
    (void)state;
    fixture_t f;
    fx_defaults(&f);
    urb_node_t *node = &f.node;
    for (uint16_t len = 21u; len <= 22u; len++) {
        memset(node, 0, sizeof *node);
        memset(f.storage, 0xEE, sizeof f.storage); /* whatever the caller's block held */
        node->storage = f.storage;
        node->storage_len = len;
        urb_mailbox_reset(node);
        assert_int_equal(urb_node_setup_inbox(node, 1u, 5u), URB_NODE_OK); /* bytes 0 .. 9 */
        /* 12 bytes for outbox 1: one more than the 11 left of 21, exactly the 12 left of 22 */
        int const expect = (len == 21u) ? URB_NODE_ERR_NOMEM : URB_NODE_OK;
        assert_int_equal(urb_node_setup_outbox(node, 1u, 6u), expect);
        uint16_t const carved = (len == 21u) ? 10u : 22u;
        assert_int_equal(node->storage_used, carved);
        for (uint16_t k = 0u; k < sizeof f.storage; k++) {
            assert_int_equal(f.storage[k], (k < carved) ? 0u : 0xEEu);
        }
        /* the application reads zeros from both buffers before the first commit */
        node->started = 1u;
        const uint8_t *in = NULL;
        assert_int_equal(urb_lock_inbox_any(node, 1u, &in), URB_NODE_OK);
        for (uint8_t k = 0u; k < 5u; k++) {
            assert_int_equal(in[k], 0u);
        }
        assert_int_equal(urb_release_inbox_any(node, 1u), URB_NODE_OK);
    }
}

/* Inbox 0 and outbox 0 share mb0 without overlapping: a command landing in either inbox-0 buffer
 * leaves the identification the bridge reads from either outbox-0 buffer intact. */
static void command_write_leaves_the_identification_intact(void **state)
{
    urb_node_t *node = &((fixture_t *)*state)->node;
    for (unsigned round = 0u; round < 2u; round++) {
        assert_int_equal(fx_command(node, URB_COMMAND_CODE_IDENTIFY, 0u, 0u, 0u), FX_ALL_ACKED);
        assert_true((urb_node_poll(node) & URB_NODE_POLL_IDENT) != 0u); /* republished: the other buffer */
        uint8_t before[27];
        uint8_t after[27];
        fx_read(node, before, sizeof before);
        /* a command the application has not taken yet, with no byte in common with the identification */
        assert_int_equal(fx_command(node, URB_COMMAND_CODE_SIGNAL, 0xA5u, 0x5A5Au, 0xC3C3u), FX_ALL_ACKED);
        fx_read(node, after, sizeof after);
        assert_memory_equal(after, before, sizeof before);
        urb_identification_t id;
        assert_int_equal(urb_identification_decode(&id, after, 25u), 25);
        assert_int_equal(id.class_id, 0x42u);
        assert_int_equal(id.fingerprint, 0xDEADBEEFu);
        assert_true((urb_node_poll(node) & URB_NODE_POLL_COMMAND) != 0u); /* takes the command */
        assert_int_equal(((fixture_t *)*state)->last_signal, 0xA5u);
    }
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
        cmocka_unit_test_setup(api_edges, setup),
        cmocka_unit_test_setup(isr_steps_without_a_transfer, setup),
        cmocka_unit_test_setup(commit_without_a_write_publishes_nothing, setup),
        cmocka_unit_test_setup(mailbox_7_is_usable_and_8_is_not, setup),
        cmocka_unit_test_setup(byte_without_a_write_stores_nothing, setup),
        cmocka_unit_test(setup_zero_fills_exactly_its_bytes),
        cmocka_unit_test_setup(command_write_leaves_the_identification_intact, setup),
    };
    return cmocka_run_group_tests_name("node_mailbox", tests, NULL, NULL);
}
