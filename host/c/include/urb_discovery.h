/*
 * urb_discovery.h: what the host knows of node types (the schema table), the discovery of one
 * bridge's downlink, and the system table of every node found (duplicates, fingerprints, lookup
 * by class and index). Sans-IO like urb_host_core.h: discovery submits transfers to a core and
 * goes on in their completion callbacks, so it runs in real time (urb_loop) and in virtual time
 * alike. The Python library's _Discovery, NodeRecord, URBInterface._merge and find_node
 * (host/urb/api.py), rule for rule.
 *
 * Discovery of one bridge (Discovery.tla ScanAddress):
 *   1. read BridgeInfo (address 0, outbox 0). A bridge is believed only when it comes back OK,
 *      decodes (protocol 1, a known downlink) and checks (FIFO depth and bit rate above 0):
 *      anything else is URB_DISCOVERY_NO_BRIDGE, whatever the bytes were. Its fifo_depth (at
 *      most 15) becomes the core's window;
 *   2. unless rescan is false, write BridgeCommand SCAN (answered when the scan is over: it
 *      carries answer_within_ns = URB_SCAN_ANSWER_NS);
 *   3. read BridgeScan (address 0, outbox 1);
 *   4. read outbox 0 (Identification) of every present address, all submitted at once; a gap never
 *      ends the scan. A read failing with a transient status (TIMEOUT, CHECKSUM, BUS_STUCK, BUSY,
 *      UPLINK_CHECKSUM) is tried twice more. Each node is matched to the schema by class: an
 *      undeclared class flags it UNKNOWN_CLASS, another fingerprint (or mailbox sizes) MISMATCH.
 * The system table then flags DUPLICATE every row whose (class, index) answers more than once in
 * the whole system. Rows are never merged (Discovery.tla).
 */
#ifndef URB_DISCOVERY_H
#define URB_DISCOVERY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_core.h"
#include "urb_host_base.h"
#include "urb_host_core.h"
#include "urb_transfer.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ===== Node types (the schema the host was built with) ======================================= */

/** One node type: its class and mailbox layout, from the generated headers. */
typedef struct {
    const char *name;          /**< "MotorDriver" */
    uint8_t class_id;          /**< Identification.class_id */
    uint32_t fingerprint;      /**< Identification.fingerprint of a node built from this schema */
    uint8_t inbox_sizes[8];    /**< Bytes of inboxes 0..7 (0: none) */
    uint8_t outbox_sizes[8];   /**< Bytes of outboxes 0..7 (0: none) */
    const char *schema_file;   /**< Where it is declared ("spec/schema/sensorhex.urbs") */
} urb_node_type_t;

/** The node types a host knows (every class at most once). */
typedef struct {
    const urb_node_type_t *types;
    size_t count;
} urb_schema_t;

/** The SensoRHex node types (gen/c/urb_sensorhex.h), the Python library's default schema. */
const urb_schema_t *urb_schema_default(void);

/** The bridge itself as a node type (address 0: outbox 0 BridgeInfo, outbox 1 BridgeScan, inbox 0
 *  BridgeCommand). */
const urb_node_type_t *urb_schema_bridge(void);

/** The type of class `class_id`, or NULL (schema NULL or class not declared). O(types). */
const urb_node_type_t *urb_schema_find_class(const urb_schema_t *schema, uint8_t class_id);

/** The type named `name`, compared without case ("motordriver" finds MotorDriver), or NULL.
 *  O(types * name length). */
const urb_node_type_t *urb_schema_find_name(const urb_schema_t *schema, const char *name);

/* ===== Discovery of one bridge ================================================================ */

#define URB_ADDRESSES 127u        /**< Downlink addresses 1..127 */
#define URB_IDENT_RETRIES 2u      /**< Extra identification reads after a transient failure */

/** Flags of a node row (api.py DUPLICATE, MISMATCH, UNKNOWN_CLASS). */
#define URB_NODE_DUPLICATE 1u     /**< Another row of the system has the same class and index */
#define URB_NODE_MISMATCH 2u      /**< Its fingerprint or mailbox sizes differ from the schema's */
#define URB_NODE_UNKNOWN_CLASS 4u /**< Its class is not in the host's schema */

/** One node that answered discovery. */
typedef struct {
    uint8_t address;
    urb_identification_t ident;
    const urb_node_type_t *type; /**< The schema's type for its class, NULL when unknown */
    uint8_t flags;               /**< URB_NODE_MISMATCH, URB_NODE_UNKNOWN_CLASS */
} urb_found_node_t;

/** What went wrong with one address, or with the SCAN command (address 0). */
typedef enum {
    URB_PROBLEM_SCAN_REFUSED = 1,    /**< The bridge did not accept SCAN (flags): its last scan is used */
    URB_PROBLEM_IDENT_FAILED = 2,    /**< The identification read failed (flags), retries included */
    URB_PROBLEM_IDENT_UNDECODABLE = 3, /**< The identification does not decode */
    URB_PROBLEM_SIZES_DIFFER = 4     /**< The fingerprint matches but the mailbox sizes differ */
} urb_problem_kind_t;

typedef struct {
    uint8_t kind;       /**< urb_problem_kind_t */
    uint8_t address;
    urb_flags_t flags;  /**< The failed read's flag (SCAN_REFUSED, IDENT_FAILED) */
} urb_discovery_problem_t;

/** Where a discovery is (urb_discovery_t.outcome). */
typedef enum {
    URB_DISCOVERY_IDLE = 0,      /**< Not started */
    URB_DISCOVERY_RUNNING = 1,   /**< Transfers outstanding */
    URB_DISCOVERY_DONE = 2,      /**< Finished: nodes[], present[], problems[] are the report */
    URB_DISCOVERY_NO_BRIDGE = 3, /**< Finished: nothing answered like a URB bridge */
    URB_DISCOVERY_SCAN_FAILED = 4 /**< Finished: the scan map could not be read (failure_flags) */
} urb_discovery_outcome_t;

typedef struct urb_discovery urb_discovery_t;

/** Called once when a discovery finishes (any outcome), from a transfer callback. */
typedef void (*urb_discovery_done_fn)(urb_discovery_t *d, void *user);

/** One bridge's discovery: its transfers and its report. Size: about 39 KiB (129 transfers and
 *  127 node rows); no other memory. */
struct urb_discovery {
    urb_core_t *core;              /**< The bridge's core (discovery submits to it) */
    const urb_schema_t *schema;
    bool rescan;
    urb_discovery_done_fn on_done;
    void *user;
    uint32_t outstanding;          /**< Transfers submitted and not called back */
    uint8_t outcome;               /**< urb_discovery_outcome_t */
    /* the report */
    bool have_info;
    urb_bridge_info_t info;        /**< The bridge's identification (have_info) */
    uint8_t present_count;
    uint8_t present[URB_ADDRESSES];        /**< Addresses the scan map lists, ascending */
    uint8_t node_count;
    urb_found_node_t nodes[URB_ADDRESSES]; /**< Nodes identified, by address */
    uint8_t problem_count;
    urb_discovery_problem_t problems[URB_ADDRESSES + 1u];
    urb_flags_t failure_flags;     /**< SCAN_FAILED: the scan-map read's flag */
    uint64_t stray_at_failure;     /**< NO_BRIDGE: stray bytes received by then */
    char lost_at_failure[URB_REASON_MAX]; /**< NO_BRIDGE: the core's lost reason by then ("" if usable) */
    /* the transfers */
    urb_transfer_t info_read;
    urb_transfer_t scan_command;
    urb_transfer_t scan_read;
    urb_transfer_t ident[URB_ADDRESSES];   /**< ident[a - 1] reads address a */
    uint8_t attempts[URB_ADDRESSES];
};

/** Makes `d` an idle discovery (call once before its first urb_discovery_start). O(size). */
void urb_discovery_init(urb_discovery_t *d);

/**
 * Starts discovering the bridge behind `core` at `now`: submits the BridgeInfo read. The rest
 * happens in the transfers' callbacks, which the caller's runtime dispatches (urb_core_dispatch
 * or urb_loop); `on_done(d, user)` runs once at the end, from one of them. `schema` NULL: the
 * default. Returns URB_HOST_OK; URB_HOST_EINVAL for d or core NULL; URB_HOST_ESTATE while d is
 * running (d must have been through urb_discovery_init once). d must stay in place until it finishes. O(1).
 */
int32_t urb_discovery_start(urb_discovery_t *d, urb_core_t *core, const urb_schema_t *schema, bool rescan,
                            urb_discovery_done_fn on_done, void *user, urb_ns_t now);

/** True once d finished (outcome DONE, NO_BRIDGE or SCAN_FAILED). */
bool urb_discovery_finished(const urb_discovery_t *d);

/**
 * What a failed discovery means and what to do, in the Python library's words
 * (api.no_bridge_answered and the scan-map failure), for the bridge named `name` (a port path);
 * "" for a discovery that succeeded or is not finished. Written NUL-terminated into out[0 .. size
 * - 1]; returns the length, URB_HOST_EINVAL for NULL arguments or size 0, URB_HOST_ENOSPC when
 * cut. O(size).
 */
int32_t urb_discovery_describe(const urb_discovery_t *d, const char *name, char *out, size_t size);

/**
 * Takes every completed transfer of `core`, stamps its callback_ns = now and runs its on_done,
 * in completion order, until none is left (callbacks may submit more). What a runtime does after
 * each step; the sans-IO users (tests, the simulation) call it themselves. Returns how many ran.
 * O(completions).
 */
size_t urb_core_dispatch(urb_core_t *core, urb_ns_t now);

/* ===== The system table: every node of every bridge ========================================== */

#ifndef URB_SYSTEM_MAX_ROWS
#define URB_SYSTEM_MAX_ROWS 256u  /**< Node rows over all bridges (override with -D) */
#endif

/** One row: one node that answered on one (bridge, address). */
typedef struct {
    uint8_t bridge;              /**< The caller's bridge number, as given to urb_system_merge */
    uint8_t address;
    urb_identification_t ident;
    const urb_node_type_t *type; /**< NULL: class unknown */
    uint8_t flags;               /**< URB_NODE_* */
    bool used;                   /**< The slot holds a row */
    bool active;                 /**< false once a rediscovery of its bridge no longer found it */
    bool pinned;                 /**< An accessor refers to it: the slot is never reused */
    uint32_t order;              /**< Listing order (registration, then address) */
} urb_node_row_t;

typedef struct {
    const urb_schema_t *schema;
    uint32_t next_order;
    urb_node_row_t rows[URB_SYSTEM_MAX_ROWS];
} urb_system_t;

/** Why urb_system_find gave no row. */
typedef enum {
    URB_FIND_OK = 0,
    URB_FIND_UNKNOWN_CLASS = 1,  /**< The class is not in the schema */
    URB_FIND_NOT_FOUND = 2,      /**< No active row has that class and index */
    URB_FIND_DUPLICATE = 3,      /**< More than one does */
    URB_FIND_MISMATCH = 4        /**< The one that does was built from another schema */
} urb_find_t;

/** Empties the table for `schema` (NULL: the default). Nothing happens for s == NULL. */
void urb_system_init(urb_system_t *s, const urb_schema_t *schema);

/**
 * Replaces the rows of bridge number `bridge` with the nodes of a finished, successful discovery
 * (URBInterface._merge): a node found again (same class and index as an active row of that
 * bridge) keeps its row, so accessors stay valid; rows not found again become inactive (requests
 * to them complete URB_FLAG_UNKNOWN_NODE); then DUPLICATE is recomputed over the whole table.
 * Returns URB_HOST_OK; URB_HOST_EINVAL for NULL arguments; URB_HOST_ESTATE when d is not DONE;
 * URB_HOST_ENOSPC when the new rows do not fit (nothing changes). O(rows^2) worst case.
 */
int32_t urb_system_merge(urb_system_t *s, uint8_t bridge, const urb_discovery_t *d);

/** Makes every row of `bridge` inactive (the bridge was removed). O(rows). */
void urb_system_forget(urb_system_t *s, uint8_t bridge);

/**
 * The row of the node with class `class_id` and `index` (find_node): its index into rows[], or
 * URB_HOST_ENOTFOUND with *why saying why (why may be NULL). A found row is pinned. O(rows).
 */
int32_t urb_system_find(urb_system_t *s, uint8_t class_id, uint8_t index, urb_find_t *why);

/** The active row at `address` of `bridge` (node_at), whatever its flags; URB_HOST_ENOTFOUND
 *  otherwise. A found row is pinned. O(rows). */
int32_t urb_system_at(urb_system_t *s, uint8_t bridge, uint8_t address);

/**
 * Active rows in listing order (nodes()): their indexes into out[0 .. cap - 1]. Returns how many
 * there are (which may exceed cap: only cap are written). O(rows^2).
 */
size_t urb_system_list(const urb_system_t *s, uint32_t *out, size_t cap);

/**
 * The host's refusal of a request to row `row` (NodeAccessor._refusal): URB_FLAG_UNKNOWN_NODE for
 * an inactive row, URB_FLAG_FINGERPRINT_MISMATCH for a MISMATCH row used with the schema's layout,
 * URB_FLAG_HOST_SIZE_MISMATCH when the mailbox does not exist in the layout used (the schema's,
 * or with own_layout the node's own report) or has another size; URB_FLAG_NONE when it may be
 * sent. Invalid row or mailbox > 7: URB_FLAG_UNKNOWN_NODE. O(1).
 */
urb_flags_t urb_system_refusal(const urb_system_t *s, uint32_t row, bool own_layout, bool read, uint8_t mailbox,
                               uint8_t length);

/**
 * Why urb_system_find(class_id, index) failed, in the Python library's words (NodeNotFoundError,
 * DuplicateNodeError, FingerprintMismatchError, UnknownClassError), naming bridges by
 * names[bridge] (names may be NULL: "bridge N"). Returns the length written to out, or
 * URB_HOST_EINVAL / URB_HOST_ENOSPC as urb_discovery_describe. O(rows).
 */
int32_t urb_system_describe_find(const urb_system_t *s, uint8_t class_id, uint8_t index, urb_find_t why,
                                 const char *const *names, size_t name_count, char *out, size_t size);

#ifdef __cplusplus
}
#endif

#endif /* URB_DISCOVERY_H */
