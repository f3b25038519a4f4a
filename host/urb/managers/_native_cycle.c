/*
 * The cycle state of urb.managers._native (issue #38): the C half of urb.cycle.Cycle, a fixed set
 * of requests (reads and writes of mailboxes of nodes behind one bridge) submitted together every
 * control tick, which completes with one Python callback per tick instead of one per request.
 *
 * A CycleState holds, per item, the request (address, mailbox, direction, length, the next write
 * payload) and its last outcome (flags, bridge status, response, sequence number, sending and
 * completion times, lost reason). Core._cycle_submit(state, now, refusals) hands every item to the
 * C core at once, as C transfers that point back to the state (native_xfer_t.cycle_item) instead of
 * to a Python Transfer; when the core completes one, native_collect() (in _native_xfer.c) calls
 * native_cycle_item_done, which writes its outcome into the state, and when the last item of the
 * tick completed the state itself goes to the core's completion list, once: the manager then
 * queues the state's `on_done` for its dispatcher. A state without on_done is polled: its owner
 * collects the completions (Cycle.poll) and the pump does not wake the dispatcher for its items. No Python object is built per item on this path;
 * the accessors (flags(i), data(i), ...) build the one asked for, when asked.
 *
 * Every item of a submission ends in exactly one outcome: the core's (response, timeout, loss), or
 * the caller's refusal (`refusals[i]` != 0: completed at once with that flag, never sent). A state
 * with items pending refuses another submission (RuntimeError; nothing changes).
 */
#include "_native.h"

#include <string.h>

#include "urb_flags.h"

typedef struct {
    uint8_t address;
    uint8_t mailbox;
    uint8_t length;
    bool read;
    bool has_data;                         /* a write item was given its payload */
    uint8_t data[URB_HOST_MAILBOX_MAX];    /* the payload of its next submission */
    /* the outcome of the last submission */
    bool done;
    uint16_t flags;
    int8_t status;
    int8_t seq;
    uint8_t response_len;
    uint8_t response[URB_HOST_MAILBOX_MAX];
    urb_ns_t sent_ns;
    urb_ns_t completed_ns;
    PyObject *lost_reason;                 /* str for BRIDGE_LOST, else NULL */
} cycle_item_t;

struct native_cycle {
    PyObject_HEAD
    Py_ssize_t n;
    Py_ssize_t pending;   /* items of the current submission not completed yet */
    Py_ssize_t failed;    /* items of the last submission completed with a flag */
    bool lost;            /* one of them completed BRIDGE_LOST */
    bool polled;          /* on_done is None: the owner collects the completion (Cycle.poll), so the
                             pump does not wake the dispatcher for its items */
    PyObject *on_done;    /* what the manager queues for its dispatcher when the last item completed */
    cycle_item_t *items;
};

/* ----- building --------------------------------------------------------------------------------- */

static int parse_spec(PyObject *spec, Py_ssize_t i, cycle_item_t *it)
{
    int address = 0, mailbox = 0, read = 0, length = 0;
    if (!PyTuple_Check(spec) || !PyArg_ParseTuple(spec, "iipi", &address, &mailbox, &read, &length)) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "cycle item %zd: a spec is a tuple (address, mailbox, read, length)", i);
        return -1;
    }
    urb_transfer_t probe; /* the same range checks as the submission's */
    uint8_t const zeros[URB_HOST_MAILBOX_MAX] = {0};
    bool const in_range = (address >= 0) && (address <= 255) && (mailbox >= 0) && (mailbox <= 255) && (length >= 0) &&
                          (length <= (int)URB_HOST_MAILBOX_MAX);
    int32_t const rc = !in_range ? URB_HOST_EINVAL
                       : read    ? urb_transfer_read(&probe, (uint8_t)address, (uint8_t)mailbox, (uint8_t)length)
                                 : urb_transfer_write(&probe, (uint8_t)address, (uint8_t)mailbox, zeros, (uint8_t)length);
    if (rc != URB_HOST_OK) {
        PyErr_Format(PyExc_ValueError, "cycle item %zd: address %d (0..127), mailbox %d (0..7), length %d (1..32) must "
                     "be in range", i, address, mailbox, length);
        return -1;
    }
    it->address = (uint8_t)address;
    it->mailbox = (uint8_t)mailbox;
    it->read = read != 0;
    it->length = (uint8_t)length;
    it->status = -1;
    it->seq = -1;
    it->sent_ns = URB_NO_TIME;
    it->completed_ns = URB_NO_TIME;
    return 0;
}

static PyObject *cycle_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    PyObject *specs = NULL;
    if ((kwds != NULL) && (PyDict_GET_SIZE(kwds) > 0)) {
        PyErr_SetString(PyExc_TypeError, "CycleState(specs) takes no keyword arguments");
        return NULL;
    }
    if (!PyArg_ParseTuple(args, "O!", &PyTuple_Type, &specs)) {
        return NULL;
    }
    Py_ssize_t const n = PyTuple_GET_SIZE(specs);
    if ((n < 1) || (n > NATIVE_CYCLE_MAX)) {
        PyErr_Format(PyExc_ValueError, "a cycle holds 1..%d items per bridge, not %zd", NATIVE_CYCLE_MAX, n);
        return NULL;
    }
    native_cycle_t *self = (native_cycle_t *)type->tp_alloc(type, 0);
    if (self == NULL) {
        return NULL;
    }
    self->items = PyMem_Calloc((size_t)n, sizeof *self->items);
    if (self->items == NULL) {
        Py_DECREF(self);
        return PyErr_NoMemory();
    }
    self->n = n;
    for (Py_ssize_t i = 0; i < n; i++) {
        if (parse_spec(PyTuple_GET_ITEM(specs, i), i, &self->items[i]) < 0) {
            Py_DECREF(self);
            return NULL;
        }
    }
    self->on_done = Py_None;
    Py_INCREF(Py_None);
    self->polled = true;
    return (PyObject *)self;
}

static int cycle_traverse(native_cycle_t *self, visitproc visit, void *arg)
{
    Py_VISIT(self->on_done);
    return 0;
}

static int cycle_clear(native_cycle_t *self)
{
    Py_CLEAR(self->on_done);
    if (self->items != NULL) {
        for (Py_ssize_t i = 0; i < self->n; i++) {
            Py_CLEAR(self->items[i].lost_reason);
        }
    }
    return 0;
}

static void cycle_dealloc(native_cycle_t *self)
{
    PyObject_GC_UnTrack(self);
    (void)cycle_clear(self);
    PyMem_Free(self->items);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* ----- submission and completion (with the core's lock held) ------------------------------------ */

static void item_complete(native_cycle_t *state, cycle_item_t *it, uint16_t flags)
{
    it->done = true;
    it->flags = flags;
    if (flags != 0u) {
        state->failed++;
        state->lost = state->lost || ((flags & URB_FLAG_BRIDGE_LOST) != 0u);
    }
    state->pending--;
}

int native_cycle_item_done(native_core_t *core, native_xfer_t *x)
{
    native_cycle_t *state = (native_cycle_t *)x->py;
    cycle_item_t *it = &state->items[x->cycle_item];
    urb_transfer_t const *t = &x->t;
    it->status = t->status;
    it->seq = t->seq;
    it->sent_ns = t->sent_ns;
    it->completed_ns = t->completed_ns;
    it->response_len = (it->read && (t->status == 0)) ? t->response_len : 0u;
    (void)memcpy(it->response, t->response, it->response_len);
    if ((t->flags & URB_FLAG_BRIDGE_LOST) != 0u) {
        PyObject *reason = native_reason_text(core, t->lost_reason);
        if (reason == NULL) {
            return -1;
        }
        Py_XSETREF(it->lost_reason, reason);
    }
    item_complete(state, it, (uint16_t)t->flags);
    return state->pending == 0 ? 1 : 0;
}

bool native_cycle_item_polled(const native_xfer_t *x)
{
    return (x->cycle_item >= 0) && ((const native_cycle_t *)x->py)->polled;
}

/* _cycle_submit(state, now, refusals): every item of `state` to the core, except those refused
 * (refusals: None, or a tuple of one flag per item, 0 to send it). */
PyObject *native_cycle_submit(native_core_t *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (native_not_ready(self)) {
        return NULL;
    }
    if ((nargs != 3) || !PyObject_TypeCheck(args[0], &native_cycle_type)) {
        PyErr_SetString(PyExc_TypeError, "_cycle_submit(state, now, refusals) takes a CycleState of this module, "
                                         "the time and None or a tuple of flags");
        return NULL;
    }
    native_cycle_t *state = (native_cycle_t *)args[0];
    long long const now = PyLong_AsLongLong(args[1]);
    if ((now == -1) && PyErr_Occurred()) {
        return NULL;
    }
    PyObject *refusals = args[2];
    if ((refusals != Py_None) && (!PyTuple_Check(refusals) || (PyTuple_GET_SIZE(refusals) != state->n))) {
        PyErr_Format(PyExc_TypeError, "refusals: None or a tuple of %zd flags", state->n);
        return NULL;
    }
    if (self->trace != Py_None) {
        PyErr_SetString(PyExc_RuntimeError, "a traced core takes single transfers only (its trace records Python "
                                            "Transfer objects): submit the items one by one");
        return NULL;
    }
    if (state->pending > 0) {
        PyErr_Format(PyExc_RuntimeError, "the cycle is still in flight (%zd of %zd items pending)", state->pending,
                     state->n);
        return NULL;
    }
    uint16_t refused[NATIVE_CYCLE_MAX];
    for (Py_ssize_t i = 0; i < state->n; i++) {
        cycle_item_t const *it = &state->items[i];
        long const r = (refusals == Py_None) ? 0L : PyLong_AsLong(PyTuple_GET_ITEM(refusals, i));
        if ((r == -1L) && PyErr_Occurred()) {
            return NULL;
        }
        if ((r < 0L) || (r > 0xFFFFL)) {
            PyErr_Format(PyExc_ValueError, "refusal %ld of item %zd is not a flag", r, i);
            return NULL;
        }
        if ((r == 0L) && !it->read && !it->has_data) {
            PyErr_Format(PyExc_ValueError, "cycle item %zd writes, but was given no data", i);
            return NULL;
        }
        refused[i] = (uint16_t)r;
    }
    /* every C transfer first: a submission either sends all its items or none */
    native_xfer_t *xs[NATIVE_CYCLE_MAX];
    for (Py_ssize_t i = 0; i < state->n; i++) {
        xs[i] = (refused[i] != 0u) ? NULL : native_xfer_get(self);
        if ((refused[i] == 0u) && (xs[i] == NULL)) {
            for (Py_ssize_t k = 0; k < i; k++) {
                if (xs[k] != NULL) {
                    xs[k]->py = NULL;
                    native_xfer_put(self, xs[k]);
                }
            }
            return NULL;
        }
    }
    state->pending = state->n;
    state->failed = 0;
    state->lost = false;
    for (Py_ssize_t i = 0; i < state->n; i++) {
        cycle_item_t *it = &state->items[i];
        it->done = false;
        it->flags = 0u;
        it->status = -1;
        it->seq = -1;
        it->sent_ns = URB_NO_TIME;
        it->completed_ns = URB_NO_TIME;
        it->response_len = 0u;
        Py_CLEAR(it->lost_reason);
    }
    for (Py_ssize_t i = 0; i < state->n; i++) {
        cycle_item_t *it = &state->items[i];
        if (refused[i] != 0u) {
            it->completed_ns = now;
            item_complete(state, it, refused[i]);
            continue;
        }
        native_xfer_t *x = xs[i];
        /* ranges checked when the state was built */
        (void)(it->read ? urb_transfer_read(&x->t, it->address, it->mailbox, it->length)
                        : urb_transfer_write(&x->t, it->address, it->mailbox, it->data, it->length));
        x->py = (PyObject *)state;
        Py_INCREF(state);
        x->cycle_item = (int32_t)i;
        x->sent_unmarked = false;
        (void)urb_core_submit(&self->core, &x->t, now);
    }
    if ((state->pending == 0) && (PyList_Append(self->completed, (PyObject *)state) < 0)) {
        return NULL;
    }
    Py_RETURN_NONE;
}

PyObject *native_new_cycle_state(native_core_t *self, PyObject *specs)
{
    (void)self;
    return PyObject_CallOneArg((PyObject *)&native_cycle_type, specs);
}

/* ----- the outcome, read lazily ----------------------------------------------------------------- */

static cycle_item_t *item_at(native_cycle_t *self, PyObject *arg)
{
    Py_ssize_t const i = PyLong_AsSsize_t(arg);
    if ((i == -1) && PyErr_Occurred()) {
        return NULL;
    }
    if ((i < 0) || (i >= self->n)) {
        PyErr_Format(PyExc_IndexError, "cycle item %zd: the cycle has items 0..%zd", i, self->n - 1);
        return NULL;
    }
    return &self->items[i];
}

static PyObject *ns_or_none(urb_ns_t v)
{
    if (v == URB_NO_TIME) {
        Py_RETURN_NONE;
    }
    return PyLong_FromLongLong(v);
}

static PyObject *cycle_flags(native_cycle_t *self, PyObject *arg)
{
    cycle_item_t const *it = item_at(self, arg);
    return (it == NULL) ? NULL : PyLong_FromUnsignedLong(it->flags);
}

static PyObject *cycle_status(native_cycle_t *self, PyObject *arg)
{
    cycle_item_t const *it = item_at(self, arg);
    return (it == NULL) ? NULL : PyLong_FromLong(it->status);
}

static PyObject *cycle_data(native_cycle_t *self, PyObject *arg)
{
    cycle_item_t const *it = item_at(self, arg);
    if (it == NULL) {
        return NULL;
    }
    if (!it->done || !it->read || (it->status != 0)) {
        Py_RETURN_NONE;
    }
    return PyBytes_FromStringAndSize((const char *)it->response, it->response_len);
}

static PyObject *cycle_seq(native_cycle_t *self, PyObject *arg)
{
    cycle_item_t const *it = item_at(self, arg);
    return (it == NULL) ? NULL : PyLong_FromLong(it->seq);
}

static PyObject *cycle_sent_ns(native_cycle_t *self, PyObject *arg)
{
    cycle_item_t const *it = item_at(self, arg);
    return (it == NULL) ? NULL : ns_or_none(it->sent_ns);
}

static PyObject *cycle_completed_ns(native_cycle_t *self, PyObject *arg)
{
    cycle_item_t const *it = item_at(self, arg);
    return (it == NULL) ? NULL : ns_or_none(it->completed_ns);
}

static PyObject *cycle_lost_reason(native_cycle_t *self, PyObject *arg)
{
    cycle_item_t const *it = item_at(self, arg);
    if (it == NULL) {
        return NULL;
    }
    PyObject *r = (it->lost_reason != NULL) ? it->lost_reason : Py_None;
    Py_INCREF(r);
    return r;
}

static PyObject *cycle_set_data(native_cycle_t *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "set_data(i, data) takes 2 arguments");
        return NULL;
    }
    cycle_item_t *it = item_at(self, args[0]);
    if (it == NULL) {
        return NULL;
    }
    if (it->read) {
        PyErr_SetString(PyExc_ValueError, "this cycle item reads: it takes no data");
        return NULL;
    }
    Py_buffer data;
    if (PyObject_GetBuffer(args[1], &data, PyBUF_SIMPLE) < 0) {
        return NULL;
    }
    if (data.len != (Py_ssize_t)it->length) {
        PyErr_Format(PyExc_ValueError, "%zd data bytes: this inbox takes %u (its previous data stay)", data.len,
                     (unsigned)it->length);
        PyBuffer_Release(&data);
        return NULL;
    }
    (void)memcpy(it->data, data.buf, (size_t)data.len);
    it->has_data = true;
    PyBuffer_Release(&data);
    Py_RETURN_NONE;
}

static PyObject *cycle_get_size(native_cycle_t *self, void *closure)
{
    (void)closure;
    return PyLong_FromSsize_t(self->n);
}

static PyObject *cycle_get_pending(native_cycle_t *self, void *closure)
{
    (void)closure;
    return PyLong_FromSsize_t(self->pending);
}

static PyObject *cycle_get_failed(native_cycle_t *self, void *closure)
{
    (void)closure;
    return PyLong_FromSsize_t(self->failed);
}

static PyObject *cycle_get_lost(native_cycle_t *self, void *closure)
{
    (void)closure;
    return PyBool_FromLong(self->lost);
}

static PyObject *cycle_get_on_done(native_cycle_t *self, void *closure)
{
    (void)closure;
    Py_INCREF(self->on_done);
    return self->on_done;
}

static int cycle_set_on_done(native_cycle_t *self, PyObject *value, void *closure)
{
    (void)closure;
    if ((value == NULL) || ((value != Py_None) && !PyCallable_Check(value))) {
        PyErr_SetString(PyExc_TypeError, "on_done is a callable or None");
        return -1;
    }
    if (self->pending > 0) { /* the pump reads `polled` of the items in flight */
        PyErr_SetString(PyExc_RuntimeError, "on_done changes only while the cycle is not in flight");
        return -1;
    }
    Py_INCREF(value);
    Py_XSETREF(self->on_done, value);
    self->polled = value == Py_None;
    return 0;
}

static PyMethodDef cycle_methods[] = {
    {"flags", (PyCFunction)cycle_flags, METH_O, "flags(i) -> int: the ErrorFlag bits of item i (0: success)."},
    {"status", (PyCFunction)cycle_status, METH_O, "status(i) -> int: the bridge's Status of item i, -1 when none."},
    {"data", (PyCFunction)cycle_data, METH_O, "data(i) -> bytes | None: what a successful read of item i read."},
    {"seq", (PyCFunction)cycle_seq, METH_O, "seq(i) -> int: item i's sequence number, -1 when never sent."},
    {"sent_ns", (PyCFunction)cycle_sent_ns, METH_O, "sent_ns(i) -> int | None: when item i was sent."},
    {"completed_ns", (PyCFunction)cycle_completed_ns, METH_O, "completed_ns(i) -> int | None: when item i completed."},
    {"lost_reason", (PyCFunction)cycle_lost_reason, METH_O, "lost_reason(i) -> str | None: why the bridge was lost."},
    {"set_data", (PyCFunction)(void (*)(void))cycle_set_data, METH_FASTCALL,
     "set_data(i, data): the payload of write item i from its next submission on."},
    {NULL, NULL, 0, NULL},
};

static PyGetSetDef cycle_getset[] = {
    {"size", (getter)cycle_get_size, NULL, "Items.", NULL},
    {"pending", (getter)cycle_get_pending, NULL, "Items of the current submission not completed yet.", NULL},
    {"failed", (getter)cycle_get_failed, NULL, "Items of the last submission that completed with a flag.", NULL},
    {"lost", (getter)cycle_get_lost, NULL, "One of them completed BRIDGE_LOST.", NULL},
    {"on_done", (getter)cycle_get_on_done, (setter)cycle_set_on_done,
     "What the manager runs on its dispatcher once every item of a submission completed; None: nothing "
     "(a polled cycle, whose owner collects it).", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

PyTypeObject native_cycle_type = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "urb.managers._native.CycleState",
    .tp_basicsize = sizeof(native_cycle_t),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_doc = "The requests of one urb.cycle.Cycle on one bridge and their last outcomes (_native_cycle.c).",
    .tp_new = cycle_new,
    .tp_dealloc = (destructor)cycle_dealloc,
    .tp_traverse = (traverseproc)cycle_traverse,
    .tp_clear = (inquiry)cycle_clear,
    .tp_methods = cycle_methods,
    .tp_getset = cycle_getset,
};
