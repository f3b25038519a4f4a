/*
 * Proof: the node's I2C slave downlink (urb_node_i2c_event, firmware/node/urb_i2c.c), the byte
 * state machine over the mailboxes (spec/schema/README.md "Frames").
 *
 * One harness, three parts (sweep items PART=n). Mailbox contents, front buffers, new flags and
 * which buffer the application holds are arbitrary; every event is measured and asserted within
 * FW_I2C_EVENT_BUDGET = 540 cycles, half of one I2C byte time at 400 kb/s (9 bit times = 22.5 us =
 * 1080 cycles at 48 MHz; the other half is interrupt entry/exit and the timer interrupt of equal
 * priority, fw_budgets.h). The PLL update a SYNC's counter byte triggers is fw_node_pll_update's,
 * with its own budget.
 *
 *   PART=1 read   (SIZE=s: outbox size) select outbox FW_OUT, read size + check + 1 bytes while the
 *                 application publishes a new version: the bytes are the version latched at the
 *                 address, its check over m|0x80 and the data in the size's tier, then 0xFF; the
 *                 read writes no byte and ends closed
 *   PART=2 SYNC   a general call with the magic then a counter calls the PLL once with the captured
 *                 tick and the counter; any other first byte is NACKed and calls nothing; a third
 *                 byte is NACKed
 *   PART=3 step   induction over event sequences of any length: from an ARBITRARY valid driver
 *                 state (any phase, count, running check, check verdict, transaction on mailbox MB,
 *                 application inbox and outbox of arbitrary sizes 1..32, so both check tiers), ANY event
 *                 with any byte (an RX_BYTE during a read too: it ends the read) leaves a valid
 *                 driver state (valid_driver: the TLA+ index invariants, count and tier
 *                 consistent with the phase), answers ACK/NACK or a byte, writes at most
 *                 data byte `count` at offset `count` of the inbox's back buffer and no other
 *                 mailbox or guard byte, never moves an outbox front, moves the inbox front only at
 *                 a STOP / repeated START after DONE (marking it new), and costs at most the budget.
 *                 The write path byte by byte (write_step): the select starts the check over
 *                 itself with count 0; data byte k extends the check and lands at offset k; each
 *                 check byte is compared with the finished check of those bytes; DONE (the only
 *                 state a clean end publishes from) only when every check byte matched, a bad check
 *                 NACKed on its last byte with a CHECKSUM fault, data[0] NACKed with OVERRUN when
 *                 the application holds the back buffer, a byte after size + check NACKed and the
 *                 write aborted. By induction from IDLE: a write is published exactly once, exactly
 *                 when size + check bytes came with the right check and the end was clean; a short,
 *                 long, refused or badly checked write is not published.
 *
 * Why the write path is an induction and not a frame like the read: ESBMC 8.4 keeps urb_node_t as
 * one SSA value, so after a few symbolic events every store through &node->inbox[mailbox] becomes
 * a byte-level update of the whole 336-byte struct; a 2-byte write frame ran Boolector out of
 * memory at 4 GiB (the last session's report, and again here), a single event from an arbitrary
 * state does not.
 *
 * Fast tier: part 1 at a 2-byte outbox (CRC-8), part 2, part 3 on an application mailbox (inbox
 * and outbox 3, sizes 1..32: both tiers). Full tier adds part 1 at 13 and 14 bytes (covered
 * lengths 14 and 15: both sides of the CRC-8 / CRC-16 boundary) and part 3 on mailbox 0 (inbox 0,
 * 6 bytes, CRC-8, and outbox 0, 25 bytes, CRC-16, inside urb_node_t; application inbox 3 and
 * outbox 5 of sizes 1..32 beside them).
 *
 * Worst case (COST): 369 cycles = 7.7 us at 48 MHz, 68% of FW_I2C_EVENT_BUDGET and 34% of one
 * I2C byte time, on mailbox 0 (its reads also count the identification reads); on an application
 * mailbox 357 cycles.
 *
 * Cover points (URB_COVER, checked by the reach run): part 1 a read with and without the
 * application publishing meanwhile; part 2 a SYNC and a refused general call; part 3 every write
 * step (select, a data byte stored, a write refused with OVERRUN, a good and a bad last check byte,
 * a byte after DONE), a publish at a clean end, a byte sent by a read and a byte received during a
 * read.
 *
 * The harness includes the prepared urb_node.c (urb_isr_fault is the real one); urb_pll_sync is a
 * stub recording its call (fw_node_pll_update proves it); the CRC byte steps are an order-sensitive
 * stand-in (stubs/fw_node_crc_stub.c: the state machine only carries the check). Storage is a local
 * array (arbitrary contents without a set-up loop) and "no other byte changes" is checked at one
 * arbitrary probe index, which stands for every index.
 */
#include "urb_verify.h"

#include "urb_node.c"

#include "urb_runtime.h"

#include "fw_budgets.h"

#include "fw_node_crc_stub.c"

#define FW_COST_BUDGET FW_I2C_EVENT_BUDGET

#ifndef URB_PART
#define URB_PART 1
#endif
#ifndef URB_SIZE
#define URB_SIZE 2u /* part 1: application mailbox size */
#endif
#ifndef URB_MB
#define URB_MB 3u /* part 3: the mailbox of the transaction in progress (0 or FW_IN) */
#endif

#define FW_IN 3u  /* the application inbox */
#define FW_OUT 5u /* the application outbox (parts 1-2; part 3 uses outbox MB) */
#define FW_GUARD 2u
#define FW_BOX_MAX ((URB_PART == 3) ? URB_NODE_MAX_SIZE : URB_SIZE)
#define FW_STORAGE (4u * FW_BOX_MAX + FW_GUARD)

URB_PROOF_COST_STORAGE;

static urb_node_t node;
static urb_node_hal_t hal;
static uint8_t *storage;
static uint32_t capture_tick;
static uint8_t pll_calls;
static uint32_t pll_t_d;
static uint8_t pll_counter;

/* ----- stubs ----- */

void urb_pll_sync(urb_node_t *n, uint32_t t_d, uint8_t counter)
{
    URB_ASSERT(n == &node, "PLL: the node");
    pll_calls++;
    pll_t_d = t_d;
    pll_counter = counter;
}

static uint32_t hal_now(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    return capture_tick;
}

static uint32_t hal_capture(void *ctx)
{
    (void)ctx;
    URB_COST(FW_HAL_CALL_CYCLES);
    return capture_tick;
}

static void hal_mark(void *ctx, urb_node_mark_t mark)
{
    (void)ctx;
    URB_ASSERT(mark == URB_NODE_MARK_SYNC, "the I2C interrupt marks SYNC only");
    URB_COST(FW_HAL_CALL_CYCLES);
}

/* ----- set-up ----- */

static uint8_t arbitrary_index(void)
{
    uint8_t const b = URB_NONDET_U8();
    URB_ASSUME(b <= 1u);
    return b;
}

/* The node after urb_node_init with inbox `in` (size si) and outbox `out` (size so) set up in the
 * storage block (outbox first), with an arbitrary mailbox history and no transaction. */
static void setup_node(uint8_t *block, uint8_t in, uint8_t si, uint8_t out, uint8_t so)
{
    hal.now = hal_now;
    hal.sync_capture = URB_NONDET_BOOL() ? hal_capture : NULL;
    hal.mark = URB_NONDET_BOOL() ? hal_mark : NULL;
    node.hal = &hal;
    node.started = 1u;
    storage = block;
    node.storage = block;
    node.storage_len = (uint16_t)FW_STORAGE;
    /* urb_mailbox_reset, written field by field with constant indices (see stubs/fw_node_stubs.c) */
    for (uint8_t n = 0u; n < URB_NODE_MAILBOXES; n++) {
        node.outbox[n].isr_idx = URB_NONE;
        node.outbox[n].held = URB_NONE;
        node.inbox[n].isr_idx = URB_NONE;
        node.inbox[n].app_idx = URB_NONE;
    }
    node.outbox[0].size = URB_NODE_OUTBOX0_SIZE;
    node.inbox[0].offset = 2u * URB_NODE_OUTBOX0_SIZE;
    node.inbox[0].size = URB_NODE_INBOX0_SIZE;
    node.outbox[out].size = so;
    node.outbox[out].offset = 0u;
    node.inbox[in].size = si;
    node.inbox[in].offset = (uint16_t)(2u * so);
    node.storage_used = (uint16_t)(2u * (so + si));
    /* arbitrary history: fronts, new flags, the application holding a buffer */
    node.outbox[out].front = arbitrary_index();
    node.outbox[0].front = arbitrary_index();
    node.inbox[in].front = arbitrary_index();
    node.inbox[in].fresh[0] = arbitrary_index();
    node.inbox[in].fresh[1] = arbitrary_index();
    uint8_t const app = URB_NONDET_U8();
    URB_ASSUME(app <= URB_NONE);
    node.inbox[in].app_idx = app;
    node.i2c.state = URB_I2C_ST_IDLE;
    node.i2c.selected = 0u;
    capture_tick = URB_NONDET_U32();
}

static uint16_t event(urb_i2c_event_t e, uint8_t byte)
{
    URB_COST_BEGIN();
    uint16_t const r = urb_node_i2c_event(&node, e, byte);
    URB_COST_END(FW_COST_BUDGET);
    return r;
}

/* Check bytes of a frame covering the select byte and `size` bytes (the two tiers). */
static uint8_t check_len_of(uint8_t size)
{
    return ((1u + (unsigned)size) <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u;
}

#if URB_PART == 1
/* ----- part 1: a read ----- */

/* link_check over the select byte then URB_SIZE data bytes, as the master computes it: the tier
 * rule and the byte steps (here the stub's, see stubs/fw_node_crc_stub.c). */
static uint32_t reference_check(uint8_t select, const uint8_t *data)
{
    if (check_len_of(URB_SIZE) == 1u) {
        uint8_t crc = urb_crc8_link_check_byte(URB_CRC8_LINK_CHECK_INIT, select);
        for (uint8_t k = 0u; k < URB_SIZE; k++) {
            crc = urb_crc8_link_check_byte(crc, data[k]);
        }
        return urb_crc8_link_check_final(crc);
    }
    uint16_t crc = urb_crc16_link_check_byte(URB_CRC16_LINK_CHECK_INIT, select);
    for (uint8_t k = 0u; k < URB_SIZE; k++) {
        crc = urb_crc16_link_check_byte(crc, data[k]);
    }
    return urb_crc16_link_check_final(crc);
}


static void part_read(void)
{
    uint8_t block[FW_STORAGE];
    URB_NONDET_BYTES(block, sizeof block);
    setup_node(block, FW_IN, URB_SIZE, FW_OUT, URB_SIZE);
    urb_node_outbox_t *ob = &node.outbox[FW_OUT];
    uint8_t const cl = check_len_of(URB_SIZE);
    uint8_t const probe = URB_NONDET_U8();
    URB_ASSUME(probe < FW_STORAGE);
    uint8_t const probe0 = storage[probe];

    URB_ASSERT(event(URB_I2C_ADDR_WRITE, 0u) == URB_I2C_ACK, "address: ACK");
    URB_ASSERT(event(URB_I2C_RX_BYTE, (uint8_t)(0x80u | FW_OUT)) == URB_I2C_ACK, "read select of a set-up outbox: ACK");
    URB_ASSERT(event(URB_I2C_STOP, 0u) == URB_I2C_ACK, "STOP");
    uint8_t const latched = ob->front;
    uint8_t const *const data = &storage[(latched != 0u) ? URB_SIZE : 0u];
    uint8_t sent[URB_SIZE];
    for (uint8_t k = 0u; k < URB_SIZE; k++) {
        sent[k] = data[k];
    }
    uint32_t const want = reference_check((uint8_t)(0x80u | FW_OUT), sent);
    URB_ASSERT(event(URB_I2C_ADDR_READ, 0u) == URB_I2C_ACK, "read address: ACK");
    /* the application publishes the other buffer meanwhile (its lock succeeds: not being read) */
    uint8_t published_at = FW_STORAGE; /* the byte the application changes, if it publishes */
    if (URB_NONDET_BOOL()) {
        uint8_t *w = NULL;
        published_at = (latched != 0u) ? 0u : URB_SIZE;
        URB_ASSERT(urb_lock_outbox_any(&node, FW_OUT, &w) == URB_NODE_OK, "the buffer not being read is free");
        URB_ASSERT(w == &storage[(latched != 0u) ? 0u : URB_SIZE], "the lock hands out the other buffer");
        w[0] = (uint8_t)~sent[0]; /* a new version differs from the one being read */
        URB_ASSERT(urb_release_outbox_any(&node, FW_OUT) == URB_NODE_OK, "release");
    }
    for (uint8_t k = 0u; k < (uint8_t)(URB_SIZE + cl + 1u); k++) {
        uint16_t const r = event(URB_I2C_TX_BYTE, 0u);
        uint8_t expect = 0xFFu;
        if (k < URB_SIZE) {
            expect = sent[k];
        } else if (k < (uint8_t)(URB_SIZE + cl)) {
            expect = (uint8_t)(want >> (8u * (uint8_t)(k - URB_SIZE)));
        }
        URB_ASSERT(r == expect, "read: the latched version, its check, then 0xFF");
    }
    URB_ASSERT(event(URB_I2C_TX_NACK, 0u) == URB_I2C_ACK, "end of the read");
    URB_ASSERT(ob->isr_idx == URB_NONE, "the read is closed");
    if (probe != published_at) {
        URB_ASSERT(storage[probe] == probe0, "a read writes no mailbox or guard byte");
    }
    if (published_at != FW_STORAGE) {
        URB_COVER("part1-read-while-the-application-publishes");
    } else {
        URB_COVER("part1-read-of-an-unchanged-outbox");
    }
}
#endif


#if URB_PART == 2
/* ----- part 2: SYNC ----- */

static void part_sync(void)
{
    uint8_t block[FW_STORAGE];
    URB_NONDET_BYTES(block, sizeof block);
    setup_node(block, FW_IN, URB_SIZE, FW_OUT, URB_SIZE);
    uint8_t const magic = URB_NONDET_U8();
    uint8_t const counter = URB_NONDET_U8();
    URB_ASSERT(event(URB_I2C_GENERAL_CALL, 0u) == URB_I2C_ACK, "general call: ACK");
    uint16_t const r = event(URB_I2C_RX_BYTE, magic);
    URB_ASSERT((r == URB_I2C_ACK) == (magic == URB_SYNC_MAGIC), "SYNC magic: ACK exactly for 0xA5");
    if (magic == URB_SYNC_MAGIC) {
        URB_ASSERT(event(URB_I2C_RX_BYTE, counter) == URB_I2C_ACK, "SYNC counter: ACK");
        URB_ASSERT((pll_calls == 1u) && (pll_t_d == capture_tick) && (pll_counter == counter),
                   "SYNC: one PLL update with the captured tick and the counter");
    }
    URB_ASSERT(event(URB_I2C_RX_BYTE, URB_NONDET_U8()) == URB_I2C_NACK, "a SYNC has two bytes");
    URB_ASSERT(event(URB_I2C_STOP, 0u) == URB_I2C_ACK, "STOP");
    URB_ASSERT(pll_calls == ((magic == URB_SYNC_MAGIC) ? 1u : 0u), "the PLL runs for a SYNC only");
    if (magic == URB_SYNC_MAGIC) {
        URB_COVER("part2-sync-taken");
    } else {
        URB_COVER("part2-other-general-call-refused");
    }
}
#endif

#if URB_PART == 3
/* ----- part 3: one event from an arbitrary valid driver state (induction) ----- */

/* The application outbox of part 3: MB itself, or FW_OUT when the transaction is on mailbox 0
 * (whose sizes are the library's: outbox 0 25 bytes, CRC-16; inbox 0 6 bytes, CRC-8). */
#define FW_OUT3 ((URB_MB == 0u) ? FW_OUT : URB_MB)

static bool in_write(uint8_t st)
{
    return (st == URB_I2C_ST_DATA) || (st == URB_I2C_ST_CHECK) || (st == URB_I2C_ST_DONE);
}

/* The driver invariant: what urb_i2c.c keeps between two events, for mailboxes 0 and MB. */
static bool valid_driver(void)
{
    urb_node_i2c_t const *i2c = &node.i2c;
    uint8_t const st = i2c->state;
    uint8_t const m = i2c->mailbox;
    if ((st > URB_I2C_ST_IGNORE) || (i2c->selected >= URB_NODE_MAILBOXES) || (node.outbox[i2c->selected].size == 0u)) {
        return false;
    }
    if ((i2c->check_ok > 1u) || (i2c->sync_ok > 1u) || (i2c->crc16 > 1u)) {
        return false;
    }
    uint8_t const boxes[3] = {0u, FW_IN, FW_OUT3};
    for (uint8_t j = 0u; j < 3u; j++) {
        uint8_t const n = boxes[j];
        urb_node_inbox_t const *ib = &node.inbox[n];
        urb_node_outbox_t const *ob = &node.outbox[n];
        bool const writing = in_write(st) && (m == n) && ((st != URB_I2C_ST_DATA) || (i2c->count != 0u));
        bool const reading = (st == URB_I2C_ST_READ) && (m == n);
        if ((ib->front > 1u) || (ib->app_idx > URB_NONE) || (ib->fresh[0] > 1u) || (ib->fresh[1] > 1u)) {
            return false;
        }
        if (ib->isr_idx != (writing ? (uint8_t)(1u - ib->front) : URB_NONE)) {
            return false; /* MailboxInbox.tla: the interrupt fills 1 - front, only during a write */
        }
        if (writing && (ib->app_idx == ib->isr_idx)) {
            return false;
        }
        if ((ob->front > 1u) || (ob->held > URB_NONE) || (reading ? (ob->isr_idx > 1u) : (ob->isr_idx != URB_NONE))) {
            return false; /* MailboxOutbox.tla: isr_idx latched only during a read */
        }
    }
    if (in_write(st) || (st == URB_I2C_ST_READ)) {
        if ((m != 0u) && (m != ((st == URB_I2C_ST_READ) ? FW_OUT3 : FW_IN))) {
            return false;
        }
        uint8_t const size = (st == URB_I2C_ST_READ) ? node.outbox[m].size : node.inbox[m].size;
        uint8_t const cl = check_len_of(size);
        if ((size == 0u) || (i2c->crc16 != (uint8_t)(cl - 1u))) {
            return false;
        }
        uint8_t const c = i2c->count;
        if (((st == URB_I2C_ST_DATA) && (c >= size)) || ((st == URB_I2C_ST_CHECK) && ((c < size) || (c >= size + cl))) ||
            ((st == URB_I2C_ST_DONE) && (c != size + cl)) || ((st == URB_I2C_ST_READ) && (c > size + cl))) {
            return false;
        }
    }
    return true;
}

/* The write path, one received byte at a time (with the step's other properties, by induction
 * over the bytes of a write): the select starts the check over itself with count 0; data byte k
 * extends the check and lands at offset k of the back buffer (above); each check byte is compared
 * with the finished check of exactly those bytes; the write reaches DONE (the only state a clean
 * end publishes from) only if every check byte matched; a bad check is NACKed on its last byte
 * with a CHECKSUM fault, data[0] is NACKed with an OVERRUN fault when the application holds the
 * back buffer, and a byte after size + check is NACKed and aborts the write. */
static void write_step(uint8_t st0, uint8_t count0, uint16_t check0, uint8_t check_ok0, uint8_t crc16_0, uint8_t app0,
                       uint8_t overrun0, uint8_t checksum0, uint8_t byte, uint16_t r)
{
    urb_node_i2c_t const *i2c = &node.i2c;
    urb_node_inbox_t const *ib = &node.inbox[URB_MB];
    uint8_t const overrun = node.isr_faults[URB_NODE_FAULT_OVERRUN - 1u];
    uint8_t const checksum = node.isr_faults[URB_NODE_FAULT_CHECKSUM - 1u];
    if (st0 == URB_I2C_ST_SELECT) {
        uint8_t const n = (uint8_t)(byte & 0x07u);
        bool const read = (byte & 0x80u) != 0u;
        bool const ok = ((byte & 0x78u) == 0u) && ((read ? node.outbox[n].size : node.inbox[n].size) != 0u);
        URB_ASSERT((r == URB_I2C_ACK) == ok, "select: ACK exactly a set-up mailbox with reserved bits zero");
        if (ok && !read) {
            bool const tier16 = check_len_of(node.inbox[n].size) == 2u;
            uint16_t const start = tier16 ? urb_crc16_link_check_byte(URB_CRC16_LINK_CHECK_INIT, byte)
                                          : urb_crc8_link_check_byte(URB_CRC8_LINK_CHECK_INIT, byte);
            URB_ASSERT((i2c->state == URB_I2C_ST_DATA) && (i2c->mailbox == n) && (i2c->count == 0u) &&
                           (i2c->check_ok == 1u) && (i2c->crc == start),
                       "write select: data of inbox n next, the check started over the select byte");
        }
        if (ok && read) {
            URB_ASSERT((i2c->state == URB_I2C_ST_SELECTED) && (i2c->selected == n), "read select: outbox n selected");
        }
        if (ok && !read) {
            URB_COVER("part3-write-select-taken");
        }
    }
    uint8_t const size = ib->size;
    uint8_t const back = (uint8_t)(1u - ib->front);
    if (st0 == URB_I2C_ST_DATA) {
        bool const refused = (count0 == 0u) && (app0 == back);
        URB_ASSERT((r == URB_I2C_NACK) == refused, "data: NACK exactly when the application holds the back buffer");
        URB_ASSERT(overrun == (uint8_t)(overrun0 + (refused ? 1u : 0u)), "data: OVERRUN exactly for a refused write");
        if (refused) {
            URB_COVER("part3-write-refused-overrun");
        } else {
            URB_COVER("part3-data-byte-taken");
        }
        if (!refused) {
            uint16_t const next = (crc16_0 != 0u) ? urb_crc16_link_check_byte(check0, byte)
                                                  : urb_crc8_link_check_byte((uint8_t)check0, byte);
            URB_ASSERT((i2c->count == (uint8_t)(count0 + 1u)) && (i2c->crc == next) &&
                           (i2c->state == ((i2c->count == size) ? URB_I2C_ST_CHECK : URB_I2C_ST_DATA)),
                       "data: counted and checked, the check follows the last data byte");
        }
    }
    if (st0 == URB_I2C_ST_CHECK) {
        uint8_t const k = (uint8_t)(count0 - size);
        uint8_t expect = urb_crc8_link_check_final((uint8_t)check0);
        if (crc16_0 != 0u) {
            uint16_t const fin = urb_crc16_link_check_final(check0);
            expect = (uint8_t)((k == 0u) ? fin : (fin >> 8));
        }
        bool const matched = (check_ok0 != 0u) && (byte == expect);
        bool const last = (uint8_t)(k + 1u) == (uint8_t)(1u + crc16_0);
        URB_ASSERT(i2c->crc == check0, "check: the data's check is kept");
        if (!last) {
            URB_ASSERT((r == URB_I2C_ACK) && (i2c->state == URB_I2C_ST_CHECK) && (i2c->check_ok == (matched ? 1u : 0u)),
                       "check: the first of two check bytes is ACKed and remembered");
        } else {
            URB_ASSERT((r == URB_I2C_ACK) == matched, "check: the last check byte is NACKed exactly when a check byte differed");
            URB_ASSERT((i2c->state == URB_I2C_ST_DONE) == matched, "check: DONE (commit at STOP) only for a good check");
            URB_ASSERT(checksum == (uint8_t)(checksum0 + (matched ? 0u : 1u)), "check: CHECKSUM exactly for a bad check");
            if (matched) {
                URB_COVER("part3-last-check-byte-good");
            } else {
                URB_COVER("part3-last-check-byte-bad");
            }
        }
    }
    if (st0 == URB_I2C_ST_DONE) {
        URB_ASSERT((r == URB_I2C_NACK) && (i2c->state == URB_I2C_ST_IGNORE),
                   "a byte after size + check is NACKed and aborts the write");
        URB_COVER("part3-byte-after-done-aborts");
    }
}

static void part_step(void)
{
    uint8_t block[FW_STORAGE];
    URB_NONDET_BYTES(block, sizeof block);
    uint8_t const si = URB_NONDET_U8();
    uint8_t const so = URB_NONDET_U8();
    URB_ASSUME((si >= 1u) && (si <= URB_NODE_MAX_SIZE) && (so >= 1u) && (so <= URB_NODE_MAX_SIZE));
    setup_node(block, FW_IN, si, FW_OUT3, so);
    /* an arbitrary driver state, constrained to the invariant below */
    urb_node_i2c_t *i2c = &node.i2c;
    i2c->state = URB_NONDET_U8();
    i2c->mailbox = URB_MB;
    i2c->selected = URB_NONDET_BOOL() ? FW_OUT3 : 0u;
    i2c->count = URB_NONDET_U8();
    i2c->crc = URB_NONDET_U16();
    i2c->check_ok = URB_NONDET_U8();
    i2c->crc16 = URB_NONDET_U8();
    i2c->sync_ok = URB_NONDET_U8();
    i2c->sync_t = URB_NONDET_U32();
    node.inbox[URB_MB].isr_idx = URB_NONDET_U8();
    node.inbox[URB_MB].front = URB_NONDET_U8();
    node.inbox[URB_MB].app_idx = URB_NONDET_U8();
    node.inbox[URB_MB].fresh[0] = URB_NONDET_U8();
    node.inbox[URB_MB].fresh[1] = URB_NONDET_U8();
    node.outbox[URB_MB].isr_idx = URB_NONDET_U8();
    node.outbox[URB_MB].front = URB_NONDET_U8();
    node.outbox[URB_MB].held = URB_NONDET_U8();
    URB_ASSUME(valid_driver());

    urb_node_inbox_t const *ib = &node.inbox[URB_MB];
    uint8_t const st0 = i2c->state;
    uint8_t const count0 = i2c->count;
    uint16_t const check0 = i2c->crc;
    uint8_t const check_ok0 = i2c->check_ok;
    uint8_t const crc16_0 = i2c->crc16;
    uint8_t const app0 = ib->app_idx;
    uint8_t const overrun0 = node.isr_faults[URB_NODE_FAULT_OVERRUN - 1u];
    uint8_t const checksum0 = node.isr_faults[URB_NODE_FAULT_CHECKSUM - 1u];
    uint8_t const in_front0 = ib->front;
    uint8_t const out_front0 = node.outbox[URB_MB].front;
    uint8_t const out0_front0 = node.outbox[0].front;
    uint8_t const in0_front0 = node.inbox[0].front;
    uint8_t const back = (uint8_t)(1u - in_front0);
    uint8_t *const buf = (URB_MB == 0u) ? node.mb0 : storage;
    uint16_t const size_in = ib->size;
    uint16_t const base = (uint16_t)(ib->offset + ((back != 0u) ? size_in : 0u)); /* back buffer of inbox MB */
    uint16_t const buf_len = (URB_MB == 0u) ? (uint16_t)sizeof node.mb0 : (uint16_t)FW_STORAGE;
    uint16_t const probe = URB_NONDET_U16();
    URB_ASSUME(probe < buf_len);
    uint8_t const probe0 = buf[probe];

    uint8_t const e = URB_NONDET_U8();
    URB_ASSUME(e <= (uint8_t)URB_I2C_EV_ERROR); /* slave events, and master ones the slave must refuse */
    uint8_t const byte = URB_NONDET_U8();
    uint16_t const r = event((urb_i2c_event_t)e, byte);

    URB_ASSERT(valid_driver(), "step: the driver invariant holds after any event");
    if (e == (uint8_t)URB_I2C_TX_BYTE) {
        URB_ASSERT(r <= 0xFFu, "step: a transmitted byte is a byte");
    } else {
        URB_ASSERT((r == URB_I2C_ACK) || (r == URB_I2C_NACK), "step: ACK or NACK");
    }
    bool const stored = (st0 == URB_I2C_ST_DATA) && (e == (uint8_t)URB_I2C_RX_BYTE);
    if (stored && (probe == (uint16_t)(base + count0))) {
        URB_ASSERT((buf[probe] == probe0) || (buf[probe] == byte), "step: a data byte is stored at its offset");
    } else {
        URB_ASSERT(buf[probe] == probe0, "step: no other mailbox byte changes");
    }
    bool const clean_end = (e == (uint8_t)URB_I2C_ADDR_WRITE) || (e == (uint8_t)URB_I2C_ADDR_READ) ||
                           (e == (uint8_t)URB_I2C_GENERAL_CALL) || (e == (uint8_t)URB_I2C_STOP);
    bool const publish = (st0 == URB_I2C_ST_DONE) && clean_end;
    URB_ASSERT(ib->front == (publish ? back : in_front0), "step: an inbox front moves only at the clean end of a checked write");
    if (publish) {
        URB_ASSERT(ib->fresh[back] == 1u, "step: a published write is new");
        URB_COVER("part3-write-published");
    }
    if ((st0 == URB_I2C_ST_READ) && (e == (uint8_t)URB_I2C_TX_BYTE)) {
        URB_COVER("part3-read-sends-a-byte");
    }
    if ((st0 == URB_I2C_ST_READ) && (e == (uint8_t)URB_I2C_RX_BYTE)) {
        URB_COVER("part3-byte-received-during-a-read");
    }
    URB_ASSERT((node.outbox[URB_MB].front == out_front0) && (node.outbox[0].front == out0_front0),
               "step: outbox fronts are the application's");
    if (URB_MB != 0u) {
        URB_ASSERT(node.inbox[0].front == in0_front0, "step: inbox 0 is not written");
    }
    if (e == (uint8_t)URB_I2C_RX_BYTE) {
        write_step(st0, count0, check0, check_ok0, crc16_0, app0, overrun0, checksum0, byte, r);
    }
}
#endif

void harness(void)
{
#if URB_PART == 1
    part_read();
#elif URB_PART == 2
    part_sync();
#else
    part_step();
#endif
}
