/*
 * Proof of the inbox algorithm (spec/tla/MailboxInbox.tla) on firmware/node/urb_mailbox.c:
 * urb_node_lock_inbox / urb_lock_inbox_any, urb_node_release_inbox / urb_release_inbox_any
 * (application) against urb_isr_write_begin / _byte / _commit / _abort (I2C interrupt).
 *
 * Part 1, interleavings. The application runs FW_ROUNDS rounds of lock, read, release. The
 * interrupt preempts it at every point the model lets it: after each step that touches shared
 * state (the library's URB_STEP hook, built with URB_NODE_TESTING, lands in urb_node_test_step
 * below) and before and after the application's reads. At each such point up to FW_ISR_STEPS
 * interrupt events run, chosen by the solver: begin a write (the algorithm may refuse it: NACK),
 * commit it, abort it (a short write, a bad check, a bus error); at most FW_WRITES writes begin.
 * This part tracks which version each buffer holds (a shadow of the model's buffers) instead of
 * moving bytes: the algorithm never looks at the data, so by data independence a read of the
 * wrong version or of a buffer being written is exactly a shadow mismatch or an exclusivity
 * violation, checked at every point.
 *
 * Part 2, data. With arbitrary bytes in a fixed schedule that keeps both buffers in use: the
 * application holds version A while the interrupt writes and commits version B into the other
 * buffer (every byte through urb_isr_write_byte), A must still read back intact; then B is what
 * the next lock returns, NEW once, and a third write is refused while B is held.
 *
 * Inbox FW_BOX (7: the last array element), any size 1..FW_SIZE_MAX, after a neighbouring outbox
 * of 0..2 bytes in the storage block (its bytes must stay untouched).
 *
 * Properties (besides bounds, pointers, overflow and shifts on every access):
 *   no torn read    the buffer a lock hands out holds the version committed last at the lock's
 *                   linearization point (AppLockCheckFront), and no write lands in it while held
 *   no aborted write delivered (the same check: aborted versions are never committed)
 *   NEW             the lock returns URB_NODE_NEW exactly for a version no earlier lock returned
 *   NACK rule       a write is refused only while the application claims the buffer it needs
 *   BUSY            only after three attempts, each defeated by a commit that landed during it
 *   write then read a committed write of arbitrary bytes is what the next lock returns
 *   isolation       the neighbouring mailbox's bytes stay untouched
 *
 * Cover points (URB_COVER, checked by the reach run): part 1 reaches an accepted and a refused
 * write, a commit and an abort, a commit while the application holds the inbox, a NEW and a not-new
 * lock, a BUSY lock (full tier: its three defeated attempts need more writes than the fast tier's),
 * and completes its rounds; part 2 its end; a neighbour is present.
 *
 * Proof view (views.json): the two stores `ib->fresh[x] = v` with a variable x are rewritten as
 * `if (x == 0) fresh[0] = v; else { assert(x == 1); fresh[1] = v; }`, which has the same meaning
 * for every x the original accepts and fails where the original would store out of bounds.
 * ESBMC 8.4 turns a store through a pointer with a variable array index inside urb_node_t into a
 * byte-level update of the whole struct (pointers included), which exhausted 4 GiB even for one
 * write; the rewritten store stays field-level.
 */
#include "urb_verify.h"

#include "urb_node_internal.h"

#include "../stubs/fw_budgets.h"

#include "../stubs/fw_node_stubs.c"

#ifndef FW_BOX
#define FW_BOX 7u /* the inbox under proof */
#endif
#ifndef FW_SIZE_MAX
#define FW_SIZE_MAX 4u /* largest size tried (the code has no size-dependent branch) */
#endif
#ifndef FW_ROUNDS
#define FW_ROUNDS 2u /* interleaved application lock/read/release rounds */
#endif
#ifndef FW_ISR_STEPS
#define FW_ISR_STEPS 1u /* interrupt events at one preemption point */
#endif
#ifndef FW_WRITES
#define FW_WRITES 4u /* writes the interrupt may begin during part 1 */
#endif
#define FW_PRE_MAX 2u /* a neighbouring outbox of 0..2 bytes sits before the inbox in storage */
#define FW_NO_VERSION 0xFFu

URB_PROOF_COST_STORAGE;

static urb_node_t node;
static uint8_t storage[2u * FW_PRE_MAX + 2u * FW_SIZE_MAX];
static uint8_t box;  /* the inbox under proof */
static uint8_t size; /* its size */

/* Shadow state: what the model says. Version 0: the zero-filled buffers of setup. */
static uint8_t buf_ver[2];   /* version each buffer holds (FW_NO_VERSION: a write is in it) */
static uint8_t committed;    /* version committed last (IsrWriteCommit) */
static uint8_t returned;     /* version the latest successful lock returned (0: none yet) */
static uint8_t linearized;   /* version at the linearization point of the lock in progress */
static bool linearized_new;  /* ... and whether no earlier lock returned it */
static bool holding;         /* the application holds the inbox (AppLockCheckFront .. release) */
static uint8_t versions;     /* writes begun so far = the last version number used */
static bool writing;         /* a write is between an accepted IsrWriteBegin and commit/abort */
static uint8_t write_ver;    /* its version */
static uint8_t commits;      /* commits since the lock in progress began */
static bool interleave = true; /* the interrupt may preempt the application */

/* The model's invariant at every point: the interrupt never writes the buffer the application
 * holds, and the held buffer still holds the version the lock returned. */
static void check_exclusive(void)
{
    urb_node_inbox_t const *ib = &node.inbox[box];
    if (holding) {
        URB_ASSERT(ib->app_idx < 2u, "a held inbox names one buffer");
        URB_ASSERT(!writing || (ib->isr_idx != ib->app_idx),
                   "exclusive: the interrupt never writes the buffer the application holds");
        URB_ASSERT(buf_ver[ib->app_idx] == linearized, "no torn read: the held buffer keeps its version");
    }
}

/* One interrupt event chosen by the solver (MailboxInbox.tla IsrWriteBegin, IsrWriteCommit,
 * IsrWriteAbort; the bytes of IsrWriteByte are part 2's business). */
static void isr_event(void)
{
    urb_node_inbox_t const *ib = &node.inbox[box];
    if (!writing) {
        if (versions < FW_WRITES) {
            uint8_t const t = (uint8_t)(1u - ib->front);
            if (urb_isr_write_begin(&node, box)) {
                URB_ASSERT(ib->isr_idx == t, "IsrWriteBegin: the buffer that is not front");
                versions++;
                writing = true;
                write_ver = versions;
                buf_ver[t] = FW_NO_VERSION; /* being overwritten */
                if (interleave) {
                    URB_COVER("part1-write-accepted");
                }
            } else {
                URB_ASSERT(ib->app_idx == t, "NACK only while the application claims the buffer it needs");
                URB_ASSERT(ib->isr_idx == URB_NONE, "a refused write changes nothing");
                URB_COVER("part1-write-refused");
            }
        }
    } else if (URB_NONDET_BOOL()) {
        uint8_t const b = ib->isr_idx;
        urb_isr_write_commit(&node, box);
        URB_ASSERT((b < 2u) && (ib->front == b), "IsrWriteCommit publishes the buffer written");
        URB_ASSERT(ib->isr_idx == URB_NONE, "IsrWriteCommit frees the buffer");
        buf_ver[b] = write_ver;
        committed = write_ver;
        writing = false;
        commits++;
        URB_COVER("part1-write-committed");
        if (holding) {
            URB_COVER("part1-commit-while-the-application-holds-the-inbox");
        }
    } else {
        urb_isr_write_abort(&node, box);
        URB_ASSERT(ib->isr_idx == URB_NONE, "IsrWriteAbort frees the buffer");
        writing = false; /* the buffer keeps FW_NO_VERSION: its bytes are garbage */
        URB_COVER("part1-write-aborted");
    }
    check_exclusive();
}

/* A preemption point: up to FW_ISR_STEPS interrupt events, as many as the solver likes. */
static void preempt(void)
{
    for (uint8_t i = 0u; i < FW_ISR_STEPS; i++) {
        if (URB_NONDET_BOOL()) {
            isr_event();
        }
    }
}

/* The library calls this after every application step that touches shared state. */
void urb_node_test_step(urb_node_t *n, uint8_t step)
{
    if (!interleave) {
        return; /* part 2: a fixed schedule */
    }
    URB_ASSERT(n == &node, "hook: the node under proof");
    if (step == URB_STEP_IN_CHECK_FRONT) {
        /* AppLockCheckFront passed: the linearization point of the read */
        linearized = committed;
        linearized_new = (committed != returned);
        holding = true;
        check_exclusive();
    }
    if (step == URB_STEP_IN_RELEASE) {
        holding = false;
    }
    preempt();
}

static int lock(urb_node_t *n, const uint8_t **data)
{
    return urb_node_lock_inbox(n, box, data);
}

static int release(urb_node_t *n)
{
    return urb_node_release_inbox(n, box);
}

/* Mailbox reset, the neighbour of `pre` bytes and the inbox of `size` bytes. */
static void setup(urb_node_t *n, uint8_t *st, uint8_t pre)
{
    fw_node_mailbox_reset(n); /* = urb_mailbox_reset (see fw_node_stubs.c) */
    n->storage = st;
    n->storage_len = (uint16_t)sizeof storage;
    if (pre > 0u) {
        URB_ASSERT(urb_node_setup_outbox(n, box, pre) == URB_NODE_OK, "setup of the neighbour");
        URB_COVER("a-neighbour-precedes-the-inbox");
    }
    URB_ASSERT(urb_node_setup_inbox(n, box, size) == URB_NODE_OK, "setup of the inbox");
}

static void part1_interleavings(void)
{
    /* ---- Part 1: interleavings ---- */
    const uint8_t *data = NULL;
    for (uint8_t r = 0u; r < FW_ROUNDS; r++) {
        preempt();
        commits = 0u;
        int const rc = lock(&node, &data);
        if (rc == URB_NODE_ERR_BUSY) {
            URB_ASSERT(commits >= 3u, "BUSY only after three attempts, each defeated by a commit");
            URB_ASSERT(node.inbox[box].app_idx == URB_NONE, "BUSY leaves nothing claimed");
            URB_COVER_FULL("part1-lock-busy");
            continue;
        }
        URB_ASSERT((rc == URB_NODE_OK) || (rc == URB_NODE_NEW), "lock: OK, NEW or BUSY");
        URB_ASSERT(holding, "a granted lock passed AppLockCheckFront");
        URB_ASSERT((rc == URB_NODE_NEW) == linearized_new, "NEW exactly for a version no lock returned");
        if ((rc == URB_NODE_NEW) && (linearized != 0u)) {
            URB_COVER("part1-lock-new-version");
        }
        if (rc == URB_NODE_OK) {
            URB_COVER("part1-lock-same-version");
        }
        returned = linearized;
        URB_ASSERT(data == urb_inbox_buf(&node, box, node.inbox[box].app_idx), "the lock hands out its buffer");
        URB_ASSERT(lock(&node, &data) == URB_NODE_ERR_STATE, "double lock");
        preempt(); /* the application reads its buffer meanwhile */
        check_exclusive();
        URB_ASSERT(release(&node) == URB_NODE_OK, "release");
        URB_ASSERT(!holding, "released");
        if (r == (uint8_t)(FW_ROUNDS - 1u)) {
            URB_COVER("part1-last-round-released");
        }
    }
}

static void part2_data(uint8_t pre)
{
    /* ---- Part 2: data, with both buffers in use ---- */
    interleave = false;
    const uint8_t *data = NULL;
    uint8_t a_bytes[FW_SIZE_MAX];
    uint8_t b_bytes[FW_SIZE_MAX];
    URB_ASSERT(urb_isr_write_begin(&node, box), "the application holds nothing: write A is accepted");
    for (uint8_t k = 0u; k < FW_SIZE_MAX; k++) {
        if (k < size) {
            a_bytes[k] = URB_NONDET_U8();
            urb_isr_write_byte(&node, box, k, a_bytes[k]);
        }
    }
    urb_isr_write_commit(&node, box);
    URB_ASSERT(lock(&node, &data) == URB_NODE_NEW, "no interrupt activity: the lock returns A, new");
    URB_ASSERT(urb_isr_write_begin(&node, box), "the other buffer is free: write B is accepted");
    for (uint8_t k = 0u; k < FW_SIZE_MAX; k++) {
        if (k < size) {
            b_bytes[k] = URB_NONDET_U8();
            urb_isr_write_byte(&node, box, k, b_bytes[k]);
        }
    }
    urb_isr_write_commit(&node, box);
    URB_ASSERT(!urb_isr_write_begin(&node, box), "both buffers in use: a third write is refused (NACK)");
    for (uint8_t k = 0u; k < FW_SIZE_MAX; k++) {
        if (k < size) {
            URB_ASSERT(data[k] == a_bytes[k], "no torn read: A is intact while B is written");
        }
    }
    URB_ASSERT(release(&node) == URB_NODE_OK, "release A");
    URB_ASSERT(lock(&node, &data) == URB_NODE_NEW, "the lock returns B, new");
    for (uint8_t k = 0u; k < FW_SIZE_MAX; k++) {
        if (k < size) {
            URB_ASSERT(data[k] == b_bytes[k], "write then read: the lock returns what was committed last");
        }
    }
    URB_ASSERT(release(&node) == URB_NODE_OK, "release B");
    URB_ASSERT(lock(&node, &data) == URB_NODE_OK, "the same version again: OK, not NEW");
    URB_ASSERT(release(&node) == URB_NODE_OK, "release");
    URB_COVER("part2-both-versions-read-back");

    /* The neighbour in the storage block was never written. */
    for (uint8_t k = 0u; k < 2u * FW_PRE_MAX; k++) {
        if (k < 2u * pre) { /* the neighbour comes first in storage */
            URB_ASSERT(storage[k] == 0u, "isolation: the neighbouring mailbox is untouched");
        }
    }
}

void harness(void)
{
    /* the nodes are zero-initialised (static), as urb_node_init leaves them before urb_mailbox_reset */
    box = FW_BOX; /* concrete: a symbolic index into the node's arrays multiplies the proof time by ten */
    uint8_t const pre = URB_NONDET_U8();
    URB_ASSUME(pre <= FW_PRE_MAX);
    size = URB_NONDET_U8();
    URB_ASSUME((size >= 1u) && (size <= FW_SIZE_MAX));
    setup(&node, storage, pre);
    URB_ASSERT(urb_node_setup_inbox(&node, box, size) == URB_NODE_ERR_SETUP, "set up twice");
    URB_ASSERT(urb_node_inbox_size(&node, box) == size, "size recorded");
    URB_ASSERT(urb_node_lock_inbox(&node, 0u, NULL) == URB_NODE_ERR_ARG, "inbox 0 belongs to the library");
    URB_ASSERT(release(&node) == URB_NODE_ERR_STATE, "release without lock");

    /* Each part on its own path: one run, but part 2's checks do not carry part 1's paths. */
    if (URB_NONDET_BOOL()) {
        part1_interleavings();
    } else {
        part2_data(pre);
    }
}
