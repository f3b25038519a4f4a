/*
 * A node's mailboxes as a downlink slave sees them (urb_dl_slave.h), for the CAN and RS485 tests
 * and fuzz targets: every inbox double-buffered as MailboxInbox.tla (a write is refused while the
 * test holds both buffers: `app_holds`), every outbox a buffer whose latch the fake tracks, with
 * counters of each call so a test can check the calling rules (begin, then exactly one commit or
 * abort; read begin, then exactly one end).
 */
#ifndef FAKE_MAILBOX_H
#define FAKE_MAILBOX_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_dl_slave.h"

#define FAKE_NONE 0xFFu

typedef struct {
    urb_dl_mailbox_t ops;
    uint8_t in_size[8], out_size[8];
    uint8_t inbox[8][32];       /* last committed message of each inbox */
    uint8_t filling[8][32];     /* the buffer write_begin handed out */
    uint8_t outbox[8][32];      /* current contents of each outbox */
    bool app_holds[8];          /* the application holds the other buffer: write_begin refuses */
    bool writing[8];            /* between write_begin and commit/abort */
    bool latched[8];            /* between read_begin and read_end */
    uint32_t commits[8], aborts[8], refusals[8];
    uint32_t reads_begun[8], reads_complete[8], reads_cut[8];
    uint32_t faults[5];
    uint32_t syncs;
    uint32_t sync_t;
    uint8_t sync_counter;
    uint32_t rule_violations;   /* a call the calling rules forbid */
} fake_mailbox_t;

/** Sets up *fm with the given sizes (0 = not set up), outboxes filled with a pattern. */
void fake_mailbox_init(fake_mailbox_t *fm, const uint8_t in_size[8], const uint8_t out_size[8]);

/** Total of commits over all inboxes. */
uint32_t fake_mailbox_commits(const fake_mailbox_t *fm);

/** Number of operations in urb_dl_mailbox_t (fake_mailbox_ops_without's k ranges over 0..this - 1). */
#define FAKE_MAILBOX_OPS 8

/** A copy of fm's operations with the k-th one (in the struct's order) NULL: the slaves' init must
 * refuse every such table. */
urb_dl_mailbox_t fake_mailbox_ops_without(const fake_mailbox_t *fm, int k);

#endif /* FAKE_MAILBOX_H */
