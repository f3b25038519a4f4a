/*
 * Proof of the I2C downlink master (firmware/bridge/i2c_master.c), by lemmas over single steps
 * from an arbitrary state of a transaction (one sweep part each), instead of long event sequences.
 *
 * State invariant (what begin() sets up and no step breaks): the transaction's fields (op, address,
 * mailbox, length, hdr, n_hdr, n_data, n_tail, n_rx, read_after, t0) are those begin() computed for
 * some request; the phase and position are consistent with them:
 *   START pos 0 | TX pos < n_hdr + n_data + n_tail | RSTART read_after | ADDR_R READ |
 *   RX READ, pos < n_rx | FINISH result | FAULT | CLEAR clear_step <= 21 | IDLE.
 * The harness reaches such a state by calling begin() on an arbitrary request (any op, address,
 * mailbox, length 1..FW_LEN_MAX, reselect, cached selection, start time, line levels) and then
 * choosing the phase, position and pending fields arbitrarily within the invariant.
 *
 * Lemmas (URB_PART):
 *   1 begin   an idle master on free lines accepts any request but CLEAR, refuses a second one,
 *             and issues exactly one START; the planned bytes are the request's: address, select
 *             or SYNC bytes, data, the check over select + data; a read selects only when needed
 *   2 event   any HAL event (START, ACK, NACK, BYTE with any value, ERROR) in any phase: at most one
 *             bus operation issued, exactly one when the master then waits for an event (one
 *             operation at a time), a STOP when the bus part ends; a NACK gets the status
 *             urb_downlink.h names for the byte it refused; a written byte is the next planned one;
 *             a read byte lands in data or check; ERROR or an unexpected event: FAULT; a late event
 *             (idle, finished, faulted, clearing) changes nothing
 *   3 poll    free lines, any poll time, any phase but CLEAR: a waiting transaction is aborted and
 *             gives TIMEOUT exactly when more than timeout_us have passed since begin(); FINISH
 *             gives the outcome (a read: OK exactly when its check matches; the selection cache
 *             keeps a good read's mailbox and forgets it on any failure); FAULT gives TIMEOUT
 *   4 clear   one bus-clear step (clear_step(), what poll() runs in PH_CLEAR) at any step, any
 *             time, any line levels, for a stuck bus or a CLEAR request: the next half clock of
 *             nine SCL pulses and a STOP, the outcome (BUS_STUCK, or for CLEAR OK exactly when the
 *             lines are free) only after the 21st step
 * NOT covered yet: the entry into the bus clear (begin() of a CLEAR or on a line held low, a fault
 * or timeout with a line low): it runs forget_all's 128 stores, and every such run (Boolector and
 * Bitwuzla) ran out of memory or time within 240 s. tests/firmware covers those paths.
 * Termination (from 2, 3 and 4, and the uncovered clear entry): events never leave FINISH, FAULT or CLEAR and move a waiting phase
 * only to a waiting phase, FINISH or FAULT; the first poll after timeout_us leaves every waiting
 * phase; FINISH and FAULT end at the next poll or start the clear; each clear step takes one poll
 * at least clear_half_us apart and the outcome comes at step 21. So the outcome comes within
 * timeout_us + 22 x clear_half_us of begin() (plus the main loop's poll period), exactly once.
 * Cost: every event (interrupt) within FW_I2C_EVENT_BUDGET (half an I2C byte time); begin() and
 * every poll (main loop, the check over up to 33 bytes) within FW_BRIDGE_MASTER_CALL_BUDGET (two
 * byte times of idle bus: begin() runs before the START, the final poll after the STOP).
 */
#include "urb_verify.h"

/* The prepared (cost-instrumented, maybe mutated) i2c_master.c, to reach its static steps. */
#include "i2c_master.c"

#include "../stubs/fw_budgets.h"
#include "fw_bridge_check.h"

/* The recorded worst case (COST) is a main-loop call's (begin or poll); events have their own,
 * smaller budget, asserted in lemma 2. */
#define FW_COST_BUDGET FW_BRIDGE_MASTER_CALL_BUDGET

#ifndef FW_LEN_MAX
#define FW_LEN_MAX 32u /* longest payload (the master has no loop over it: all lengths are cheap) */
#endif
#define FW_TIMEOUT_US 2000u
#define FW_CLEAR_HALF_US 5u
#define FW_CLEAR_STEPS 21u


URB_PROOF_COST_STORAGE;

static urb_i2c_master_t master;
static urb_downlink_t dl;
static uint8_t data[32];

/* HAL record. */
static uint8_t ops;          /* start, write, read and stop calls */
static uint8_t last_op;      /* 1 start, 2 write, 3 read, 4 stop */
static uint8_t last_byte;    /* the byte of the last write */
static bool aborted;
static uint8_t drives;
static uint8_t last_drive;
static bool released;
static uint8_t last_lines;

static void hal_start(void *ctx)
{
    URB_ASSERT(ctx == &master, "HAL: its context");
    ops++;
    last_op = 1u;
}

static void hal_write(void *ctx, uint8_t byte)
{
    (void)ctx;
    ops++;
    last_op = 2u;
    last_byte = byte;
}

static void hal_read(void *ctx, bool ack)
{
    (void)ctx;
    (void)ack;
    ops++;
    last_op = 3u;
}

static void hal_stop(void *ctx)
{
    (void)ctx;
    ops++;
    last_op = 4u;
}

static void hal_abort(void *ctx)
{
    (void)ctx;
    aborted = true;
}

/* Free lines, or (lines_any: lemma 4) any level at any call. */
static bool lines_any;

static uint8_t hal_lines(void *ctx)
{
    (void)ctx;
    last_lines = lines_any ? (uint8_t)(URB_NONDET_U8() & (URB_I2C_SCL | URB_I2C_SDA)) : (uint8_t)(URB_I2C_SCL | URB_I2C_SDA);
    return last_lines;
}

static void hal_drive(void *ctx, uint8_t lines)
{
    (void)ctx;
    drives++;
    last_drive = lines;
}

static void hal_release(void *ctx)
{
    (void)ctx;
    released = true;
}

static const urb_i2c_hal_t hal = {&master, hal_start, hal_write, hal_read, hal_stop, hal_abort,
                                  hal_lines, hal_drive, hal_release};

static urb_downlink_txn_t t;
static uint8_t sel_before;
static uint32_t t0;

static uint8_t check_size(uint8_t len)
{
    return ((1u + (uint32_t)len) <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u;
}

static void reset_record(void)
{
    ops = 0u;
    last_op = 0u;
    aborted = false;
    drives = 0u;
    released = false;
}

/* An idle master with the default configuration and any cached selection for the request's node
 * (urb_i2c_master_init's 128-address loop is forget_all, which the bus clear runs). */
static void idle_master(void)
{
    master.hal = &hal;
    master.cfg.bitrate_kbps = 400u;
    master.cfg.timeout_us = FW_TIMEOUT_US;
    master.cfg.clear_half_us = FW_CLEAR_HALF_US;
    master.phase = PH_IDLE;
    urb_i2c_master_downlink(&master, &dl);
    t.op = URB_NONDET_U8();
    URB_ASSUME(t.op <= (uint8_t)URB_DL_PROBE);
    t.address = URB_NONDET_U8();
    URB_ASSUME((t.address >= URB_I2C_FIRST_ADDRESS) && (t.address <= URB_I2C_LAST_ADDRESS));
    t.mailbox = URB_NONDET_U8();
    URB_ASSUME(t.mailbox < 8u);
    t.length = URB_NONDET_U8();
    URB_ASSUME((t.length >= 1u) && (t.length <= FW_LEN_MAX));
    t.counter = URB_NONDET_U8();
    t.reselect = URB_NONDET_BOOL();
    t.data = data;
    sel_before = URB_NONDET_U8();
    URB_ASSUME((sel_before < 8u) || (sel_before == URB_I2C_NO_SELECTION));
    master.sel[t.address] = sel_before;
    t0 = URB_NONDET_U32(); /* any start time: the clock may wrap */
}

/* The byte the master must write at position `pos` of a WRITE (address, select, data, check). */
static uint8_t planned_write_byte(uint8_t pos)
{
    if (pos == 0u) {
        return (uint8_t)(t.address << 1);
    }
    if (pos == 1u) {
        return t.mailbox;
    }
    if (pos < (uint8_t)(2u + t.length)) {
        return data[pos - 2u];
    }
    return (uint8_t)(fw_bridge_check_last >> (8u * (uint32_t)((pos - 2u - t.length) & 1u)));
}

#if URB_PART == 1
static void lemma_begin(void)
{
    idle_master();
    URB_ASSUME(t.op != (uint8_t)URB_DL_CLEAR);
    reset_record();
    fw_bridge_check_last = 0u;
    URB_COST_BEGIN();
    bool const ok = dl.begin(dl.ctx, &t, t0);
    URB_COST_END(FW_COST_BUDGET); /* begin(): FW_BRIDGE_MASTER_CALL_BUDGET */
    URB_ASSERT(ok, "begin: an idle master starts the request");
    uint8_t const ops_first = ops;
    URB_ASSERT(!dl.begin(dl.ctx, &t, t0), "begin: refused while a request runs");
    URB_ASSERT(ops == ops_first, "begin: a refused request issues nothing");
    if (master.phase == PH_CLEAR) {
        URB_ASSERT((t.op == (uint8_t)URB_DL_CLEAR) || ((last_lines & 3u) != 3u),
                   "begin: the bus clear only for CLEAR or a line held low");
        URB_ASSERT((ops == 0u) && (master.clear_step == 0u), "begin: the clear starts at its first step, no bus operation");
        uint8_t const a = URB_NONDET_U8();
        URB_ASSUME(a < 128u);
        URB_ASSERT(master.sel[a] == URB_I2C_NO_SELECTION, "a bus clear forgets every cached selection");
        return;
    }
    URB_ASSERT((t.op != (uint8_t)URB_DL_CLEAR) && ((last_lines & 3u) == 3u), "begin: a request starts on free lines");
    URB_ASSERT((master.phase == PH_START) && (ops == 1u) && (last_op == 1u) && (master.pos == 0u),
               "begin: exactly one START, then wait for it");
    URB_ASSERT(master.t0 == t0, "begin: the timeout counts from begin()");
    if (t.op == (uint8_t)URB_DL_WRITE) {
        URB_ASSERT((master.n_hdr == 2u) && (master.n_data == t.length) && (master.n_tail == check_size(t.length)) &&
                   !master.read_after, "write: address, select, data, check");
        uint8_t const k = URB_NONDET_U8();
        URB_ASSUME(k < (uint8_t)(2u + t.length + master.n_tail));
        uint8_t const want = planned_write_byte(k);
        uint8_t got;
        if (k < 2u) {
            got = master.hdr[k];
        } else if (k < (uint8_t)(2u + t.length)) {
            got = master.data[k - 2u];
        } else {
            got = master.tail[(k - 2u - t.length) & 1u];
        }
        URB_ASSERT(got == want, "write: the planned bytes are the request's, the check over select + data");
    } else if (t.op == (uint8_t)URB_DL_READ) {
        bool const select = t.reselect || (sel_before != t.mailbox);
        URB_ASSERT(master.read_after == select, "read: the select only when needed (reselect, or another cached)");
        URB_ASSERT(master.n_hdr == (select ? 2u : 0u), "read: address and select, or nothing before the read address");
        if (select) {
            URB_ASSERT((master.hdr[0] == (uint8_t)(t.address << 1)) && (master.hdr[1] == (uint8_t)(t.mailbox | 0x80u)),
                       "read: a DownlinkReadSelect of the outbox");
        }
        URB_ASSERT(master.n_rx == (uint8_t)(t.length + check_size(t.length)), "read: data and check");
    } else if (t.op == (uint8_t)URB_DL_PROBE) {
        URB_ASSERT((master.n_hdr == 1u) && (master.hdr[0] == (uint8_t)(t.address << 1)) && (master.n_rx == 0u),
                   "probe: the address alone");
    } else {
        URB_ASSERT((master.n_hdr == 3u) && (master.hdr[0] == 0u) && (master.hdr[1] == (uint8_t)URB_SYNC_MAGIC) &&
                   (master.hdr[2] == t.counter), "sync: general call, magic, counter");
    }
}
#endif

/* Lemmas 2 to 5: a transaction begun on free lines, then any phase of it (the clear phases are
 * set up by lemmas 4 and 5 themselves). */
static void arbitrary_transaction(void)
{
    idle_master();
    URB_ASSUME(t.op != (uint8_t)URB_DL_CLEAR);
    bool const ok = dl.begin(dl.ctx, &t, t0);
    URB_ASSUME(ok);
    uint8_t const ph = URB_NONDET_U8();
    uint8_t const pos = URB_NONDET_U8();
    uint8_t const total = (uint8_t)(master.n_hdr + master.n_data + master.n_tail);
    bool const read = t.op == (uint8_t)URB_DL_READ;
    URB_ASSUME((ph == PH_START) || ((ph == PH_TX) && (pos < total)) || ((ph == PH_RSTART) && master.read_after) ||
               ((ph == PH_ADDR_R) && read) || ((ph == PH_RX) && read && (pos < master.n_rx)) || (ph == PH_FINISH) ||
               (ph == PH_FAULT) || (ph == PH_IDLE));
    URB_ASSUME((ph != PH_START) || (pos == 0u));
    master.phase = ph;
    master.pos = pos;
    if (ph == PH_FINISH) {
        master.result = URB_NONDET_U8();
        URB_ASSUME(master.result <= (uint8_t)URB_STATUS_NODE_BUSY);
    }
    master.rx_check[0] = URB_NONDET_U8();
    master.rx_check[1] = URB_NONDET_U8();
}

#if URB_PART == 2
static void lemma_event(void)
{
    arbitrary_transaction();
    uint8_t const ph = master.phase;
    uint8_t const pos = master.pos;
    uint8_t const ev = URB_NONDET_U8();
    URB_ASSUME(ev <= (uint8_t)URB_I2C_EV_ERROR);
    uint8_t const byte = URB_NONDET_U8();
    uint8_t const data_k = URB_NONDET_U8();
    URB_ASSUME(data_k < 32u);
    uint8_t const data_before = data[data_k];
    reset_record();
    URB_COST_BEGIN();
    urb_i2c_master_event(&master, (urb_i2c_event_t)ev, byte);
    URB_ASSERT(urb_proof_cost <= FW_I2C_EVENT_BUDGET, "cost: an event within half an I2C byte time");
    URB_COST_END(FW_COST_BUDGET);
    uint8_t const now_ph = master.phase;
    URB_ASSERT(ops <= 1u, "one bus operation at a time: at most one per event");
    URB_ASSERT(!aborted && (drives == 0u), "an event never aborts or bit-bangs");
    if ((ph == PH_IDLE) || (ph >= PH_FINISH)) {
        URB_ASSERT((ops == 0u) && (now_ph == ph), "a late event starts nothing and changes nothing");
        return;
    }
    URB_ASSERT(now_ph <= PH_FAULT, "an event never starts a bus clear (poll() does)");
    if ((now_ph >= PH_START) && (now_ph <= PH_RX)) {
        URB_ASSERT((ops == 1u) && (last_op != 4u), "waiting again: exactly the one operation it waits for");
    } else if (now_ph == PH_FINISH) {
        URB_ASSERT((ops == 1u) && (last_op == 4u), "the bus part ends with a STOP");
    } else {
        URB_ASSERT(ops == 0u, "a fault issues nothing (poll() handles it)");
    }
    if (ev == (uint8_t)URB_I2C_EV_ERROR) {
        URB_ASSERT(now_ph == PH_FAULT, "ERROR: the transaction faults");
        return;
    }
    bool const expected = ((ph == PH_START || ph == PH_RSTART) && (ev == URB_I2C_EV_START)) ||
                          ((ph == PH_TX || ph == PH_ADDR_R) && ((ev == URB_I2C_EV_ACK) || (ev == URB_I2C_EV_NACK))) ||
                          ((ph == PH_RX) && (ev == URB_I2C_EV_BYTE));
    if (!expected) {
        URB_ASSERT(now_ph == PH_FAULT, "an event the phase does not expect: the transaction faults");
        return;
    }
    if ((ph == PH_TX) && (ev == URB_I2C_EV_NACK)) {
        uint8_t want = URB_STATUS_CHECKSUM;
        if (t.op == (uint8_t)URB_DL_SYNC) {
            want = URB_STATUS_OK;
        } else if (pos == 0u) {
            want = URB_STATUS_NO_NODE;
        } else if (pos == 1u) {
            want = URB_STATUS_BAD_REQUEST;
        } else if (pos == 2u) {
            want = URB_STATUS_NODE_BUSY;
        } else if (pos < (uint8_t)(2u + t.length)) {
            want = URB_STATUS_SIZE_MISMATCH;
        } else {
            /* a check byte */
        }
        /* (a READ's header and a PROBE have at most 2 bytes, a SYNC's NACK is nobody's error) */
        URB_ASSERT((now_ph == PH_FINISH) && (master.result == want), "error flags: a NACK gets the status the contract names");
        return;
    }
    if ((ph == PH_ADDR_R) && (ev == URB_I2C_EV_NACK)) {
        URB_ASSERT((now_ph == PH_FINISH) && (master.result == URB_STATUS_NO_NODE), "error flags: a read address NACKed is NO_NODE");
        return;
    }
    if ((ph == PH_TX) && (now_ph == PH_TX)) {
        URB_ASSERT(master.pos == (uint8_t)(pos + 1u), "write: the next byte");
        if (t.op == (uint8_t)URB_DL_WRITE) {
            URB_ASSERT(last_byte == planned_write_byte(master.pos), "bytes: address, select, data, check as planned");
        }
    }
    if (ph == PH_RX) {
        if (pos < t.length) {
            URB_ASSERT(data[pos] == byte, "read: a data byte lands in the request's buffer");
        } else {
            URB_ASSERT(master.rx_check[(pos - t.length) & 1u] == byte, "read: a check byte is kept for poll()");
            URB_ASSERT(data[data_k] == data_before, "read: a check byte writes no data");
        }
        URB_ASSERT((now_ph == PH_FINISH) == ((uint8_t)(pos + 1u) >= master.n_rx), "read: the last byte ends the bus part");
    }
    if ((ph != PH_RX) && (data_k < 32u)) {
        URB_ASSERT(data[data_k] == data_before, "only a read byte writes the request's buffer");
    }
    if ((now_ph == PH_FINISH) && (ph != PH_RX)) {
        URB_ASSERT(master.result == URB_STATUS_OK, "a bus part acknowledged throughout is OK");
    }
}
#endif

#if (URB_PART == 3) || (URB_PART == 4)
static void lemma_poll(void)
{
    arbitrary_transaction();
#if URB_PART == 3
    URB_ASSUME(master.phase != PH_CLEAR); /* free lines: a fault or timeout ends in TIMEOUT */
#elif URB_PART == 4
    /* a bus clear at any step, of a stuck bus or of a CLEAR request, any line levels */
    master.phase = PH_CLEAR;
    master.clear_for = URB_NONDET_BOOL() ? (uint8_t)URB_STATUS_BUS_STUCK : 0xFEu;
    master.clear_step = URB_NONDET_U8();
    URB_ASSUME(master.clear_step <= FW_CLEAR_STEPS);
    master.t_step = URB_NONDET_U32();
    lines_any = true;
#endif
    uint8_t const ph = master.phase;
    uint8_t const k = master.clear_step;
    uint8_t const clear_for = master.clear_for;
    uint8_t const result = master.result;
    uint32_t const t_step = master.t_step;
    uint32_t const now = URB_NONDET_U32();
    reset_record();
    fw_bridge_check_last = URB_NONDET_U32();
    URB_COST_BEGIN();
#if URB_PART == 3
    int8_t const r = dl.poll(dl.ctx, now);
#else
    int8_t const r = clear_step(&master, now); /* what poll() runs in PH_CLEAR */
#endif
    URB_COST_END(FW_COST_BUDGET); /* poll(): FW_BRIDGE_MASTER_CALL_BUDGET */
    uint8_t const now_ph = master.phase;
    URB_ASSERT(ops == 0u, "poll() issues no bus operation (the controller is stopped or waiting)");
    URB_ASSERT((r >= 0) == ((now_ph == PH_IDLE) && (ph != PH_IDLE)), "an outcome exactly when the master goes idle");
    if (ph == PH_IDLE) {
        URB_ASSERT(r == URB_DOWNLINK_IDLE, "idle: nothing to report");
        return;
    }
    uint8_t const a = t.address;
    bool const timed_out = (uint32_t)(now - t0) > FW_TIMEOUT_US;
    if ((ph >= PH_START) && (ph <= PH_RX)) {
        URB_ASSERT(aborted == timed_out, "timeout: a waiting transaction is aborted exactly after timeout_us");
        if (!timed_out) {
            URB_ASSERT((r == URB_DOWNLINK_BUSY) && (now_ph == ph), "before the timeout: still waiting");
            return;
        }
    }
    if (((ph >= PH_START) && (ph <= PH_RX)) || (ph == PH_FAULT)) {
        if (t.op != (uint8_t)URB_DL_SYNC) {
            URB_ASSERT(master.sel[a] == URB_I2C_NO_SELECTION, "a fault forgets the node's selection");
        }
        if ((last_lines & 3u) != 3u) {
            URB_ASSERT((r == URB_DOWNLINK_BUSY) && (now_ph == PH_CLEAR) && (master.clear_step == 0u) &&
                       (master.clear_for == URB_STATUS_BUS_STUCK), "a line low after a fault: the bus clear starts");
        } else {
            URB_ASSERT((r == (int8_t)URB_STATUS_TIMEOUT) && released, "free lines after a fault: TIMEOUT");
        }
        return;
    }
    if (ph == PH_FINISH) {
        URB_ASSERT(r >= 0, "FINISH: the outcome");
        uint8_t const st = (uint8_t)r;
        if (t.op == (uint8_t)URB_DL_READ) {
            if (result == URB_STATUS_OK) {
                uint32_t got = master.rx_check[0];
                if (check_size(t.length) == 2u) {
                    got |= (uint32_t)master.rx_check[1] << 8;
                }
                URB_ASSERT((st == URB_STATUS_OK) == (got == fw_bridge_check_last),
                           "a read received in full: OK exactly when its check matches, else CHECKSUM");
                URB_ASSERT((st == URB_STATUS_OK) || (st == URB_STATUS_CHECKSUM), "a read: OK or CHECKSUM");
            } else {
                URB_ASSERT(st == result, "a read refused on the bus keeps its status");
            }
            URB_ASSERT(master.sel[a] == ((st == URB_STATUS_OK) ? t.mailbox : URB_I2C_NO_SELECTION),
                       "selection cache: a good read caches its mailbox, a failed one forgets it");
        } else if (t.op == (uint8_t)URB_DL_SYNC) {
            URB_ASSERT(st == URB_STATUS_OK, "SYNC: nobody's NACK is an error");
        } else {
            URB_ASSERT(st == result, "the bus part's status");
            if ((t.op == (uint8_t)URB_DL_WRITE) && ((st == URB_STATUS_NO_NODE) || (st == URB_STATUS_BAD_REQUEST))) {
                URB_ASSERT(master.sel[a] == URB_I2C_NO_SELECTION, "a write the node may have missed forgets its selection");
            }
        }
        return;
    }
    /* PH_CLEAR: one half clock per poll, nine pulses, a STOP, then the outcome */
    URB_ASSERT(!aborted, "a bus clear aborts nothing");
    if ((k > 0u) && ((uint32_t)(now - t_step) < FW_CLEAR_HALF_US)) {
        URB_ASSERT((r == URB_DOWNLINK_BUSY) && (master.clear_step == k) && (drives == 0u), "the half clock has not passed");
        return;
    }
    if (k < FW_CLEAR_STEPS) {
        URB_ASSERT((r == URB_DOWNLINK_BUSY) && (master.clear_step == (uint8_t)(k + 1u)) && (drives == 1u) &&
                   (master.t_step == now), "clear: one step per half clock, the outcome only after the last");
        uint8_t const want = (k < 18u) ? (((k & 1u) != 0u) ? 3u : (uint8_t)URB_I2C_SDA)
                                       : ((k == 18u) ? 0u : ((k == 19u) ? (uint8_t)URB_I2C_SCL : 3u));
        URB_ASSERT(last_drive == want, "clear: nine SCL pulses with SDA released, then a STOP");
        return;
    }
    URB_ASSERT(released && (drives == 0u), "clear: the lines go back to the controller");
    if ((clear_for == 0xFEu) && ((last_lines & 3u) == 3u)) {
        URB_ASSERT(r == (int8_t)URB_STATUS_OK, "CLEAR: OK when the lines are free after");
    } else {
        URB_ASSERT(r == (int8_t)URB_STATUS_BUS_STUCK, "BUS_STUCK after the full clear of a stuck bus or lines still low");
    }
}
#endif

void harness(void)
{
#if URB_PART == 1
    lemma_begin();
#elif URB_PART == 2
    lemma_event();
#elif (URB_PART == 3) || (URB_PART == 4)
    lemma_poll();
#else
#error "set URB_PART (the Makefile's SWEEP)"
#endif
}
