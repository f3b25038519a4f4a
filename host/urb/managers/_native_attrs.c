/*
 * The attributes of urb.managers._native.Core (_native.c): the C core's counters, the settable lost
 * reason and the USB pipeline trace, each read and written with the core's lock held (_native.h).
 */
#include "_native.h"

#include <stdint.h>
#include <string.h>

enum { G_STRAY, G_LATE, G_RELEASED, G_IN_FLIGHT, G_PLACEHOLDERS, G_HAS_QUEUED, G_FRAMES, G_TRANSFERS_IN, G_BAD_HEADERS };

static PyObject *core_get_counter(native_core_t *self, void *which)
{
    if (native_not_ready(self)) {
        return NULL;
    }
    const urb_core_t *c = &self->core;
    switch ((int)(intptr_t)which) {
    case G_STRAY: return PyLong_FromUnsignedLongLong(c->m.stray_bytes);
    case G_LATE: return PyLong_FromUnsignedLongLong(c->m.late_responses);
    case G_RELEASED: return PyLong_FromUnsignedLongLong(c->m.released_placeholders);
    case G_IN_FLIGHT: return PyLong_FromUnsignedLong(urb_core_in_flight(c));
    case G_PLACEHOLDERS: return PyLong_FromUnsignedLong(urb_core_placeholders(c));
    case G_HAS_QUEUED: return PyBool_FromLong(urb_core_has_queued(c));
    case G_FRAMES: return PyLong_FromUnsignedLongLong(c->frames_written);
    case G_TRANSFERS_IN: return PyLong_FromUnsignedLongLong(c->transfers_in);
    default: return PyLong_FromUnsignedLongLong(c->bad_headers);
    }
}

static PyObject *core_get_lost_reason(native_core_t *self, void *unused)
{
    (void)unused;
    if (native_not_ready(self)) {
        return NULL;
    }
    const char *r = urb_core_lost_reason(&self->core);
    if (r == NULL) {
        Py_RETURN_NONE;
    }
    return native_reason_text(self, r);
}

/* What MatchingCore callers do after link_lost on a core lost already: say why it is lost now. */
static int core_set_lost_reason(native_core_t *self, PyObject *value, void *unused)
{
    (void)unused;
    if (native_not_ready(self)) {
        return -1;
    }
    if ((value == NULL) || !self->core.lost) {
        PyErr_SetString(PyExc_ValueError, "only a lost core's reason can be replaced (call link_lost first; reset "
                                          "makes the core usable again)");
        return -1;
    }
    const char *text = PyUnicode_Check(value) ? PyUnicode_AsUTF8(value) : NULL;
    if ((text == NULL) || (native_set_full_reason(self, value) < 0)) {
        if (!PyErr_Occurred()) {
            PyErr_SetString(PyExc_TypeError, "a lost reason is a str");
        }
        return -1;
    }
    size_t n = strlen(text);
    if (n > URB_REASON_MAX - 1u) {
        n = URB_REASON_MAX - 1u;
    }
    memcpy(self->core.lost_reason, text, n);
    self->core.lost_reason[n] = '\0';
    return 0;
}

static PyObject *core_get_trace(native_core_t *self, void *unused)
{
    (void)unused;
    Py_INCREF(self->trace);
    return self->trace;
}

static int core_set_trace(native_core_t *self, PyObject *value, void *unused)
{
    (void)unused;
    if ((value == NULL) || ((value != Py_None) && !PyList_CheckExact(value))) {
        PyErr_SetString(PyExc_TypeError, "trace is None or a list");
        return -1;
    }
    Py_INCREF(value);
    Py_XSETREF(self->trace, value);
    return 0;
}

static PyObject *core_get_counter_locked(native_core_t *self, void *which)
{
    if (native_locked_enter(self) < 0) {
        return NULL;
    }
    PyObject *const out = core_get_counter(self, which);
    native_core_unlock(self);
    return out;
}

static PyObject *core_get_lost_reason_locked(native_core_t *self, void *unused)
{
    if (native_locked_enter(self) < 0) {
        return NULL;
    }
    PyObject *const out = core_get_lost_reason(self, unused);
    native_core_unlock(self);
    return out;
}

static int core_set_lost_reason_locked(native_core_t *self, PyObject *value, void *unused)
{
    if (native_locked_enter(self) < 0) {
        return -1;
    }
    int const rc = core_set_lost_reason(self, value, unused);
    native_core_unlock(self);
    return rc;
}

#define COUNTER(name, which, doc) {name, (getter)core_get_counter_locked, NULL, doc, (void *)(intptr_t)(which)}
PyGetSetDef native_core_getset[] = {
    COUNTER("stray_bytes", G_STRAY, "Received bytes that answered no request."),
    COUNTER("late_responses", G_LATE, "Responses that came after their request had timed out (discarded)."),
    COUNTER("released_placeholders", G_RELEASED, "Placeholders released without their late response."),
    COUNTER("in_flight", G_IN_FLIGHT, "Requests in flight, placeholders included."),
    COUNTER("placeholders", G_PLACEHOLDERS, "Timed-out requests whose sequence numbers stay reserved."),
    COUNTER("has_queued", G_HAS_QUEUED, "Requests buffered that the window lets go out."),
    COUNTER("frames_written", G_FRAMES, "USB: OUT transfers built."),
    COUNTER("transfers_in", G_TRANSFERS_IN, "USB: IN transfers received."),
    COUNTER("bad_headers", G_BAD_HEADERS, "USB: IN transfers whose header did not decode."),
    {"lost_reason", (getter)core_get_lost_reason_locked, (setter)core_set_lost_reason_locked, "Why the bridge is lost, or None.",
     NULL},
    {"trace", (getter)core_get_trace, (setter)core_set_trace,
     "None, or a list the USB pipeline's steps are appended to (usb_core.UsbTraceEvent).", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

