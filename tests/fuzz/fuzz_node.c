/*
 * libFuzzer target: one node of the node library (firmware/node) on the hosted HAL, driven by a
 * script of bus transactions, application mailbox calls, heartbeats and garbage bus events
 * (tests/fuzz/README.md).
 *
 * The input is a script. Its first bytes configure the node: which urb_node_config_t fields leave
 * their defaults (then any value, valid or not), the storage block's length and the size of every
 * inbox and outbox 1..7 (0: not set up). Then each operation byte selects one of: begin a
 * well-formed write of an inbox (maybe with a corrupted check), begin a read of an outbox, one more
 * byte of the transaction in progress, end it (STOP, bus error, end of read), lock or release an
 * inbox or an outbox from the application, let time pass (heartbeats, app_update, the main loop),
 * a SYNC broadcast, an inbox-0 command of arbitrary bytes, or a garbage slave event (any event,
 * any byte, at any point of a transaction).
 *
 * The BMC proof fw_node_i2c_slave covers the slave's event handler by induction; this target runs
 * the whole node (PLL, commands, main loop, identification, the application's locks) for long
 * scripts at every mailbox size. Sanitizers catch memory errors and undefined behaviour; the
 * script asserts against a ghost of the mailboxes (MailboxInbox.tla, MailboxOutbox.tla):
 *   - urb_node_init refuses exactly the configurations and layouts its contract refuses;
 *   - every ACK/NACK of a well-formed transaction is the one spec/schema/README.md gives
 *     (unknown inbox or outbox NACKed at the select, a write into both busy buffers NACKed at its
 *     first byte, a bad check NACKed at its last byte, a byte past the check NACKed);
 *   - a write publishes exactly when it ended cleanly after size + check bytes with a good check,
 *     and the application's next lock returns exactly that message, flagged NEW exactly when a
 *     message was committed since its previous lock; a locked inbox never changes under the
 *     application (no torn read);
 *   - a bus read returns the outbox version released last before the read began, byte for byte,
 *     with a valid check, never the application's half-written buffer; outbox 0 decodes as an
 *     Identification of this node's layout;
 *   - an outbox lock is BUSY only while a read that began before the latest release is in progress;
 *   - a refused write and a failed check reach the fault hook at the next poll; fault codes are
 *     in range;
 *   - the heartbeat never stops: every beat arms the next.
 * After a garbage event the ghost forgets what it cannot know (a garbage sequence may complete a
 * write) and learns the inbox contents again at the application's next lock.
 */
/* lobster-trace: urb.CRC_004, urb.MEM_002 (the requirements this fuzz target verifies) */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_require.h"
#include "urb_core.h"
#include "urb_hal_hosted.h"
#include "urb_node.h"
#include "urb_runtime.h"

#define MB URB_NODE_MAILBOXES
#define MAX URB_NODE_MAX_SIZE
#define STORAGE URB_NODE_STORAGE_BYTES((MB - 1u) * MAX)
#define NONE (-1)
#define POLLS 8u /* main-loop iterations after time passes: enough to run what became due */
#define MAX_BEATS 256u

typedef enum { BUS_IDLE, BUS_WRITE, BUS_REFUSED, BUS_READ } bus_phase_t;

typedef struct {
    const uint8_t *data;
    size_t size, pos;
} script_t;

typedef struct {
    urb_node_t node;
    urb_hal_hosted_t port;
    urb_node_config_t cfg;
    urb_node_hooks_t hooks;
    uint8_t storage[STORAGE];
    uint8_t in_size[MB], out_size[MB];
    /* inbox ghost */
    uint8_t committed[MB][MAX]; /* the latest message committed, when known */
    bool known[MB];             /* false after garbage events: learnt again at the next lock */
    bool fresh[MB];             /* committed since the application's latest lock */
    int in_held;                /* inbox the application holds, or NONE */
    const uint8_t *in_data;
    uint8_t in_seen[MAX];       /* what that lock returned */
    unsigned commits_in_hold;   /* commits into in_held since its lock */
    bool hold_blind;            /* garbage events during that hold */
    /* outbox ghost */
    uint8_t released[MB][MAX];
    int out_held;
    uint8_t out_pending[MAX];
    /* the well-formed transaction in progress */
    bus_phase_t bus;
    uint8_t m;
    uint8_t frame[1u + MAX + 2u]; /* write: select, data, check */
    size_t flen, fpos;
    bool good;
    uint8_t expect[MAX];          /* read: the version released before the read began */
    uint8_t got[MAX + 2u];
    size_t got_len;
    unsigned releases_in_read;    /* releases of outbox m since the read began */
    bool blind;                   /* garbage events since the last well-formed START */
    /* faults */
    unsigned faults[URB_NODE_FAULT_CODES + 1u];
    unsigned due[URB_NODE_FAULT_CODES + 1u]; /* counted since the last poll: reach the hook at the next */
    unsigned due_base[URB_NODE_FAULT_CODES + 1u];
    unsigned garbage_since_poll;
    uint8_t updates;
} rig_t;

static rig_t R;

static uint8_t next(script_t *s)
{
    return (s->pos < s->size) ? s->data[s->pos++] : 0u;
}

static uint16_t next16(script_t *s)
{
    uint16_t const lo = next(s);
    return (uint16_t)(lo | ((uint16_t)next(s) << 8));
}

/* ===== Hooks ================================================================================= */

static void hook_bootup(urb_node_t *node, void *user)
{
    rig_t *r = user;
    REQUIRE(urb_node_set_class(node, 0x42u) == URB_NODE_OK);
    REQUIRE(urb_node_set_index(node, 7u) == URB_NODE_OK);
    for (uint8_t n = 1u; n < MB; n++) {
        if (r->in_size[n] != 0u) {
            (void)urb_node_setup_inbox(node, n, r->in_size[n]);
        }
        if (r->out_size[n] != 0u) {
            (void)urb_node_setup_outbox(node, n, r->out_size[n]);
        }
    }
}

static void hook_fault(urb_node_t *node, void *user, urb_node_fault_t fault)
{
    (void)node;
    rig_t *r = user;
    REQUIRE(fault >= URB_NODE_FAULT_CHECKSUM && fault <= URB_NODE_FAULT_STUCK_BUS);
    r->faults[fault]++;
}

/* An outbox lock may be BUSY only while a read begun before the latest release of it runs. */
static void check_outbox_lock(const rig_t *r, uint8_t n, int rc)
{
    if (rc == URB_NODE_ERR_BUSY) {
        REQUIRE(r->blind || (r->bus == BUS_READ && r->m == n && r->releases_in_read >= 1u));
    } else {
        REQUIRE(rc == URB_NODE_OK);
    }
}

static void published(rig_t *r, uint8_t n, const uint8_t *value)
{
    memcpy(r->released[n], value, r->out_size[n]);
    if (r->bus == BUS_READ && r->m == n) {
        r->releases_in_read++;
    }
}

/* app_update: publish a counter pattern into the next outbox the script does not hold. */
static void hook_update(urb_node_t *node, void *user)
{
    rig_t *r = user;
    r->updates++;
    uint8_t const n = (uint8_t)(1u + r->updates % (MB - 1u));
    urb_node_mark_acquired(node);
    if (r->out_size[n] == 0u || r->out_held == (int)n) {
        return;
    }
    uint8_t *buf = NULL;
    int const rc = urb_node_lock_outbox(node, n, &buf);
    check_outbox_lock(r, n, rc);
    if (rc != URB_NODE_OK) {
        return;
    }
    for (uint8_t k = 0u; k < r->out_size[n]; k++) {
        buf[k] = (uint8_t)(r->updates + 3u * k);
    }
    uint8_t value[MAX];
    memcpy(value, buf, r->out_size[n]);
    REQUIRE(urb_node_release_outbox(node, n) == URB_NODE_OK);
    published(r, n, value);
}

/* ===== Bus =================================================================================== */

static uint16_t ev(urb_i2c_event_t e, uint8_t byte)
{
    uint16_t const rc = urb_node_i2c_event(&R.node, e, byte);
    REQUIRE(e == URB_I2C_TX_BYTE ? rc <= 0xFFu : (rc == URB_I2C_ACK || rc == URB_I2C_NACK));
    return rc;
}

static void expect_fault(rig_t *r, urb_node_fault_t code)
{
    if (r->due[code] == 0u) {
        r->due_base[code] = r->faults[code];
    }
    r->due[code]++;
}

static void commit(rig_t *r, uint8_t m)
{
    if (m == 0u) {
        return; /* inbox 0 belongs to the library */
    }
    memcpy(r->committed[m], &r->frame[1], r->in_size[m]);
    r->known[m] = true;
    r->fresh[m] = true;
    if (r->in_held == (int)m) {
        r->commits_in_hold++;
    }
}

/* A garbage event, or the end of what garbage left open, may have committed a write into any
 * inbox, the one the application holds too: the ghost no longer knows them. */
static void forget(rig_t *r)
{
    for (uint8_t n = 0u; n < MB; n++) {
        r->known[n] = false;
    }
    if (r->in_held != NONE) {
        r->hold_blind = true;
    }
}

/* After the STOP or START that ended what garbage events left open. */
static void unblind(rig_t *r)
{
    if (r->blind) {
        forget(r);
    }
    r->blind = false;
}

/* Ends the transaction in progress with a STOP (clean) or a bus error. */
static void bus_end(rig_t *r, bool clean)
{
    if (r->bus == BUS_WRITE && clean && r->fpos == r->flen) {
        commit(r, r->m);
    }
    if (r->bus == BUS_READ && r->m == 0u && r->got_len >= (size_t)URB_NODE_OUTBOX0_SIZE + 1u) {
        urb_identification_t id;
        REQUIRE(urb_identification_decode(&id, r->got, URB_NODE_OUTBOX0_SIZE) == URB_NODE_OUTBOX0_SIZE);
        REQUIRE(id.class_id == 0x42u && id.index == 7u);
        for (uint8_t n = 0u; n < MB; n++) {
            REQUIRE(id.inbox_sizes[n] == r->in_size[n] && id.outbox_sizes[n] == r->out_size[n]);
        }
    }
    bool const reading = r->bus == BUS_READ;
    r->bus = BUS_IDLE;
    (void)ev(clean ? (reading ? URB_I2C_TX_NACK : URB_I2C_STOP) : URB_I2C_BUS_ERROR, 0u);
    if (reading && clean) {
        (void)ev(URB_I2C_STOP, 0u);
    }
    unblind(r);
}

/* A START of a well-formed transaction: the bus is clean from here on. */
static void bus_start(rig_t *r)
{
    if (r->bus != BUS_IDLE) {
        bus_end(r, true);
    }
    (void)ev(URB_I2C_STOP, 0u);
    unblind(r);
    REQUIRE(ev(URB_I2C_ADDR_WRITE, 0u) == URB_I2C_ACK);
}

/* The select byte of a mailbox of `size` bytes (0: not set up): ACKed exactly when it is set up;
 * true when the transaction goes on. */
static bool send_select(rig_t *r, uint8_t select, uint8_t size)
{
    REQUIRE(ev(URB_I2C_RX_BYTE, select) == (size != 0u ? URB_I2C_ACK : URB_I2C_NACK));
    if (size == 0u) {
        r->bus = BUS_REFUSED;
        return false;
    }
    return true;
}

static void begin_write(rig_t *r, script_t *s, uint8_t m, bool corrupt)
{
    bus_start(r);
    uint8_t const size = r->in_size[m];
    uint8_t const select = m;
    if (!send_select(r, select, size)) {
        return;
    }
    r->frame[0] = select;
    for (uint8_t k = 0u; k < size; k++) {
        r->frame[1u + k] = next(s);
    }
    uint32_t const check = urb_link_check(NULL, 0u, r->frame, 1u + (size_t)size);
    size_t const cl = urb_link_check_size(1u + (size_t)size);
    for (size_t k = 0u; k < cl; k++) {
        r->frame[1u + size + k] = (uint8_t)(check >> (8u * k));
    }
    r->good = !corrupt;
    if (corrupt) {
        r->frame[size + cl] ^= (uint8_t)(1u << (next(s) & 7u));
    }
    r->m = m;
    r->flen = 1u + size + cl;
    r->fpos = 1u;
    r->bus = BUS_WRITE;
}

static void begin_read(rig_t *r, uint8_t m)
{
    bus_start(r);
    uint8_t const size = r->out_size[m];
    if (!send_select(r, (uint8_t)(0x80u | m), size)) {
        return;
    }
    REQUIRE(ev(URB_I2C_ADDR_READ, 0u) == URB_I2C_ACK); /* repeated START */
    memcpy(r->expect, r->released[m], size);
    r->m = m;
    r->got_len = 0u;
    r->releases_in_read = 0u;
    r->bus = BUS_READ;
}

/* Bytes a read of outbox m sends before 0xFF: the data and its check. */
static size_t read_len(const rig_t *r)
{
    uint8_t const size = r->out_size[r->m];
    return size + urb_link_check_size(1u + (size_t)size);
}

/* One more byte of the transaction in progress. */
static void bus_step(rig_t *r)
{
    switch (r->bus) {
    case BUS_WRITE: {
        if (r->fpos == r->flen) { /* a byte past the check: refused, and the write is void */
            REQUIRE(ev(URB_I2C_RX_BYTE, 0x5Au) == URB_I2C_NACK);
            r->bus = BUS_REFUSED;
            return;
        }
        uint16_t const rc = ev(URB_I2C_RX_BYTE, r->frame[r->fpos]);
        bool const first = r->fpos == 1u;
        bool const last = r->fpos + 1u == r->flen;
        r->fpos++;
        if (first && r->m != 0u && r->in_held == (int)r->m && !r->hold_blind) {
            /* the application holds the front buffer; after a commit the other is the one it holds */
            REQUIRE(rc == (r->commits_in_hold == 0u ? URB_I2C_ACK : URB_I2C_NACK));
        }
        if (first && rc == URB_I2C_NACK) {
            REQUIRE(r->m != 0u && r->in_held == (int)r->m);
            expect_fault(r, URB_NODE_FAULT_OVERRUN);
            r->bus = BUS_REFUSED;
            return;
        }
        if (last && !r->good) {
            REQUIRE(rc == URB_I2C_NACK);
            expect_fault(r, URB_NODE_FAULT_CHECKSUM);
            r->bus = BUS_REFUSED;
            return;
        }
        REQUIRE(rc == URB_I2C_ACK);
        return;
    }
    case BUS_READ: {
        uint8_t const size = r->out_size[r->m];
        uint8_t const b = (uint8_t)ev(URB_I2C_TX_BYTE, 0u);
        if (r->got_len < size) {
            if (r->m != 0u) {
                REQUIRE(b == r->expect[r->got_len]);
            }
        } else if (r->got_len < read_len(r)) {
            uint8_t const select = (uint8_t)(0x80u | r->m);
            uint32_t const check = urb_link_check(&select, 1u, r->got, size);
            REQUIRE(b == (uint8_t)(check >> (8u * (r->got_len - size))));
        } else {
            REQUIRE(b == 0xFFu);
            return;
        }
        r->got[r->got_len++] = b;
        return;
    }
    case BUS_REFUSED:
        REQUIRE(ev(URB_I2C_RX_BYTE, 0u) == URB_I2C_NACK);
        return;
    default:
        return;
    }
}

/* The rest of the transaction in progress: every byte of a write up to its check, or of a read. */
static void finish(rig_t *r)
{
    while ((r->bus == BUS_WRITE && r->fpos < r->flen) || (r->bus == BUS_READ && r->got_len < read_len(r))) {
        bus_step(r);
    }
}

/* Any slave event with any byte, wherever the transaction is: the ghost stops predicting. */
static void garbage(rig_t *r, script_t *s)
{
    static const urb_i2c_event_t events[] = {
        URB_I2C_ADDR_WRITE, URB_I2C_ADDR_READ, URB_I2C_GENERAL_CALL, URB_I2C_RX_BYTE, URB_I2C_TX_BYTE,
        URB_I2C_TX_NACK,    URB_I2C_STOP,      URB_I2C_BUS_ERROR,    URB_I2C_STUCK,   URB_I2C_EV_BYTE,
    };
    urb_i2c_event_t const e = events[next(s) % (sizeof events / sizeof events[0])];
    (void)ev(e, next(s));
    r->bus = BUS_IDLE;
    r->blind = true;
    r->garbage_since_poll++;
    forget(r);
}

static void sync_broadcast(rig_t *r, uint8_t counter)
{
    if (r->bus != BUS_IDLE) {
        bus_end(r, true);
    }
    r->port.capture = r->port.now;
    REQUIRE(ev(URB_I2C_GENERAL_CALL, 0u) == URB_I2C_ACK);
    unblind(r);
    REQUIRE(ev(URB_I2C_RX_BYTE, 0xA5u) == URB_I2C_ACK);
    REQUIRE(ev(URB_I2C_RX_BYTE, counter) == URB_I2C_ACK);
    REQUIRE(ev(URB_I2C_RX_BYTE, 0x00u) == URB_I2C_NACK); /* a SYNC has exactly two bytes */
    (void)ev(URB_I2C_STOP, 0u);
}

/* ===== Application =========================================================================== */

static void lock_inbox(rig_t *r, uint8_t n)
{
    const uint8_t *data = NULL;
    if (r->in_held == (int)n) {
        REQUIRE(urb_node_lock_inbox(&R.node, n, &data) == URB_NODE_ERR_STATE); /* a double lock */
        return;
    }
    if (r->in_held != NONE) {
        return; /* the script's application holds one inbox at a time */
    }
    int const rc = urb_node_lock_inbox(&R.node, n, &data);
    if (r->in_size[n] == 0u) {
        REQUIRE(rc == URB_NODE_ERR_SETUP);
        return;
    }
    REQUIRE(rc == URB_NODE_OK || rc == URB_NODE_NEW); /* nothing preempts the lock here: never BUSY */
    if (r->known[n]) {
        REQUIRE(memcmp(data, r->committed[n], r->in_size[n]) == 0);
        REQUIRE((rc == URB_NODE_NEW) == r->fresh[n]);
    }
    memcpy(r->committed[n], data, r->in_size[n]);
    r->known[n] = true;
    r->fresh[n] = false;
    memcpy(r->in_seen, data, r->in_size[n]);
    r->in_data = data;
    r->in_held = (int)n;
    r->commits_in_hold = 0u;
    r->hold_blind = false;
}

static void release_inbox(rig_t *r)
{
    if (r->in_held == NONE) {
        REQUIRE(urb_node_release_inbox(&R.node, 1u) == (r->in_size[1] == 0u ? URB_NODE_ERR_SETUP : URB_NODE_ERR_STATE));
        return;
    }
    uint8_t const n = (uint8_t)r->in_held;
    REQUIRE(memcmp(r->in_data, r->in_seen, r->in_size[n]) == 0); /* not torn under the application */
    REQUIRE(urb_node_release_inbox(&R.node, n) == URB_NODE_OK);
    r->in_held = NONE;
}

static void lock_outbox(rig_t *r, script_t *s, uint8_t n)
{
    uint8_t *data = NULL;
    if (r->out_held == (int)n) {
        REQUIRE(urb_node_lock_outbox(&R.node, n, &data) == URB_NODE_ERR_STATE); /* a double lock */
        return;
    }
    if (r->out_held != NONE) {
        return;
    }
    int const rc = urb_node_lock_outbox(&R.node, n, &data);
    if (r->out_size[n] == 0u) {
        REQUIRE(rc == URB_NODE_ERR_SETUP);
        return;
    }
    check_outbox_lock(r, n, rc);
    if (rc != URB_NODE_OK) {
        return;
    }
    for (uint8_t k = 0u; k < r->out_size[n]; k++) {
        r->out_pending[k] = next(s);
        data[k] = r->out_pending[k]; /* written now: a read begun meanwhile must not see it */
    }
    r->out_held = (int)n;
}

static void release_outbox(rig_t *r)
{
    if (r->out_held == NONE) {
        return;
    }
    uint8_t const n = (uint8_t)r->out_held;
    REQUIRE(urb_node_release_outbox(&R.node, n) == URB_NODE_OK);
    published(r, n, r->out_pending);
    r->out_held = NONE;
}

static void poll(rig_t *r)
{
    (void)urb_node_poll(&R.node);
    for (unsigned c = 1u; c <= URB_NODE_FAULT_CODES; c++) {
        /* the interrupt counts faults modulo 256 for the main loop: 256 between two polls (never
         * on a bus, where a poll comes every few bytes) look like none */
        if (r->due[c] != 0u && r->due[c] + r->garbage_since_poll < 256u) {
            REQUIRE(r->faults[c] > r->due_base[c]);
        }
        r->due[c] = 0u;
    }
    r->garbage_since_poll = 0u;
}

static void pass_time(rig_t *r, script_t *s)
{
    uint32_t ticks = (uint32_t)next16(s) * (1u + (next(s) & 0x3Fu));
    /* at most about MAX_BEATS heartbeats per operation, however short the period: inputs stay fast */
    uint32_t beats = 0u;
    while (ticks > 0u && beats < MAX_BEATS) {
        uint32_t const step = ticks < 4096u ? ticks : 4096u;
        beats += urb_hal_hosted_advance(&r->port, &R.node, step);
        ticks -= step;
        REQUIRE(r->port.armed != 0u); /* the heartbeat never stops: every beat arms the next */
    }
    for (unsigned i = 0u; i < POLLS && urb_node_has_work(&R.node); i++) {
        poll(r);
    }
}

/* An inbox-0 command: six arbitrary bytes in a well-formed frame (the library ignores what does
 * not decode), then the main loop. */
static void command(rig_t *r, script_t *s)
{
    begin_write(r, s, 0u, false);
    finish(r);
    bus_end(r, true);
    poll(r);
}

/* ===== Configuration ========================================================================= */

static bool config_ok(const urb_node_config_t *c)
{
    uint32_t const ticks = (uint32_t)c->heartbeat_us * c->ticks_per_us;
    return c->i2c_address >= 1u && c->i2c_address <= 127u && c->ticks_per_us >= 1u && c->ticks_per_us <= 1000u &&
           ticks >= 64u && ticks <= 0x1FFFFFu && c->update_divider >= 1u && c->lost_sync_beats >= 2u;
}

static void configure(rig_t *r, script_t *s)
{
    urb_node_config_default(&r->cfg);
    r->cfg.i2c_address = 0x21u;
    uint8_t const which = next(s);
    if (which & 0x01u) {
        r->cfg.i2c_address = next(s);
    }
    if (which & 0x02u) {
        r->cfg.ticks_per_us = next16(s);
        r->cfg.heartbeat_us = next16(s);
    }
    if (which & 0x04u) {
        r->cfg.update_divider = next(s);
        r->cfg.sync_enabled = next(s) & 1u;
        r->cfg.lead_us = next16(s);
    }
    if (which & 0x08u) {
        r->cfg.kd_q8 = next(s);
        r->cfg.kn_q8 = next(s);
        r->cfg.lock_count = next(s);
        r->cfg.max_outliers = next(s);
        r->cfg.max_gap = next(s);
    }
    if (which & 0x10u) {
        r->cfg.lock_ns = next16(s);
        r->cfg.outlier_ns = next16(s);
        r->cfg.lost_sync_beats = next(s);
        r->cfg.acq_window = next(s);
        r->cfg.acq_guard_us = next(s);
    }
    r->in_size[0] = URB_NODE_INBOX0_SIZE;
    r->out_size[0] = URB_NODE_OUTBOX0_SIZE;
    for (uint8_t n = 1u; n < MB; n++) {
        r->in_size[n] = (uint8_t)(next(s) % (MAX + 1u));
        r->out_size[n] = (uint8_t)(next(s) % (MAX + 1u));
    }
}

/* ===== Entry ================================================================================= */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* urb_node_init on the script's configuration and layout; true when the node is on the bus
 * (otherwise it refused exactly what its contract refuses). */
static bool start(rig_t *r, script_t *s)
{
    configure(r, s);
    uint8_t const options = next(s);
    size_t needed = 0u;
    for (uint8_t n = 1u; n < MB; n++) {
        needed += (size_t)r->in_size[n] + r->out_size[n];
    }
    needed = URB_NODE_STORAGE_BYTES(needed);
    size_t const offered = (options & 0x80u) ? (size_t)next(s) * 2u : STORAGE;
    size_t const storage_len = offered < STORAGE ? offered : STORAGE;
    urb_hal_hosted_init(&r->port, (uint32_t)next16(s) << 16, (options & 0x01u) != 0u); /* near a wrap */
    r->hooks.bootup = hook_bootup;
    r->hooks.update = hook_update;
    r->hooks.fault = hook_fault;
    r->in_held = NONE;
    r->out_held = NONE;
    int const rc = urb_node_init(&r->node, &r->port.hal, &r->hooks, r, &r->cfg, r->storage, storage_len);
    if (!config_ok(&r->cfg)) {
        REQUIRE(rc == URB_NODE_ERR_CONFIG);
        return false;
    }
    if (needed > storage_len) {
        REQUIRE(rc == URB_NODE_ERR_NOMEM);
        return false;
    }
    REQUIRE(rc == URB_NODE_OK);
    return true;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    script_t s = {data, size, 0u};
    rig_t *r = &R;
    memset(r, 0, sizeof *r);
    if (!start(r, &s)) {
        return 0;
    }
    while (s.pos < s.size) {
        uint8_t const op = next(&s);
        uint8_t const m = (uint8_t)((op >> 4) & 7u);  /* a mailbox; bit 7 is a flag */
        uint8_t const app_box = (uint8_t)(1u + m % (MB - 1u)); /* the application's are 1..7 */
        switch (op & 0x0Fu) {
        case 0:
            begin_write(r, &s, m, false);
            break;
        case 1:
            begin_write(r, &s, m, (op & 0x80u) != 0u);
            break;
        case 2:
            begin_read(r, m);
            break;
        case 3:
            bus_step(r);
            break;
        case 4:
            finish(r);
            break;
        case 5:
            bus_end(r, (op & 0x80u) == 0u);
            break;
        case 6:
            lock_inbox(r, app_box);
            break;
        case 7:
            release_inbox(r);
            break;
        case 8:
            lock_outbox(r, &s, app_box);
            break;
        case 9:
            release_outbox(r);
            break;
        case 10:
            pass_time(r, &s);
            break;
        case 11:
            poll(r);
            break;
        case 12:
            sync_broadcast(r, next(&s));
            break;
        case 13:
            command(r, &s);
            break;
        default:
            garbage(r, &s);
            break;
        }
    }
    return 0;
}
