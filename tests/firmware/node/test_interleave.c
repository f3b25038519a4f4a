/*
 * Exhaustive interleavings of the application and the interrupt, mirroring the TLA+ models
 * spec/tla/MailboxInbox.tla and MailboxOutbox.tla on the real C code.
 *
 * The library calls urb_node_test_step() after every application step that touches shared state
 * (the TLA+ actions: AppLockLoadFront, AppLockClaim, ...); this test adds a point after each byte
 * the application reads or writes (AppReadByte / AppWriteByte). At every such point the explorer
 * decides whether the next interrupt event runs now (the interrupt preempts the application) or
 * the application goes on; a stateless depth-first search over those decisions (re-running from
 * a fresh node each time) enumerates EVERY interleaving of the application script with the
 * interrupt script.
 *
 * Interrupt events are whole I2C events grouped where the grouping is invisible to the
 * application: the address and select bytes touch no shared state, so they ride with the first
 * data byte (IsrWriteBegin + IsrWriteByte), a good check byte rides with the STOP that commits.
 *
 * Checked in every state (the models' invariants):
 *   inbox:  AppReadNotTorn, AppReadFresh (the value committed at the AppLockCheckFront
 *           linearization point), NoAbortedDelivered, AppLockExclusive, the NACK rule of
 *           IsrWriteBegin, and URB_NODE_NEW exactly when the message differs from the last lock's;
 *   outbox: IsrReadNotTorn, IsrReadFresh (the value released at IsrReadBegin), a valid check on
 *           every complete read, AppLockExclusive.
 * Every script of 1 and 2 bus transactions drawn from {commit, corrupt check, cut short} is run
 * against an application that locks, reads byte by byte and releases twice (inbox: 2-byte
 * messages, MaxRetry 2, as MCMailboxInbox.cfg); 1..2 bus reads against 2 releases and 1 read
 * against 3 releases (outbox). Larger configurations are TLC's job (spec/tla, *Large.cfg).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "node_fixture.h"
#include "urb_runtime.h"

#define MSG 2u        /* bytes per message: >= 2 so that tearing is observable */
#define MAX_DEPTH 256u
#define MAX_EVENTS 16u

/* ===== Stateless DFS over "interrupt now or later" decisions =============================== */

typedef struct explorer explorer_t;

struct explorer {
    uint8_t forced[MAX_DEPTH];
    size_t nforced;
    uint8_t trace[MAX_DEPTH];
    size_t ntrace;
    size_t next_event;
    size_t n_events;
    void (*run_event)(explorer_t *x, size_t idx);
    void (*at_point)(explorer_t *x); /* invariant checks at every preemption point */
    fixture_t fx;
    /* ghost state */
    uint8_t committed;      /* inbox: tag of the latest commit; outbox: of the latest release */
    uint8_t snap;           /* value of `committed` at the application's linearization point */
    uint32_t aborted;       /* inbox: tags of writes that began and were not committed (bit set) */
    /* scripts */
    uint8_t kinds[3];       /* inbox: per transaction; outbox: unused */
    size_t ntx;
    size_t ev_tx[MAX_EVENTS];
    uint8_t ev_part[MAX_EVENTS];
    uint8_t tx_dead[3];     /* inbox: write refused (NACK at data 0) */
    /* application state visible to the invariant checks */
    bool holding;
    uint8_t held;
    /* outbox reader state */
    uint8_t got[MSG + 2u];
    size_t ngot;
    uint8_t read_snap;
    unsigned runs;
};

/* One preemption point: run interrupt events as the schedule says. */
static void preempt(explorer_t *x)
{
    if (x->at_point != NULL) {
        x->at_point(x);
    }
    while (x->next_event < x->n_events) {
        assert_true(x->ntrace < MAX_DEPTH);
        uint8_t const c = (x->ntrace < x->nforced) ? x->forced[x->ntrace] : 0u;
        x->trace[x->ntrace++] = c;
        if (c == 0u) {
            return; /* the application goes on */
        }
        x->run_event(x, x->next_event++);
        if (x->at_point != NULL) {
            x->at_point(x);
        }
    }
}

/* Next schedule in DFS order: flip the deepest "later" decision to "now". */
static bool next_schedule(explorer_t *x)
{
    size_t d = x->ntrace;
    while (d > 0u) {
        d--;
        if (x->trace[d] == 0u) {
            memcpy(x->forced, x->trace, d);
            x->forced[d] = 1u;
            x->nforced = d + 1u;
            return true;
        }
    }
    return false;
}

static void step_hook(urb_node_t *node, uint8_t step, void *ctx)
{
    (void)node;
    explorer_t *x = ctx;
    if (step == URB_STEP_IN_CHECK_FRONT || step == URB_STEP_OUT_RELEASE) {
        x->snap = x->committed; /* linearization point (inbox) / AppRelease ghost (outbox) */
    }
    preempt(x);
}

/* ===== Inbox ================================================================================ */

enum { TX_COMMIT = 0, TX_BADCHECK = 1, TX_SHORT = 2 };

static void inbox_event(explorer_t *x, size_t idx)
{
    urb_node_t *node = &x->fx.node;
    size_t const t = x->ev_tx[idx];
    uint8_t const tag = (uint8_t)(t + 1u);
    uint8_t const data[MSG] = {tag, tag};
    uint8_t frame[8];
    size_t const n = fx_frame(frame, 1u, data, MSG, (x->kinds[t] == TX_BADCHECK) ? 0x01u : 0x00u);
    urb_node_inbox_t const *ib = &node->inbox[1];
    if (x->tx_dead[t] != 0u) {
        return; /* refused earlier: the bridge already sent STOP */
    }
    switch (x->ev_part[idx]) {
    case 0: { /* START, address, select, data 0: IsrWriteBegin + IsrWriteByte */
        bool const expect_nack = ib->app_idx == (uint8_t)(1u - ib->front); /* MailboxInbox.tla IsrWriteBegin */
        assert_int_equal(urb_node_i2c_event(node, URB_I2C_ADDR_WRITE, 0u), URB_I2C_ACK);
        assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, frame[0]), URB_I2C_ACK);
        uint16_t const r = urb_node_i2c_event(node, URB_I2C_RX_BYTE, frame[1]);
        assert_int_equal(r, expect_nack ? URB_I2C_NACK : URB_I2C_ACK);
        if (r != URB_I2C_ACK) {
            (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
            x->tx_dead[t] = 1u;
        }
        break;
    }
    case 1: /* data 1: IsrWriteByte */
        assert_int_equal(urb_node_i2c_event(node, URB_I2C_RX_BYTE, frame[2]), URB_I2C_ACK);
        break;
    default: /* end: check + STOP (commit or abort), or STOP alone (cut short) */
        if (x->kinds[t] == TX_SHORT) {
            (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u); /* IsrWriteAbort */
            x->aborted |= 1u << tag;
        } else {
            uint16_t const r = urb_node_i2c_event(node, URB_I2C_RX_BYTE, frame[n - 1u]);
            (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
            if (x->kinds[t] == TX_COMMIT) {
                assert_int_equal(r, URB_I2C_ACK);
                x->committed = tag; /* IsrWriteCommit */
            } else {
                assert_int_equal(r, URB_I2C_NACK);
                x->aborted |= 1u << tag; /* IsrWriteAbort */
            }
        }
        break;
    }
}

static void inbox_invariants(explorer_t *x)
{
    urb_node_inbox_t const *ib = &x->fx.node.inbox[1];
    if (x->holding) { /* AppLockExclusive */
        assert_int_equal(ib->app_idx, x->held);
        assert_int_not_equal(ib->isr_idx, x->held);
    }
}

/* The application: lock, read byte by byte, release; twice. */
static void inbox_app(explorer_t *x)
{
    urb_node_t *node = &x->fx.node;
    uint8_t last = 0u; /* tag the previous successful lock returned (0: the setup value) */
    for (int cycle = 0; cycle < 2; cycle++) {
        const uint8_t *data = NULL;
        int const rc = urb_node_lock_inbox(node, 1u, &data);
        if (rc == URB_NODE_ERR_BUSY) {
            continue; /* allowed: writes kept landing during all three attempts */
        }
        assert_true(rc == URB_NODE_OK || rc == URB_NODE_NEW);
        x->holding = true;
        x->held = node->inbox[1].app_idx;
        uint8_t got[MSG];
        for (size_t k = 0u; k < MSG; k++) {
            got[k] = data[k]; /* AppReadByte */
            preempt(x);
        }
        x->holding = false;
        assert_int_equal(urb_node_release_inbox(node, 1u), URB_NODE_OK);
        for (size_t k = 1u; k < MSG; k++) {
            assert_int_equal(got[k], got[0]); /* AppReadNotTorn */
        }
        assert_int_equal(got[0], x->snap);                 /* AppReadFresh */
        assert_int_equal((x->aborted >> got[0]) & 1u, 0u); /* NoAbortedDelivered */
        assert_int_equal(rc == URB_NODE_NEW, got[0] != last);
        last = got[0];
    }
}

static unsigned explore_inbox(const uint8_t *kinds, size_t ntx)
{
    static explorer_t x;
    fx_step_hook = NULL; /* a failed assertion in an earlier run may have left it set */
    memset(&x, 0, sizeof x);
    for (size_t t = 0u; t < ntx; t++) {
        x.kinds[t] = kinds[t];
        uint8_t const parts = (kinds[t] == TX_SHORT) ? 2u : 3u;
        for (uint8_t p = 0u; p < parts; p++) {
            x.ev_tx[x.n_events] = t;
            x.ev_part[x.n_events] = (p + 1u == parts) ? 2u : p;
            x.n_events++;
        }
    }
    x.ntx = ntx;
    x.run_event = inbox_event;
    x.at_point = inbox_invariants;
    do {
        x.ntrace = 0u;
        x.next_event = 0u;
        x.committed = 0u;
        x.snap = 0u;
        x.aborted = 0u;
        x.holding = false;
        memset(x.tx_dead, 0, sizeof x.tx_dead);
        fx_defaults(&x.fx);
        x.fx.in_sizes[2] = 0u;
        assert_int_equal(fx_start(&x.fx), URB_NODE_OK);
        fx_step_hook = step_hook;
        fx_step_ctx = &x;
        preempt(&x); /* interrupts before the application's first step */
        inbox_app(&x);
        while (x.next_event < x.n_events) {
            x.run_event(&x, x.next_event++);
        }
        fx_step_hook = NULL;
        x.runs++;
    } while (next_schedule(&x));
    return x.runs;
}

/* lobster-trace: urb.MBX_006 */
static void inbox_all_scripts(void **state)
{
    (void)state;
    unsigned total = 0u;
    /* every script of one and of two transactions */
    for (unsigned len = 1u; len <= 2u; len++) {
        unsigned const combos = (len == 1u) ? 3u : 9u;
        for (unsigned c = 0u; c < combos; c++) {
            uint8_t kinds[2] = {(uint8_t)(c % 3u), (uint8_t)((c / 3u) % 3u)};
            total += explore_inbox(kinds, len);
        }
    }
    printf("inbox: %u interleavings explored\n", total);
    assert_true(total > 400000u);
}

/* ===== Outbox =============================================================================== */

static void outbox_event(explorer_t *x, size_t idx)
{
    urb_node_t *node = &x->fx.node;
    switch (x->ev_part[idx]) {
    case 0: /* START, address + R: IsrReadBegin */
        assert_int_equal(urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u), URB_I2C_ACK);
        x->ngot = 0u;
        x->read_snap = x->committed; /* IsrReadFresh: the release in force at the linearization point */
        break;
    case 1: /* one data byte: IsrReadByte */
        x->got[x->ngot++] = (uint8_t)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
        break;
    default: { /* check byte, NACK, STOP: IsrReadEnd */
        x->got[x->ngot++] = (uint8_t)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
        (void)urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u);
        (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
        for (size_t k = 1u; k < MSG; k++) {
            assert_int_equal(x->got[k], x->got[0]); /* IsrReadNotTorn */
        }
        assert_int_equal(x->got[0], x->read_snap); /* IsrReadFresh */
        uint8_t const sel = 0x81u;
        assert_int_equal(urb_link_check(&sel, 1u, x->got, MSG), x->got[MSG]);
        break;
    }
    }
}

static void outbox_invariants(explorer_t *x)
{
    urb_node_outbox_t const *ob = &x->fx.node.outbox[1];
    if (x->holding) { /* AppLockExclusive */
        assert_int_not_equal(ob->isr_idx, x->held);
        assert_int_not_equal(ob->front, x->held);
    }
}

/* The application: publish messages 1..n (a BUSY lock is retried, at most three times). */
static void outbox_app(explorer_t *x, uint8_t n)
{
    urb_node_t *node = &x->fx.node;
    for (uint8_t tag = 1u; tag <= n; tag++) {
        uint8_t *buf = NULL;
        int rc = URB_NODE_ERR_BUSY;
        for (int tries = 0; tries < 3 && rc == URB_NODE_ERR_BUSY; tries++) {
            rc = urb_node_lock_outbox(node, 1u, &buf);
        }
        if (rc == URB_NODE_ERR_BUSY) {
            continue;
        }
        assert_int_equal(rc, URB_NODE_OK);
        x->holding = true;
        x->held = node->outbox[1].held;
        for (size_t k = 0u; k < MSG; k++) {
            buf[k] = tag; /* AppWriteByte */
            preempt(x);
        }
        x->holding = false;
        x->committed = tag; /* the ghost `released`, updated at AppRelease (step hook snapshot) */
        assert_int_equal(urb_node_release_outbox(node, 1u), URB_NODE_OK);
    }
}

static void step_hook_out(urb_node_t *node, uint8_t step, void *ctx)
{
    (void)node;
    preempt((explorer_t *)ctx);
    (void)step;
}

static unsigned explore_outbox(size_t reads, uint8_t messages)
{
    static explorer_t x;
    fx_step_hook = NULL;
    memset(&x, 0, sizeof x);
    for (size_t r = 0u; r < reads; r++) {
        for (uint8_t p = 0u; p < 2u + MSG - 1u + 1u; p++) {
            x.ev_part[x.n_events] = (p == 0u) ? 0u : ((p <= MSG) ? 1u : 2u);
            x.n_events++;
        }
    }
    x.run_event = outbox_event;
    x.at_point = outbox_invariants;
    do {
        x.ntrace = 0u;
        x.next_event = 0u;
        x.committed = 0u;
        x.holding = false;
        fx_defaults(&x.fx);
        x.fx.out_sizes[1] = MSG;
        x.fx.out_sizes[2] = 0u;
        assert_int_equal(fx_start(&x.fx), URB_NODE_OK);
        assert_true(fx_select(&x.fx.node, 1u));
        fx_step_hook = step_hook_out;
        fx_step_ctx = &x;
        preempt(&x);
        outbox_app(&x, messages);
        while (x.next_event < x.n_events) {
            x.run_event(&x, x.next_event++);
        }
        fx_step_hook = NULL;
        x.runs++;
    } while (next_schedule(&x));
    return x.runs;
}

/* lobster-trace: urb.MBX_002 */
static void outbox_all_scripts(void **state)
{
    (void)state;
    unsigned total = 0u;
    /* 1..2 reads against 2 releases, 1 read against 3 releases */
    for (size_t reads = 1u; reads <= 2u; reads++) {
        total += explore_outbox(reads, 2u);
    }
    total += explore_outbox(1u, 3u);
    printf("outbox: %u interleavings explored\n", total);
    assert_true(total > 10000u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(inbox_all_scripts),
        cmocka_unit_test(outbox_all_scripts),
    };
    return cmocka_run_group_tests_name("node_interleavings", tests, NULL, NULL);
}
