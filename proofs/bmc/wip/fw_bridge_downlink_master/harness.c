/*
 * Proof of the I2C downlink master (firmware/bridge/i2c_master.c): one transaction (READ, WRITE,
 * SYNC, CLEAR or PROBE, any mailbox, length and cached selection) against any slave and controller
 * behaviour, then a quiet bus polled by the main loop.
 *
 * The HAL (below) records what the master asks for. The environment runs FW_STEPS steps, each
 * chosen by the solver: a HAL event (START, ACK, NACK, BYTE with any value, ERROR), in answer to
 * the operation the master issued or unexpected (garbage), or a main-loop poll at any later time.
 * lines() returns any level at any call (a bus stuck low, or released later). Then nothing
 * answers any more and the main loop polls every clear_half_us microseconds.
 *
 * Part 1 (URB_PART=1) keeps the lines free and runs FW_STEPS steps: error flags, bytes, cache,
 * timeouts. Part 2 lets lines() return anything and runs one step before the quiet phase: stuck
 * bus, bus clear and CLEAR (each poll of the quiet phase is a full copy of the master's poll for
 * the checker, so part 2 keeps the environment short). Without URB_PART, both at once.
 *
 * Properties (besides bounds, pointers, overflow and shifts on every access):
 *   terminates      the outcome comes within FW_QUIET_POLLS polls of the quiet phase, the first
 *                   after the timeout: within timeout_us + 22 x clear_half_us of begin() whatever
 *                   the slave does (no ACK, stretching forever, garbage), and exactly once
 *   one operation   the master never issues a bus operation while another one awaits its event,
 *                   and after the outcome no event makes it issue one
 *   error flags     a transaction answered by the contract (no ERROR, no unexpected event) gets
 *                   the status urb_downlink.h names: OK when every byte was acknowledged (and a
 *                   read's check matches), NO_NODE / BAD_REQUEST / NODE_BUSY / SIZE_MISMATCH /
 *                   CHECKSUM for a NACK of the address, select, first data byte, a later data byte,
 *                   a check byte; a timeout or fault gives TIMEOUT with free lines and BUS_STUCK
 *                   (after the nine-clock clear) when a line was low; CLEAR gives OK or BUS_STUCK
 *   bytes           a completed write put exactly address, select, data and check on the bus
 *   selection cache a read that succeeded caches its mailbox; any failed read forgets the cache
 *   cost            every event handler call fits FW_COST_BUDGET (half an I2C byte time), every
 *                   begin() and poll() FW_BRIDGE_MASTER_CALL_BUDGET
 */
#include "urb_verify.h"

#include "bridge_internal.h"
#include "urb_core.h"
#include "urb_runtime.h"

#include "../stubs/fw_budgets.h"
#include "fw_bridge_check.h"

#define FW_COST_BUDGET FW_I2C_EVENT_BUDGET

#ifndef FW_STEPS
#define FW_STEPS 6u /* environment steps before the quiet phase */
#endif
#ifndef FW_LEN_MAX
#define FW_LEN_MAX 32u /* largest payload tried */
#endif
#define FW_ADDR 0x2Au /* the node (the master treats the address as data, besides the cache index) */
#define FW_TIMEOUT_US 2000u
#define FW_CLEAR_HALF_US 5u
#define FW_CLEAR_POLLS 22u /* 21 half clocks (nine pulses, STOP) and the release */
/* Quiet phase: the poll that sees the timeout, then the clear (part 2); part 1 has free lines. */
#if defined(URB_PART) && (URB_PART == 1)
#define FW_QUIET_POLLS 1u
#define FW_ENV_STEPS FW_STEPS
#elif defined(URB_PART)
#define FW_QUIET_POLLS (1u + FW_CLEAR_POLLS)
#define FW_ENV_STEPS 1u /* one event or poll (an ERROR, garbage, a first answer), then quiet */
#else
#define FW_QUIET_POLLS (1u + FW_CLEAR_POLLS)
#define FW_ENV_STEPS FW_STEPS
#endif

URB_PROOF_COST_STORAGE;

enum { OP_NONE = 0u, OP_START = 1u, OP_WRITE = 2u, OP_READ = 3u };

static urb_i2c_master_t master;
static urb_downlink_t dl;

/* HAL record. */
static uint8_t pending;         /* the operation awaiting its event (OP_NONE: none) */
static uint8_t writes;          /* bytes written in this transaction */
static uint8_t written[40];     /* their values */
static uint8_t reads;           /* bytes read */
static bool stopped;            /* STOP issued */
static bool driving;            /* bit-banging (bus clear) */
static uint8_t drives;          /* drive() calls */
static uint8_t last_lines;      /* the value lines() returned last */
static uint8_t lines_calls;

static void hal_start(void *ctx)
{
    URB_ASSERT(ctx == &master, "HAL: its context");
    URB_ASSERT(pending == OP_NONE, "one operation at a time");
    pending = OP_START;
}

static void hal_write(void *ctx, uint8_t byte)
{
    (void)ctx;
    URB_ASSERT(pending == OP_NONE, "one operation at a time");
    pending = OP_WRITE;
    if (writes < sizeof written) {
        written[writes] = byte;
    }
    writes++;
}

static void hal_read(void *ctx, bool ack)
{
    (void)ctx;
    (void)ack;
    URB_ASSERT(pending == OP_NONE, "one operation at a time");
    pending = OP_READ;
    reads++;
}

static void hal_stop(void *ctx)
{
    (void)ctx;
    pending = OP_NONE;
    stopped = true;
}

static void hal_abort(void *ctx)
{
    (void)ctx;
    pending = OP_NONE; /* no event of the abandoned operation is delivered */
}

static bool lines_free_always; /* part 1: nobody holds a line low */

static uint8_t hal_lines(void *ctx)
{
    (void)ctx;
    last_lines = lines_free_always ? (uint8_t)(URB_I2C_SCL | URB_I2C_SDA)
                                   : (uint8_t)(URB_NONDET_U8() & (URB_I2C_SCL | URB_I2C_SDA));
    lines_calls++;
    return last_lines;
}

static void hal_drive(void *ctx, uint8_t lines)
{
    (void)ctx;
    (void)lines;
    URB_ASSERT(pending == OP_NONE, "bit-banging only with the controller stopped");
    driving = true;
    drives++;
}

static void hal_release(void *ctx)
{
    (void)ctx;
    driving = false;
}

static const urb_i2c_hal_t hal = {&master, hal_start, hal_write, hal_read, hal_stop, hal_abort,
                                  hal_lines, hal_drive, hal_release};

/* The contract's view of the transaction. */
static bool off_contract;  /* an ERROR or an event that answers no pending operation, before the STOP */
static bool nacked;        /* the first NACK ... */
static uint8_t nack_at;    /* ... answered write number nack_at */
static uint8_t rx_check[2];

static void event(void)
{
    uint8_t const ev = URB_NONDET_U8();
    URB_ASSUME(ev <= (uint8_t)URB_I2C_EV_ERROR);
    uint8_t const byte = URB_NONDET_U8();
    bool const expected = ((pending == OP_START) && (ev == URB_I2C_EV_START)) ||
                          ((pending == OP_WRITE) && ((ev == URB_I2C_EV_ACK) || (ev == URB_I2C_EV_NACK))) ||
                          ((pending == OP_READ) && (ev == URB_I2C_EV_BYTE));
    bool const running = (master.phase != 0u) && (master.phase < 6u); /* after the bus part, events are ignored */
    if (!expected && running) {
        off_contract = true;
    }
    if ((ev == URB_I2C_EV_NACK) && expected && !nacked) {
        nacked = true;
        nack_at = (uint8_t)(writes - 1u);
    }
    if ((pending == OP_READ) && (ev == URB_I2C_EV_BYTE)) {
        uint8_t const k = (uint8_t)(reads - 1u);
        if (k >= master.length) {
            rx_check[(k - master.length) & 1u] = byte;
        }
    }
    if (expected || running) {
        /* the event completes the operation; an ERROR or an unexpected event means the controller
         * gave up (the master then treats the transaction as faulted) */
        pending = OP_NONE;
    }
    URB_COST_BEGIN();
    urb_i2c_master_event(&master, (urb_i2c_event_t)ev, byte);
    URB_COST_END(FW_COST_BUDGET);
}

static int8_t poll_at(uint32_t now)
{
    urb_proof_cost = 0u;
    int8_t const r = dl.poll(dl.ctx, now);
    URB_ASSERT(urb_proof_cost <= FW_BRIDGE_MASTER_CALL_BUDGET, "cost: poll() within its budget");
    return r;
}

void harness(void)
{
#if defined(URB_PART) && (URB_PART == 1)
    lines_free_always = true; /* part 1: the contract's answers; part 2: stuck lines and bus clears */
#endif
    /* What urb_i2c_master_init leaves (its 128-entry loop is the one forget_all, run by every bus
     * clear below), with the default configuration and an arbitrary cached selection for the node. */
    master.hal = &hal;
    master.cfg.bitrate_kbps = 400u;
    master.cfg.timeout_us = FW_TIMEOUT_US;
    master.cfg.clear_half_us = FW_CLEAR_HALF_US;
    master.phase = 0u;
    master.sel[FW_ADDR] = URB_NONDET_U8();
    URB_ASSUME((master.sel[FW_ADDR] < 8u) || (master.sel[FW_ADDR] == URB_I2C_NO_SELECTION));
    urb_i2c_master_downlink(&master, &dl);

    uint8_t data[32];
    URB_NONDET_BYTES(data, sizeof data);
    urb_downlink_txn_t t;
    t.op = URB_NONDET_U8();
    URB_ASSUME(t.op <= (uint8_t)URB_DL_PROBE);
#if defined(URB_PART) && (URB_PART == 1)
    URB_ASSUME(t.op != (uint8_t)URB_DL_CLEAR); /* a bus clear is part 2's */
#endif
    t.address = FW_ADDR;
    t.mailbox = URB_NONDET_U8();
    URB_ASSUME(t.mailbox < 8u);
    t.length = URB_NONDET_U8();
    URB_ASSUME((t.length >= 1u) && (t.length <= FW_LEN_MAX));
    t.counter = URB_NONDET_U8();
    t.reselect = URB_NONDET_BOOL();
    t.data = data;
    uint8_t const sel_before = master.sel[FW_ADDR];

    uint32_t now = URB_NONDET_U32(); /* any start time: the clock may wrap */
    uint32_t const t0 = now;
    urb_proof_cost = 0u;
    fw_bridge_check_calls = 0u;
    URB_ASSERT(dl.begin(dl.ctx, &t, now), "begin: an idle master starts the transaction");
    URB_ASSERT(urb_proof_cost <= FW_BRIDGE_MASTER_CALL_BUDGET, "cost: begin() within its budget");
    URB_ASSERT(!dl.begin(dl.ctx, &t, now), "begin: refused while a transaction runs");
    bool const stuck_at_begin = (lines_calls > 0u) && ((last_lines & 3u) != 3u);

    bool done = false;
    int8_t result = URB_DOWNLINK_BUSY;
    bool stuck_seen = stuck_at_begin; /* a fault or timeout found a line low */
    for (uint8_t s = 0u; s < FW_ENV_STEPS; s++) {
        if (URB_NONDET_BOOL()) {
            event();
        } else {
            uint32_t const dt = URB_NONDET_U32();
            URB_ASSUME(dt <= 4u * FW_TIMEOUT_US);
            now += dt;
            uint8_t const calls = lines_calls;
            int8_t const r = poll_at(now);
            if ((lines_calls != calls) && ((last_lines & 3u) != 3u)) {
                stuck_seen = true;
            }
            if (r >= 0) {
                URB_ASSERT(!done, "one outcome per transaction");
                done = true;
                result = r;
            } else if (done) {
                URB_ASSERT(r == URB_DOWNLINK_IDLE, "idle after the outcome");
            }
        }
    }
    /* Quiet bus: nothing answers; the main loop polls, first after the timeout, then every half clock. */
    uint32_t const quiet = URB_NONDET_U32();
    URB_ASSUME(quiet <= 4u * FW_TIMEOUT_US);
    now += quiet;
    if ((uint32_t)(now - t0) <= FW_TIMEOUT_US) {
        now = t0 + FW_TIMEOUT_US + 1u;
    }
    pending = OP_NONE; /* the controller gave up on whatever it was doing */
    for (uint8_t q = 0u; (q < FW_QUIET_POLLS) && !done; q++) {
        uint8_t const calls = lines_calls;
        int8_t const r = poll_at(now);
        if ((lines_calls != calls) && ((last_lines & 3u) != 3u)) {
            stuck_seen = true;
        }
        if (r >= 0) {
            done = true;
            result = r;
        }
        now += FW_CLEAR_HALF_US;
    }
    URB_ASSERT(done, "terminates: an outcome within the timeout and one bus clear");
    URB_ASSERT(master.phase == 0u, "the master is idle after its outcome");
    URB_ASSERT(!driving, "the lines are given back to the controller");
    URB_ASSERT(poll_at(now) == URB_DOWNLINK_IDLE, "idle after the outcome");
    pending = OP_NONE;
    event();
    URB_ASSERT(pending == OP_NONE, "a late event starts nothing");

    uint8_t const st = (uint8_t)result;
    uint8_t const sel_after = master.sel[FW_ADDR];
    if (t.op == (uint8_t)URB_DL_CLEAR) {
        URB_ASSERT((st == URB_STATUS_OK) || (st == URB_STATUS_BUS_STUCK), "CLEAR: OK or BUS_STUCK");
        URB_ASSERT((st == URB_STATUS_OK) == ((last_lines & 3u) == 3u), "CLEAR: OK exactly when the lines are free after");
        URB_ASSERT(drives == 21u, "CLEAR: nine clock pulses and a STOP");
        return;
    }
    URB_ASSERT((st == URB_STATUS_BUS_STUCK) == stuck_seen, "BUS_STUCK exactly when a line was seen low");
    if (st == URB_STATUS_BUS_STUCK) {
        URB_ASSERT(drives == 21u, "BUS_STUCK after the full bus clear");
    }
    if (st == URB_STATUS_TIMEOUT) {
        URB_ASSERT(!stopped || off_contract, "TIMEOUT only when the bus part did not finish");
    }
    if (t.op == (uint8_t)URB_DL_SYNC) {
        URB_ASSERT((st == URB_STATUS_OK) || (st == URB_STATUS_TIMEOUT) || (st == URB_STATUS_BUS_STUCK),
                   "SYNC: nobody's NACK is an error");
        return;
    }
    if (!off_contract && !stuck_at_begin && stopped) {
        /* The bus part finished by the contract: the status names what happened. */
        if (nacked) {
            uint8_t want = URB_STATUS_CHECKSUM;
            if (t.op == (uint8_t)URB_DL_READ) {
                want = (nack_at == 1u) ? URB_STATUS_BAD_REQUEST : URB_STATUS_NO_NODE;
            } else if (nack_at == 0u) {
                want = URB_STATUS_NO_NODE;
            } else if (nack_at == 1u) {
                want = URB_STATUS_BAD_REQUEST;
            } else if (nack_at == 2u) {
                want = URB_STATUS_NODE_BUSY;
            } else if (nack_at < (uint8_t)(2u + t.length)) {
                want = URB_STATUS_SIZE_MISMATCH;
            } else {
                /* a check byte */
            }
            URB_ASSERT(st == want, "error flags: a NACK gets the status the contract names");
        } else if (t.op == (uint8_t)URB_DL_PROBE) {
            URB_ASSERT(st == URB_STATUS_OK, "PROBE: OK when the address is acknowledged");
            URB_ASSERT((writes == 1u) && (written[0] == (uint8_t)(FW_ADDR << 1)), "PROBE: the address alone");
        } else if (t.op == (uint8_t)URB_DL_WRITE) {
            URB_ASSERT(st == URB_STATUS_OK, "a write acknowledged throughout is OK");
            uint8_t const n_tail = (1u + t.length <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u;
            URB_ASSERT(writes == (uint8_t)(2u + t.length + n_tail), "bytes: address, select, data, check");
            URB_ASSERT(written[0] == (uint8_t)(FW_ADDR << 1), "bytes: the node's write address");
            URB_ASSERT(written[1] == t.mailbox, "bytes: the select of the inbox");
            uint8_t const k = URB_NONDET_U8();
            URB_ASSUME(k < t.length);
            URB_ASSERT(written[2u + k] == data[k], "bytes: the data as given");
        } else {
            uint32_t got = rx_check[0];
            if ((1u + t.length) > URB_CRC8_LINK_CHECK_MAX_COVERED) {
                got |= (uint32_t)rx_check[1] << 8;
            }
            URB_ASSERT((st == URB_STATUS_OK) == (got == fw_bridge_check_last),
                       "a read received in full: OK exactly when its check matches, else CHECKSUM");
            URB_ASSERT((st == URB_STATUS_OK) || (st == URB_STATUS_CHECKSUM), "a read received in full: OK or CHECKSUM");
            bool const selected = t.reselect || (sel_before != t.mailbox);
            URB_ASSERT(writes == (selected ? 3u : 1u), "a read sends the select only when needed");
        }
    }
    if (t.op == (uint8_t)URB_DL_READ) {
        if (st == URB_STATUS_OK) {
            URB_ASSERT(sel_after == t.mailbox, "selection cache: a good read caches its mailbox");
            URB_ASSERT(!off_contract && stopped, "a read is OK only when received by the contract");
        } else {
            URB_ASSERT(sel_after == URB_I2C_NO_SELECTION, "selection cache: a failed read forgets it");
        }
    }
    if (st == URB_STATUS_OK) {
        URB_ASSERT(stopped && !off_contract, "OK only for a transaction the bus completed");
    }
}
