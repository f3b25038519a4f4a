/*
 * Internals shared by the node library's translation units. Not a public header.
 *
 * Files: urb_mailbox.c (the two TLA+ mailbox algorithms), urb_i2c.c (downlink byte state
 * machine), urb_pll.c (heartbeat timer and SYNC PLL), urb_node.c (lifecycle, main loop, inbox 0
 * commands, outbox 0 identification, faults), urb_observe.c (read-only views).
 */
#ifndef URB_NODE_INTERNAL_H
#define URB_NODE_INTERNAL_H

#include "urb_node.h"

/* "No buffer": the NONE of MailboxInbox.tla / MailboxOutbox.tla (fits the uint8_t indices). */
#define URB_NONE URB_NODE_NO_BUFFER

/* Compiler barrier. The index variables are volatile, so the compiler keeps their accesses in
 * program order, but it may move plain buffer accesses across them; the barrier pins the data
 * copies before a publish and after a lock. Cortex-M0+ has no cache or store buffer, so no DMB.
 * A port for a core that reorders memory (or a C11 build) can override it. */
#ifndef URB_NODE_BARRIER
#define URB_NODE_BARRIER() __asm__ __volatile__("" ::: "memory")
#endif

/* Application-side steps, named after their TLA+ actions. Tests build the library with
 * URB_NODE_TESTING and define urb_node_test_step(): it runs after every step that touches
 * shared state, so a test can run interrupt events at every point the application can be
 * preempted (exhaustive interleavings, tests/firmware/node/test_interleave.c). */
enum {
    URB_STEP_OUT_LOCK_PICK = 1,     /* step AppLockPick of MailboxOutbox.tla */
    URB_STEP_OUT_LOCK_CHECK = 2,    /* step AppLockCheck of MailboxOutbox.tla (lock granted or BUSY) */
    URB_STEP_OUT_RELEASE = 3,       /* step AppRelease of MailboxOutbox.tla */
    URB_STEP_IN_LOAD_FRONT = 4,     /* step AppLockLoadFront of MailboxInbox.tla */
    URB_STEP_IN_CLAIM = 5,          /* step AppLockClaim of MailboxInbox.tla */
    URB_STEP_IN_CHECK_ISR = 6,      /* step AppLockCheckIsr of MailboxInbox.tla (passed or failed) */
    URB_STEP_IN_CHECK_FRONT = 7,    /* step AppLockCheckFront of MailboxInbox.tla passed: linearization point */
    URB_STEP_IN_CHECK_FAILED = 8,   /* step AppLockCheckFront of MailboxInbox.tla failed */
    URB_STEP_IN_UNCLAIM = 9,        /* step AppLockUnclaim of MailboxInbox.tla (app_idx := NONE) */
    URB_STEP_IN_RELEASE = 10        /* step AppRelease of MailboxInbox.tla */
};

#if defined(URB_NODE_TESTING)
void urb_node_test_step(urb_node_t *node, uint8_t step);
#define URB_STEP(node, step) urb_node_test_step((node), (uint8_t)(step))
#else
#define URB_STEP(node, step) ((void)0)
#endif

/* Main-loop flags (urb_node_t.flags; written only by the main loop, so plain bit updates). */
#define URB_F_FAULT 0x01u      /* Identification.fault: a fault reached the application */
#define URB_F_ID_DIRTY 0x02u   /* outbox 0 must be refreshed */
#define URB_F_ID_SYNCED 0x04u  /* published Identification.synced */
#define URB_F_ID_FAULT 0x08u   /* published Identification.fault */
#define URB_F_IN_UPDATE 0x10u  /* inside app_update */
#define URB_F_ACQ_MARKED 0x20u /* this update's acquisition end is marked */
#define URB_F_ACQ_VALID 0x40u  /* this update started on time: its mark is measured */

/* I2C downlink states (urb_node_i2c_t.state): the public phases (urb_node_dl_phase_t). */
enum {
    URB_I2C_ST_IDLE = URB_NODE_DL_IDLE,         /* no transaction: bytes are NACKed, reads return 0xFF */
    URB_I2C_ST_SELECT = URB_NODE_DL_SELECT,     /* addressed for writing: the next byte is MailboxSelect */
    URB_I2C_ST_DATA = URB_NODE_DL_WRITE,        /* receiving data of inbox `mailbox` */
    URB_I2C_ST_CHECK = URB_NODE_DL_WRITE_CHECK, /* receiving the check */
    URB_I2C_ST_DONE = URB_NODE_DL_WRITE_DONE,   /* size + check bytes received, check passed: commit at STOP/restart */
    URB_I2C_ST_SELECTED = URB_NODE_DL_SELECTED, /* read select received: nothing more expected */
    URB_I2C_ST_READ = URB_NODE_DL_READ,         /* sending outbox `mailbox` */
    URB_I2C_ST_SYNC = URB_NODE_DL_SYNC,         /* general call: SYNC magic, then counter */
    URB_I2C_ST_IGNORE = URB_NODE_DL_IGNORE      /* refused or finished: NACK until STOP/START */
};

/* ----- mailbox algorithms (urb_mailbox.c) ----- */

/* ACSL: the mailbox layout (proofs/framac/mailbox/ proves the mailbox functions under it and that
 * they keep it; proofs/framac/node_i2c/ that the I2C interrupt calls them within it). */
/*@ predicate urb_mb_indices(urb_node_t *node) =
      \forall integer n; 0 <= n < URB_NODE_MAILBOXES ==>
        node->outbox[n].front <= 1 && node->outbox[n].isr_idx <= URB_NONE && node->outbox[n].held <= URB_NONE &&
        node->inbox[n].front <= 1 && node->inbox[n].isr_idx <= URB_NONE && node->inbox[n].app_idx <= URB_NONE;

    predicate urb_mb_box(urb_node_t *node, integer n, integer offset, integer size) =
      n == 0 ? offset + 2 * size <= 2 * URB_NODE_OUTBOX0_SIZE + 2 * URB_NODE_INBOX0_SIZE
             : (size == 0 || offset + 2 * size <= node->storage_used);

    predicate urb_mb_memory(urb_node_t *node) =
      \valid(node) && node->storage_used <= node->storage_len &&
      \valid(node->storage + (0 .. node->storage_len - 1)) &&
      \separated(node, node->storage + (0 .. node->storage_len - 1));

    predicate urb_mb_boxes(urb_node_t *node) =
      \forall integer n; 0 <= n < URB_NODE_MAILBOXES ==>
        urb_mb_box(node, n, node->outbox[n].offset, node->outbox[n].size) &&
        urb_mb_box(node, n, node->inbox[n].offset, node->inbox[n].size);

    predicate urb_mb_layout(urb_node_t *node) = urb_mb_memory(node) && urb_mb_indices(node) && urb_mb_boxes(node);

    logic uint8_t *urb_mb_buf(urb_node_t *node, integer n, integer offset, integer size, integer b) =
      (n == 0 ? &node->mb0[0] : node->storage) + offset + (b != 0 ? size : 0);

    logic uint8_t *urb_mb_out(urb_node_t *node, integer n, integer b) =
      urb_mb_buf(node, n, node->outbox[n].offset, node->outbox[n].size, b);

    logic uint8_t *urb_mb_in(urb_node_t *node, integer n, integer b) =
      urb_mb_buf(node, n, node->inbox[n].offset, node->inbox[n].size, b);
*/

/* Buffer b of outbox n / inbox n. */
uint8_t *urb_outbox_buf(urb_node_t *node, uint8_t n, uint8_t b);
uint8_t *urb_inbox_buf(urb_node_t *node, uint8_t n, uint8_t b);

/* Interrupt side, inbox n: begin (false: refused, NACK), store byte k, commit, abort. */
bool urb_isr_write_begin(urb_node_t *node, uint8_t n);
void urb_isr_write_byte(urb_node_t *node, uint8_t n, uint8_t k, uint8_t byte);
void urb_isr_write_commit(urb_node_t *node, uint8_t n);
void urb_isr_write_abort(urb_node_t *node, uint8_t n);

/* Interrupt side, outbox n: begin (latch front), byte k, end. */
void urb_isr_read_begin(urb_node_t *node, uint8_t n);
uint8_t urb_isr_read_byte(urb_node_t *node, uint8_t n, uint8_t k);
void urb_isr_read_end(urb_node_t *node, uint8_t n);

/* Application side for any mailbox, 0 included (the library's own use of mailbox 0). */
int urb_lock_inbox_any(urb_node_t *node, uint8_t n, const uint8_t **data);
int urb_release_inbox_any(urb_node_t *node, uint8_t n);
int urb_lock_outbox_any(urb_node_t *node, uint8_t n, uint8_t **data);
int urb_release_outbox_any(urb_node_t *node, uint8_t n);

/* Resets all mailboxes to "not set up" and sets up mailbox 0 (urb_node_init). */
void urb_mailbox_reset(urb_node_t *node);

/* ----- heartbeat (urb_pll.c) ----- */

/* Applies the configuration to the PLL and arms the first heartbeat (urb_node_init, no interrupt yet). */
void urb_pll_start(urb_node_t *node);
/* A SYNC with counter `counter` was time-stamped at tick t_d (I2C interrupt). */
void urb_pll_sync(urb_node_t *node, uint32_t t_d, uint8_t counter);
/* Signed difference a - b of two ticks less than 2^31 apart, without implementation-defined casts. */
int32_t urb_tick_diff(uint32_t a, uint32_t b);

/* ----- setup ----- */

/* Records the first setup error of bootup (urb_node_init returns it); ignored after start. */
void urb_setup_error(urb_node_t *node, int rc);

/* ----- faults ----- */

/* Interrupt side: count one fault of `code` (delivered to the fault hook by urb_node_poll). */
void urb_isr_fault(urb_node_t *node, urb_node_fault_t code);

#endif /* URB_NODE_INTERNAL_H */
