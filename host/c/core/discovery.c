/*
 * Discovery of one bridge's downlink (host/urb/api.py _Discovery): BridgeInfo, SCAN, BridgeScan,
 * then the identification of every present address, as a chain of transfer callbacks.
 */
#include "urb_discovery.h"

#include <stdio.h>
#include <string.h>

#define TRANSIENT (URB_FLAG_TIMEOUT | URB_FLAG_CHECKSUM | URB_FLAG_BUS_STUCK | URB_FLAG_BUSY | URB_FLAG_UPLINK_CHECKSUM)

size_t urb_core_dispatch(urb_core_t *core, urb_ns_t now)
{
    size_t ran = 0u;
    urb_transfer_t *t;
    while ((t = urb_core_take_completed(core)) != NULL) {
        t->callback_ns = now;
        if (t->on_done != NULL) {
            t->on_done(t, t->user); /* t is the caller's again: do not touch it after this */
        }
        ran++;
    }
    return ran;
}

static void transfer_done(urb_transfer_t *t, void *user);

/* Submits one of d's transfers (built by the caller) with d's callback. */
static void send(urb_discovery_t *d, urb_transfer_t *t, urb_ns_t now)
{
    (void)urb_transfer_set_callback(t, transfer_done, d);
    d->outstanding++;
    if (urb_core_submit(d->core, t, now) != URB_HOST_OK) {
        d->outstanding--; /* not reached: discovery builds only valid requests of its own */
    }
}

static void send_read(urb_discovery_t *d, urb_transfer_t *t, uint8_t address, uint8_t mailbox, uint8_t length,
                      urb_ns_t now)
{
    (void)urb_transfer_read(t, address, mailbox, length);
    send(d, t, now);
}

static void fail(urb_discovery_t *d, urb_discovery_outcome_t outcome)
{
    if (d->outcome == URB_DISCOVERY_RUNNING) {
        d->outcome = (uint8_t)outcome;
    }
}

static void problem(urb_discovery_t *d, urb_problem_kind_t kind, uint8_t address, urb_flags_t flags)
{
    if (d->problem_count < URB_ADDRESSES + 1u) {
        d->problems[d->problem_count].kind = (uint8_t)kind;
        d->problems[d->problem_count].address = address;
        d->problems[d->problem_count].flags = flags;
        d->problem_count++;
    }
}

void urb_discovery_init(urb_discovery_t *d)
{
    if (d != NULL) {
        memset(d, 0, sizeof *d);
    }
}

int32_t urb_discovery_start(urb_discovery_t *d, urb_core_t *core, const urb_schema_t *schema, bool rescan,
                            urb_discovery_done_fn on_done, void *user, urb_ns_t now)
{
    if ((d == NULL) || (core == NULL)) {
        return URB_HOST_EINVAL;
    }
    if (d->outcome == URB_DISCOVERY_RUNNING) {
        return URB_HOST_ESTATE;
    }
    memset(d, 0, sizeof *d);
    d->core = core;
    d->schema = (schema == NULL) ? urb_schema_default() : schema;
    d->rescan = rescan;
    d->on_done = on_done;
    d->user = user;
    d->outcome = URB_DISCOVERY_RUNNING;
    send_read(d, &d->info_read, URB_BRIDGE_ADDRESS, URB_NODE_BRIDGE_OUTBOX_BRIDGE_INFO, URB_NODE_BRIDGE_OUTBOX0_SIZE,
              now);
    return URB_HOST_OK;
}

bool urb_discovery_finished(const urb_discovery_t *d)
{
    return (d != NULL) && (d->outcome >= URB_DISCOVERY_DONE);
}

/* The bridge's own identification: the only evidence that a URB bridge is there (api.believed_bridge). */
static void got_info(urb_discovery_t *d, const urb_transfer_t *t, urb_ns_t now)
{
    urb_bridge_info_t info;
    if (!urb_transfer_ok(t) || (t->response_len == 0u) ||
        (urb_bridge_info_decode(&info, t->response, t->response_len) < 0) || (info.fifo_depth == 0u) ||
        (info.bitrate_kbps == 0u)) {
        d->stray_at_failure = d->core->m.stray_bytes;
        const char *lost = urb_core_lost_reason(d->core);
        (void)snprintf(d->lost_at_failure, sizeof d->lost_at_failure, "%s", (lost == NULL) ? "" : lost);
        fail(d, URB_DISCOVERY_NO_BRIDGE);
        return;
    }
    d->info = info;
    d->have_info = true;
    (void)urb_core_set_window(d->core, (uint8_t)((info.fifo_depth < URB_MAX_WINDOW) ? info.fifo_depth : URB_MAX_WINDOW));
    if (d->rescan) {
        urb_bridge_command_t cmd = {URB_BRIDGE_OPCODE_SCAN, 0u};
        uint8_t bytes[URB_BRIDGE_COMMAND_SIZE];
        (void)urb_bridge_command_encode(&cmd, bytes, sizeof bytes);
        (void)urb_transfer_write(&d->scan_command, URB_BRIDGE_ADDRESS, URB_NODE_BRIDGE_INBOX_BRIDGE_COMMAND, bytes,
                                 (uint8_t)sizeof bytes);
        /* answered when the scan is over; the scan-map read behind it waits for it */
        (void)urb_transfer_set_answer_within(&d->scan_command, URB_SCAN_ANSWER_NS);
        send(d, &d->scan_command, now);
    }
    send_read(d, &d->scan_read, URB_BRIDGE_ADDRESS, URB_NODE_BRIDGE_OUTBOX_BRIDGE_SCAN, URB_NODE_BRIDGE_OUTBOX1_SIZE, now);
}

static void got_scan(urb_discovery_t *d, const urb_transfer_t *t, urb_ns_t now)
{
    urb_bridge_scan_t scan;
    if (!urb_transfer_ok(t) || (t->response_len == 0u) ||
        (urb_bridge_scan_decode(&scan, t->response, t->response_len) < 0)) {
        d->failure_flags = t->flags;
        fail(d, URB_DISCOVERY_SCAN_FAILED);
        return;
    }
    /* Discovery.tla ScanAddress: a gap never ends the scan */
    for (uint8_t a = 1u; a <= URB_ADDRESSES; a++) {
        if (scan.present[a]) {
            d->present[d->present_count++] = a;
        }
    }
    for (uint8_t i = 0u; i < d->present_count; i++) {
        uint8_t const a = d->present[i];
        send_read(d, &d->ident[a - 1u], a, 0u, URB_IDENTIFICATION_SIZE, now);
    }
}

static bool same_sizes(const uint8_t *a, const uint8_t *b)
{
    return memcmp(a, b, 8u) == 0;
}

static void got_ident(urb_discovery_t *d, urb_transfer_t *t, urb_ns_t now)
{
    uint8_t const addr = t->address;
    uint8_t *attempts = &d->attempts[addr - 1u];
    if (!urb_transfer_ok(t) && ((t->flags & TRANSIENT) != 0u) && (*attempts < URB_IDENT_RETRIES)) {
        (*attempts)++;
        send_read(d, t, addr, 0u, URB_IDENTIFICATION_SIZE, now); /* a rescan of that address */
        return;
    }
    if (!urb_transfer_ok(t) || (t->response_len == 0u)) {
        problem(d, URB_PROBLEM_IDENT_FAILED, addr, t->flags);
        return;
    }
    urb_found_node_t *n = &d->nodes[d->node_count];
    if (urb_identification_decode(&n->ident, t->response, t->response_len) < 0) {
        problem(d, URB_PROBLEM_IDENT_UNDECODABLE, addr, URB_FLAG_NONE);
        return;
    }
    n->address = addr;
    n->type = urb_schema_find_class(d->schema, n->ident.class_id);
    n->flags = 0u;
    if (n->type == NULL) {
        n->flags = URB_NODE_UNKNOWN_CLASS;
    } else if (n->ident.fingerprint != n->type->fingerprint) {
        n->flags = URB_NODE_MISMATCH;
    } else if (!same_sizes(n->ident.inbox_sizes, n->type->inbox_sizes) ||
               !same_sizes(n->ident.outbox_sizes, n->type->outbox_sizes)) {
        n->flags = URB_NODE_MISMATCH;
        problem(d, URB_PROBLEM_SIZES_DIFFER, addr, URB_FLAG_NONE);
    }
    d->node_count++;
}

/* The report's nodes by address (records.sort(key=address)); at most 127, insertion sort. */
static void sort_nodes(urb_discovery_t *d)
{
    for (uint32_t i = 1u; i < d->node_count; i++) {
        urb_found_node_t const n = d->nodes[i];
        uint32_t j = i;
        while ((j > 0u) && (d->nodes[j - 1u].address > n.address)) {
            d->nodes[j] = d->nodes[j - 1u];
            j--;
        }
        d->nodes[j] = n;
    }
}

static void transfer_done(urb_transfer_t *t, void *user)
{
    urb_discovery_t *d = user;
    urb_ns_t const now = t->callback_ns;
    d->outstanding--;
    if (t == &d->info_read) {
        got_info(d, t, now);
    } else if (t == &d->scan_command) {
        if (!urb_transfer_ok(t)) {
            problem(d, URB_PROBLEM_SCAN_REFUSED, 0u, t->flags); /* its last scan is used */
        }
    } else if (t == &d->scan_read) {
        got_scan(d, t, now);
    } else {
        got_ident(d, t, now);
    }
    if ((d->outstanding == 0u) && (d->outcome == URB_DISCOVERY_RUNNING)) {
        d->outcome = URB_DISCOVERY_DONE;
        sort_nodes(d);
    }
    if ((d->outstanding == 0u) && (d->on_done != NULL)) {
        urb_discovery_done_fn fn = d->on_done;
        d->on_done = NULL; /* once */
        fn(d, d->user);
    }
}

int32_t urb_discovery_describe(const urb_discovery_t *d, const char *name, char *out, size_t size)
{
    if ((d == NULL) || (name == NULL) || (out == NULL) || (size == 0u)) {
        return URB_HOST_EINVAL;
    }
    int n = 0;
    if (d->outcome == URB_DISCOVERY_NO_BRIDGE) {
        char heard[URB_REASON_MAX + 96u];
        if (d->lost_at_failure[0] != '\0') {
            (void)snprintf(heard, sizeof heard, "%s", d->lost_at_failure);
        } else if (d->stray_at_failure > 0u) {
            (void)snprintf(heard, sizeof heard,
                           "%llu byte(s) came back, none of them a URB bridge's identification: what a wrong baud "
                           "rate or another device looks like",
                           (unsigned long long)d->stray_at_failure);
        } else {
            (void)snprintf(heard, sizeof heard, "nothing came back");
        }
        n = snprintf(out, size,
                     "no URB bridge answered on %s (%s). Check that the baud rate matches the bridge firmware's, that "
                     "%s is the bridge's device, and that the bridge is powered and connected.",
                     name, heard, name);
    } else if (d->outcome == URB_DISCOVERY_SCAN_FAILED) {
        char flags[160];
        (void)urb_flags_describe(d->failure_flags, flags, sizeof flags);
        n = snprintf(out, size, "reading the scan map of %s failed: %s: %s", name, flags,
                     urb_flags_hint(d->failure_flags));
    } else {
        out[0] = '\0';
    }
    if (n < 0) {
        return URB_HOST_EINVAL;
    }
    return ((size_t)n >= size) ? URB_HOST_ENOSPC : (int32_t)n;
}
