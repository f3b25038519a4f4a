/*
 * URB bridge core: admission, the request FIFO, serving on the downlink or locally (address 0),
 * emitting responses in order, discovery and the SYNC heartbeat.
 *
 * Memory follows Bridge.tla (its queue): a ring of response slots (header only) in arrival order, and a FIFO
 * of data slots (payload buffers) held from admission until the response has left. Admission
 * errors take a response slot but no data slot, so they keep their place in the answer order
 * without using a payload buffer. Data slots are allocated in ring order and freed in ring order
 * (responses leave in order), so they form a FIFO inside the ring: head = oldest not yet emitted,
 * head + served = oldest not yet served (Bridge.tla FirstPending, found in O(1)).
 */
#include "bridge_internal.h"

#include "urb_core.h"
#include "urb_runtime.h"

/* ===== Small helpers ========================================================================== */

/* ACSL for Frama-C WP (proofs/framac/fifo/): the response ring and the data-slot FIFO inside it
 * never index outside their arrays, keep their counts within the configured depth (urbb_fifo_ok,
 * bridge_internal.h), and admission answers BUSY only when every data slot is taken (Bridge.tla
 * SubmitAndAdmit). */
/*@ logic integer urbb_ring_at(integer head, integer offset) =
      head + offset < URB_BRIDGE_RING_MAX ? head + offset : head + offset - URB_BRIDGE_RING_MAX;

    logic integer urbb_slot_at(urb_bridge_t *b, integer offset) =
      b->slot_head + offset < b->cfg.fifo_depth ? b->slot_head + offset : b->slot_head + offset - b->cfg.fifo_depth;

    predicate urbb_slots_ok(urb_bridge_t *b) =
      \forall integer j; 0 <= j < URB_BRIDGE_FIFO_MAX ==>
        b->slots[j].resp < URB_BRIDGE_RING_MAX && b->slots[j].address < 128;

*/

/*@ requires head < URB_BRIDGE_RING_MAX && offset <= URB_BRIDGE_RING_MAX;
    assigns \nothing;
    ensures \result == urbb_ring_at(head, offset) && \result < URB_BRIDGE_RING_MAX; */
static uint8_t ring_index(uint8_t head, uint8_t offset)
{
    uint8_t i = (uint8_t)(head + offset);
    if (i >= URB_BRIDGE_RING_MAX) {
        i = (uint8_t)(i - URB_BRIDGE_RING_MAX);
    }
    return i;
}

/* Wrap without a division: Cortex-M0+ has no divide instruction. */
/*@ requires urbb_fifo_ok(b) && offset <= b->cfg.fifo_depth;
    assigns \nothing;
    ensures \result == urbb_slot_at(b, offset) && \result < b->cfg.fifo_depth; */
static uint8_t slot_index(const urb_bridge_t *b, uint8_t offset)
{
    uint8_t i = (uint8_t)(b->slot_head + offset);
    if (i >= b->cfg.fifo_depth) {
        i = (uint8_t)(i - b->cfg.fifo_depth);
    }
    return i;
}

/* The contract states the HAL rule for `mark` (urb_bridge_hal.h: it calls no bridge function): a
 * hypothesis for WP, reviewed, never proved (mark is in no -wp-fct; proofs/framac/README.md). It
 * speaks of the bridge's memory only: the HAL's own state behind ctx is no part of it. */
/*@ requires \valid_read(b) && \valid_read(b->hal);
    assigns \nothing; */
static void mark(const urb_bridge_t *b, uint8_t id, bool level)
{
    if (b->hal->mark != NULL) {
        b->hal->mark(b->hal->ctx, id, level);
    }
}

static void set_present(urb_bridge_t *b, uint8_t a, bool on)
{
    uint8_t const bit = (uint8_t)(1u << (a & 7u));
    if (on) {
        b->present[a >> 3] = (uint8_t)(b->present[a >> 3] | bit);
    } else {
        b->present[a >> 3] = (uint8_t)(b->present[a >> 3] & (uint8_t)~bit);
    }
}

/* ===== What the bridge knows about its nodes ================================================== */

/*@ requires \valid(b) && urbb_nodes_ok(b);
    assigns b->nodes[0 .. URB_BRIDGE_MAX_NODES - 1].address, b->node_of[0 .. 127];
    ensures urbb_nodes_ok(b); */
static void node_forget(urb_bridge_t *b, uint8_t a)
{
    uint8_t const i = (uint8_t)(a % 128u); /* % rather than & 0x7F: the provers reason about it */
    uint8_t const k = b->node_of[i];
    if (k != 0u) {
        b->nodes[k - 1u].address = 0u;
        b->node_of[i] = 0u;
    }
}

/* Remember the mailbox sizes a node reported in its Identification (outbox 0). */
/*@ requires \valid(b) && urbb_nodes_ok(b) && a < 128;
    requires \valid_read(frame + (0 .. URB_IDENTIFICATION_SIZE - 1));
    requires \separated(frame + (0 .. URB_IDENTIFICATION_SIZE - 1), &b->nodes[0 .. URB_BRIDGE_MAX_NODES - 1],
                        &b->node_of[0 .. 127]);
    assigns b->nodes[0 .. URB_BRIDGE_MAX_NODES - 1], b->node_of[0 .. 127];
    ensures urbb_nodes_ok(b); */
static void node_learn(urb_bridge_t *b, uint8_t a, const uint8_t *frame)
{
    urb_identification_t id;
    if (urb_identification_decode(&id, frame, URB_IDENTIFICATION_SIZE) < 0) {
        node_forget(b, a); /* unreadable identification: sizes unknown, requests go to the node */
        return;
    }
    uint8_t k = b->node_of[a];
    /* loop bound: URB_BRIDGE_MAX_NODES entries */
    /*@ loop invariant 0 <= i <= URB_BRIDGE_MAX_NODES && k <= URB_BRIDGE_MAX_NODES;
        loop assigns i, k;
        loop variant URB_BRIDGE_MAX_NODES - i; */
    for (uint8_t i = 0u; (k == 0u) && (i < URB_BRIDGE_MAX_NODES); i++) {
        if (b->nodes[i].address == 0u) {
            k = (uint8_t)(i + 1u);
        }
    }
    if (k == 0u) {
#ifdef URB_MUTANT_TABLE_FULL_OVERWRITE
        k = 1u; /* mutant: a node past the full table takes the first node's entry */
#else
        return; /* table full: this node's sizes stay unknown (checked by the node itself) */
#endif
    }
    /* built here and stored whole: as for admit's data slot (proofs/bmc/fw_bridge_fifo) */
    urb_bridge_node_t n;
    n.address = a;
    /* loop bound: 8 mailboxes */
    /*@ loop invariant 0 <= i <= 8;
        loop assigns i, n.in[0 .. 7], n.out[0 .. 7];
        loop variant 8 - i; */
    for (uint8_t i = 0u; i < 8u; i++) {
        n.in[i] = id.inbox_sizes[i];
        n.out[i] = id.outbox_sizes[i];
    }
    b->nodes[k - 1u] = n;
    b->node_of[a] = k;
}

/* Mailbox size learnt for (a, box, dir), or -1 when unknown. */
/*@ requires \valid_read(b) && urbb_nodes_ok(b) && a < 128 && box < 8;
    assigns \nothing;
    ensures -1 <= \result <= 255; */
static int16_t known_size(const urb_bridge_t *b, uint8_t a, uint8_t box, bool read)
{
    if (a == URB_BRIDGE_ADDRESS) {
        return read ? (int16_t)urb_node_bridge_outbox_sizes[box] : (int16_t)urb_node_bridge_inbox_sizes[box];
    }
    uint8_t const k = b->node_of[a];
    if (k == 0u) {
        return -1;
    }
    return read ? (int16_t)b->nodes[k - 1u].out[box] : (int16_t)b->nodes[k - 1u].in[box];
}

/* ===== Admission ============================================================================== */

/* Bridge.tla AdmissionStatus. Header validation without downlink traffic. An address the last
 * scan did not find is NOT refused: a node may appear after the scan; the downlink decides. */
/*@ requires \valid_read(b) && urbb_nodes_ok(b) && a < 128 && box < 8;
    assigns \nothing;
    ensures \result == URB_STATUS_OK || \result == URB_STATUS_BAD_REQUEST || \result == URB_STATUS_SIZE_MISMATCH; */
static uint8_t admission_status(const urb_bridge_t *b, uint8_t a, uint8_t box, bool read, uint8_t len)
{
    if ((a != URB_BRIDGE_ADDRESS) && ((a < b->dl.first_address) || (a > b->dl.last_address))) {
        return URB_STATUS_BAD_REQUEST; /* reserved downlink address */
    }
    int16_t const size = known_size(b, a, box, read);
    if ((size >= 0) && (size != (int16_t)len)) {
        return URB_STATUS_SIZE_MISMATCH; /* includes mailboxes the node does not use (size 0) */
    }
    return URB_STATUS_OK;
}

static bool emit_entry(urb_bridge_t *b, uint8_t r);

/* One request as admission sees it, from either uplink. */
typedef struct {
    uint8_t uplink;  /* where its response goes */
    uint8_t seq;     /* its sequence number (4 bits kept) */
    uint8_t status;  /* OK: well-formed; BAD_REQUEST: passed its check but breaks a schema rule */
    uint8_t address, mailbox, length;
    bool read;
    const uint8_t *data; /* a write's payload (length bytes); NULL for a read */
} urbb_request_t;

/* Fill data slot s with request q, answered in ring entry r. The slot is built locally and stored
 * whole (see admit); payload bytes past the request's length are no part of it (nothing reads
 * them): not cleared. A function of its own so that WP proves admit without the payload copy. */
/*@ requires \valid(b) && s < URB_BRIDGE_FIFO_MAX && \valid_read(q) && \separated(q, b) && q->length <= 32;
    requires !q->read ==> \valid_read(q->data + (0 .. q->length - 1)) && \separated(q->data + (0 .. q->length - 1), b);
    assigns b->slots[s];
    ensures b->slots[s].resp == r; */
static void store_slot(urb_bridge_t *b, uint8_t s, uint8_t r, const urbb_request_t *q)
{
    urb_bridge_slot_t d;
    d.address = q->address;
    d.mailbox = q->mailbox;
    d.length = q->length;
    d.read = q->read;
    d.resp = r;
    /* loop bound: 32 bytes */
    /*@ loop invariant 0 <= i <= 32;
        loop assigns i, d.data[0 .. 31];
        loop variant 32 - i; */
    for (uint8_t i = 0u; (!q->read) && (i < q->length) && (i < 32u); i++) {
        d.data[i] = q->data[i];
    }
    b->slots[s] = d;
}

/* Bridge.tla: SubmitAndAdmit. */
/*@ requires \valid(b) && urbb_fifo_ok(b) && urbb_nodes_ok(b);
    requires \valid_read(q) && \separated(q, b);
    requires q->status == URB_STATUS_OK || q->status == URB_STATUS_BAD_REQUEST;
    requires q->status == URB_STATUS_OK ==> q->address < 128 && q->mailbox < 8 && q->length <= 32;
    requires q->status == URB_STATUS_OK && !q->read ==>
               \valid_read(q->data + (0 .. q->length - 1)) && \separated(q->data + (0 .. q->length - 1), b);
    assigns b->ring[0 .. URB_BRIDGE_RING_MAX - 1], b->ring_count, b->slots[0 .. URB_BRIDGE_FIFO_MAX - 1], b->slot_count,
            b->stats.window_overflow, b->stats.busy;
    ensures urbb_fifo_ok(b);
    behavior window_overflow:
      assumes b->ring_count >= URB_BRIDGE_RING_MAX;
      assigns b->stats.window_overflow;
      ensures b->ring_count == \old(b->ring_count) && b->slot_count == \old(b->slot_count);
    behavior answered:
      assumes b->ring_count < URB_BRIDGE_RING_MAX;
      ensures b->ring_count == \old(b->ring_count) + 1;
      ensures b->ring[urbb_ring_at(b->ring_head, \old(b->ring_count))].status == URB_STATUS_BUSY ==>
                \old(b->slot_count) == b->cfg.fifo_depth;
      ensures b->ring[urbb_ring_at(b->ring_head, \old(b->ring_count))].status == URB_BRIDGE_PENDING ==>
                b->slot_count == \old(b->slot_count) + 1 &&
                b->ring[urbb_ring_at(b->ring_head, \old(b->ring_count))].slot == urbb_slot_at(b, \old(b->slot_count)) &&
                b->slots[urbb_slot_at(b, \old(b->slot_count))].resp == urbb_ring_at(b->ring_head, \old(b->ring_count));
      ensures b->ring[urbb_ring_at(b->ring_head, \old(b->ring_count))].status != URB_BRIDGE_PENDING ==>
                b->slot_count == \old(b->slot_count);
    complete behaviors;
    disjoint behaviors; */
static void admit(urb_bridge_t *b, const urbb_request_t *q)
{
    if (b->ring_count >= URB_BRIDGE_RING_MAX) {
        /* The host has more requests outstanding than its window (Bridge.tla HostWindow): outside
         * the contract, and there is no slot left even for a BUSY. Counted, not answered. */
        b->stats.window_overflow++;
        return;
    }
    uint8_t status = q->status;
    if (status == URB_STATUS_OK) {
        status = admission_status(b, q->address, q->mailbox, q->read, q->length);
    }
    if (status == URB_STATUS_OK) {
#if defined(URB_MUTANT_FIFO_OFF_BY_ONE)
        bool const full = (uint8_t)(b->slot_count + 1u) >= b->cfg.fifo_depth; /* mutant: one slot never used */
#else
        bool const full = b->slot_count >= b->cfg.fifo_depth;
#endif
        if (full) {
#ifdef URB_MUTANT_DROP_WHEN_FULL
            return; /* mutant: silent drop */
#else
            status = URB_STATUS_BUSY; /* Bridge.tla: SubmitAndAdmit, BUSY only when every data slot is taken */
            b->stats.busy++;
#endif
        }
    }
    /* The ring entry is built here and stored whole, by index (the data slot likewise, in
     * store_slot): the bounded model checker (proofs/bmc/fw_bridge_fifo) turns every store at a
     * variable index inside the bridge into an update of the whole struct, one per field otherwise. */
    uint8_t const r = ring_index(b->ring_head, b->ring_count);
    urb_bridge_resp_t e = {(uint8_t)(q->seq & 0x0Fu), status, q->uplink, URB_BRIDGE_NO_SLOT};
    if (status == URB_STATUS_OK) {
        uint8_t const s = slot_index(b, b->slot_count);
        store_slot(b, s, r, q);
        e.status = URB_BRIDGE_PENDING;
        e.slot = s;
        b->slot_count++;
    }
    b->ring[r] = e;
#ifdef URB_MUTANT_REORDER
    if (e.slot == URB_BRIDGE_NO_SLOT) {
        /* mutant (Bridge_BusyOvertakes): an admission error leaves at once, ahead of earlier requests */
        (void)emit_entry(b, r);
        return;
    }
#endif
    b->ring_count++;
}

/* The decoders' contracts state every decoded member's range (gen/c): with them WP proves admit's
 * preconditions here, and this function's contract (bridge_internal.h) for its callers, the
 * uplink parsers (proofs/framac/frame, proofs/framac/uplink_parsers). */
bool urbb_frame(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len)
{
    /* A range error (r < 0 but not a check, short or long frame) in a frame whose check passed: it
     * was meant as a request, so it is answered BAD_REQUEST. The decoder stopped before assigning
     * every member then, so only a well-formed request's members are copied. */
    urbb_request_t req = {uplink, (uint8_t)(frame[1] >> 4), URB_STATUS_BAD_REQUEST, 0u, 0u, 0u, (frame[0] & 1u) != 0u,
                          NULL};
    urb_uplink_write_request_t w; /* outside the branch: req.data points into it until admit */
    int32_t r;
    if (req.read) {
        urb_uplink_read_request_t q;
        r = urb_uplink_read_request_decode(&q, frame, len);
        if (r >= 0) {
            req.address = q.address;
            req.mailbox = q.mailbox;
            req.length = q.length;
        }
    } else {
        r = urb_uplink_write_request_decode(&w, frame, len);
        if (r >= 0) {
            req.address = w.address;
            req.mailbox = w.mailbox;
            req.length = w.length;
            req.data = w.data;
        }
    }
    if ((r == URB_ERR_CHECKSUM) || (r == URB_ERR_SHORT) || (r == URB_ERR_LONG)) {
        return false;
    }
    b->stats.frames++;
    if (r >= 0) {
        req.status = URB_STATUS_OK;
    }
    admit(b, &req);
    return true;
}

/* ===== Serving ================================================================================ */

/* Bridge.tla FirstPending, in O(1): served slots form a prefix of the slot FIFO. The data slot of
 * the oldest pending request, or URB_BRIDGE_NO_SLOT when nothing is pending. */
/*@ requires urbb_fifo_ok(b);
    assigns \nothing;
    ensures b->slot_served == b->slot_count ==> \result == URB_BRIDGE_NO_SLOT;
    ensures b->slot_served < b->slot_count ==> \result == urbb_slot_at(b, b->slot_served) < b->cfg.fifo_depth; */
static uint8_t first_pending(const urb_bridge_t *b)
{
    if (b->slot_served >= b->slot_count) {
        return URB_BRIDGE_NO_SLOT;
    }
    return slot_index(b, b->slot_served);
}

/* The oldest pending request, or NULL (for the serving code; the FIFO itself works by index). */
/*@ requires \valid(b) && urbb_fifo_ok(b);
    assigns \nothing;
    ensures b->slot_served == b->slot_count ==> \result == \null;
    ensures b->slot_served < b->slot_count ==> \result == &b->slots[urbb_slot_at(b, b->slot_served)];
    ensures \result == \null || \valid(\result); */
static urb_bridge_slot_t *oldest_pending(urb_bridge_t *b)
{
    uint8_t const s = first_pending(b);
    return (s == URB_BRIDGE_NO_SLOT) ? NULL : &b->slots[s];
}

/* Bridge.tla: Serve (second half): the outcome of the oldest pending request is final. */
/*@ requires \valid(b) && urbb_fifo_ok(b) && urbb_nodes_ok(b) && urbb_slots_ok(b) && status != URB_BRIDGE_PENDING;
    behavior nothing_pending:
      assumes b->slot_served >= b->slot_count;
      assigns \nothing;
    behavior serve_oldest:
      assumes b->slot_served < b->slot_count;
      assigns b->ring[b->slots[urbb_slot_at(b, b->slot_served)].resp].status, b->slot_served, b->size_checked,
              b->nodes[0 .. URB_BRIDGE_MAX_NODES - 1], b->node_of[0 .. 127];
      ensures b->slot_served == \old(b->slot_served) + 1;
      ensures b->ring[\old(b->slots[urbb_slot_at(b, b->slot_served)].resp)].status == status;
      ensures urbb_fifo_ok(b) && urbb_nodes_ok(b);
    complete behaviors;
    disjoint behaviors; */
static void complete(urb_bridge_t *b, uint8_t status)
{
    uint8_t const s = first_pending(b);
    if (s == URB_BRIDGE_NO_SLOT) {
        return;
    }
    if ((status == URB_STATUS_OK) && b->slots[s].read && (b->slots[s].address != URB_BRIDGE_ADDRESS) &&
        (b->slots[s].mailbox == 0u) && (b->slots[s].length == URB_IDENTIFICATION_SIZE)) {
        /* the host read an identification: learn the sizes too */
        node_learn(b, b->slots[s].address, b->slots[s].data);
    }
    b->ring[b->slots[s].resp].status = status;
    b->slot_served++;
    b->size_checked = false; /* it belonged to this request */
}

static void start_scan(urb_bridge_t *b, bool for_request)
{
    b->scanning = true;
    b->scan_for_request = for_request;
    b->scan_addr = b->dl.first_address;
}

/* Serve a request to address 0. Returns true when it completed at once, false when it occupies the
 * downlink (SCAN, BUS_CLEAR) or the downlink could not start yet. */
static bool serve_local(urb_bridge_t *b, urb_bridge_slot_t *d, uint32_t now)
{
    if (d->read && (d->mailbox == URB_NODE_BRIDGE_OUTBOX_BRIDGE_INFO)) {
        urb_bridge_info_t info;
        info.downlink = b->dl.kind;
        info.bitrate_kbps = b->dl.bitrate_kbps;
        info.fifo_depth = b->cfg.fifo_depth;
        info.heartbeat_us = b->cfg.heartbeat_us;
        info.fw_major = URB_BRIDGE_FW_MAJOR;
        info.fw_minor = URB_BRIDGE_FW_MINOR;
        info.fw_patch = URB_BRIDGE_FW_PATCH;
        complete(b, (urb_bridge_info_encode(&info, d->data, sizeof d->data) < 0) ? URB_STATUS_BAD_REQUEST
                                                                                  : URB_STATUS_OK);
        return true;
    }
    if (d->read && (d->mailbox == URB_NODE_BRIDGE_OUTBOX_BRIDGE_SCAN)) {
        urb_bridge_scan_t scan;
        /* loop bound: 128 addresses */
        for (uint8_t a = 0u; a < 128u; a++) {
            scan.present[a] = (b->present[a >> 3] & (1u << (a & 7u))) != 0u;
        }
        complete(b, (urb_bridge_scan_encode(&scan, d->data, sizeof d->data) < 0) ? URB_STATUS_BAD_REQUEST
                                                                                  : URB_STATUS_OK);
        return true;
    }
    if ((!d->read) && (d->mailbox == URB_NODE_BRIDGE_INBOX_BRIDGE_COMMAND)) {
        urb_bridge_command_t cmd;
        if (urb_bridge_command_decode(&cmd, d->data, d->length) < 0) {
            complete(b, URB_STATUS_BAD_REQUEST); /* unknown opcode */
            return true;
        }
        switch (cmd.opcode) {
        case URB_BRIDGE_OPCODE_SCAN:
            start_scan(b, true); /* answered when the scan is over, so later reads see the new map */
            return false;
        case URB_BRIDGE_OPCODE_SET_HEARTBEAT:
            b->cfg.heartbeat_us = cmd.value;
            b->hb_done = b->hb_ticks; /* ticks of the old period do not trigger a SYNC */
            b->hal->heartbeat_period(b->hal->ctx, cmd.value);
            complete(b, URB_STATUS_OK);
            return true;
        case URB_BRIDGE_OPCODE_BUS_CLEAR: {
            urb_downlink_txn_t t = {URB_DL_CLEAR, 0u, 0u, 0u, 0u, false, NULL};
            if (b->dl.begin(b->dl.ctx, &t, now)) {
                b->activity = URBB_ACT_REQUEST;
                mark(b, URB_MARK_SERVE, true);
            }
            return false;
        }
        default:
            complete(b, URB_STATUS_OK); /* NOP */
            return true;
        }
    }
    complete(b, URB_STATUS_BAD_REQUEST); /* unreachable: admission checked the mailbox size */
    return true;
}

/* Read node a's identification (outbox 0, selected again) into scan_buf as `activity` (a scan or an
 * identification before a request); nothing starts while the downlink is busy. */
static void identification_begin(urb_bridge_t *b, uint8_t a, uint8_t activity, uint32_t now)
{
    urb_downlink_txn_t t = {URB_DL_READ, a, 0u, (uint8_t)URB_IDENTIFICATION_SIZE, 0u, true, b->scan_buf};
    if (b->dl.begin(b->dl.ctx, &t, now)) {
        b->activity = activity;
    }
}

/* Discovery.tla: ScanAddress(b), first half: probe the next address by reading its outbox 0. */
static void scan_begin(urb_bridge_t *b, uint32_t now)
{
    identification_begin(b, b->scan_addr, URBB_ACT_SCAN, now);
}

/* Discovery.tla: ScanAddress(b), second half. Acknowledged: present, and its identification gives
 * the mailbox sizes. Not acknowledged: absent and forgotten; the scan goes on (a gap never ends it). */
static void scan_done(urb_bridge_t *b, uint8_t status)
{
    uint8_t const a = b->scan_addr;
    /* The node answered its address (even if the read then failed its check): NoPhantoms holds
     * because TIMEOUT and BUS_STUCK, where we cannot tell, count as absent. */
    bool const acked = (status == URB_STATUS_OK) || (status == URB_STATUS_CHECKSUM) ||
                       (status == URB_STATUS_BAD_REQUEST) || (status == URB_STATUS_SIZE_MISMATCH);
    set_present(b, a, acked);
    if (status == URB_STATUS_OK) {
        node_learn(b, a, b->scan_buf);
    } else {
        node_forget(b, a);
    }
    bool last = a >= b->dl.last_address;
#ifdef URB_MUTANT_SCAN_STOP_AT_GAP
    last = last || !acked; /* mutant (Discovery_StopAtFirstGap) */
#endif
    if (last) {
        b->scanning = false;
        b->stats.scans++;
        if (b->scan_for_request) {
            complete(b, URB_STATUS_OK);
        }
    } else {
        b->scan_addr = (uint8_t)(a + 1u);
    }
}

/* Bridge.tla: Serve, for a request to a node. The downlink names what the bus did; the answer is
 * the status the specification allows for what the bridge knows of the node: NO_NODE only for a
 * node its presence state calls absent (Discovery.tla: HostRequest), OK or a downlink fault for a
 * present one. A present node that does not acknowledge its address is probed first (a bit error
 * or a vanished node: the probe tells). Requests to address 0 complete here unchanged. */
static void served(urb_bridge_t *b, uint8_t status)
{
    urb_bridge_slot_t const *d = oldest_pending(b);
    if ((d == NULL) || (d->address == URB_BRIDGE_ADDRESS)) {
        complete(b, status);
        return;
    }
    uint8_t const a = d->address;
    if (status == URB_STATUS_NO_NODE) {
#ifndef URB_MUTANT_NO_PROBE
        if (urb_bridge_present(b, a)) {
            b->probing = true; /* answered by probed() */
            return;
        }
#endif
        complete(b, URB_STATUS_NO_NODE);
        return;
    }
    if ((status != URB_STATUS_TIMEOUT) && (status != URB_STATUS_BUS_STUCK)) {
        set_present(b, a, true); /* it acknowledged its address (the model's NodeAppear, as seen here) */
    }
    if (((status == URB_STATUS_BAD_REQUEST) || (status == URB_STATUS_SIZE_MISMATCH)) &&
        ((known_size(b, a, d->mailbox, d->read) >= 0) || b->size_checked)) {
        /* admission checked mailbox and length against the node's layout: a NACKed select or data
         * byte is a corrupted byte (a node that followed the contract would not refuse it) */
        status = URB_STATUS_CHECKSUM;
    }
    complete(b, status);
}

/* The probe of a present node whose address went unacknowledged. Acknowledged: the request's
 * address byte or its acknowledge was corrupted, it reached no mailbox: TIMEOUT. Not
 * acknowledged: the node is gone (the model's NodeVanish, as seen here): absent, and NO_NODE
 * (Discovery.tla: HostRequest). A fault of the probe itself answers the request. */
static void probed(urb_bridge_t *b, uint8_t status)
{
    urb_bridge_slot_t const *d = oldest_pending(b);
    b->probing = false;
    if (d == NULL) {
        return;
    }
    if (status == URB_STATUS_OK) {
        status = URB_STATUS_TIMEOUT;
    } else if (status == URB_STATUS_NO_NODE) {
        set_present(b, d->address, false);
    } else {
        /* TIMEOUT or BUS_STUCK: the request was not executed either */
    }
    complete(b, status);
}

/* A node request's length must match the node's mailbox before it goes to the bus: a node cannot
 * refuse a write shorter than its inbox (it ACKs every byte, takes the check for data and drops the
 * write at STOP, and the bridge would answer OK: Bridge.tla WriteStatusTruthful), nor reliably a
 * read shorter than its outbox (a data byte taken for the check matches it one time in 256). The
 * table holds the sizes of the nodes the scan identified; a node it does not hold (hot-plugged, an
 * identification that did not decode, past the table's URB_BRIDGE_MAX_NODES entries) is identified
 * first: its outbox 0 is read, and learned when the table has room. Outbox 0 and inbox 0 have the
 * same size on every node, so requests to them need no identification. */
static bool needs_identification(const urb_bridge_t *b, const urb_bridge_slot_t *d)
{
    if ((d->address == URB_BRIDGE_ADDRESS) || b->size_checked) {
        return false;
    }
    if ((d->mailbox == 0u) && (d->length == (d->read ? URB_IDENTIFICATION_SIZE : URB_COMMAND_SIZE))) {
        return false;
    }
#ifdef URB_MUTANT_NO_IDENTIFY_UNKNOWN
    return false; /* mutant: a request to a node of unknown sizes goes to the bus unchecked */
#else
    return known_size(b, d->address, d->mailbox, d->read) < 0;
#endif
}

/* The identification read for the oldest pending request came back (see needs_identification).
 * Its node's sizes answer the request SIZE_MISMATCH, or let it go to the bus; a fault of the read
 * answers the request, which did not reach the mailbox: NO_NODE (the node is absent), TIMEOUT or
 * BUS_STUCK, and CHECKSUM for an identification that failed its check or does not decode. */
static void identified(urb_bridge_t *b, uint8_t status)
{
    urb_bridge_slot_t const *d = oldest_pending(b);
    if (d == NULL) {
        return;
    }
    uint8_t const a = d->address;
    if ((status == URB_STATUS_TIMEOUT) || (status == URB_STATUS_BUS_STUCK)) {
        complete(b, status);
        return;
    }
    if (status == URB_STATUS_NO_NODE) {
        set_present(b, a, false);
        complete(b, URB_STATUS_NO_NODE);
        return;
    }
    set_present(b, a, true); /* it acknowledged its address */
    urb_identification_t id;
    if ((status != URB_STATUS_OK) || (urb_identification_decode(&id, b->scan_buf, URB_IDENTIFICATION_SIZE) < 0)) {
        complete(b, URB_STATUS_CHECKSUM);
        return;
    }
    node_learn(b, a, b->scan_buf);
    uint8_t const size = d->read ? id.outbox_sizes[d->mailbox & 7u] : id.inbox_sizes[d->mailbox & 7u];
    if (size != d->length) {
        complete(b, URB_STATUS_SIZE_MISMATCH); /* as admission answers for a node in the table */
        return;
    }
    b->size_checked = true; /* start_next serves it now */
}

/* The downlink reported the outcome of what we asked it to do. */
static void activity_done(urb_bridge_t *b, uint8_t status)
{
    uint8_t const act = b->activity;
    b->activity = URBB_ACT_NONE;
    if (act == URBB_ACT_REQUEST) {
        mark(b, URB_MARK_SERVE, false);
        served(b, status); /* Bridge.tla Serve: the request's outcome (served) */
    } else if (act == URBB_ACT_PROBE) {
        probed(b, status);
    } else if (act == URBB_ACT_LEARN) {
        identified(b, status);
    } else if (act == URBB_ACT_SCAN) {
        scan_done(b, status);
    } else if (act == URBB_ACT_SYNC) {
        mark(b, URB_MARK_SYNC, false);
    } else {
        /* nothing was running */
    }
}

/* The SYNC heartbeat goes first: its timing matters to every node (paper Sec. V-E), and a
 * transaction in progress delays it by at most one transaction. Ticks that pass while the
 * downlink is busy are not queued: the counter skips, so nodes can tell a missed SYNC. */
static bool start_sync(urb_bridge_t *b, uint32_t now)
{
    uint8_t const ticks = b->hb_ticks;
    if (ticks == b->hb_done) {
        return false;
    }
    if (b->cfg.heartbeat_us == 0u) {
        b->hb_done = ticks;
        return false;
    }
    urb_downlink_txn_t t = {URB_DL_SYNC, 0u, 0u, 0u, ticks, false, NULL};
    if (!b->dl.begin(b->dl.ctx, &t, now)) {
        return true;
    }
    b->stats.syncs_missed += (uint8_t)(ticks - b->hb_done - 1u);
    b->hb_done = ticks;
    b->stats.syncs++;
    b->activity = URBB_ACT_SYNC;
    mark(b, URB_MARK_SYNC, true);
    return true;
}

/* Start the next downlink activity: SYNC, else the next scan address, else the oldest pending
 * request (Bridge.tla: Serve, first half). Local requests complete at once and the next one is
 * tried, at most one per data slot. */
static void start_next(urb_bridge_t *b, uint32_t now)
{
    if (start_sync(b, now)) {
        return;
    }
    if (b->probing) {
        urb_bridge_slot_t const *d = oldest_pending(b);
        urb_downlink_txn_t t = {URB_DL_PROBE, (d != NULL) ? d->address : 0u, 0u, 0u, 0u, false, NULL};
        if (b->dl.begin(b->dl.ctx, &t, now)) {
            b->activity = URBB_ACT_PROBE;
        }
        return;
    }
    if (b->scanning) {
        scan_begin(b, now);
        return;
    }
    /* loop bound: URB_BRIDGE_FIFO_MAX pending requests */
    for (uint8_t i = 0u; i < URB_BRIDGE_FIFO_MAX; i++) {
        urb_bridge_slot_t *d = oldest_pending(b);
        if (d == NULL) {
            return;
        }
        if (d->address == URB_BRIDGE_ADDRESS) {
            if (!serve_local(b, d, now)) {
                return;
            }
            continue;
        }
        if (needs_identification(b, d)) {
            identification_begin(b, d->address, URBB_ACT_LEARN, now);
            return;
        }
        urb_downlink_txn_t t = {d->read ? (uint8_t)URB_DL_READ : (uint8_t)URB_DL_WRITE, d->address, d->mailbox,
                                d->length, 0u, false, d->data};
        if (b->dl.begin(b->dl.ctx, &t, now)) {
            b->activity = URBB_ACT_REQUEST;
            mark(b, URB_MARK_SERVE, true);
        }
        return;
    }
}

/* ===== Emitting =============================================================================== */

/* Encode the final response in ring entry r and hand it to its uplink; false when the uplink has
 * no room. WP (proofs/framac/emit_entry) proves its accesses and urbb_uplink_send's preconditions
 * from what a ring entry holds: no data slot, or one of the FIFO's with at most 32 bytes; and what
 * it writes (the uplink's buffers and a counter) and that it keeps urbb_usb_ok, with the HAL's
 * kick and marks through their contracts (uart_kick in bridge_uplink.c, mark above: a reviewed
 * hypothesis). */
/*@ requires \valid(b) && urbb_usb_ok(b) && \valid_read(b->hal) && r < URB_BRIDGE_RING_MAX;
    requires b->ring[r].slot == URB_BRIDGE_NO_SLOT ||
             (b->ring[r].slot < URB_BRIDGE_FIFO_MAX && b->slots[b->ring[r].slot].length <= 32);
    assigns URBB_SEND_WRITES, b->stats.responses;
    ensures usb_ok: urbb_usb_ok(b); */
static bool emit_entry(urb_bridge_t *b, uint8_t r)
{
    urb_uplink_response_t out;
    uint8_t frame[URB_UPLINK_RESPONSE_MAX_SIZE];
    urb_bridge_resp_t const e = b->ring[r];
    uint8_t const s = e.slot;
    out.seq = e.seq;
    out.status = e.status;
    out.data_len = 0u;
    if ((out.status == URB_STATUS_OK) && (s != URB_BRIDGE_NO_SLOT) && b->slots[s].read) {
        out.data_len = b->slots[s].length; /* Bridge.tla ResponseMatchesRequest: data only for an OK read */
        /* loop bound: 32 bytes */
        /*@ loop invariant 0 <= i <= b->slots[s].length;
            loop assigns i, out.data[0 .. 31];
            loop variant b->slots[s].length - i; */
        for (uint8_t i = 0u; i < b->slots[s].length; i++) {
            out.data[i] = b->slots[s].data[i];
        }
    }
    int32_t const n = urb_uplink_response_encode(&out, frame, sizeof frame);
    if (n < 0) {
        return true; /* cannot happen for a valid entry; never wedge the ring on it */
    }
    if (!urbb_uplink_send(b, e.uplink, frame, (uint8_t)n)) {
        return false;
    }
    b->stats.responses++;
    mark(b, URB_MARK_EMIT, true);
    mark(b, URB_MARK_EMIT, false);
    return true;
}

/* Bridge.tla: Emit. The oldest response leaves once final; its slots are freed. */
static void emit(urb_bridge_t *b)
{
    /* loop bound: URB_BRIDGE_RING_MAX responses */
    for (uint8_t i = 0u; (i < URB_BRIDGE_RING_MAX) && (b->ring_count > 0u); i++) {
        uint8_t const h = b->ring_head;
        urb_bridge_resp_t const e = b->ring[h];
        if (e.status == URB_BRIDGE_PENDING) {
            return;
        }
        if (!emit_entry(b, h)) {
            return; /* uplink full: try again at the next poll, order kept */
        }
        if (e.slot != URB_BRIDGE_NO_SLOT) {
            b->slot_head = slot_index(b, 1u);
            b->slot_count--;
            b->slot_served--;
        }
        b->ring_head = ring_index(b->ring_head, 1u);
        b->ring_count--;
    }
}

/* ===== Public API ============================================================================= */

void urb_bridge_default_config(urb_bridge_config_t *cfg)
{
    cfg->fifo_depth = (uint8_t)URB_BRIDGE_FIFO_MAX;
    cfg->baud = 115200u;
    cfg->idle_gap_us = 0u; /* 0: two byte times at `baud` */
    cfg->heartbeat_us = 1000u;
    cfg->scan_at_start = true;
}

int32_t urb_bridge_init(urb_bridge_t *b, const urb_bridge_config_t *cfg, const urb_bridge_hal_t *hal,
                        const urb_downlink_t *dl)
{
    if ((b == NULL) || (cfg == NULL) || (hal == NULL) || (dl == NULL) || (hal->now_us == NULL) ||
        (hal->heartbeat_period == NULL) || (hal->uart_tx_kick == NULL) || (dl->begin == NULL) ||
        (dl->poll == NULL) || (cfg->fifo_depth == 0u) || (cfg->fifo_depth > URB_BRIDGE_FIFO_MAX) ||
        (cfg->baud == 0u) || (dl->first_address == 0u) || (dl->first_address > dl->last_address) ||
        (dl->last_address > 0x7Fu)) {
        return URB_ERR_ARGUMENT;
    }
    b->cfg = *cfg;
    b->hal = hal;
    b->dl = *dl;
    if (b->cfg.idle_gap_us == 0u) {
        b->cfg.idle_gap_us = (20000000u + cfg->baud - 1u) / cfg->baud; /* 2 x 10 bits, rounded up */
    }
    b->hb_ticks = 0u;
    b->hb_done = 0u;
    b->ring_head = 0u; /* Bridge.tla: BridgeReset (the queue starts empty) */
    b->ring_count = 0u;
    b->slot_head = 0u;
    b->slot_count = 0u;
    b->slot_served = 0u;
    b->activity = URBB_ACT_NONE;
    b->probing = false;
    b->size_checked = false;
    b->scanning = false;
    b->scan_for_request = false;
    b->scan_addr = 0u;
    /* loop bound: 16 bytes */
    for (uint8_t i = 0u; i < 16u; i++) {
        b->present[i] = 0u;
    }
    /* loop bound: 128 addresses */
    for (uint8_t i = 0u; i < 128u; i++) {
        b->node_of[i] = 0u;
    }
    /* loop bound: URB_BRIDGE_MAX_NODES */
    for (uint8_t i = 0u; i < URB_BRIDGE_MAX_NODES; i++) {
        b->nodes[i].address = 0u;
    }
    urb_bridge_stats_t const zero = {0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u};
    b->stats = zero;
    urbb_uplink_init(b);
    if (cfg->scan_at_start) {
        start_scan(b, false);
    }
    hal->heartbeat_period(hal->ctx, cfg->heartbeat_us);
    return URB_OK;
}

void urb_bridge_poll(urb_bridge_t *b)
{
    uint32_t const now = b->hal->now_us(b->hal->ctx);
    urbb_uart_drain(b, now); /* Bridge.tla SubmitAndAdmit for every complete RS232 frame */
    int8_t const r = b->dl.poll(b->dl.ctx, now);
    if (r >= 0) {
        activity_done(b, (uint8_t)r);
    } else if ((r == URB_DOWNLINK_IDLE) && (b->activity != URBB_ACT_NONE)) {
        activity_done(b, URB_STATUS_TIMEOUT); /* the downlink lost our transaction: never wedge */
    } else {
        /* still running, or nothing to report */
    }
    if (b->activity == URBB_ACT_NONE) {
        start_next(b, now);
    }
    emit(b);
}

bool urb_bridge_idle(const urb_bridge_t *b)
{
    bool const rx_empty = (b->rx_head == b->rx_tail) && (b->rs232.len == 0u);
    bool const sync_due = (b->hb_ticks != b->hb_done);
    bool const work = (b->slot_served < b->slot_count) || b->scanning || sync_due;
    bool const head_final = (b->ring_count > 0u) && (b->ring[b->ring_head].status != URB_BRIDGE_PENDING);
    return rx_empty && (b->activity == URBB_ACT_NONE) && !work && !head_final;
}

void urb_bridge_heartbeat(urb_bridge_t *b)
{
    b->hb_ticks = (uint8_t)(b->hb_ticks + 1u); /* only the ISR writes it: no lost update */
}

const urb_bridge_stats_t *urb_bridge_stats(const urb_bridge_t *b)
{
    return &b->stats;
}

bool urb_bridge_present(const urb_bridge_t *b, uint8_t address)
{
    return (b->present[(address & 0x7Fu) >> 3] & (1u << (address & 7u))) != 0u;
}

uint8_t urb_bridge_outstanding(const urb_bridge_t *b)
{
    return b->ring_count;
}
