/*
 * The system table (host/urb/api.py URBInterface._merge, _flag_duplicates, find_node, node_at,
 * NodeAccessor._refusal): every node of every bridge, flagged, never merged (Discovery.tla).
 */
#include "urb_discovery.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

void urb_system_init(urb_system_t *s, const urb_schema_t *schema)
{
    if (s == NULL) {
        return;
    }
    memset(s, 0, sizeof *s);
    s->schema = (schema == NULL) ? urb_schema_default() : schema;
}

static bool valid_row(const urb_system_t *s, uint32_t row)
{
    return (row < URB_SYSTEM_MAX_ROWS) && s->rows[row].used;
}

/* Discovery.tla Flags: the same (class, index) anywhere in the system flags every such row. */
static void flag_duplicates(urb_system_t *s)
{
    for (uint32_t i = 0u; i < URB_SYSTEM_MAX_ROWS; i++) {
        urb_node_row_t *r = &s->rows[i];
        if (!r->used || !r->active) {
            continue;
        }
        uint32_t same = 0u;
        for (uint32_t j = 0u; j < URB_SYSTEM_MAX_ROWS; j++) {
            urb_node_row_t const *o = &s->rows[j];
            same += (o->used && o->active && (o->ident.class_id == r->ident.class_id) && (o->ident.index == r->ident.index))
                        ? 1u : 0u;
        }
        r->flags = (uint8_t)((same > 1u) ? (r->flags | URB_NODE_DUPLICATE) : (r->flags & ~URB_NODE_DUPLICATE));
    }
}

/* The active row of `bridge` with the node's class and index not yet claimed in this merge. */
static int32_t previous(const urb_system_t *s, uint8_t bridge, const urb_found_node_t *n, const bool *claimed)
{
    int32_t best = URB_HOST_ENOTFOUND;
    for (uint32_t i = 0u; i < URB_SYSTEM_MAX_ROWS; i++) {
        urb_node_row_t const *r = &s->rows[i];
        if (r->used && r->active && !claimed[i] && (r->bridge == bridge) && (r->ident.class_id == n->ident.class_id) &&
            (r->ident.index == n->ident.index) && ((best < 0) || (r->order < s->rows[best].order))) {
            best = (int32_t)i;
        }
    }
    return best;
}

static bool free_slot(const urb_node_row_t *r)
{
    return !r->used || (!r->active && !r->pinned);
}

/* Discovery.tla: HostBuildTable (one bridge's rows at a time, every row kept) */
int32_t urb_system_merge(urb_system_t *s, uint8_t bridge, const urb_discovery_t *d)
{
    if ((s == NULL) || (d == NULL)) {
        return URB_HOST_EINVAL;
    }
    if (d->outcome != URB_DISCOVERY_DONE) {
        return URB_HOST_ESTATE;
    }
    bool claimed[URB_SYSTEM_MAX_ROWS] = {false};
    int32_t slot_of[URB_ADDRESSES];
    uint32_t needed = 0u;
    for (uint32_t k = 0u; k < d->node_count; k++) {
        slot_of[k] = previous(s, bridge, &d->nodes[k], claimed);
        if (slot_of[k] >= 0) {
            claimed[slot_of[k]] = true;
        } else {
            needed++;
        }
    }
    uint32_t available = 0u;
    for (uint32_t i = 0u; i < URB_SYSTEM_MAX_ROWS; i++) {
        /* an unclaimed active row of this bridge is about to go: its slot is free unless pinned */
        bool const going = s->rows[i].used && s->rows[i].active && (s->rows[i].bridge == bridge) && !claimed[i];
        available += (free_slot(&s->rows[i]) || (going && !s->rows[i].pinned)) ? 1u : 0u;
    }
    if (needed > available) {
        return URB_HOST_ENOSPC;
    }
    for (uint32_t i = 0u; i < URB_SYSTEM_MAX_ROWS; i++) { /* rows not found again */
        urb_node_row_t *r = &s->rows[i];
        if (r->used && r->active && (r->bridge == bridge) && !claimed[i]) {
            r->active = false;
        }
    }
    uint32_t next_free = 0u;
    for (uint32_t k = 0u; k < d->node_count; k++) {
        urb_node_row_t *r;
        if (slot_of[k] >= 0) {
            r = &s->rows[slot_of[k]]; /* the same node again: updated in place, accessors stay valid */
        } else {
            while (!free_slot(&s->rows[next_free])) {
                next_free++;
            }
            r = &s->rows[next_free];
            memset(r, 0, sizeof *r);
            r->used = true;
            r->bridge = bridge;
        }
        r->address = d->nodes[k].address;
        r->ident = d->nodes[k].ident;
        r->type = d->nodes[k].type;
        r->flags = d->nodes[k].flags;
        r->active = true;
        r->order = s->next_order++; /* this bridge's rows go last, in address order (keep + new) */
    }
    flag_duplicates(s);
    return URB_HOST_OK;
}

void urb_system_forget(urb_system_t *s, uint8_t bridge)
{
    if (s == NULL) {
        return;
    }
    for (uint32_t i = 0u; i < URB_SYSTEM_MAX_ROWS; i++) {
        if (s->rows[i].used && (s->rows[i].bridge == bridge)) {
            s->rows[i].active = false;
        }
    }
    flag_duplicates(s);
}

int32_t urb_system_find(urb_system_t *s, uint8_t class_id, uint8_t index, urb_find_t *why)
{
    urb_find_t dummy;
    urb_find_t *w = (why == NULL) ? &dummy : why;
    if (s == NULL) {
        *w = URB_FIND_NOT_FOUND;
        return URB_HOST_ENOTFOUND;
    }
    if (urb_schema_find_class(s->schema, class_id) == NULL) {
        *w = URB_FIND_UNKNOWN_CLASS;
        return URB_HOST_ENOTFOUND;
    }
    int32_t found = URB_HOST_ENOTFOUND;
    uint32_t count = 0u;
    for (uint32_t i = 0u; i < URB_SYSTEM_MAX_ROWS; i++) {
        urb_node_row_t const *r = &s->rows[i];
        if (r->used && r->active && (r->ident.class_id == class_id) && (r->ident.index == index)) {
            count++;
            found = (int32_t)i;
        }
    }
    if (count == 0u) {
        *w = URB_FIND_NOT_FOUND;
        return URB_HOST_ENOTFOUND;
    }
    if (count > 1u) {
        *w = URB_FIND_DUPLICATE;
        return URB_HOST_ENOTFOUND;
    }
    if ((s->rows[found].flags & URB_NODE_MISMATCH) != 0u) {
        *w = URB_FIND_MISMATCH;
        return URB_HOST_ENOTFOUND;
    }
    *w = URB_FIND_OK;
    s->rows[found].pinned = true;
    return found;
}

int32_t urb_system_at(urb_system_t *s, uint8_t bridge, uint8_t address)
{
    if (s == NULL) {
        return URB_HOST_ENOTFOUND;
    }
    for (uint32_t i = 0u; i < URB_SYSTEM_MAX_ROWS; i++) {
        urb_node_row_t *r = &s->rows[i];
        if (r->used && r->active && (r->bridge == bridge) && (r->address == address)) {
            r->pinned = true;
            return (int32_t)i;
        }
    }
    return URB_HOST_ENOTFOUND;
}

size_t urb_system_list(const urb_system_t *s, uint32_t *out, size_t cap)
{
    if (s == NULL) {
        return 0u;
    }
    size_t n = 0u;
    uint32_t last = 0u;
    bool first = true;
    for (;;) { /* the next active row in listing order after `last` */
        int32_t best = -1;
        for (uint32_t i = 0u; i < URB_SYSTEM_MAX_ROWS; i++) {
            urb_node_row_t const *r = &s->rows[i];
            if (r->used && r->active && (first || (r->order > last)) &&
                ((best < 0) || (r->order < s->rows[best].order))) {
                best = (int32_t)i;
            }
        }
        if (best < 0) {
            return n;
        }
        if ((out != NULL) && (n < cap)) {
            out[n] = (uint32_t)best;
        }
        n++;
        last = s->rows[best].order;
        first = false;
    }
}

urb_flags_t urb_system_refusal(const urb_system_t *s, uint32_t row, bool own_layout, bool read, uint8_t mailbox,
                               uint8_t length)
{
    if ((s == NULL) || !valid_row(s, row) || !s->rows[row].active || (mailbox > 7u)) {
        return URB_FLAG_UNKNOWN_NODE;
    }
    urb_node_row_t const *r = &s->rows[row];
    if (((r->flags & URB_NODE_MISMATCH) != 0u) && !own_layout) {
        return URB_FLAG_FINGERPRINT_MISMATCH;
    }
    uint8_t size;
    if (own_layout || (r->type == NULL)) {
        size = read ? r->ident.outbox_sizes[mailbox] : r->ident.inbox_sizes[mailbox];
        if (size > URB_HOST_MAILBOX_MAX) {
            size = 0u; /* raw_node_info keeps 1..32 only */
        }
    } else {
        size = read ? r->type->outbox_sizes[mailbox] : r->type->inbox_sizes[mailbox];
    }
    return ((size == 0u) || (size != length)) ? URB_FLAG_HOST_SIZE_MISMATCH : URB_FLAG_NONE;
}

/* ----- messages ------------------------------------------------------------------------------- */

typedef struct {
    char *out;
    size_t size;
    size_t len;
    bool cut;
} text_t;

static void put(text_t *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void put(text_t *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    size_t const room = t->size - t->len;
    int const n = vsnprintf(t->out + t->len, room, fmt, ap);
    va_end(ap);
    if ((n < 0) || ((size_t)n >= room)) {
        t->cut = true;
        t->len = t->size - 1u;
    } else {
        t->len += (size_t)n;
    }
}

static void put_label(text_t *t, const urb_node_row_t *r)
{
    if (r->type != NULL) {
        put(t, "%s:%u", r->type->name, r->ident.index);
    } else {
        put(t, "class 0x%02x:%u", r->ident.class_id, r->ident.index);
    }
}

static void put_location(text_t *t, const urb_node_row_t *r, const char *const *names, size_t count)
{
    if ((names != NULL) && (r->bridge < count) && (names[r->bridge] != NULL)) {
        put(t, "%s address %u", names[r->bridge], r->address);
    } else {
        put(t, "bridge %u address %u", r->bridge, r->address);
    }
}

int32_t urb_system_describe_find(const urb_system_t *s, uint8_t class_id, uint8_t index, urb_find_t why,
                                 const char *const *names, size_t name_count, char *out, size_t size)
{
    if ((s == NULL) || (out == NULL) || (size == 0u)) {
        return URB_HOST_EINVAL;
    }
    text_t t = {out, size, 0u, false};
    out[0] = '\0';
    const urb_node_type_t *type = urb_schema_find_class(s->schema, class_id);
    uint32_t list[URB_SYSTEM_MAX_ROWS];
    size_t const n = urb_system_list(s, list, URB_SYSTEM_MAX_ROWS);
    if (why == URB_FIND_UNKNOWN_CLASS || type == NULL) {
        put(&t, "class 0x%02x is not declared in the host's schema; known: ", class_id);
        bool first = true;
        for (uint32_t c = 0u; c < 256u; c++) { /* sorted by class */
            const urb_node_type_t *k = urb_schema_find_class(s->schema, (uint8_t)c);
            if (k != NULL) {
                put(&t, "%s%s (0x%02x)", first ? "" : ", ", k->name, k->class_id);
                first = false;
            }
        }
    } else if (why == URB_FIND_NOT_FOUND) {
        put(&t, "no %s with index %u was discovered (bridges: ", type->name, index);
        if (name_count == 0u) {
            put(&t, "no bridges registered");
        }
        for (size_t b = 0u; b < name_count; b++) {
            put(&t, "%s%s", (b > 0u) ? ", " : "", (names != NULL && names[b] != NULL) ? names[b] : "?");
        }
        put(&t, "; found: ");
        if (n == 0u) {
            put(&t, "no nodes");
        }
        for (size_t i = 0u; i < n; i++) {
            put(&t, "%s", (i > 0u) ? ", " : "");
            put_label(&t, &s->rows[list[i]]);
            put(&t, " (");
            put_location(&t, &s->rows[list[i]], names, name_count);
            put(&t, ")");
        }
        put(&t, "). Check that the node is powered and its index, then rediscover (urb scan PORT).");
    } else if (why == URB_FIND_DUPLICATE) {
        size_t places = 0u;
        for (size_t i = 0u; i < n; i++) {
            places += (s->rows[list[i]].ident.class_id == class_id && s->rows[list[i]].ident.index == index) ? 1u : 0u;
        }
        put(&t, "%s:%u answers at %zu places (", type->name, index, places);
        bool first = true;
        for (size_t i = 0u; i < n; i++) {
            urb_node_row_t const *r = &s->rows[list[i]];
            if (r->ident.class_id == class_id && r->ident.index == index) {
                put(&t, "%s", first ? "" : "; ");
                put_location(&t, r, names, name_count);
                first = false;
            }
        }
        put(&t, "): two nodes have the same class and index. Give each a distinct index (URB_SetIndex) and rediscover.");
    } else if (why == URB_FIND_MISMATCH) {
        for (size_t i = 0u; i < n; i++) {
            urb_node_row_t const *r = &s->rows[list[i]];
            if (r->ident.class_id == class_id && r->ident.index == index) {
                put_label(&t, r);
                put(&t, " at ");
                put_location(&t, r, names, name_count);
                put(&t,
                    " reports layout fingerprint 0x%08lx, but the host's schema %s gives 0x%08lx: the node firmware "
                    "and this host were built from different schemas. Rebuild one of them from the same %s (urb "
                    "gen), then flash or reinstall.",
                    (unsigned long)r->ident.fingerprint, type->schema_file, (unsigned long)type->fingerprint,
                    type->schema_file);
                break;
            }
        }
    }
    return t.cut ? URB_HOST_ENOSPC : (int32_t)t.len;
}
