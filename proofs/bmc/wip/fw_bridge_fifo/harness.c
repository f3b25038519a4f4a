/*
 * Proof of the bridge's request FIFO (firmware/bridge/bridge.c, Bridge.tla SubmitAndAdmit, Serve,
 * Emit): the response ring (arrival order, header only) and the data slots (a FIFO inside it).
 *
 * The harness includes the prepared (cost-instrumented, maybe mutated) bridge.c to reach its
 * static functions: admit() (what urbb_frame does with a frame that passed its check), complete()
 * (the downlink's outcome for the oldest pending request, Serve) and emit() (Emit). FW_OPS steps,
 * each chosen by the solver: admit a request (either uplink, any address including the bridge's own
 * and reserved ones, any mailbox, direction and length, well-formed or BAD_REQUEST), complete the
 * oldest pending request with any status, or emit while the uplink accepts some responses and then
 * refuses (full). A shadow of Bridge.tla's queue (arrival order, slot held, final status) is
 * checked after every step.
 *
 * Properties (besides bounds, pointers, overflow and shifts on every access):
 *   order       responses leave in admission order, each on its request's uplink with its
 *               sequence number; a pending response holds back every later one (even a final BUSY)
 *   serve order complete() finishes the oldest pending request (FirstPending)
 *   BUSY        a well-formed request is answered BUSY exactly when every data slot is taken
 *   bounded     at most fifo_depth data slots and URB_BRIDGE_RING_MAX responses are outstanding;
 *               beyond the host window a request is counted, not answered
 *   no reuse    a new request's data slot is held by no outstanding request, and its payload is
 *               the request's, intact until its response has left
 *   cost        admit, complete and each emitted response within FW_COST_BUDGET
 * Capacities are lowered for the proof (FIFO 2, ring 3): the code is generic in them.
 */
#include "urb_verify.h"

#include "bridge.c"

#include "../stubs/fw_budgets.h"
#include "fw_bridge_check.h"

#define FW_COST_BUDGET FW_BRIDGE_FIFO_OP_BUDGET

#ifndef FW_OPS
#define FW_OPS 8u
#endif
#define FW_MAX_REQ FW_OPS
#ifndef FW_LEN_MAX
#define FW_LEN_MAX 4u /* payload lengths tried (the FIFO never looks at the bytes beyond the first) */
#endif

URB_PROOF_COST_STORAGE;

static urb_bridge_t bridge;
static const urb_bridge_hal_t board = {NULL, NULL, NULL, NULL, NULL};

/* Shadow of the model: every request admitted (answered or to be answered), in arrival order. */
static uint8_t req_uplink[FW_MAX_REQ];
static uint8_t req_seq[FW_MAX_REQ];
static uint8_t req_status[FW_MAX_REQ]; /* final status, or URB_BRIDGE_PENDING */
static uint8_t req_slot[FW_MAX_REQ];   /* data slot, or URB_BRIDGE_NO_SLOT */
static uint8_t req_byte[FW_MAX_REQ];   /* first payload byte of a write */
static uint8_t req_count;              /* admitted */
static uint8_t req_emitted;            /* responses gone (a prefix) */
static uint8_t req_served;             /* slot holders served (complete() called) */
static uint8_t seq_next;
static uint8_t held;                   /* data slots the outstanding requests hold */

/* The uplink: accepts responses while `room` lasts. */
static uint8_t room;
static uint8_t sent;

bool urbb_uplink_send(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    URB_ASSERT(b == &bridge, "send: the bridge under proof");
    URB_ASSERT((len >= 2u) && (len <= URB_UPLINK_RESPONSE_MAX_SIZE), "send: a response frame");
    if (room == 0u) {
        return false;
    }
    room--;
    URB_ASSERT(req_emitted < req_count, "order: a response only for an admitted request");
    uint8_t const i = req_emitted;
    URB_ASSERT(uplink == req_uplink[i], "order: the response goes back on its request's uplink");
    URB_ASSERT((frame[0] & 0x0Fu) == req_seq[i], "order: the oldest outstanding request is answered first");
    URB_ASSERT(req_status[i] != URB_BRIDGE_PENDING, "order: only a final response leaves");
    URB_ASSERT((frame[0] >> 4) == req_status[i], "the response carries its request's status");
    if (req_slot[i] != URB_BRIDGE_NO_SLOT) {
        held--;
    }
    req_emitted++;
    sent++;
    return true;
}

static uint8_t payload[32];

static void op_admit(void)
{
    uint8_t const uplink = URB_NONDET_BOOL() ? (uint8_t)URBB_UPLINK_USB : (uint8_t)URBB_UPLINK_RS232;
    uint8_t const a = URB_NONDET_U8();
    uint8_t const box = URB_NONDET_U8();
    uint8_t const len = URB_NONDET_U8();
    bool const read = URB_NONDET_BOOL();
    bool const well_formed = URB_NONDET_BOOL();
    URB_ASSUME((a < 128u) && (box < 8u) && (len >= 1u) && (len <= FW_LEN_MAX));
    payload[0] = URB_NONDET_U8();
    uint8_t const outstanding = (uint8_t)(req_count - req_emitted);
    uint8_t const held_before = held;
    uint32_t const windows = bridge.stats.window_overflow;
    uint8_t const seq = seq_next;
    URB_COST_BEGIN();
    admit(&bridge, uplink, seq, well_formed ? (uint8_t)URB_STATUS_OK : (uint8_t)URB_STATUS_BAD_REQUEST, a, box, read,
          len, read ? NULL : payload);
    URB_COST_END(FW_COST_BUDGET);
    if (outstanding >= URB_BRIDGE_RING_MAX) {
        URB_ASSERT(bridge.stats.window_overflow == windows + 1u, "beyond the window: counted ...");
        URB_ASSERT(bridge.ring_count == URB_BRIDGE_RING_MAX, "... and not answered");
        return;
    }
    seq_next = (uint8_t)((seq_next + 1u) & 0x0Fu);
    URB_ASSERT(bridge.ring_count == (uint8_t)(outstanding + 1u), "bounded: one response slot per request");
    urb_bridge_resp_t const *e = &bridge.ring[ring_index(bridge.ring_head, outstanding)];
    uint8_t const i = req_count;
    req_uplink[i] = uplink;
    req_seq[i] = seq;
    req_slot[i] = e->slot;
    req_status[i] = e->status;
    req_byte[i] = payload[0];
    req_count++;
    /* What admission must decide (Bridge.tla AdmissionStatus; no node sizes are known here). */
    bool const reserved = (a != URB_BRIDGE_ADDRESS) && ((a < 0x08u) || (a > 0x77u));
    bool const bridge_size_ok = (a != URB_BRIDGE_ADDRESS) ||
                                (len == (read ? urb_node_bridge_outbox_sizes[box] : urb_node_bridge_inbox_sizes[box]));
    if (!well_formed || reserved) {
        URB_ASSERT(e->status == URB_STATUS_BAD_REQUEST, "admission: a malformed request or reserved address is BAD_REQUEST");
    } else if (!bridge_size_ok) {
        URB_ASSERT(e->status == URB_STATUS_SIZE_MISMATCH, "admission: a length the bridge's mailbox does not have");
    } else if (held_before >= bridge.cfg.fifo_depth) {
        URB_ASSERT(e->status == URB_STATUS_BUSY, "BUSY when every data slot is taken");
    } else {
        URB_ASSERT(e->status == URB_BRIDGE_PENDING, "BUSY only when every data slot is taken: admitted");
        URB_ASSERT(e->slot < bridge.cfg.fifo_depth, "a data slot of the FIFO");
        for (uint8_t j = 0u; j < FW_MAX_REQ; j++) {
            if ((j >= req_emitted) && (j < i)) {
                URB_ASSERT(req_slot[j] != e->slot, "no reuse: the new slot is held by no outstanding request");
            }
        }
        urb_bridge_slot_t const *d = &bridge.slots[e->slot];
        URB_ASSERT((d->address == a) && (d->mailbox == box) && (d->length == len) && (d->read == read),
                   "the slot holds the request");
    }
    URB_ASSERT((e->status == URB_BRIDGE_PENDING) == (e->slot != URB_BRIDGE_NO_SLOT),
               "a slot exactly for the requests that wait for the downlink");
    if (e->slot != URB_BRIDGE_NO_SLOT) {
        held++;
    }
}

static void op_complete(void)
{
    uint8_t const status = URB_NONDET_U8();
    URB_ASSUME(status <= (uint8_t)URB_STATUS_NODE_BUSY);
    /* The oldest pending request in the shadow. */
    uint8_t oldest = FW_MAX_REQ;
    for (uint8_t j = 0u; j < FW_MAX_REQ; j++) {
        if ((oldest == FW_MAX_REQ) && (j < req_count) && (req_status[j] == URB_BRIDGE_PENDING)) {
            oldest = j;
        }
    }
    URB_COST_BEGIN();
    urb_bridge_slot_t *d = oldest_pending(&bridge);
    complete(&bridge, status);
    URB_COST_END(FW_COST_BUDGET);
    if (oldest == FW_MAX_REQ) {
        URB_ASSERT(d == NULL, "nothing pending: nothing to serve");
        return;
    }
    URB_ASSERT(d == &bridge.slots[req_slot[oldest]], "serve order: the oldest pending request is served");
    URB_ASSERT(bridge.ring[d->resp].status == status, "its response takes the outcome");
    req_status[oldest] = status;
    req_served++;
}

static void op_emit(void)
{
    room = URB_NONDET_U8();
    URB_ASSUME(room <= 2u);
    sent = 0u;
    uint8_t const before = req_emitted;
    URB_COST_BEGIN();
    emit(&bridge);
    uint32_t const cost = urb_proof_cost;
    URB_ASSERT(cost <= FW_COST_BUDGET * (uint32_t)((sent > 0u) ? sent : 1u), "cost: each emitted response within the budget");
    /* emit stops exactly at a pending response or a full uplink */
    bool const blocked = (req_emitted == req_count) || (req_status[req_emitted] == URB_BRIDGE_PENDING) || (room == 0u);
    URB_ASSERT(blocked, "emit sends every final response it may");
    URB_ASSERT(bridge.ring_count == (uint8_t)(req_count - req_emitted), "freed exactly the responses sent");
    (void)before;
}

static void check_invariants(void)
{
    URB_ASSERT(bridge.slot_count == held, "bounded: the data slots in use are those of outstanding requests");
    URB_ASSERT(bridge.slot_count <= bridge.cfg.fifo_depth, "bounded: at most fifo_depth data slots");
    URB_ASSERT(bridge.ring_count <= URB_BRIDGE_RING_MAX, "bounded: at most RING_MAX responses");
    for (uint8_t j = 0u; j < FW_MAX_REQ; j++) {
        if ((j >= req_emitted) && (j < req_count) && (req_slot[j] != URB_BRIDGE_NO_SLOT)) {
            urb_bridge_slot_t const *d = &bridge.slots[req_slot[j]];
            if (!d->read) {
                URB_ASSERT(d->data[0] == req_byte[j], "no reuse: a write's payload stays intact until its response left");
            }
        }
    }
}

void harness(void)
{
    bridge.cfg.fifo_depth = URB_NONDET_U8();
    URB_ASSUME((bridge.cfg.fifo_depth >= 1u) && (bridge.cfg.fifo_depth <= URB_BRIDGE_FIFO_MAX));
    bridge.hal = &board;
    bridge.dl.first_address = (uint8_t)URB_I2C_FIRST_ADDRESS;
    bridge.dl.last_address = (uint8_t)URB_I2C_LAST_ADDRESS;
    /* ring_head, slot_head: anywhere (wrap-around from the start) */
    bridge.ring_head = URB_NONDET_U8();
    URB_ASSUME(bridge.ring_head < URB_BRIDGE_RING_MAX);
    bridge.slot_head = URB_NONDET_U8();
    URB_ASSUME(bridge.slot_head < bridge.cfg.fifo_depth);
    for (uint8_t s = 0u; s < FW_OPS; s++) {
        uint8_t const op = URB_NONDET_U8();
        if (op == 0u) {
            op_complete();
        } else if (op == 1u) {
            op_emit();
        } else {
            op_admit();
        }
        check_invariants();
    }
}
