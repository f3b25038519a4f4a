/*
 * Double-buffered mailboxes: spec/tla/MailboxOutbox.tla and spec/tla/MailboxInbox.tla, action by
 * action. Each shared access is one statement and carries the name of the TLA+ action it
 * implements; URB_STEP marks the points where a test can preempt the application (the states
 * TLC explores between two application actions).
 *
 * Shared variables and their single writers (see urb_node.h):
 *   outbox: front (application), isr_idx (interrupt)
 *   inbox:  front (interrupt), isr_idx (interrupt), app_idx (application)
 * fresh[b] of an inbox belongs to buffer b like its data bytes: only the side that owns buffer b
 * under the algorithm touches it (the interrupt at commit, the application while holding b).
 *
 * Seeded bugs for the mutant check (tests/firmware/node/run_mutants.sh), never in a real build:
 *   URB_MUTANT_SINGLE_BUFFER          both sides use the published buffer (single buffering)
 *   URB_MUTANT_OUTBOX_NO_BUSY_CHECK   AppLockCheck skipped
 *   URB_MUTANT_INBOX_NO_FRONT_RECHECK AppLockCheckFront skipped (the design TLC refuted)
 *   URB_MUTANT_INBOX_NO_NACK          IsrWriteBegin never refuses
 */
#include "urb_node_internal.h"

/* MaxRetry of MailboxInbox.tla (attempts after the first before URB_NODE_ERR_BUSY). */
#define URB_INBOX_MAX_RETRY 2u

/* Mailbox 0 buffers inside urb_node_t.mb0: outbox 0 first, then inbox 0. */
#define URB_MB0_INBOX_OFFSET (2u * URB_NODE_OUTBOX0_SIZE)

/* ACSL for Frama-C WP (proofs/framac/mailbox/). WP proves each function as one sequential step
 * (-wp-no-volatile): the interleavings of the two sides are TLC's and ESBMC's job. What WP adds is
 * that no path indexes outside the mailbox storage and that each function keeps the index bytes in
 * {0, 1, NONE} and the layout intact, for every node state the layout predicate allows. */
/* The layout predicates (urb_mb_layout, ...) are in urb_node_internal.h: the callers' contracts
 * (urb_i2c.c, proofs/framac/node_i2c/) use them too. */

/* Buffer b of a mailbox at `offset` with `size` bytes: mailbox 0 in mb0, the others in storage. */
/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES && urb_mb_box(node, n, offset, size);
    assigns \nothing;
    ensures \result == urb_mb_buf(node, n, offset, size, b);
    ensures size > 0 ==> \valid(\result + (0 .. size - 1)); */
static uint8_t *box_buf(urb_node_t *node, uint8_t n, uint16_t offset, uint8_t size, uint8_t b)
{
    uint8_t *base = (n == 0u) ? node->mb0 : node->storage;
    return base + offset + ((b != 0u) ? size : 0u);
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    assigns \nothing;
    ensures \result == urb_mb_out(node, n, b);
    ensures node->outbox[n].size > 0 ==> \valid(\result + (0 .. node->outbox[n].size - 1)); */
uint8_t *urb_outbox_buf(urb_node_t *node, uint8_t n, uint8_t b)
{
    return box_buf(node, n, node->outbox[n].offset, node->outbox[n].size, b);
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    assigns \nothing;
    ensures \result == urb_mb_in(node, n, b);
    ensures node->inbox[n].size > 0 ==> \valid(\result + (0 .. node->inbox[n].size - 1)); */
uint8_t *urb_inbox_buf(urb_node_t *node, uint8_t n, uint8_t b)
{
    return box_buf(node, n, node->inbox[n].offset, node->inbox[n].size, b);
}

/* ===== Outbox: application writes, interrupt reads (MailboxOutbox.tla) ===================== */

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    requires \valid(data) && \separated(data, node) && \separated(data, node->storage + (0 .. node->storage_len - 1));
    assigns node->outbox[n].held, *data;
    ensures urb_mb_layout(node);
    behavior not_set_up:
      assumes node->outbox[n].size == 0;
      assigns \nothing;
      ensures \result == URB_NODE_ERR_SETUP;
    behavior double_lock:
      assumes node->outbox[n].size != 0 && node->outbox[n].held != URB_NONE;
      assigns \nothing;
      ensures \result == URB_NODE_ERR_STATE;
    behavior busy:
      assumes node->outbox[n].size != 0 && node->outbox[n].held == URB_NONE;
      assumes node->outbox[n].isr_idx == 1 - node->outbox[n].front;
      assigns \nothing;
      ensures \result == URB_NODE_ERR_BUSY;
    behavior granted:
      assumes node->outbox[n].size != 0 && node->outbox[n].held == URB_NONE;
      assumes node->outbox[n].isr_idx != 1 - node->outbox[n].front;
      assigns node->outbox[n].held, *data;
      ensures \result == URB_NODE_OK;
      ensures node->outbox[n].held == 1 - node->outbox[n].front;
      ensures node->outbox[n].held != node->outbox[n].isr_idx;
      ensures *data == urb_mb_out(node, n, 1 - node->outbox[n].front);
      ensures \valid(*data + (0 .. node->outbox[n].size - 1));
    complete behaviors;
    disjoint behaviors; */
int urb_lock_outbox_any(urb_node_t *node, uint8_t n, uint8_t **data)
{
    urb_node_outbox_t *ob = &node->outbox[n];
    if (ob->size == 0u) {
        return URB_NODE_ERR_SETUP;
    }
    if (ob->held != URB_NONE) {
        return URB_NODE_ERR_STATE; /* double lock: the model's application holds one lock at a time */
    }
#if defined(URB_MUTANT_SINGLE_BUFFER)
    uint8_t const w = ob->front;
#else
    uint8_t const w = (uint8_t)(1u - ob->front); /* MailboxOutbox.tla: AppLockPick */
#endif
    URB_STEP(node, URB_STEP_OUT_LOCK_PICK);
#if !defined(URB_MUTANT_OUTBOX_NO_BUSY_CHECK)
    if (ob->isr_idx == w) { /* MailboxOutbox.tla: AppLockCheck (the ISR still sends buffer w) */
        URB_STEP(node, URB_STEP_OUT_LOCK_CHECK);
        return URB_NODE_ERR_BUSY;
    }
#endif
    URB_STEP(node, URB_STEP_OUT_LOCK_CHECK);
    ob->held = w; /* application local: the app owns buf[w] */
    URB_NODE_BARRIER(); /* the caller's stores into buf[w] stay after the check */
    *data = urb_outbox_buf(node, n, w);
    return URB_NODE_OK;
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    assigns node->outbox[n].front, node->outbox[n].held;
    ensures urb_mb_layout(node);
    behavior not_set_up:
      assumes node->outbox[n].size == 0;
      assigns \nothing;
      ensures \result == URB_NODE_ERR_SETUP;
    behavior not_locked:
      assumes node->outbox[n].size != 0 && node->outbox[n].held == URB_NONE;
      assigns \nothing;
      ensures \result == URB_NODE_ERR_STATE;
    behavior publish:
      assumes node->outbox[n].size != 0 && node->outbox[n].held != URB_NONE;
      assigns node->outbox[n].front, node->outbox[n].held;
      ensures \result == URB_NODE_OK;
      ensures node->outbox[n].front == \old(node->outbox[n].held);
      ensures node->outbox[n].held == URB_NONE;
    complete behaviors;
    disjoint behaviors; */
int urb_release_outbox_any(urb_node_t *node, uint8_t n)
{
    urb_node_outbox_t *ob = &node->outbox[n];
    if (ob->size == 0u) {
        return URB_NODE_ERR_SETUP;
    }
    if (ob->held == URB_NONE) {
        return URB_NODE_ERR_STATE;
    }
    URB_NODE_BARRIER(); /* every data byte is stored before the buffer is published */
    ob->front = ob->held; /* MailboxOutbox.tla: AppRelease (one single store) */
    ob->held = URB_NONE;
    URB_STEP(node, URB_STEP_OUT_RELEASE);
    return URB_NODE_OK;
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    assigns node->outbox[n].isr_idx;
    ensures urb_mb_layout(node);
    ensures node->outbox[n].isr_idx == node->outbox[n].front; */
void urb_isr_read_begin(urb_node_t *node, uint8_t n)
{
    urb_node_outbox_t *ob = &node->outbox[n];
    ob->isr_idx = ob->front; /* MailboxOutbox.tla: IsrReadBegin (linearization point of the read) */
    URB_NODE_BARRIER();
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES && k < node->outbox[n].size;
    assigns \nothing;
    ensures node->outbox[n].isr_idx == URB_NONE ==> \result == 0xFF;
    ensures node->outbox[n].isr_idx != URB_NONE ==> \result == urb_mb_out(node, n, node->outbox[n].isr_idx)[k]; */
uint8_t urb_isr_read_byte(urb_node_t *node, uint8_t n, uint8_t k)
{
    urb_node_outbox_t const *ob = &node->outbox[n];
    if (ob->isr_idx == URB_NONE) {
        return 0xFFu; /* no read in progress (defensive: the state machine never asks then) */
    }
    return urb_outbox_buf(node, n, ob->isr_idx)[k]; /* MailboxOutbox.tla: IsrReadByte */
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    assigns node->outbox[n].isr_idx;
    ensures urb_mb_layout(node);
    ensures node->outbox[n].isr_idx == URB_NONE; */
void urb_isr_read_end(urb_node_t *node, uint8_t n)
{
    urb_node_outbox_t *ob = &node->outbox[n];
    URB_NODE_BARRIER();
    ob->isr_idx = URB_NONE; /* MailboxOutbox.tla: IsrReadEnd */
}

/* ===== Inbox: interrupt writes, application reads (MailboxInbox.tla) ======================= */

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    assigns node->inbox[n].isr_idx;
    ensures urb_mb_layout(node);
    behavior refused:
      assumes node->inbox[n].app_idx == 1 - node->inbox[n].front;
      assigns \nothing;
      ensures \result == \false;
    behavior accepted:
      assumes node->inbox[n].app_idx != 1 - node->inbox[n].front;
      assigns node->inbox[n].isr_idx;
      ensures \result == \true;
      ensures node->inbox[n].isr_idx == 1 - node->inbox[n].front;
      ensures node->inbox[n].isr_idx != node->inbox[n].app_idx;
    complete behaviors;
    disjoint behaviors; */
bool urb_isr_write_begin(urb_node_t *node, uint8_t n)
{
    urb_node_inbox_t *ib = &node->inbox[n];
#if defined(URB_MUTANT_SINGLE_BUFFER)
    uint8_t const t = ib->front;
#else
    uint8_t const t = (uint8_t)(1u - ib->front); /* MailboxInbox.tla: IsrWriteBegin (t := 1 - front) */
#endif
#if !defined(URB_MUTANT_INBOX_NO_NACK)
    if (ib->app_idx == t) { /* MailboxInbox.tla: IsrWriteBegin (app holds t: NACK, nothing changes) */
        return false;
    }
#endif
    ib->isr_idx = t; /* MailboxInbox.tla: IsrWriteBegin (isr_idx := t) */
    URB_NODE_BARRIER();
    return true;
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES && k < node->inbox[n].size;
    assigns urb_mb_in(node, n, node->inbox[n].isr_idx)[k];
    ensures urb_mb_layout(node);
    behavior idle:
      assumes node->inbox[n].isr_idx == URB_NONE;
      assigns \nothing;
    behavior store:
      assumes node->inbox[n].isr_idx != URB_NONE;
      assigns urb_mb_in(node, n, node->inbox[n].isr_idx)[k];
      ensures urb_mb_in(node, n, node->inbox[n].isr_idx)[k] == byte;
    complete behaviors;
    disjoint behaviors; */
void urb_isr_write_byte(urb_node_t *node, uint8_t n, uint8_t k, uint8_t byte)
{
    urb_node_inbox_t const *ib = &node->inbox[n];
    if (ib->isr_idx == URB_NONE) {
        return; /* defensive: the state machine only stores after a successful begin */
    }
    urb_inbox_buf(node, n, ib->isr_idx)[k] = byte; /* MailboxInbox.tla: IsrWriteByte */
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    assigns node->inbox[n].fresh[0 .. 1], node->inbox[n].front, node->inbox[n].isr_idx;
    ensures urb_mb_layout(node);
    behavior idle:
      assumes node->inbox[n].isr_idx == URB_NONE;
      assigns \nothing;
    behavior publish:
      assumes node->inbox[n].isr_idx != URB_NONE;
      assigns node->inbox[n].fresh[node->inbox[n].isr_idx], node->inbox[n].front, node->inbox[n].isr_idx;
      ensures node->inbox[n].front == \old(node->inbox[n].isr_idx);
      ensures node->inbox[n].fresh[node->inbox[n].front] == 1;
      ensures node->inbox[n].isr_idx == URB_NONE;
    complete behaviors;
    disjoint behaviors; */
void urb_isr_write_commit(urb_node_t *node, uint8_t n)
{
    urb_node_inbox_t *ib = &node->inbox[n];
    uint8_t const b = ib->isr_idx;
    if (b == URB_NONE) {
        return;
    }
    ib->fresh[b] = 1u; /* part of buffer b's contents: the interrupt owns b until the publish below */
    URB_NODE_BARRIER(); /* data and fresh flag are stored before the publish */
    ib->front = b;          /* MailboxInbox.tla: IsrWriteCommit (front := isr_idx) */
    ib->isr_idx = URB_NONE; /* MailboxInbox.tla: IsrWriteCommit (isr_idx := NONE), in this order */
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    assigns node->inbox[n].isr_idx;
    ensures urb_mb_layout(node);
    ensures node->inbox[n].isr_idx == URB_NONE; */
void urb_isr_write_abort(urb_node_t *node, uint8_t n)
{
    urb_node_inbox_t *ib = &node->inbox[n];
    ib->isr_idx = URB_NONE; /* MailboxInbox.tla: IsrWriteAbort (nothing published) */
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    requires \valid(data) && \separated(data, node) && \separated(data, node->storage + (0 .. node->storage_len - 1));
    assigns node->inbox[n].app_idx, node->inbox[n].fresh[0 .. 1], *data;
    ensures urb_mb_layout(node);
    ensures \result == URB_NODE_ERR_SETUP || \result == URB_NODE_ERR_STATE || \result == URB_NODE_ERR_BUSY ||
            \result == URB_NODE_OK || \result == URB_NODE_NEW;
    behavior not_set_up:
      assumes node->inbox[n].size == 0;
      ensures \result == URB_NODE_ERR_SETUP;
    behavior double_lock:
      assumes node->inbox[n].size != 0 && node->inbox[n].app_idx != URB_NONE;
      ensures \result == URB_NODE_ERR_STATE;
    behavior attempt:
      assumes node->inbox[n].size != 0 && node->inbox[n].app_idx == URB_NONE;
      ensures \result >= 0 ==> node->inbox[n].app_idx == node->inbox[n].front;
      ensures \result >= 0 ==> node->inbox[n].app_idx != node->inbox[n].isr_idx;
      ensures \result >= 0 ==> *data == urb_mb_in(node, n, node->inbox[n].app_idx);
      ensures \result >= 0 ==> \valid_read(*data + (0 .. node->inbox[n].size - 1));
      ensures \result >= 0 ==> (\result == URB_NODE_NEW <==> \old(node->inbox[n].fresh[node->inbox[n].front]) != 0);
      ensures \result < 0 ==> node->inbox[n].app_idx == URB_NONE;
    complete behaviors;
    disjoint behaviors; */
int urb_lock_inbox_any(urb_node_t *node, uint8_t n, const uint8_t **data)
{
    urb_node_inbox_t *ib = &node->inbox[n];
    if (ib->size == 0u) {
        return URB_NODE_ERR_SETUP;
    }
    if (ib->app_idx != URB_NONE) {
        return URB_NODE_ERR_STATE; /* double lock */
    }
    /* bound: 1 + URB_INBOX_MAX_RETRY = 3 attempts (MaxRetry of the model), then BUSY */
    /*@ loop invariant 0 <= attempt <= URB_INBOX_MAX_RETRY + 1;
        loop invariant node->inbox[n].app_idx == URB_NONE;
        loop invariant urb_mb_layout(node);
        loop invariant node->inbox[n].fresh[0] == \at(node->inbox[n].fresh[0], Pre);
        loop invariant node->inbox[n].fresh[1] == \at(node->inbox[n].fresh[1], Pre);
        loop assigns attempt, node->inbox[n].app_idx, node->inbox[n].fresh[0 .. 1], *data;
        loop variant URB_INBOX_MAX_RETRY + 1 - attempt; */
    for (uint8_t attempt = 0u; attempt <= URB_INBOX_MAX_RETRY; attempt++) {
        uint8_t const a = ib->front; /* MailboxInbox.tla: AppLockLoadFront */
        URB_STEP(node, URB_STEP_IN_LOAD_FRONT);
        ib->app_idx = a; /* MailboxInbox.tla: AppLockClaim (from now on the ISR NACKs writes to a) */
        URB_STEP(node, URB_STEP_IN_CLAIM);
        bool owned = (ib->isr_idx != a); /* MailboxInbox.tla: AppLockCheckIsr (no write to a in progress) */
        URB_STEP(node, URB_STEP_IN_CHECK_ISR);
#if !defined(URB_MUTANT_INBOX_NO_FRONT_RECHECK)
        if (owned) {
            owned = (ib->front == a); /* MailboxInbox.tla: AppLockCheckFront (no commit since step 1) */
            URB_STEP(node, owned ? URB_STEP_IN_CHECK_FRONT : URB_STEP_IN_CHECK_FAILED);
        }
#else
        if (owned) {
            URB_STEP(node, URB_STEP_IN_CHECK_FRONT);
        }
#endif
        if (owned) {
            /* AppLockCheckFront passed: the app owns buf[a] (the linearization point of the read) */
            URB_NODE_BARRIER(); /* the caller's loads from buf[a] stay after the checks */
            *data = urb_inbox_buf(node, n, a);
            int const result = (ib->fresh[a] != 0u) ? URB_NODE_NEW : URB_NODE_OK;
            ib->fresh[a] = 0u;
            return result;
        }
        ib->app_idx = URB_NONE; /* MailboxInbox.tla: AppLockUnclaim (then retry from step 1) */
        URB_STEP(node, URB_STEP_IN_UNCLAIM);
    }
    return URB_NODE_ERR_BUSY; /* MailboxInbox.tla: AppLockUnclaim after MaxRetry retries: URB_BUSY */
}

/*@ requires urb_mb_layout(node) && n < URB_NODE_MAILBOXES;
    ensures urb_mb_layout(node);
    behavior not_set_up:
      assumes node->inbox[n].size == 0;
      assigns \nothing;
      ensures \result == URB_NODE_ERR_SETUP;
    behavior not_locked:
      assumes node->inbox[n].size != 0 && node->inbox[n].app_idx == URB_NONE;
      assigns \nothing;
      ensures \result == URB_NODE_ERR_STATE;
    behavior release:
      assumes node->inbox[n].size != 0 && node->inbox[n].app_idx != URB_NONE;
      assigns node->inbox[n].app_idx;
      ensures \result == URB_NODE_OK;
      ensures node->inbox[n].app_idx == URB_NONE;
    complete behaviors;
    disjoint behaviors; */
int urb_release_inbox_any(urb_node_t *node, uint8_t n)
{
    urb_node_inbox_t *ib = &node->inbox[n];
    if (ib->size == 0u) {
        return URB_NODE_ERR_SETUP;
    }
    if (ib->app_idx == URB_NONE) {
        return URB_NODE_ERR_STATE;
    }
    URB_NODE_BARRIER(); /* every load from the buffer is done before it is handed back */
    ib->app_idx = URB_NONE; /* MailboxInbox.tla: AppRelease */
    URB_STEP(node, URB_STEP_IN_RELEASE);
    return URB_NODE_OK;
}

/* ===== Setup ================================================================================ */

/* The mailbox positions urb_mailbox_reset leaves: mailbox 0 in mb0, no other mailbox set up. */
/*@ predicate urb_mb_only_mb0(urb_node_t *node) =
      node->outbox[0].offset == 0 && node->outbox[0].size == URB_NODE_OUTBOX0_SIZE &&
      node->inbox[0].offset == URB_MB0_INBOX_OFFSET && node->inbox[0].size == URB_NODE_INBOX0_SIZE &&
      \forall integer n; 1 <= n < URB_NODE_MAILBOXES ==>
        node->outbox[n].offset == 0 && node->outbox[n].size == 0 && node->inbox[n].offset == 0 && node->inbox[n].size == 0; */

/*@ requires \valid(node) && node->storage_used <= node->storage_len;
    requires \valid(node->storage + (0 .. node->storage_len - 1));
    requires \separated(node, node->storage + (0 .. node->storage_len - 1));
    requires \forall integer n; 0 <= n < URB_NODE_MAILBOXES ==>
               node->outbox[n].front <= 1 && node->inbox[n].front <= 1 &&
               node->outbox[n].offset == 0 && node->outbox[n].size == 0 &&
               node->inbox[n].offset == 0 && node->inbox[n].size == 0;
    assigns node->outbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx, node->outbox[0 .. URB_NODE_MAILBOXES - 1].held,
            node->inbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx, node->inbox[0 .. URB_NODE_MAILBOXES - 1].app_idx,
            node->outbox[0].size, node->inbox[0].offset, node->inbox[0].size;
    ensures urb_mb_memory(node);
    ensures node->outbox[0].offset == 0 && node->outbox[0].size == URB_NODE_OUTBOX0_SIZE;
    ensures node->inbox[0].offset == URB_MB0_INBOX_OFFSET && node->inbox[0].size == URB_NODE_INBOX0_SIZE;
    ensures \forall integer n; 0 <= n < URB_NODE_MAILBOXES ==>
              node->outbox[n].isr_idx == URB_NONE && node->outbox[n].held == URB_NONE &&
              node->inbox[n].isr_idx == URB_NONE && node->inbox[n].app_idx == URB_NONE;
    ensures \forall integer n; 0 <= n < URB_NODE_MAILBOXES ==>
              node->outbox[n].front == \old(node->outbox[n].front) && node->inbox[n].front == \old(node->inbox[n].front);
    ensures reset_positions: urb_mb_only_mb0(node);
    ensures reset_layout: urb_mb_layout(node);
    ensures reset_i2c_mailbox: node->i2c.mailbox == \old(node->i2c.mailbox);
    ensures reset_i2c_crc16: node->i2c.crc16 == \old(node->i2c.crc16); */
void urb_mailbox_reset(urb_node_t *node)
{
    /* urb_node_init has zeroed the node: sizes, offsets, fronts, fresh flags and buffers are 0 */
    /* bound: URB_NODE_MAILBOXES = 8 */
    /* WP proof steps (annotations only): one invariant per framed field, `apart` (the addresses this
     * round's inbox stores cannot reach an outbox size), and the layout restated after each store
     * below, so that no goal sees through a store into the other array of urb_node_t: z3 and cvc4
     * time out on those, even at 30 s per goal, and prove each step in under a second. */
    /*@ loop invariant 0 <= n <= URB_NODE_MAILBOXES;
        loop invariant \forall integer i; 0 <= i < n ==>
          node->outbox[i].isr_idx == URB_NONE && node->outbox[i].held == URB_NONE &&
          node->inbox[i].isr_idx == URB_NONE && node->inbox[i].app_idx == URB_NONE;
        loop invariant unset_out: \forall integer i; 0 <= i < URB_NODE_MAILBOXES ==> node->outbox[i].size == 0;
        loop invariant unset_in: \forall integer i; 0 <= i < URB_NODE_MAILBOXES ==> node->inbox[i].size == 0;
        loop invariant front_out: \forall integer i; 0 <= i < URB_NODE_MAILBOXES ==> node->outbox[i].front == \at(node->outbox[i].front, Pre);
        loop invariant front_in: \forall integer i; 0 <= i < URB_NODE_MAILBOXES ==> node->inbox[i].front == \at(node->inbox[i].front, Pre);
        loop assigns n, node->outbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx, node->outbox[0 .. URB_NODE_MAILBOXES - 1].held,
                     node->inbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx, node->inbox[0 .. URB_NODE_MAILBOXES - 1].app_idx;
        loop variant URB_NODE_MAILBOXES - n; */
    for (uint8_t n = 0u; n < URB_NODE_MAILBOXES; n++) {
        node->outbox[n].isr_idx = URB_NONE;
        node->outbox[n].held = URB_NONE;
        /*@ assert apart: \forall integer i; 0 <= i < URB_NODE_MAILBOXES ==>
              &node->outbox[i].size != &node->inbox[n].isr_idx && &node->outbox[i].size != &node->inbox[n].app_idx; */
        node->inbox[n].isr_idx = URB_NONE;
        node->inbox[n].app_idx = URB_NONE;
    }
    /*@ assert urb_mb_indices(node); */
    node->outbox[0].size = URB_NODE_OUTBOX0_SIZE;
    /*@ assert urb_mb_indices(node); */
    node->inbox[0].offset = URB_MB0_INBOX_OFFSET;
    /*@ assert urb_mb_memory(node); */
    node->inbox[0].size = URB_NODE_INBOX0_SIZE;
    /*@ assert urb_mb_indices(node); */
    /*@ assert urb_mb_only_mb0(node); */
}

/* Sets up inbox or outbox n with `size` bytes carved (zeroed) from the storage block: the carved
 * range holds both buffers (offset and offset + size), so an application reads zeros before the
 * first commit (setup_zeroed). */
/*@ requires node == \null || urb_mb_layout(node);
    ensures setup_layout: node != \null ==> urb_mb_layout(node);
    ensures setup_i2c: node != \null ==> node->i2c == \old(node->i2c);
    ensures setup_sizes: node != \null ==> \forall integer m; 0 <= m < URB_NODE_MAILBOXES ==>
              \old(node->inbox[m].size) != 0 ==> node->inbox[m].size == \old(node->inbox[m].size);
    behavior bad_argument:
      assumes node == \null || n == 0 || n >= URB_NODE_MAILBOXES || size == 0 || size > URB_NODE_MAX_SIZE;
      assigns node->setup_err;
      ensures \result == URB_NODE_ERR_ARG;
    behavior refused:
      assumes node != \null && 1 <= n < URB_NODE_MAILBOXES && 1 <= size <= URB_NODE_MAX_SIZE;
      assumes node->started != 0 || (inbox ? node->inbox[n].size : node->outbox[n].size) != 0 ||
              node->storage == \null || 2 * size > node->storage_len - node->storage_used;
      assigns node->setup_err;
      ensures urb_mb_layout(node);
      ensures \result == URB_NODE_ERR_STATE || \result == URB_NODE_ERR_SETUP || \result == URB_NODE_ERR_NOMEM;
    behavior carved:
      assumes node != \null && 1 <= n < URB_NODE_MAILBOXES && 1 <= size <= URB_NODE_MAX_SIZE;
      assumes node->started == 0 && (inbox ? node->inbox[n].size : node->outbox[n].size) == 0 &&
              node->storage != \null && 2 * size <= node->storage_len - node->storage_used;
      assigns node->storage[node->storage_used .. node->storage_used + 2 * size - 1], node->storage_used,
              node->inbox[n].offset, node->inbox[n].size, node->outbox[n].offset, node->outbox[n].size;
      ensures \result == URB_NODE_OK;
      ensures urb_mb_layout(node);
      ensures node->storage_used == \old(node->storage_used) + 2 * size;
      ensures inbox ==> node->inbox[n].offset == \old(node->storage_used) && node->inbox[n].size == size &&
                        node->outbox[n].offset == \old(node->outbox[n].offset) &&
                        node->outbox[n].size == \old(node->outbox[n].size);
      ensures !inbox ==> node->outbox[n].offset == \old(node->storage_used) && node->outbox[n].size == size &&
                         node->inbox[n].offset == \old(node->inbox[n].offset) &&
                         node->inbox[n].size == \old(node->inbox[n].size);
      ensures setup_zeroed: \forall integer k; \old(node->storage_used) <= k < \old(node->storage_used) + 2 * size ==>
                node->storage[k] == 0;
    complete behaviors;
    disjoint behaviors; */
static int setup_box(urb_node_t *node, uint8_t n, uint8_t size, bool inbox)
{
    int rc = URB_NODE_OK;
    if ((node == NULL) || (n == 0u) || (n >= URB_NODE_MAILBOXES) || (size == 0u) || (size > URB_NODE_MAX_SIZE)) {
        urb_setup_error(node, URB_NODE_ERR_ARG);
        return URB_NODE_ERR_ARG;
    }
    uint16_t *const offset_of = inbox ? &node->inbox[n].offset : &node->outbox[n].offset;
    uint8_t *const size_of = inbox ? &node->inbox[n].size : &node->outbox[n].size;
    if (node->started != 0u) {
        rc = URB_NODE_ERR_STATE; /* sizes are fixed before the node goes on the bus */
    } else if (*size_of != 0u) {
        rc = URB_NODE_ERR_SETUP;
    } else if ((node->storage == NULL) ||
               ((uint16_t)(2u * size) > (uint16_t)(node->storage_len - node->storage_used))) {
        rc = URB_NODE_ERR_NOMEM;
    } else {
        uint16_t const offset = node->storage_used;
        /* bound: 2 * URB_NODE_MAX_SIZE = 64 */
        /*@ loop invariant 0 <= k <= 2 * size;
            loop invariant zeroed: \forall integer j; offset <= j < offset + k ==> node->storage[j] == 0;
            loop assigns k, node->storage[offset .. offset + 2 * size - 1];
            loop variant 2 * size - k; */
        for (uint8_t k = 0u; k < (uint8_t)(2u * size); k++) {
            node->storage[offset + k] = 0u;
        }
        node->storage_used = (uint16_t)(offset + 2u * size);
        *offset_of = offset;
        *size_of = size;
        return URB_NODE_OK;
    }
    urb_setup_error(node, rc);
    return rc;
}

int urb_node_setup_inbox(urb_node_t *node, uint8_t n, uint8_t size)
{
    return setup_box(node, n, size, true);
}

int urb_node_setup_outbox(urb_node_t *node, uint8_t n, uint8_t size)
{
    return setup_box(node, n, size, false);
}

uint8_t urb_node_inbox_size(const urb_node_t *node, uint8_t n)
{
    return ((node == NULL) || (n >= URB_NODE_MAILBOXES)) ? 0u : node->inbox[n].size;
}

uint8_t urb_node_outbox_size(const urb_node_t *node, uint8_t n)
{
    return ((node == NULL) || (n >= URB_NODE_MAILBOXES)) ? 0u : node->outbox[n].size;
}

/* ===== Public application-side wrappers (mailboxes 1..7) ==================================== */

int urb_node_lock_inbox(urb_node_t *node, uint8_t n, const uint8_t **data)
{
    if ((node == NULL) || (data == NULL) || (n == 0u) || (n >= URB_NODE_MAILBOXES)) {
        return URB_NODE_ERR_ARG; /* inbox 0 belongs to the library (commands) */
    }
    return urb_lock_inbox_any(node, n, data);
}

int urb_node_release_inbox(urb_node_t *node, uint8_t n)
{
    if ((node == NULL) || (n == 0u) || (n >= URB_NODE_MAILBOXES)) {
        return URB_NODE_ERR_ARG;
    }
    return urb_release_inbox_any(node, n);
}

int urb_node_lock_outbox(urb_node_t *node, uint8_t n, uint8_t **data)
{
    if ((node == NULL) || (data == NULL) || (n == 0u) || (n >= URB_NODE_MAILBOXES)) {
        return URB_NODE_ERR_ARG; /* outbox 0 belongs to the library (identification) */
    }
    return urb_lock_outbox_any(node, n, data);
}

int urb_node_release_outbox(urb_node_t *node, uint8_t n)
{
    if ((node == NULL) || (n == 0u) || (n >= URB_NODE_MAILBOXES)) {
        return URB_NODE_ERR_ARG;
    }
    int const rc = urb_release_outbox_any(node, n);
    if (rc == URB_NODE_OK) {
        urb_node_mark_acquired(node); /* no-op outside app_update or once marked */
    }
    return rc;
}
