/*
 * I2C slave downlink: one call per bus event, O(1) each (at most one CRC byte update, whose
 * bit loop is bounded by 8). The contract is the one in spec/schema/README.md ("Frames"), which
 * the bridge implements as master:
 *
 *   write inbox m:  START addr+W  select(m, read=0)  data[size]  check  STOP
 *     NACK select     inbox m not set up, or reserved bits set      (bridge: BAD_REQUEST)
 *     NACK data[0]    IsrWriteBegin refused: both buffers in use    (bridge: NODE_BUSY; fault OVERRUN)
 *     NACK last check the check failed, nothing stored              (bridge: CHECKSUM; fault CHECKSUM)
 *     NACK extra byte more than size + check bytes                  (bridge: SIZE_MISMATCH; no fault)
 *     (a write longer than size puts data where the check goes: the node cannot tell it from a bad
 *      check, so it NACKs it as a failed check, fault CHECKSUM; the bridge, knowing the length it
 *      sent, reports SIZE_MISMATCH when the NACK falls on one of its data bytes)
 *     commit          only at STOP / repeated START after exactly size + check bytes with a good
 *                     check; any other end (short write, bus error, stuck bus) aborts.
 *   select outbox m: START addr+W  select(m, read=1)  STOP|Sr    (NACK: outbox m not set up)
 *   read:            START addr+R  data[size] check 0xFF...      (check covers m|0x80, then data)
 *     a byte received during a read (a port that lost the direction) ends it and is NACKed
 *   SYNC:            START 0x00+W  0xA5 counter                  (time-stamped at the address match)
 *
 * The check is link_check: CRC-8 when the covered length (select + data) is at most 14 bytes,
 * else CRC-16 sent little-endian.
 *
 * Seeded bugs for the mutant check: URB_MUTANT_COMMIT_BAD_CHECK (a failed check still commits),
 * URB_MUTANT_READ_CHECK_NO_SELECT (the read check leaves out the implicit select byte),
 * URB_MUTANT_READ_KEPT_ON_RX (a byte received during a read refuses it without ending it).
 */
#include "urb_node_internal.h"

#include "urb_core.h"
#include "urb_runtime.h"

#define URB_SELECT_READ 0x80u     /* MailboxSelect.read */
#define URB_SELECT_RESERVED 0x78u /* MailboxSelect._ (must be zero) */
#define URB_SELECT_MAILBOX 0x07u  /* MailboxSelect.mailbox */

/* ACSL for Frama-C WP (proofs/framac/node_i2c/): every call of a mailbox function below is within
 * its contract (urb_mailbox.c) and no run-time error, for every slave state the invariant
 * urb_i2c_ok allows: the mailbox layout, the transaction's and the read select's mailbox numbers
 * below 8, the state one of URB_I2C_ST_*, a CRC-8 or CRC-16 check, and while data arrive the byte
 * count below the inbox size. */
/*@ predicate urb_i2c_ok(urb_node_t *node) =
      urb_mb_layout(node) &&
      node->i2c.mailbox < URB_NODE_MAILBOXES && node->i2c.selected < URB_NODE_MAILBOXES &&
      node->i2c.state <= URB_I2C_ST_IGNORE && node->i2c.crc16 <= 1 &&
      (node->i2c.state == URB_I2C_ST_DATA ==> node->i2c.count < node->inbox[node->i2c.mailbox].size);
*/

/*@ requires \valid(i2c);
    assigns i2c->crc; */
static void check_update(urb_node_i2c_t *i2c, uint8_t byte)
{
    i2c->crc = (i2c->crc16 != 0u) ? urb_crc16_link_check_byte(i2c->crc, byte)
                                  : urb_crc8_link_check_byte((uint8_t)i2c->crc, byte);
}

/* Starts the check of a transaction on a mailbox of `size` bytes: the tier follows the covered
 * length 1 + size (select byte + data), then the select byte itself is covered. */
/*@ requires \valid(i2c);
    assigns i2c->crc16, i2c->crc;
    ensures i2c->crc16 <= 1; */
/* lobster-trace: urb.CRC_003 */
static void check_start(urb_node_i2c_t *i2c, uint8_t size, uint8_t select)
{
    i2c->crc16 = ((1u + (unsigned)size) > URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 0u;
    i2c->crc = (i2c->crc16 != 0u) ? (uint16_t)URB_CRC16_LINK_CHECK_INIT : (uint16_t)URB_CRC8_LINK_CHECK_INIT;
#if defined(URB_MUTANT_READ_CHECK_NO_SELECT)
    if ((select & URB_SELECT_READ) != 0u) {
        return;
    }
#endif
    check_update(i2c, select);
}

/*@ requires \valid_read(i2c) && i2c->crc16 <= 1;
    assigns \nothing;
    ensures \result == 1 + i2c->crc16; */
static uint8_t check_len(const urb_node_i2c_t *i2c)
{
    return (uint8_t)(1u + i2c->crc16);
}

/* Byte k (0: low) of the finished check, as sent on the wire (little-endian). */
/*@ requires \valid_read(i2c);
    assigns \nothing; */
static uint8_t check_byte(const urb_node_i2c_t *i2c, uint8_t k)
{
    if (i2c->crc16 == 0u) {
        return urb_crc8_link_check_final((uint8_t)i2c->crc);
    }
    uint16_t const fin = urb_crc16_link_check_final(i2c->crc);
    return (uint8_t)((k == 0u) ? (fin & 0xFFu) : (fin >> 8));
}

/* Ends the transaction in progress. `clean`: a STOP, repeated START or end of read, which
 * commits a complete write; otherwise (bus error, stuck bus) a complete write is aborted too. */
/*@ requires urb_i2c_ok(node);
    assigns node->i2c.state, node->id_done, node->outbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx,
            node->inbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx, node->inbox[0 .. URB_NODE_MAILBOXES - 1].front,
            node->inbox[0 .. URB_NODE_MAILBOXES - 1].fresh[0 .. 1];
    ensures urb_i2c_ok(node);
    ensures node->i2c.state == URB_I2C_ST_IDLE; */
static void end_transaction(urb_node_t *node, bool clean)
{
    urb_node_i2c_t *i2c = &node->i2c;
    uint8_t const m = i2c->mailbox;
    switch (i2c->state) {
    case URB_I2C_ST_DATA:
    case URB_I2C_ST_CHECK:
        if (i2c->count != 0u) {
            urb_isr_write_abort(node, m); /* cut short: MailboxInbox.tla IsrWriteAbort */
        }
        break;
    case URB_I2C_ST_DONE:
        if (clean) {
            urb_isr_write_commit(node, m); /* MailboxInbox.tla IsrWriteCommit */
        } else {
            urb_isr_write_abort(node, m); /* MailboxInbox.tla IsrWriteAbort */
        }
        break;
    case URB_I2C_ST_READ: {
        uint8_t const size = node->outbox[m].size;
        urb_isr_read_end(node, m); /* MailboxOutbox.tla IsrReadEnd */
        if ((m == 0u) && (i2c->count >= (uint8_t)(size + check_len(i2c)))) {
            node->id_done = node->id_reads; /* a complete identification read (clears the fault flag) */
            /*@ assert urb_mb_layout(node); */
        }
        break;
    }
    default:
        break; /* nothing held: IDLE, SELECT, SELECTED, SYNC, IGNORE */
    }
    /*@ assert urb_mb_layout(node); */
    i2c->state = URB_I2C_ST_IDLE;
}

/* Refuses the current byte and everything after it until STOP / START. */
/*@ requires urb_i2c_ok(node);
    assigns node->i2c.state;
    ensures urb_i2c_ok(node);
    ensures \result == URB_I2C_NACK; */
/* lobster-trace: urb.MBX_005 */
static uint16_t refuse(urb_node_t *node)
{
    node->i2c.state = URB_I2C_ST_IGNORE;
    return URB_I2C_NACK;
}

/*@ requires urb_i2c_ok(node);
    assigns node->i2c;
    ensures urb_i2c_ok(node); */
static uint16_t rx_select(urb_node_t *node, uint8_t byte)
{
    urb_node_i2c_t *i2c = &node->i2c;
    uint8_t const m = (uint8_t)(byte % (URB_SELECT_MAILBOX + 1u)); /* byte & URB_SELECT_MAILBOX (same code) */
    /*@ assert m < URB_NODE_MAILBOXES; */
    if ((byte & URB_SELECT_RESERVED) != 0u) {
        return refuse(node); /* strict decoding: reserved bits must be zero */
    }
    if ((byte & URB_SELECT_READ) != 0u) {
        if (node->outbox[m].size == 0u) {
            return refuse(node);
        }
        i2c->selected = m; /* kept until the next read select */
        /*@ assert urb_mb_layout(node); */
        i2c->state = URB_I2C_ST_SELECTED;
        return URB_I2C_ACK;
    }
    uint8_t const size = node->inbox[m].size;
    if (size == 0u) {
        return refuse(node);
    }
    i2c->mailbox = m;
    i2c->count = 0u;
    i2c->check_ok = 1u;
    /*@ assert urb_mb_layout(node); */
    check_start(i2c, size, byte);
    /*@ assert urb_mb_layout(node); */
    i2c->state = URB_I2C_ST_DATA;
    return URB_I2C_ACK;
}

/*@ requires urb_i2c_ok(node) && node->i2c.state == URB_I2C_ST_DATA;
    assigns node->i2c, node->isr_faults[0 .. URB_NODE_FAULT_CODES - 1], node->inbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx,
            node->mb0[0 .. 2 * URB_NODE_OUTBOX0_SIZE + 2 * URB_NODE_INBOX0_SIZE - 1], node->storage[0 .. node->storage_len - 1];
    ensures urb_i2c_ok(node); */
static uint16_t rx_data(urb_node_t *node, uint8_t byte)
{
    urb_node_i2c_t *i2c = &node->i2c;
    uint8_t const m = i2c->mailbox;
    uint8_t const size = node->inbox[m].size;
    if (i2c->count == 0u) {
        if (!urb_isr_write_begin(node, m)) { /* MailboxInbox.tla IsrWriteBegin refused: NACK */
            urb_isr_fault(node, URB_NODE_FAULT_OVERRUN);
            return refuse(node);
        }
    }
    urb_isr_write_byte(node, m, i2c->count, byte); /* MailboxInbox.tla IsrWriteByte */
    check_update(i2c, byte);
    /*@ assert urb_mb_layout(node); */
    i2c->count++;
    /*@ assert urb_mb_layout(node); */
    if (i2c->count == size) {
        i2c->state = URB_I2C_ST_CHECK;
    }
    return URB_I2C_ACK;
}

/*@ requires urb_i2c_ok(node) && node->i2c.state == URB_I2C_ST_CHECK;
    assigns node->i2c, node->isr_faults[0 .. URB_NODE_FAULT_CODES - 1], node->inbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx;
    ensures urb_i2c_ok(node); */
/* lobster-trace: urb.CRC_004 */
static uint16_t rx_check(urb_node_t *node, uint8_t byte)
{
    urb_node_i2c_t *i2c = &node->i2c;
    uint8_t const m = i2c->mailbox;
    uint8_t const size = node->inbox[m].size;
    uint8_t const k = (uint8_t)(i2c->count - size);
    if (byte != check_byte(i2c, k)) {
        i2c->check_ok = 0u;
    }
    /*@ assert urb_mb_layout(node); */
    i2c->count++;
    /*@ assert urb_mb_layout(node); */
    if (k + 1u < check_len(i2c)) {
        return URB_I2C_ACK; /* the verdict is given on the last check byte */
    }
#if !defined(URB_MUTANT_COMMIT_BAD_CHECK)
    if (i2c->check_ok == 0u) {
        urb_isr_write_abort(node, m); /* MailboxInbox.tla IsrWriteAbort: corrupt, nothing published */
        urb_isr_fault(node, URB_NODE_FAULT_CHECKSUM);
        return refuse(node);
    }
#endif
    i2c->state = URB_I2C_ST_DONE; /* commit waits for STOP / repeated START */
    return URB_I2C_ACK;
}

/*@ requires urb_i2c_ok(node);
    assigns node->i2c, node->pll;
    ensures urb_i2c_ok(node); */
static uint16_t rx_sync(urb_node_t *node, uint8_t byte)
{
    urb_node_i2c_t *i2c = &node->i2c;
    if (i2c->sync_ok == 0u) {
        if (byte != URB_SYNC_MAGIC) {
            return refuse(node); /* another general-call command: not ours */
        }
        i2c->sync_ok = 1u;
        return URB_I2C_ACK;
    }
    urb_pll_sync(node, i2c->sync_t, byte);
    i2c->state = URB_I2C_ST_IGNORE; /* a SYNC has exactly two bytes */
    return URB_I2C_ACK;
}

/* (no assigns clause: WP 25 asks the call result temporary of the default case's `return refuse()`
 * to be assigned, a goal it reduces to false; the caller needs only the invariant) */
/*@ requires urb_i2c_ok(node);
    ensures urb_i2c_ok(node); */
static uint16_t rx_byte(urb_node_t *node, uint8_t byte)
{
    switch (node->i2c.state) {
    case URB_I2C_ST_SELECT:
        return rx_select(node, byte);
    case URB_I2C_ST_DATA:
        return rx_data(node, byte);
    case URB_I2C_ST_CHECK:
        return rx_check(node, byte);
    case URB_I2C_ST_SYNC:
        return rx_sync(node, byte);
    case URB_I2C_ST_DONE: /* more than size + check bytes: a long write, aborted */
#if !defined(URB_MUTANT_READ_KEPT_ON_RX)
    case URB_I2C_ST_READ:
        /* a byte received while this node transmits: the port lost the direction (a glitch). The
         * read ends here, or the outbox would stay latched (MailboxOutbox.tla IsrReadEnd) and the
         * application's next lock but one would be BUSY until the next read of it. */
#endif
        end_transaction(node, false);
        return refuse(node);
    default:
        return refuse(node); /* IDLE, SELECTED (a select has one byte), IGNORE */
    }
}

/*@ requires urb_i2c_ok(node);
    assigns node->i2c.count, node->i2c.crc;
    ensures urb_i2c_ok(node); */
static uint16_t tx_byte(urb_node_t *node)
{
    urb_node_i2c_t *i2c = &node->i2c;
    if (i2c->state != URB_I2C_ST_READ) {
        return 0xFFu; /* not in a read: release SDA (reads as 0xFF) */
    }
    uint8_t const m = i2c->mailbox;
    uint8_t const size = node->outbox[m].size;
    uint8_t const count = i2c->count;
    if (count < size) {
        uint8_t const b = urb_isr_read_byte(node, m, count); /* MailboxOutbox.tla IsrReadByte */
        check_update(i2c, b);
        /*@ assert urb_mb_layout(node); */
        i2c->count++;
        return b;
    }
    if (count < (uint8_t)(size + check_len(i2c))) {
        i2c->count++;
        return check_byte(i2c, (uint8_t)(count - size));
    }
    return 0xFFu; /* the master clocks more than size + check bytes */
}

/*@ requires urb_i2c_ok(node);
    assigns node->i2c, node->id_reads, node->outbox[0 .. URB_NODE_MAILBOXES - 1].isr_idx;
    ensures urb_i2c_ok(node); */
static uint16_t addr_read(urb_node_t *node)
{
    urb_node_i2c_t *i2c = &node->i2c;
    uint8_t const m = i2c->selected;
    uint8_t const size = node->outbox[m].size;
    urb_isr_read_begin(node, m); /* MailboxOutbox.tla IsrReadBegin */
    if (m == 0u) {
        node->id_reads = (uint8_t)(node->id_reads + 1u);
    }
    /*@ assert urb_mb_layout(node); */
    i2c->mailbox = m;
    i2c->count = 0u;
    /*@ assert urb_mb_layout(node); */
    check_start(i2c, size, (uint8_t)(m | URB_SELECT_READ)); /* the check covers the implicit select */
    /*@ assert urb_mb_layout(node); */
    i2c->state = URB_I2C_ST_READ;
    return URB_I2C_ACK;
}

/*@ requires urb_i2c_ok(node) && \valid_read(node->hal);
    assigns node->i2c;
    ensures urb_i2c_ok(node); */
static uint16_t general_call(urb_node_t *node)
{
    urb_node_hal_t const *hal = node->hal;
    urb_node_i2c_t *i2c = &node->i2c;
    /* t_d: hardware capture at the address match when the port has one (no latency jitter) */
    i2c->sync_t = (hal->sync_capture != NULL) ? hal->sync_capture(hal->ctx) : hal->now(hal->ctx);
    i2c->sync_ok = 0u;
    i2c->state = URB_I2C_ST_SYNC;
    if (hal->mark != NULL) {
        hal->mark(hal->ctx, URB_NODE_MARK_SYNC);
    }
    return URB_I2C_ACK;
}

/* The dispatcher's two steps after end_transaction (ADDR_WRITE, STUCK), each a function with its
 * own contract for WP: z3 and cvc4 time out carrying the quantified layout of urb_i2c_ok across
 * the store inside the dispatcher's goal, and prove it at once in these small ones. The compiler
 * inlines both (same machine code as the statements written in place). */
/*@ requires urb_i2c_ok(node);
    assigns node->i2c.state;
    ensures urb_i2c_ok(node); */
static void addr_write(urb_node_t *node)
{
    node->i2c.state = URB_I2C_ST_SELECT;
}

/*@ requires urb_i2c_ok(node);
    assigns node->isr_faults[URB_NODE_FAULT_STUCK_BUS - 1];
    ensures urb_i2c_ok(node); */
static void bus_stuck(urb_node_t *node)
{
    urb_isr_fault(node, URB_NODE_FAULT_STUCK_BUS);
}

/* One bus event keeps the slave invariant urb_i2c_ok (the induction step over event sequences):
 * every handler it calls ensures it, and so do addr_write and bus_stuck, its steps after
 * end_transaction (proofs/framac/README.md, "Node I2C WP unit"). No assigns clause: the frame of
 * end_transaction's inbox[0 .. 7].fresh[0 .. 1] does not prove included in one here (README). */
/*@ requires node == \null || (urb_i2c_ok(node) && \valid_read(node->hal));
    ensures node != \null ==> urb_i2c_ok(node); */
/* lobster-trace: urb.WCET_001 */
uint16_t urb_node_i2c_event(urb_node_t *node, urb_i2c_event_t event, uint8_t byte)
{
    if ((node == NULL) || (node->started == 0u)) {
        return (event == URB_I2C_TX_BYTE) ? 0xFFu : URB_I2C_NACK;
    }
    switch (event) {
    case URB_I2C_RX_BYTE:
        return rx_byte(node, byte);
    case URB_I2C_TX_BYTE:
        return tx_byte(node);
    case URB_I2C_TX_NACK:
        if (node->i2c.state == URB_I2C_ST_READ) {
            end_transaction(node, true); /* the master took what it wanted: end of the read */
        }
        return URB_I2C_ACK;
    default:
        break;
    }
    if (event > URB_I2C_STUCK) {
        return URB_I2C_NACK; /* not a slave event (urb_i2c_event.h) */
    }
    /* every other event ends the transaction in progress: a (repeated) START or a STOP cleanly
     * (a complete write commits), a bus error or a stuck bus not (it aborts) */
    end_transaction(node, event <= URB_I2C_STOP);
    if (event == URB_I2C_ADDR_WRITE) {
        addr_write(node);
    } else if (event == URB_I2C_ADDR_READ) {
        return addr_read(node);
    } else if (event == URB_I2C_GENERAL_CALL) {
        return general_call(node);
    } else if (event == URB_I2C_STUCK) {
        bus_stuck(node);
    } else {
        /* STOP, BUS_ERROR: nothing more */
    }
    return URB_I2C_ACK;
}
