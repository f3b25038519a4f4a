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
 *   1 begin   an idle master accepts any request and refuses a second one; on free lines a request
 *             but CLEAR issues exactly one START and keeps the cached selection; the planned bytes
 *             are the request's: address, select or SYNC bytes, data, the check over select + data;
 *             a read selects only when needed. CLEAR, or any request with a line held low, enters
 *             the bus clear instead: no bus operation, step 0 timed from begin(), BUS_STUCK (or the
 *             lines' verdict for CLEAR) to report, counted, every cached selection forgotten
 *   2 event   any HAL event (START, ACK, NACK, BYTE with any value, ERROR) in any phase: at most one
 *             bus operation issued, exactly one when the master then waits for an event (one
 *             operation at a time), a STOP when the bus part ends; a NACK gets the status
 *             urb_downlink.h names for the byte it refused; a written byte is the next planned one;
 *             a read byte lands in data or check; ERROR or an unexpected event: FAULT; a late event
 *             (idle, finished, faulted, clearing) changes nothing
 *   3 poll    any line levels, any poll time, any phase but CLEAR: a waiting transaction is aborted
 *             (and counted) exactly when more than timeout_us have passed since begin(); FINISH
 *             gives the outcome (a read: OK exactly when its check matches; the selection cache
 *             keeps a good read's mailbox and forgets it on any failure); a fault or timeout gives
 *             TIMEOUT on free lines and enters the bus clear (BUS_STUCK, counted, every cached
 *             selection forgotten) with a line held low; only that entry forgets them
 *   4 clear   one bus-clear step (clear_step(), what poll() runs in PH_CLEAR) at any step, any
 *             time, any line levels, for a stuck bus or a CLEAR request: the next half clock of
 *             nine SCL pulses and a STOP, the outcome (BUS_STUCK, or for CLEAR OK exactly when the
 *             lines are free) only after the 21st step
 *   5 forget  forget_all from any master state: every one of the 128 cached selections becomes
 *             URB_I2C_NO_SELECTION, no other field changes, at most FW_FORGET_ALL_COST cycles
 *             (`make tight SWEEP_ITEM=PART=5` shows the number is reached)
 * Lemmas 1 to 4 use lemma 5 as a contract (the Makefile stubs forget_all out of their sources):
 * its 128 stores inside the master ran every run of the clear entry (Boolector, Bitwuzla) out of
 * memory or time within 240 s. The contract is a ghost call count and the cost; its one caller,
 * start_clear(), is the last thing begin() and poll() do, so no step under proof reads a
 * selection after it.
 * Termination (from 1 to 4): events never leave FINISH, FAULT or CLEAR and move a waiting phase
 * only to a waiting phase, FINISH or FAULT; the first poll after timeout_us leaves every waiting
 * phase; FINISH and FAULT end at the next poll or start the clear; each clear step takes one poll
 * at least clear_half_us apart and the outcome comes at step 21. So the outcome comes within
 * timeout_us + 22 x clear_half_us of begin() (plus the main loop's poll period), exactly once.
 * Cover points (URB_COVER, checked by the reach run): every lemma's branches: 1 a bus clear for a
 * stuck line and for CLEAR, a write, a read with and without its select, a probe, a SYNC; 2 a NACK
 * of the address and of a data byte, a data and a check byte read, the last byte, an unexpected
 * and a late event; 3 still waiting, a timeout, a fault into the bus clear and into TIMEOUT, a read
 * OK and a read CHECKSUM; 4 a half clock not yet passed, a clear step, CLEAR OK, BUS_STUCK; 5 the
 * forget itself.
 * Cost: every event (interrupt) within FW_I2C_EVENT_BUDGET (half an I2C byte time); begin() and
 * every poll (main loop, the check over up to 33 bytes) within FW_BRIDGE_MASTER_CALL_BUDGET (two
 * byte times of idle bus: begin() runs before the START, the final poll after the STOP).
 */
#include "urb_verify.h"

#include "bridge_internal.h"

#if URB_PART != 5
/* forget_all by its contract (lemma 5 proves it): the Makefile removes its definition from the
 * prepared i2c_master.c for every other part, and the contract is defined below. */
static void forget_all(urb_i2c_master_t *m);
#endif

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

/* forget_all's cost on the model: its entry and 128 loop rounds. Lemma 5 asserts the real function
 * costs at most this (the contract below charges it), and the worst-case witness run of PART=5
 * shows it is reached. */
#define FW_FORGET_ALL_COST 1304u

/* Ghost: how often forget_all ran during the step under proof. */
static uint8_t forget_calls;

#if URB_PART != 5
/* The contract of lemma 5 (every selection becomes URB_I2C_NO_SELECTION, nothing else changes) as
 * a ghost call count: its only caller, start_clear(), is the last thing begin() and poll() do, so
 * nothing under proof reads a selection after it; the harness asserts the call (exactly once per
 * clear entry) instead of 128 stores, which ran ESBMC out of memory inside the whole master state. */
static void forget_all(urb_i2c_master_t *m)
{
    URB_ASSERT(m == &master, "forget_all: called on the master under proof");
    URB_COST(FW_FORGET_ALL_COST);
    forget_calls++;
}
#endif

static uint8_t check_size(uint8_t len)
{
    return ((1u + (uint32_t)len) <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u;
}

static void reset_record(void)
{
    forget_calls = 0u;
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
    master.bus_clears = URB_NONDET_U32(); /* the counters may wrap */
    master.timeouts = URB_NONDET_U32();
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
    lines_any = true; /* any line levels: a line held low must start the bus clear */
    reset_record();
    last_lines = BOTH_LINES; /* a CLEAR reads no lines: do not let a stale level decide below */
    fw_bridge_check_last = 0u;
    uint32_t const clears_before = master.bus_clears;
    URB_COST_BEGIN();
    bool const ok = dl.begin(dl.ctx, &t, t0);
    URB_COST_END(FW_COST_BUDGET); /* begin(): FW_BRIDGE_MASTER_CALL_BUDGET */
    URB_ASSERT(ok, "begin: an idle master starts the request");
    uint8_t const ops_first = ops;
    uint8_t const forgets_first = forget_calls;
    URB_ASSERT(!dl.begin(dl.ctx, &t, t0), "begin: refused while a request runs");
    URB_ASSERT((ops == ops_first) && (forget_calls == forgets_first), "begin: a refused request does nothing");
    bool const clear_entry = (t.op == (uint8_t)URB_DL_CLEAR) || ((last_lines & 3u) != 3u);
    URB_ASSERT(!aborted && (drives == 0u), "begin: aborts nothing and bit-bangs nothing itself");
    if (clear_entry) {
        /* The bus-clear entry: CLEAR, or a line held low before the request (not executed). */
        URB_ASSERT(master.phase == PH_CLEAR, "begin: CLEAR or a line held low starts the bus clear");
        URB_ASSERT((ops == 0u) && (master.clear_step == 0u) && (master.t_step == t0),
                   "begin: the clear starts at its first step, timed from begin(), no bus operation");
        URB_ASSERT(master.clear_for == ((t.op == (uint8_t)URB_DL_CLEAR) ? CLEAR_FOR_COMMAND : (uint8_t)URB_STATUS_BUS_STUCK),
                   "begin: a CLEAR is judged by the lines after it, a stuck bus is BUS_STUCK");
        URB_ASSERT(forget_calls == 1u, "a bus clear forgets every cached selection (forget_all, lemma 5)");
        URB_ASSERT(master.bus_clears == clears_before + 1u, "begin: the bus clear is counted");
        if (t.op == (uint8_t)URB_DL_CLEAR) {
            URB_COVER("part1-clear-command-starts-the-bus-clear");
        } else {
            URB_COVER("part1-a-line-held-low-starts-the-bus-clear");
        }
        return;
    }
    URB_ASSERT((forget_calls == 0u) && (master.bus_clears == clears_before), "begin: no clear on free lines");
    URB_ASSERT(master.sel[t.address] == sel_before, "begin: a request keeps the cached selection");
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
        URB_COVER("part1-write-planned");
    } else if (t.op == (uint8_t)URB_DL_READ) {
        bool const select = t.reselect || (sel_before != t.mailbox);
        URB_ASSERT(master.read_after == select, "read: the select only when needed (reselect, or another cached)");
        URB_ASSERT(master.n_hdr == (select ? 2u : 0u), "read: address and select, or nothing before the read address");
        if (select) {
            URB_ASSERT((master.hdr[0] == (uint8_t)(t.address << 1)) && (master.hdr[1] == (uint8_t)(t.mailbox | 0x80u)),
                       "read: a DownlinkReadSelect of the outbox");
        }
        URB_ASSERT(master.n_rx == (uint8_t)(t.length + check_size(t.length)), "read: data and check");
        if (select) {
            URB_COVER("part1-read-with-its-select");
        } else {
            URB_COVER("part1-read-of-the-cached-selection");
        }
    } else if (t.op == (uint8_t)URB_DL_PROBE) {
        URB_ASSERT((master.n_hdr == 1u) && (master.hdr[0] == (uint8_t)(t.address << 1)) && (master.n_rx == 0u),
                   "probe: the address alone");
        URB_COVER("part1-probe-planned");
    } else {
        URB_ASSERT((master.n_hdr == 3u) && (master.hdr[0] == 0u) && (master.hdr[1] == (uint8_t)URB_SYNC_MAGIC) &&
                   (master.hdr[2] == t.counter), "sync: general call, magic, counter");
        URB_COVER("part1-sync-planned");
    }
}
#endif

/* Lemmas 2 to 4: a transaction begun on free lines, then any phase of it (the clear phase is
 * lemma 4's to set up). */
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
        URB_COVER("part2-late-event-ignored");
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
        URB_COVER("part2-unexpected-event-faults");
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
        if (want == URB_STATUS_SIZE_MISMATCH) {
            URB_COVER("part2-nack-of-a-data-byte");
        }
        if (want == URB_STATUS_CHECKSUM) {
            URB_COVER("part2-nack-of-a-check-byte");
        }
        return;
    }
    if ((ph == PH_ADDR_R) && (ev == URB_I2C_EV_NACK)) {
        URB_ASSERT((now_ph == PH_FINISH) && (master.result == URB_STATUS_NO_NODE), "error flags: a read address NACKed is NO_NODE");
        URB_COVER("part2-read-address-nacked");
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
        if (pos < t.length) {
            URB_COVER("part2-a-data-byte-read");
        } else if (now_ph == PH_FINISH) {
            URB_COVER("part2-the-last-check-byte-read");
        }
    }
    if ((ph != PH_RX) && (data_k < 32u)) {
        URB_ASSERT(data[data_k] == data_before, "only a read byte writes the request's buffer");
    }
    if ((now_ph == PH_FINISH) && (ph != PH_RX)) {
        URB_ASSERT(master.result == URB_STATUS_OK, "a bus part acknowledged throughout is OK");
        URB_COVER("part2-a-write-acknowledged-to-its-stop");
    }
}
#endif

#if (URB_PART == 3) || (URB_PART == 4)
static void lemma_poll(void)
{
    arbitrary_transaction();
#if URB_PART == 3
    /* any phase but CLEAR (lemma 4), any line levels: a fault or timeout with a line held low
     * enters the bus clear, with free lines it ends in TIMEOUT */
    URB_ASSUME(master.phase != PH_CLEAR);
    lines_any = true;
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
    uint32_t const clears_before = master.bus_clears;
    uint32_t const timeouts_before = master.timeouts;
    uint32_t const now = URB_NONDET_U32();
    reset_record();
    last_lines = BOTH_LINES; /* only fault() reads the lines: a stale level must not decide below */
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
#if URB_PART == 3
    bool const entered_clear = now_ph == PH_CLEAR;
#else
    bool const entered_clear = false; /* a clear step never starts another */
#endif
    URB_ASSERT(forget_calls == (entered_clear ? 1u : 0u),
               "poll: every cached selection is forgotten (forget_all, lemma 5) exactly when a bus clear starts");
    URB_ASSERT(master.bus_clears == clears_before + (entered_clear ? 1u : 0u), "poll: each bus clear counted once");
    URB_ASSERT((r >= 0) == ((now_ph == PH_IDLE) && (ph != PH_IDLE)), "an outcome exactly when the master goes idle");
    if (ph == PH_IDLE) {
        URB_ASSERT(r == URB_DOWNLINK_IDLE, "idle: nothing to report");
        return;
    }
    uint8_t const a = t.address;
    bool const timed_out = (uint32_t)(now - t0) > FW_TIMEOUT_US;
    if ((ph >= PH_START) && (ph <= PH_RX)) {
        URB_ASSERT(aborted == timed_out, "timeout: a waiting transaction is aborted exactly after timeout_us");
        URB_ASSERT(master.timeouts == timeouts_before + (timed_out ? 1u : 0u), "timeout: counted once");
        if (!timed_out) {
            URB_ASSERT((r == URB_DOWNLINK_BUSY) && (now_ph == ph), "before the timeout: still waiting");
#if URB_PART == 3
            URB_COVER("part3-still-waiting");
#endif
            return;
        }
    }
    if (((ph >= PH_START) && (ph <= PH_RX)) || (ph == PH_FAULT)) {
        if (t.op != (uint8_t)URB_DL_SYNC) {
            URB_ASSERT(master.sel[a] == URB_I2C_NO_SELECTION, "a fault forgets the node's selection");
        }
        if ((last_lines & 3u) != 3u) {
            /* The bus-clear entry after a fault or a timeout. */
            URB_ASSERT((r == URB_DOWNLINK_BUSY) && (now_ph == PH_CLEAR) && (master.clear_step == 0u) &&
                       (master.clear_for == URB_STATUS_BUS_STUCK) && (master.t_step == now),
                       "a line low after a fault: the bus clear starts, timed from this poll");
            URB_ASSERT(!released && (drives == 0u), "the clear's first half clock is the next poll's");
#if URB_PART == 3
            URB_COVER("part3-a-fault-with-a-line-low-starts-the-bus-clear");
#endif
        } else {
            URB_ASSERT((r == (int8_t)URB_STATUS_TIMEOUT) && released, "free lines after a fault: TIMEOUT");
            if (timed_out && (ph != PH_FAULT)) {
#if URB_PART == 3
                URB_COVER("part3-a-waiting-transaction-times-out");
#endif
            }
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
                if (st == URB_STATUS_OK) {
#if URB_PART == 3
                    URB_COVER("part3-a-read-ok");
#endif
                } else {
#if URB_PART == 3
                    URB_COVER("part3-a-read-checksum");
#endif
                }
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
#if URB_PART == 4
        URB_COVER("part4-the-half-clock-has-not-passed");
#endif
        return;
    }
    if (k < FW_CLEAR_STEPS) {
        URB_ASSERT((r == URB_DOWNLINK_BUSY) && (master.clear_step == (uint8_t)(k + 1u)) && (drives == 1u) &&
                   (master.t_step == now), "clear: one step per half clock, the outcome only after the last");
        uint8_t const want = (k < 18u) ? (((k & 1u) != 0u) ? 3u : (uint8_t)URB_I2C_SDA)
                                       : ((k == 18u) ? 0u : ((k == 19u) ? (uint8_t)URB_I2C_SCL : 3u));
        URB_ASSERT(last_drive == want, "clear: nine SCL pulses with SDA released, then a STOP");
#if URB_PART == 4
        URB_COVER("part4-a-clear-step");
#endif
        return;
    }
    URB_ASSERT(released && (drives == 0u), "clear: the lines go back to the controller");
    if ((clear_for == 0xFEu) && ((last_lines & 3u) == 3u)) {
        URB_ASSERT(r == (int8_t)URB_STATUS_OK, "CLEAR: OK when the lines are free after");
#if URB_PART == 4
        URB_COVER("part4-clear-ok");
#endif
    } else {
        URB_ASSERT(r == (int8_t)URB_STATUS_BUS_STUCK, "BUS_STUCK after the full clear of a stuck bus or lines still low");
#if URB_PART == 4
        URB_COVER("part4-bus-stuck");
#endif
    }
}
#endif

#if URB_PART == 5
static urb_i2c_master_t fm; /* lemma 5's own master, so that no other state is carried along */

/* Every field of fm but sel[] and the two pointers arbitrary; the pointers are fixed (forget_all
 * never reads them, and the frame assertion still sees a store to one). Measured with ESBMC 8.4:
 * a pointer member that is one of two objects makes the 128 stores into the struct explode
 * (Boolector out of memory, Z3 past 180 s), and so does a copy of an uninitialised local struct. */
static void arbitrary_fields(void)
{
    fm.hal = &hal;
    fm.cfg.bitrate_kbps = URB_NONDET_U16();
    fm.cfg.timeout_us = URB_NONDET_U32();
    fm.cfg.clear_half_us = URB_NONDET_U16();
    fm.op = URB_NONDET_U8();
    fm.address = URB_NONDET_U8();
    fm.mailbox = URB_NONDET_U8();
    fm.length = URB_NONDET_U8();
    fm.data = data;
    fm.hdr[0] = URB_NONDET_U8();
    fm.hdr[1] = URB_NONDET_U8();
    fm.hdr[2] = URB_NONDET_U8();
    fm.tail[0] = URB_NONDET_U8();
    fm.tail[1] = URB_NONDET_U8();
    fm.rx_check[0] = URB_NONDET_U8();
    fm.rx_check[1] = URB_NONDET_U8();
    fm.n_hdr = URB_NONDET_U8();
    fm.n_data = URB_NONDET_U8();
    fm.n_tail = URB_NONDET_U8();
    fm.n_rx = URB_NONDET_U8();
    fm.read_after = URB_NONDET_BOOL();
    fm.t0 = URB_NONDET_U32();
    fm.phase = URB_NONDET_U8();
    fm.pos = URB_NONDET_U8();
    fm.result = URB_NONDET_U8();
    fm.clear_step = URB_NONDET_U8();
    fm.clear_for = URB_NONDET_U8();
    fm.t_step = URB_NONDET_U32();
    fm.bus_clears = URB_NONDET_U32();
    fm.timeouts = URB_NONDET_U32();
}

/* Every field of the master but sel[]. */
static bool same_but_selections(const urb_i2c_master_t *x, const urb_i2c_master_t *y)
{
    return (x->hal == y->hal) && (x->cfg.bitrate_kbps == y->cfg.bitrate_kbps) && (x->cfg.timeout_us == y->cfg.timeout_us) &&
           (x->cfg.clear_half_us == y->cfg.clear_half_us) && (x->op == y->op) && (x->address == y->address) &&
           (x->mailbox == y->mailbox) && (x->length == y->length) && (x->data == y->data) && (x->hdr[0] == y->hdr[0]) &&
           (x->hdr[1] == y->hdr[1]) && (x->hdr[2] == y->hdr[2]) && (x->tail[0] == y->tail[0]) && (x->tail[1] == y->tail[1]) &&
           (x->rx_check[0] == y->rx_check[0]) && (x->rx_check[1] == y->rx_check[1]) && (x->n_hdr == y->n_hdr) &&
           (x->n_data == y->n_data) && (x->n_tail == y->n_tail) && (x->n_rx == y->n_rx) && (x->read_after == y->read_after) &&
           (x->t0 == y->t0) && (x->phase == y->phase) && (x->pos == y->pos) && (x->result == y->result) &&
           (x->clear_step == y->clear_step) && (x->clear_for == y->clear_for) && (x->t_step == y->t_step) &&
           (x->bus_clears == y->bus_clears) && (x->timeouts == y->timeouts);
}

/* forget_all on its own, from any master: every field arbitrary, and any cached selection at the
 * address checked (the function reads none of them). */
static void lemma_forget_all(void)
{
    arbitrary_fields();
    uint8_t const a = URB_NONDET_U8();
    URB_ASSUME(a < 128u);
    fm.sel[a] = URB_NONDET_U8();
    urb_i2c_master_t const before = fm;
    URB_COST_BEGIN();
    forget_all(&fm);
    URB_ASSERT(fm.sel[a] == URB_I2C_NO_SELECTION, "forget_all: every cached selection is forgotten");
    URB_ASSERT(same_but_selections(&fm, &before), "forget_all: nothing but the selections changes");
    URB_ASSERT(urb_proof_cost <= FW_FORGET_ALL_COST, "forget_all: costs at most what its contract charges");
    URB_TIGHT(urb_proof_cost == FW_FORGET_ALL_COST, "forget_all: the contract charges what it costs");
    URB_COVER("part5-every-selection-forgotten");
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
#elif URB_PART == 5
    lemma_forget_all();
#else
#error "set URB_PART (the Makefile's SWEEP)"
#endif
}
