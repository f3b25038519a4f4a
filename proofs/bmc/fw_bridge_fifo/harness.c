/*
 * Proof of the bridge's request FIFO (firmware/bridge/bridge.c, Bridge.tla SubmitAndAdmit, Serve,
 * Emit): the response ring (arrival order, header only) and the data slots (a FIFO inside it).
 *
 * An inductive proof, one lemma per sweep part: the FIFO state is ARBITRARY within the invariant
 * below (so every state that any sequence of admissions, completions and emissions reaches is
 * covered, not only short sequences), one operation runs on arbitrary inputs, the operation's
 * property holds and the invariant holds again. The harness includes the prepared
 * (cost-instrumented, maybe mutated) bridge.c to reach its static functions.
 *
 * Invariant (assumed before by construction, asserted after), over the ring_count outstanding
 * responses in ring order from ring_head:
 *   - the entries holding a data slot, in ring order, hold slot_head, slot_head + 1, ... (mod
 *     fifo_depth): slot_count of them, and each slot names its entry (resp);
 *   - exactly the slot holders of rank >= slot_served are PENDING; every other entry (served, or an
 *     admission error without a slot) is final;
 *   - 1 <= fifo_depth <= FIFO_MAX, slot_served <= slot_count <= fifo_depth, ring_count <= RING_MAX,
 *     heads inside their arrays.
 * Ring order is admission order: admit appends at offset ring_count and nothing else moves an entry.
 *
 * Lemmas (URB_PART):
 *   1 admit     any request (either uplink, any address, mailbox, direction, length 1..FW_LEN_MAX,
 *               well-formed or BAD_REQUEST, any known node sizes): Bridge.tla AdmissionStatus,
 *               BUSY exactly when every data slot is taken, the new response at the end of the
 *               ring with its seq and uplink, its slot held by no outstanding request (no reuse),
 *               the payload copied, every outstanding entry and held slot unchanged; beyond the
 *               host window the request is counted, not answered
 *   2 complete  any outcome: the oldest pending request (first PENDING entry in ring order) takes
 *               it, nothing else changes; with nothing pending nothing changes (an identification
 *               read of a node, length 25, also learns its sizes: its decoder runs)
 *   3 emit      an uplink that takes any number of responses then refuses: responses leave from
 *               the head in ring order, each on its request's uplink with its seq and status (data
 *               for an OK read), exactly until the first PENDING one or the refusal; their slots
 *               are freed, the others kept
 * Every lemma: cost of the operation within FW_COST_BUDGET (per response emitted), and a frame
 * property: every ring entry and data slot the operation is not meant to write (free ones included)
 * keeps its contents. It is checked by concrete index against a snapshot of the whole ring and
 * FIFO, which the solver decides far faster than the same property by ring offset; together with
 * the lemma's own "the entry / slot written is not an outstanding one" it says that the outstanding
 * responses and their held slots stay intact.
 * Cover points (URB_COVER, checked by the reach run): 1 every admission status (admitted, BUSY,
 * BAD_REQUEST, SIZE_MISMATCH) and a request beyond the window, an admission into a wrapped ring;
 * 2 nothing pending, and a completion behind an outstanding final response; 3 an emission that
 * stops at a pending response, one stopped by the uplink, one that frees a data slot.
 * Capacities are lowered (fast tier FIFO 2, ring 3; full tier FIFO 3, ring 4): the code is generic
 * in both. Payload lengths 1..FW_LEN_MAX (fast 2, full also 32 with URB_LEN, for the cost of the
 * longest copy and an identification read in lemma 2).
 */
#include "urb_verify.h"

#include "bridge.c"

#include "../stubs/fw_budgets.h"
#include "fw_bridge_check.h"

#define FW_COST_BUDGET FW_BRIDGE_FIFO_OP_BUDGET

#ifdef URB_LEN
#undef FW_LEN_MAX
#define FW_LEN_MAX ((uint8_t)URB_LEN) /* a sweep item: the longest payload of this run */
#endif
#ifndef FW_LEN_MAX
#define FW_LEN_MAX 32u /* longest payload */
#endif
#define FW_RING URB_BRIDGE_RING_MAX
#define FW_FIFO URB_BRIDGE_FIFO_MAX
#if FW_RING > 4u
#error "lemma 3's per-response cost divides by at most 4 responses"
#endif
#define FW_NONE 0xFFu

URB_PROOF_COST_STORAGE;

static urb_bridge_t bridge;
/* A board with a timing-mark pin: emit_entry's two marks per response cost a HAL call each. */
static void board_mark(void *ctx, uint8_t id, bool level)
{
    (void)ctx;
    (void)id;
    (void)level;
    URB_COST(FW_HAL_CALL_CYCLES);
}
static const urb_bridge_hal_t board = {NULL, NULL, NULL, NULL, board_mark};

/* bridge_uplink.c's urbb_uplink_send is the harness's (lemma 3 watches what is sent); its cycles
 * are what prepare.py charges that function: the entry (call and straight-line code) 57, and for
 * a response taken 10 per byte copied and the UART kick through the HAL (RS232). */
#define FW_UPLINK_SEND_ENTRY_CYCLES 57u
#define FW_UPLINK_SEND_COPY_CYCLES(len) (10u * (uint32_t)(len) + FW_HAL_CALL_CYCLES)

/* Snapshot of the state before the operation: the whole ring and FIFO by index, and the
 * outstanding entries by ring offset from the old head. */
static urb_bridge_resp_t old_ring[FW_RING];
static urb_bridge_slot_t old_slots[FW_FIFO];
static urb_bridge_resp_t old_e[FW_RING];
static uint8_t old_rank[FW_RING]; /* rank among the slot holders, or FW_NONE */
static urb_bridge_slot_t old_d[FW_RING]; /* the slot of a holder */
static uint8_t old_head, old_count, old_slot_head, old_slot_count, old_served;
static uint8_t any_byte; /* one arbitrary payload index: a property at it holds at every index */

/* What the uplink stub saw (lemma 3). */
static uint8_t room;
static uint8_t sent;

static uint8_t wrap(uint8_t i, uint8_t n)
{
    return (i >= n) ? (uint8_t)(i - n) : i;
}

static bool final_status(uint8_t st)
{
    return st <= (uint8_t)URB_STATUS_NODE_BUSY;
}

/* An arbitrary state satisfying the invariant (every such state: all other values are free). */
static void arbitrary_state(void)
{
    uint8_t const depth = URB_NONDET_U8();
    URB_ASSUME((depth >= 1u) && (depth <= URB_BRIDGE_FIFO_MAX));
    bridge.cfg.fifo_depth = depth;
    bridge.hal = &board;
    bridge.dl.first_address = (uint8_t)URB_I2C_FIRST_ADDRESS;
    bridge.dl.last_address = (uint8_t)URB_I2C_LAST_ADDRESS;
    /* locals, not the struct's fields: a field read back after a write at a symbolic index of
     * the same struct costs the solver minutes */
    uint8_t const head = URB_NONDET_U8();
    URB_ASSUME(head < FW_RING);
    uint8_t const count = URB_NONDET_U8();
    URB_ASSUME(count <= FW_RING);
    uint8_t const slot_head = URB_NONDET_U8();
    URB_ASSUME(slot_head < depth);
    uint8_t const served = URB_NONDET_U8();
    uint8_t held = 0u;
    for (uint8_t s = 0u; s < URB_BRIDGE_FIFO_MAX; s++) { /* a free slot holds anything, payload included */
        urb_bridge_slot_t d;
        URB_NONDET_BYTES(d.data, sizeof d.data);
        d.address = URB_NONDET_U8();
        d.mailbox = URB_NONDET_U8();
        d.length = URB_NONDET_U8();
        d.read = URB_NONDET_BOOL();
        d.resp = URB_NONDET_U8();
        bridge.slots[s] = d;
    }
    for (uint8_t j = 0u; j < FW_RING; j++) {
        urb_bridge_resp_t e;
        uint8_t const r = wrap((uint8_t)(head + j), FW_RING);
        e.seq = URB_NONDET_U8();
        e.uplink = URB_NONDET_U8();
        e.status = URB_NONDET_U8();
        e.slot = URB_NONDET_U8();
        old_rank[j] = FW_NONE;
        if (j < count) {
            URB_ASSUME((e.seq <= 0x0Fu) && (e.uplink <= (uint8_t)URBB_UPLINK_USB));
            if (URB_NONDET_BOOL()) {
                URB_ASSUME(held < depth);
                uint8_t const s = wrap((uint8_t)(slot_head + held), depth);
                e.slot = s;
                /* no pointer into the struct at a symbolic offset: ESBMC resolves those over every field */
                URB_ASSUME((bridge.slots[s].address < 128u) && (bridge.slots[s].mailbox < 8u) &&
                           (bridge.slots[s].length >= 1u) && (bridge.slots[s].length <= FW_LEN_MAX));
                bridge.slots[s].resp = r;
                old_rank[j] = held;
                if (held >= served) {
                    e.status = URB_BRIDGE_PENDING;
                } else {
                    URB_ASSUME(final_status(e.status));
                }
                held++;
            } else {
                e.slot = URB_BRIDGE_NO_SLOT;
                URB_ASSUME(final_status(e.status));
            }
        }
        bridge.ring[r] = e;
    }
    URB_ASSUME(served <= held);
    bridge.ring_head = head;
    bridge.ring_count = count;
    bridge.slot_head = slot_head;
    bridge.slot_count = held;
    bridge.slot_served = served;
    /* snapshot */
    any_byte = URB_NONDET_U8();
    URB_ASSUME(any_byte < 32u);
    for (uint8_t x = 0u; x < FW_RING; x++) {
        old_ring[x] = bridge.ring[x];
    }
    for (uint8_t y = 0u; y < FW_FIFO; y++) {
        old_slots[y] = bridge.slots[y];
    }
    old_head = head;
    old_count = count;
    old_slot_head = slot_head;
    old_slot_count = held;
    old_served = served;
    for (uint8_t j = 0u; j < FW_RING; j++) {
        old_e[j] = old_ring[wrap((uint8_t)(old_head + j), FW_RING)];
        if (old_rank[j] != FW_NONE) {
            old_d[j] = old_slots[old_e[j].slot];
        }
    }
}

/* The invariant, on the state after the operation. */
static void check_invariant(void)
{
    uint8_t const depth = bridge.cfg.fifo_depth;
    URB_ASSERT(bridge.ring_head < FW_RING, "invariant: ring head inside the ring");
    URB_ASSERT(bridge.ring_count <= FW_RING, "bounded: at most RING_MAX responses outstanding");
    URB_ASSERT(bridge.slot_head < depth, "invariant: slot head inside the FIFO");
    URB_ASSERT(bridge.slot_count <= depth, "bounded: at most fifo_depth data slots in use");
    URB_ASSERT(bridge.slot_served <= bridge.slot_count, "invariant: served slots are a prefix");
    uint8_t held = 0u;
    for (uint8_t j = 0u; j < FW_RING; j++) {
        if (j < bridge.ring_count) {
            uint8_t const r = wrap((uint8_t)(bridge.ring_head + j), FW_RING);
            urb_bridge_resp_t const e = bridge.ring[r]; /* a copy: no pointer into the struct at a symbolic offset */
            if (e.slot != URB_BRIDGE_NO_SLOT) {
                URB_ASSERT(held < depth, "bounded: no more slot holders than slots");
                URB_ASSERT(e.slot == wrap((uint8_t)(bridge.slot_head + held), depth),
                           "no reuse: slot holders hold consecutive slots in ring order");
                URB_ASSERT(bridge.slots[e.slot].resp == r, "each held slot names its response");
                URB_ASSERT((e.status == URB_BRIDGE_PENDING) == (held >= bridge.slot_served),
                           "exactly the unserved slot holders are pending");
                held++;
            } else {
                URB_ASSERT(e.status != URB_BRIDGE_PENDING, "an entry without a slot is final");
            }
        }
    }
    URB_ASSERT(held == bridge.slot_count, "bounded: the slots in use are those of outstanding requests");
}

static bool same_entry(urb_bridge_resp_t const *a, urb_bridge_resp_t const *b)
{
    return (a->seq == b->seq) && (a->status == b->status) && (a->uplink == b->uplink) && (a->slot == b->slot);
}

static bool same_slot(urb_bridge_slot_t const *a, urb_bridge_slot_t const *b)
{
    return (a->address == b->address) && (a->mailbox == b->mailbox) && (a->length == b->length) &&
           (a->read == b->read) && (a->resp == b->resp) && (a->data[any_byte] == b->data[any_byte]);
}

/* Frame: every ring entry but `ring_written` and every data slot but `slot_written` (FW_NONE: none)
 * keeps its contents, free ones included. Concrete indices and copies only: a pointer into the
 * bridge makes ESBMC read through the whole struct. */
static void check_frame(uint8_t ring_written, uint8_t slot_written)
{
    for (uint8_t x = 0u; x < FW_RING; x++) {
        urb_bridge_resp_t const e = bridge.ring[x];
        if (x != ring_written) {
            URB_ASSERT(same_entry(&e, &old_ring[x]), "frame: no other response entry changes");
        }
    }
    for (uint8_t y = 0u; y < FW_FIFO; y++) {
        urb_bridge_slot_t const d = bridge.slots[y];
        if (y != slot_written) {
            URB_ASSERT(same_slot(&d, &old_slots[y]), "frame: no other data slot changes (held slots intact)");
        }
    }
}

/* The ring index r holds no outstanding response (before the operation). */
static bool not_outstanding(uint8_t r)
{
    bool free = true;
    for (uint8_t j = 0u; j < FW_RING; j++) {
        if ((j < old_count) && (wrap((uint8_t)(old_head + j), FW_RING) == r)) {
            free = false;
        }
    }
    return free;
}

#if URB_PART == 1
/* Cycles of admit's store of a whole data slot (bridge.c builds it locally): a block copy of
 * sizeof(urb_bridge_slot_t) bytes (memcpy on Cortex-M0+), which the textual cost instrumentation
 * cannot see: charged here as the model's call plus one copy-loop round per byte. */
#define FW_SLOT_STORE_CYCLES (24u + 10u * (uint32_t)sizeof(urb_bridge_slot_t))

static void lemma_admit(void)
{
    uint8_t payload[32]; /* arbitrary bytes */
    URB_NONDET_BYTES(payload, sizeof payload);
    uint8_t const uplink = URB_NONDET_BOOL() ? (uint8_t)URBB_UPLINK_USB : (uint8_t)URBB_UPLINK_RS232;
    uint8_t const seq = URB_NONDET_U8();
    uint8_t const a = URB_NONDET_U8();
    uint8_t const box = URB_NONDET_U8();
    uint8_t const len = URB_NONDET_U8();
    bool const read = URB_NONDET_BOOL();
    bool const well_formed = URB_NONDET_BOOL();
    if (well_formed) {
        URB_ASSUME((a < 128u) && (box < 8u) && (len >= 1u) && (len <= FW_LEN_MAX));
    }
    /* what the bridge knows about node a (MAX_NODES 1: the table's one entry, or unknown) */
    bridge.node_of[a & 0x7Fu] = URB_NONDET_BOOL() ? 1u : 0u;
    bridge.nodes[0].address = (uint8_t)(a & 0x7Fu);
    bridge.nodes[0].in[box & 7u] = URB_NONDET_U8();
    bridge.nodes[0].out[box & 7u] = URB_NONDET_U8();
    uint8_t const k = URB_NONDET_U8();
    URB_ASSUME(k < len);
    uint32_t const windows = bridge.stats.window_overflow;
    URB_COST_BEGIN();
    urbb_request_t const q = {uplink, seq, well_formed ? (uint8_t)URB_STATUS_OK : (uint8_t)URB_STATUS_BAD_REQUEST,
                              a, box, len, read, read ? NULL : payload};
    admit(&bridge, &q);
    if (bridge.slot_count != old_slot_count) {
        URB_COST(FW_SLOT_STORE_CYCLES);
    }
    URB_COST_END(FW_COST_BUDGET);
    check_invariant();
    URB_ASSERT((bridge.ring_head == old_head) && (bridge.slot_head == old_slot_head) &&
               (bridge.slot_served == old_served), "admit: the heads and the served prefix stay");
    if (old_count >= FW_RING) {
        check_frame(FW_NONE, FW_NONE);
        URB_ASSERT(bridge.stats.window_overflow == windows + 1u, "beyond the window: counted ...");
        URB_ASSERT((bridge.ring_count == old_count) && (bridge.slot_count == old_slot_count), "... and not answered");
        URB_COVER("part1-beyond-the-window");
        return;
    }
    URB_ASSERT(bridge.ring_count == (uint8_t)(old_count + 1u), "bounded: one response slot per request");
    uint8_t const r = wrap((uint8_t)(old_head + old_count), FW_RING);
    URB_ASSERT(not_outstanding(r), "order: the new response takes a free entry at the end of the ring");
    urb_bridge_resp_t const e = bridge.ring[r];
    check_frame(r, (e.status == URB_BRIDGE_PENDING) ? e.slot : FW_NONE);
    URB_ASSERT((e.seq == (uint8_t)(seq & 0x0Fu)) && (e.uplink == uplink),
               "order: the response takes the end of the ring, with its request's seq and uplink");
    /* Bridge.tla AdmissionStatus, with the sizes the bridge knows */
    bool const reserved = (a != URB_BRIDGE_ADDRESS) && ((a < (uint8_t)URB_I2C_FIRST_ADDRESS) || (a > (uint8_t)URB_I2C_LAST_ADDRESS));
    int16_t size = -1;
    if (a == URB_BRIDGE_ADDRESS) {
        size = read ? (int16_t)urb_node_bridge_outbox_sizes[box & 7u] : (int16_t)urb_node_bridge_inbox_sizes[box & 7u];
    } else if (bridge.node_of[a & 0x7Fu] != 0u) {
        size = read ? (int16_t)bridge.nodes[0].out[box & 7u] : (int16_t)bridge.nodes[0].in[box & 7u];
    }
    if (!well_formed || reserved) {
        URB_ASSERT(e.status == URB_STATUS_BAD_REQUEST, "admission: a malformed request or reserved address is BAD_REQUEST");
        URB_COVER("part1-bad-request");
    } else if ((size >= 0) && (size != (int16_t)len)) {
        URB_ASSERT(e.status == URB_STATUS_SIZE_MISMATCH, "admission: a length the mailbox does not have");
        URB_COVER("part1-size-mismatch");
    } else if (old_slot_count >= bridge.cfg.fifo_depth) {
        URB_ASSERT(e.status == URB_STATUS_BUSY, "BUSY when every data slot is taken");
        URB_COVER("part1-busy");
    } else {
        URB_ASSERT(e.status == URB_BRIDGE_PENDING, "BUSY only when every data slot is taken: admitted");
        for (uint8_t j = 0u; j < FW_RING; j++) {
            if ((j < old_count) && (old_rank[j] != FW_NONE)) {
                URB_ASSERT(old_e[j].slot != e.slot, "no reuse: the new slot is held by no outstanding request");
            }
        }
        urb_bridge_slot_t const d = bridge.slots[e.slot];
        URB_ASSERT((d.address == a) && (d.mailbox == box) && (d.length == len) && (d.read == read),
                   "the slot holds the request");
        if (!read) {
            URB_ASSERT(d.data[k] == payload[k], "the slot holds the request's payload");
            URB_COVER("part1-write-admitted");
        }
        if (r < old_head) {
            URB_COVER("part1-admitted-into-a-wrapped-ring");
        }
        return;
    }
    URB_ASSERT(bridge.slot_count == old_slot_count, "an admission error takes no data slot");
}
#endif

#if URB_PART == 2
static void lemma_complete(void)
{
    uint8_t const status = URB_NONDET_U8();
    URB_ASSUME(final_status(status));
    /* the oldest pending request, by the invariant's definition: the first PENDING in ring order */
    uint8_t oldest = FW_NONE;
    for (uint8_t j = 0u; j < FW_RING; j++) {
        if ((oldest == FW_NONE) && (j < old_count) && (old_e[j].status == URB_BRIDGE_PENDING)) {
            oldest = j;
        }
    }
    if (oldest != FW_NONE) { /* the node table: the served node known or not, the one entry used or free */
        bridge.node_of[old_d[oldest].address] = URB_NONDET_BOOL() ? 1u : 0u;
        bridge.nodes[0].address = URB_NONDET_U8();
    }
    /* what the serving code starts on (start_next, served, probed) and complete serves */
    uint8_t const s = first_pending(&bridge);
    urb_bridge_slot_t const *d = oldest_pending(&bridge);
    URB_COST_BEGIN();
    complete(&bridge, status);
    URB_COST_END(FW_COST_BUDGET);
    check_invariant();
    URB_ASSERT((bridge.ring_head == old_head) && (bridge.ring_count == old_count) &&
               (bridge.slot_head == old_slot_head) && (bridge.slot_count == old_slot_count),
               "complete: the ring and the FIFO keep their extent");
    if (oldest == FW_NONE) {
        URB_ASSERT((s == URB_BRIDGE_NO_SLOT) && (d == NULL), "nothing pending: nothing to serve");
        URB_ASSERT(bridge.slot_served == old_served, "nothing pending: nothing served");
        check_frame(FW_NONE, FW_NONE);
        URB_COVER("part2-nothing-pending");
        return;
    }
    URB_ASSERT((s == old_e[oldest].slot) && (d == &bridge.slots[s]), "serve order: the oldest pending request is served");
    URB_ASSERT(bridge.slot_served == (uint8_t)(old_served + 1u), "serve order: one more served");
    uint8_t const r = wrap((uint8_t)(old_head + oldest), FW_RING);
    urb_bridge_resp_t const e = bridge.ring[r];
    URB_ASSERT(e.status == status, "its response takes the outcome");
    URB_ASSERT((e.seq == old_e[oldest].seq) && (e.uplink == old_e[oldest].uplink) && (e.slot == old_e[oldest].slot),
               "its response keeps its place, seq, uplink and slot");
    check_frame(r, FW_NONE);
    if (oldest > 0u) {
        URB_COVER("part2-served-behind-an-outstanding-response");
    }
}
#endif

#if URB_PART == 3
bool urbb_uplink_send(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    URB_ASSERT(b == &bridge, "send: the bridge under proof");
    URB_ASSERT((len >= 2u) && (len <= URB_UPLINK_RESPONSE_MAX_SIZE), "send: a response frame");
    URB_COST(FW_UPLINK_SEND_ENTRY_CYCLES);
    if (room == 0u) {
        return false;
    }
    URB_COST(FW_UPLINK_SEND_COPY_CYCLES(len));
    room--;
    URB_ASSERT(sent < old_count, "order: a response only for an outstanding request");
    urb_bridge_resp_t const *e = &old_e[sent];
    URB_ASSERT(uplink == e->uplink, "order: the response goes back on its request's uplink");
    URB_ASSERT((frame[0] & 0x0Fu) == e->seq, "order: the oldest outstanding request is answered first");
    URB_ASSERT(e->status != URB_BRIDGE_PENDING, "order: only a final response leaves");
    URB_ASSERT((frame[0] >> 4) == e->status, "the response carries its request's status");
    bool const data = (e->status == URB_STATUS_OK) && (old_rank[sent] != FW_NONE) && old_d[sent].read;
    uint8_t const n = data ? old_d[sent].length : 0u;
    uint8_t const check = ((1u + n) <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u;
    URB_ASSERT(len == (uint8_t)(1u + n + check), "the response carries an OK read's data, nothing else");
    if (data) {
        uint8_t const k = URB_NONDET_U8();
        URB_ASSUME(k < n);
        URB_ASSERT(frame[1u + k] == old_d[sent].data[k], "an OK read's response carries the slot's data");
    }
    sent++;
    return true;
}

static void lemma_emit(void)
{
    room = URB_NONDET_U8();
    URB_ASSUME(room <= FW_RING + 1u);
    uint8_t const room0 = room;
    sent = 0u;
    URB_COST_BEGIN();
    emit(&bridge);
    /* amortised per response sent (the tail that finds the next one pending or refused included) */
    uint32_t const cost = urb_proof_cost;
    URB_ASSERT(cost <= FW_COST_BUDGET * (uint32_t)((sent > 0u) ? sent : 1u), "cost: within the budget per response sent");
    /* constant divisors: a division by the symbolic count costs the solver far more */
    urb_proof_cost = (sent <= 1u) ? cost
                   : (sent == 2u) ? (cost + 1u) / 2u
                   : (sent == 3u) ? (cost + 2u) / 3u
                                  : (cost + 3u) / 4u;
    URB_COST_END(FW_COST_BUDGET);
    check_invariant();
    /* emit stops exactly at a pending response, an empty ring or a full uplink */
    uint8_t finals = 0u; /* final entries at the head */
    uint8_t freed = 0u;  /* data slots among the first `sent` */
    for (uint8_t j = 0u; j < FW_RING; j++) {
        if ((finals == j) && (j < old_count) && (old_e[j].status != URB_BRIDGE_PENDING)) {
            finals++;
        }
        if ((j < sent) && (old_rank[j] != FW_NONE)) {
            freed++;
        }
    }
    uint8_t const want = (finals < room0) ? finals : room0;
    URB_ASSERT(sent == want, "emit sends every final response at the head it may, and no other");
    URB_ASSERT(bridge.ring_count == (uint8_t)(old_count - sent), "freed exactly the responses sent");
    URB_ASSERT(bridge.ring_head == wrap((uint8_t)(old_head + sent), FW_RING), "the head moves past the responses sent");
    URB_ASSERT((bridge.slot_count == (uint8_t)(old_slot_count - freed)) &&
               (bridge.slot_served == (uint8_t)(old_served - freed)) &&
               (bridge.slot_head == wrap((uint8_t)(old_slot_head + freed), bridge.cfg.fifo_depth)),
               "the data slots of the responses sent are freed, in FIFO order");
    check_frame(FW_NONE, FW_NONE); /* emit moves heads and counts only: the rest of the ring stays as it was */
    if ((sent == finals) && (finals < old_count)) {
        URB_COVER("part3-emission-stops-at-a-pending-response");
    }
    if ((sent == room0) && (sent < finals)) {
        URB_COVER("part3-emission-stopped-by-the-uplink");
    }
    if (freed > 0u) {
        URB_COVER("part3-a-data-slot-freed");
    }
}
#else
bool urbb_uplink_send(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    (void)b;
    (void)uplink;
    (void)frame;
    (void)len;
    URB_ASSERT(false, "only emit sends a response");
    return false;
}
#endif

void harness(void)
{
    arbitrary_state();
#if URB_PART == 1
    lemma_admit();
#elif URB_PART == 2
    lemma_complete();
#elif URB_PART == 3
    lemma_emit();
#else
#error "set URB_PART (the Makefile's SWEEP)"
#endif
}
