/*
 * Proof of the outbox algorithm (spec/tla/MailboxOutbox.tla) on firmware/node/urb_mailbox.c:
 * urb_node_lock_outbox / urb_lock_outbox_any, urb_node_release_outbox / urb_release_outbox_any
 * (application) against urb_isr_read_begin / _byte / _end (I2C interrupt).
 *
 * Part 1, interleavings. The application runs FW_ROUNDS rounds of lock, fill, release. The
 * interrupt preempts it at every point the model lets it: after each step that touches shared
 * state (the library's URB_STEP hook, built with URB_NODE_TESTING, lands in urb_node_test_step
 * below) and before and after the application's stores. At each such point up to FW_ISR_STEPS
 * interrupt events run, chosen by the solver: begin a read (latch front), send a byte, end the
 * read (a master may stop early). This part tracks which version each buffer holds (a shadow of
 * the model's buffers) instead of moving bytes: the algorithm never looks at the data, so by data
 * independence a torn read is exactly a read of a buffer the application is writing, or of a
 * version other than the one published at IsrReadBegin; both are checked at every point.
 *
 * Part 2, data. With arbitrary bytes in a fixed schedule that keeps both buffers in use: the
 * interrupt latches version A and sends part of it, the application writes and releases version
 * B into the other buffer, the interrupt finishes A intact; the next read returns B.
 *
 * Outbox FW_BOX (7: the last array element), any size 1..FW_SIZE_MAX, after a neighbouring inbox
 * of 0..2 bytes in the storage block (its bytes must stay untouched).
 *
 * Properties (besides bounds, pointers, overflow and shifts on every access):
 *   no torn read      a read sends the version released last before its IsrReadBegin (the
 *                     model's linearization point), from a buffer nobody writes meanwhile
 *   exclusive         the interrupt never latches the buffer the application holds
 *   BUSY exactly when the model allows it: the interrupt is sending the buffer the lock needs
 *   write then read   after a release, a complete read returns exactly the bytes written
 *   isolation         the neighbouring mailbox's bytes stay untouched
 *   API               double lock and release without lock are refused (ERR_STATE)
 *
 * Cover points (URB_COVER, checked by the reach run): part 1 reaches every interrupt event, a read
 * that begins while the application holds its buffer, a release during a read, a BUSY lock and a
 * lock granted during a read, and completes its rounds; part 2 reaches its end after a partial
 * first read; a neighbour is present.
 */
#include "urb_verify.h"

#include "urb_node_internal.h"

#include "../stubs/fw_budgets.h"

#include "../stubs/fw_node_stubs.c"

#ifndef FW_BOX
#define FW_BOX 7u /* the outbox under proof */
#endif
#ifndef FW_SIZE_MAX
#define FW_SIZE_MAX 4u /* largest size tried (the code has no size-dependent branch) */
#endif
#ifndef FW_ROUNDS
#define FW_ROUNDS 2u /* interleaved application lock/fill/release rounds */
#endif
#ifndef FW_ISR_STEPS
#define FW_ISR_STEPS 1u /* interrupt events at one preemption point */
#endif
#define FW_PRE_MAX 2u /* a neighbouring inbox of 0..2 bytes sits before the outbox in storage */
#define FW_NO_VERSION 0xFFu

URB_PROOF_COST_STORAGE;

static urb_node_t node;
static uint8_t storage[2u * FW_PRE_MAX + 2u * FW_SIZE_MAX];
static uint8_t box;  /* the outbox under proof */
static uint8_t size; /* its size */

/* Shadow state: what the model says. Version 0: the zero-filled buffers of setup. */
static uint8_t buf_ver[2];    /* version each buffer holds (FW_NO_VERSION: being written) */
static uint8_t published;     /* version released last (AppRelease) */
static uint8_t expect;        /* version the read in progress sends (latched at IsrReadBegin) */
static bool reading;          /* a read is between IsrReadBegin and IsrReadEnd */
static uint8_t read_count;    /* bytes sent by the read in progress */
static uint8_t isr_at_check;  /* isr_idx when the application made AppLockCheck */
static bool interleave = true; /* part 1: the interrupt may preempt the application */

/* The model's invariant at every point: the buffer being sent holds the latched version, and is
 * not the buffer the application holds. */
static void check_exclusive(void)
{
    urb_node_outbox_t const *ob = &node.outbox[box];
    if (reading) {
        URB_ASSERT(ob->isr_idx < 2u, "a read in progress names one buffer");
        URB_ASSERT(ob->isr_idx != ob->held, "exclusive: the interrupt never sends the buffer the application holds");
        URB_ASSERT(buf_ver[ob->isr_idx] == expect, "no torn read: the buffer being sent keeps its version");
    }
}

/* One interrupt event chosen by the solver (MailboxOutbox.tla IsrReadBegin, IsrReadByte, IsrReadEnd). */
static void isr_event(void)
{
    urb_node_outbox_t const *ob = &node.outbox[box];
    if (!reading) {
        urb_isr_read_begin(&node, box);
        URB_ASSERT(ob->isr_idx == ob->front, "IsrReadBegin latches front");
        if (interleave) {
            URB_COVER("part1-isr-read-begins");
            if (ob->held != URB_NONE) {
                URB_COVER("part1-read-begins-while-the-application-holds-a-buffer");
            }
        }
        reading = true;
        read_count = 0u;
        expect = published; /* the linearization point of the read */
    } else if (URB_NONDET_BOOL() && (read_count < size)) {
        (void)urb_isr_read_byte(&node, box, read_count); /* the bytes are part 2's business */
        read_count++;
        URB_COVER("part1-isr-sends-a-byte");
    } else {
        urb_isr_read_end(&node, box);
        URB_ASSERT(ob->isr_idx == URB_NONE, "IsrReadEnd frees the buffer");
        reading = false;
        URB_COVER("part1-isr-read-ends");
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
    urb_node_outbox_t const *ob = &node.outbox[box];
    if (step == URB_STEP_OUT_LOCK_CHECK) {
        isr_at_check = ob->isr_idx;
        if (ob->held != URB_NONE) {
            buf_ver[ob->held] = FW_NO_VERSION; /* the application writes it from now on */
        }
    }
    if (step == URB_STEP_OUT_RELEASE) {
        if (reading) {
            URB_COVER("part1-release-during-a-read");
        }
        published = (uint8_t)(published + 1u); /* AppRelease: the linearization point of the write */
        buf_ver[ob->front] = published;
    }
    check_exclusive();
    preempt();
}

static int lock(uint8_t **data)
{
    return urb_node_lock_outbox(&node, box, data);
}

static int release(void)
{
    return urb_node_release_outbox(&node, box);
}

static void part1_interleavings(void)
{
    uint8_t *data = NULL;
    for (uint8_t r = 0u; r < FW_ROUNDS; r++) {
        preempt();
        uint8_t const front = node.outbox[box].front;
        int const rc = lock(&data);
        if (rc == URB_NODE_ERR_BUSY) {
            URB_ASSERT(isr_at_check == (uint8_t)(1u - front),
                       "BUSY only while the interrupt sends the buffer the lock needs");
            URB_COVER("part1-lock-busy");
            continue;
        }
        URB_ASSERT(rc == URB_NODE_OK, "lock: OK or BUSY");
        if (reading) {
            URB_COVER("part1-lock-granted-during-a-read");
        }
        uint8_t const w = node.outbox[box].held;
        URB_ASSERT(w == (uint8_t)(1u - front), "AppLockPick: the buffer that is not published");
        URB_ASSERT(isr_at_check != w, "granted only when the interrupt is not sending w");
        URB_ASSERT(data == urb_outbox_buf(&node, box, w), "the lock hands out buffer w");
        URB_ASSERT(lock(&data) == URB_NODE_ERR_STATE, "double lock");
        preempt(); /* the application fills its buffer meanwhile */
        check_exclusive();
        URB_ASSERT(release() == URB_NODE_OK, "release");
        URB_ASSERT(node.outbox[box].front == w, "AppRelease publishes w");
        if (r == (uint8_t)(FW_ROUNDS - 1u)) {
            URB_COVER("part1-last-round-publishes");
        }
    }
}

static void part2_data(void)
{
    interleave = false;
    uint8_t *data = NULL;
    uint8_t a_bytes[FW_SIZE_MAX];
    uint8_t b_bytes[FW_SIZE_MAX];
    URB_ASSERT(lock(&data) == URB_NODE_OK, "no read in progress: the lock succeeds");
    for (uint8_t k = 0u; k < FW_SIZE_MAX; k++) {
        if (k < size) {
            a_bytes[k] = URB_NONDET_U8();
            data[k] = a_bytes[k];
        }
    }
    URB_ASSERT(release() == URB_NODE_OK, "release A");
    urb_isr_read_begin(&node, box); /* the interrupt latches A ... */
    uint8_t const sent = URB_NONDET_U8();
    URB_ASSUME(sent <= size);
    for (uint8_t k = 0u; k < FW_SIZE_MAX; k++) {
        if (k < sent) { /* ... and sends part of it */
            URB_ASSERT(urb_isr_read_byte(&node, box, k) == a_bytes[k], "write then read: A as written");
        }
    }
    URB_ASSERT(lock(&data) == URB_NODE_OK, "the other buffer is free: the lock succeeds");
    for (uint8_t k = 0u; k < FW_SIZE_MAX; k++) {
        if (k < size) {
            b_bytes[k] = URB_NONDET_U8();
            data[k] = b_bytes[k];
        }
    }
    URB_ASSERT(release() == URB_NODE_OK, "release B");
    URB_ASSERT(lock(&data) == URB_NODE_ERR_BUSY, "the buffer being sent is not handed out: BUSY");
    for (uint8_t k = 0u; k < FW_SIZE_MAX; k++) {
        if ((k >= sent) && (k < size)) { /* the rest of A */
            URB_ASSERT(urb_isr_read_byte(&node, box, k) == a_bytes[k], "no torn read: A is intact while B is written");
        }
    }
    urb_isr_read_end(&node, box);
    urb_isr_read_begin(&node, box);
    for (uint8_t k = 0u; k < FW_SIZE_MAX; k++) {
        if (k < size) {
            URB_ASSERT(urb_isr_read_byte(&node, box, k) == b_bytes[k], "write then read: the next read returns B");
        }
    }
    urb_isr_read_end(&node, box);
    if ((sent > 0u) && (sent < size)) {
        URB_COVER("part2-b-read-back-after-a-partial-read-of-a");
    }
}

void harness(void)
{
    /* node is zero-initialised (static), as urb_node_init leaves it before urb_mailbox_reset */
    fw_node_mailbox_reset(&node); /* = urb_mailbox_reset (see fw_node_stubs.c) */
    node.storage = storage;
    node.storage_len = (uint16_t)sizeof storage;
    box = FW_BOX; /* concrete: a symbolic index into the node's arrays multiplies the proof time by ten */
    uint8_t const pre = URB_NONDET_U8();
    URB_ASSUME(pre <= FW_PRE_MAX);
    if (pre > 0u) {
        URB_ASSERT(urb_node_setup_inbox(&node, box, pre) == URB_NODE_OK, "setup of the neighbour");
        URB_COVER("a-neighbour-precedes-the-outbox");
    }
    size = URB_NONDET_U8();
    URB_ASSUME((size >= 1u) && (size <= FW_SIZE_MAX));
    URB_ASSERT(urb_node_setup_outbox(&node, box, size) == URB_NODE_OK, "setup of the outbox");
    URB_ASSERT(urb_node_setup_outbox(&node, box, size) == URB_NODE_ERR_SETUP, "set up twice");
    URB_ASSERT(urb_node_outbox_size(&node, box) == size, "size recorded");
    URB_ASSERT(urb_node_setup_outbox(&node, 0u, 1u) == URB_NODE_ERR_ARG, "outbox 0 belongs to the library");
    URB_ASSERT(release() == URB_NODE_ERR_STATE, "release without lock");

    /* Each part on its own path: one run, but part 2's checks do not carry part 1's paths. */
    if (URB_NONDET_BOOL()) {
        part1_interleavings();
    } else {
        part2_data();
    }

    /* The neighbour in the storage block was never written. */
    for (uint8_t k = 0u; k < 2u * FW_PRE_MAX; k++) {
        if (k < 2u * pre) { /* the neighbour comes first in storage */
            URB_ASSERT(storage[k] == 0u, "isolation: the neighbouring mailbox is untouched");
        }
    }
}
