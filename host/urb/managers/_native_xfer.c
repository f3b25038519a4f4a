/*
 * _native_xfer.c: the C transfers of urb.managers._native's core object and their hand-back to the
 * Python `Transfer` objects (see _native.c for the type and _native.h for what the parts share).
 *
 * Each submission copies the request into a C transfer (urb_transfer_t, from the core object's free
 * list) that holds a reference to the Python one; when the C core puts it on the wire its sequence
 * number, sending time, deadline and lifetime are written back (native_mark_sent), and as soon as
 * the core completes it its outcome is (done, completed_ns, flags, status, response, lost_reason:
 * what rs232_core.finish and ResponseMatcher.lose set, at the same moment), the C transfer returns
 * to the free list and the Python one waits in the core object's `completed` list for
 * take_completed (native_collect).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "_native.h"

/* Attribute names of Transfer the hand-back writes, interned once per process (immutable constants). */
static PyObject *s_seq, *s_sent_ns, *s_due_ns, *s_expires_ns, *s_garbage, *s_done, *s_completed_ns, *s_flags, *s_status,
    *s_response, *s_lost_reason;

int native_xfer_intern(void)
{
    native_name_t const names[] = {
        {&s_seq, "seq"}, {&s_sent_ns, "sent_ns"}, {&s_due_ns, "due_ns"}, {&s_expires_ns, "expires_ns"},
        {&s_garbage, "garbage"}, {&s_done, "done"}, {&s_completed_ns, "completed_ns"}, {&s_flags, "flags"},
        {&s_status, "status"}, {&s_response, "response"}, {&s_lost_reason, "lost_reason"},
    };
    return native_intern_names(names, sizeof names / sizeof names[0]);
}

static int set_attr_ll(PyObject *obj, PyObject *name, long long v)
{
    PyObject *o = PyLong_FromLongLong(v);
    if (o == NULL) {
        return -1;
    }
    int const rc = PyObject_SetAttr(obj, name, o);
    Py_DECREF(o);
    return rc;
}

/* The free list: a C transfer is allocated once and reused (the core object frees the list). */
native_xfer_t *native_xfer_get(native_core_t *self)
{
    native_xfer_t *x = self->free_list;
    if (x != NULL) {
        self->free_list = x->free_next;
        return x;
    }
    x = PyMem_Malloc(sizeof *x);
    if (x == NULL) {
        PyErr_NoMemory();
    }
    return x;
}

void native_xfer_put(native_core_t *self, native_xfer_t *x)
{
    Py_CLEAR(x->py);
    x->free_next = self->free_list;
    self->free_list = x;
}

/* What ResponseMatcher-side `_send` sets on the Python transfer just put on the wire. */
int native_mark_sent(native_xfer_t *x, urb_ns_t due_ns, urb_ns_t expires_ns)
{
    PyObject *py = x->py;
    x->sent_unmarked = false;
    if (x->cycle_item >= 0) { /* its CycleState takes seq and sent_ns when it completes */
        return 0;
    }
    if ((set_attr_ll(py, s_seq, x->t.seq) < 0) || (set_attr_ll(py, s_sent_ns, x->t.sent_ns) < 0) ||
        (set_attr_ll(py, s_due_ns, due_ns) < 0) || (set_attr_ll(py, s_expires_ns, expires_ns) < 0) ||
        (PyObject_SetAttr(py, s_garbage, Py_False) < 0)) {
        return -1;
    }
    return 0;
}

int native_trace_event(native_core_t *self, PyObject *what, urb_ns_t now, PyObject *items)
{
    PyObject *when = PyLong_FromLongLong(now);
    if (when == NULL) {
        return -1;
    }
    PyObject *ev = PyTuple_Pack(3, what, when, items);
    Py_DECREF(when);
    if (ev == NULL) {
        return -1;
    }
    int const rc = PyList_Append(self->trace, ev);
    Py_DECREF(ev);
    return rc;
}

/* Hands one completed transfer back: writes its outcome into the Python transfer, frees the C one,
 * returns a new reference to the Python transfer. */
static PyObject *hand_back(native_core_t *self, urb_transfer_t *t)
{
    native_xfer_t *x = (native_xfer_t *)t;
    PyObject *py = x->py;
    Py_INCREF(py);
    if (x->sent_unmarked && (native_mark_sent(x, x->due_ns, x->expires_ns) < 0)) {
        native_xfer_put(self, x);
        Py_DECREF(py);
        return NULL;
    }
    PyObject *flags_key = PyLong_FromUnsignedLong((unsigned long)t->flags);
    PyObject *flag = (flags_key == NULL) ? NULL : PyDict_GetItemWithError(self->flag_of, flags_key);
    Py_XDECREF(flags_key);
    if ((flag == NULL) && !PyErr_Occurred()) {
        PyErr_Format(PyExc_ValueError, "the C core completed a request with flags 0x%x, which ErrorFlag does not name",
                     (unsigned)t->flags);
    }
    PyObject *status = Py_None;
    if ((flag != NULL) && (t->status >= 0)) {
        status = (t->status < PyTuple_GET_SIZE(self->status_of)) ? PyTuple_GET_ITEM(self->status_of, t->status) : NULL;
        if (status == NULL) {
            PyErr_Format(PyExc_ValueError, "the C core completed a request with status %d, which Status does not name",
                         (int)t->status);
        }
    }
    PyObject *response = NULL;
    if ((flag != NULL) && (status != NULL)) {
        if (t->read && (t->status == 0)) {
            response = PyBytes_FromStringAndSize((const char *)t->response, t->response_len);
        } else {
            response = Py_None;
            Py_INCREF(response);
        }
    }
    int ok = (response != NULL) && (PyObject_SetAttr(py, s_done, Py_True) == 0) &&
             (set_attr_ll(py, s_completed_ns, t->completed_ns) == 0) && (PyObject_SetAttr(py, s_flags, flag) == 0) &&
             (PyObject_SetAttr(py, s_status, status) == 0) && (PyObject_SetAttr(py, s_response, response) == 0);
    Py_XDECREF(response);
    if (ok && ((t->flags & URB_FLAG_BRIDGE_LOST) != 0u)) {
        PyObject *reason = native_reason_text(self, t->lost_reason);
        ok = (reason != NULL) && (PyObject_SetAttr(py, s_lost_reason, reason) == 0);
        Py_XDECREF(reason);
    }
    native_xfer_put(self, x);
    if (!ok) {
        Py_DECREF(py);
        return NULL;
    }
    return py;
}

/* Hands every transfer the C core completed back to its Python object at once (the reference core
 * marks a transfer done when it completes it, before take_completed), keeping it in `completed`
 * until take_completed; those answered by a response also go to `answered` when it is not NULL. */
int native_collect(native_core_t *self, PyObject *answered)
{
    urb_transfer_t *t;
    while ((t = urb_core_take_completed(&self->core)) != NULL) {
        native_xfer_t *x = (native_xfer_t *)t;
        if (x->cycle_item >= 0) { /* its state completes once, with its last item */
            int const last = native_cycle_item_done(self, x);
            int const rc = (last == 1) ? PyList_Append(self->completed, x->py) : last;
            native_xfer_put(self, x);
            if (rc < 0) {
                return -1;
            }
            continue;
        }
        bool const has_status = t->status >= 0;
        PyObject *py = hand_back(self, t);
        if (py == NULL) {
            return -1;
        }
        int rc = PyList_Append(self->completed, py);
        if ((rc == 0) && (answered != NULL) && has_status) {
            rc = PyList_Append(answered, py);
        }
        Py_DECREF(py);
        if (rc < 0) {
            return -1;
        }
    }
    return 0;
}

/* Completes everything the core still owns (BRIDGE_LOST) and drops the references: teardown. */
void native_release_all(native_core_t *self)
{
    if (!self->ready) {
        return;
    }
    urb_core_link_lost(&self->core, 0, "the core was released");
    urb_transfer_t *t;
    while ((t = urb_core_take_completed(&self->core)) != NULL) {
        native_xfer_put(self, (native_xfer_t *)t);
    }
}
