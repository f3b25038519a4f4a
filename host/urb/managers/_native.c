/*
 * urb.managers._native: the C protocol core of host/c/core (urb_host_core.h) as a CPython type, so
 * that the Python library's managers run their protocol work in C (issue #38). Built by
 * `make host-c-py` (mk/host_c.mk); host/urb/managers/native.py wraps it in NativeRs232Core and
 * NativeUsbCore, which have the public interface of the reference cores Rs232Core and UsbCore
 * (rs232_core.py, usb_core.py), and chooses between the two (URB_PURE_PYTHON).
 *
 * The Python `Transfer` objects stay the requests the API sees: each submission copies one into a C
 * transfer that the core completes, and its outcome is written back at once (_native_xfer.c).
 * tests/host_c/test_native_core.py drives this type and the reference cores with the same traces and
 * compares everything a caller can observe.
 *
 * Lost reasons: the C core keeps at most URB_REASON_MAX - 1 bytes of a reason; the whole text a
 * caller gave link_lost (or assigned to lost_reason) is kept here and handed out in its place, so
 * a long reason (a port path and an OS error) reads as the reference's does.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>

#include <string.h>

#include "_native.h"


/* Attribute names of Transfer that submit reads, and the trace's event names, interned once per
 * process (immutable constants; the hand-back's are _native_xfer.c's). */
static PyObject *s_address, *s_mailbox, *s_read, *s_length, *s_data, *s_answer_within_ns, *s_completed_ns;
static PyObject *s_submit, *s_write, *s_read_event, *s_callback;

/* ----- small helpers ---------------------------------------------------------------------------- */

int native_not_ready(const native_core_t *self)
{
    if (!self->ready) {
        PyErr_SetString(PyExc_RuntimeError, "the native core was not set up (construct NativeRs232Core or NativeUsbCore)");
        return 1;
    }
    return 0;
}

void native_core_lock(native_core_t *self)
{
    /* The pump holds the lock for a few microseconds at a time: spin that long before giving the
     * GIL away (another Python thread would take it and keep it up to the switch interval). */
    for (unsigned spin = 0u; spin < NATIVE_LOCK_SPINS; spin++) {
        if (pthread_mutex_trylock(&self->lock) == 0) {
            return;
        }
    }
    if (pthread_mutex_trylock(&self->lock) != 0) {
        Py_BEGIN_ALLOW_THREADS
        (void)pthread_mutex_lock(&self->lock);
        Py_END_ALLOW_THREADS
    }
}

void native_core_unlock(native_core_t *self)
{
    (void)pthread_mutex_unlock(&self->lock);
}

static PyObject *time_or_none(urb_ns_t v)
{
    if ((v == URB_NO_TIME) || (v == URB_NEVER)) {
        Py_RETURN_NONE;
    }
    return PyLong_FromLongLong(v);
}

/* The reason text for the C core's `r`: the caller's whole text when r is its cut. */
PyObject *native_reason_text(native_core_t *self, const char *r)
{
    size_t const n = strlen(r);
    if ((self->full_reason != NULL) && (n == URB_REASON_MAX - 1u)) {
        Py_ssize_t full_n = 0;
        const char *full = PyUnicode_AsUTF8AndSize(self->full_reason, &full_n);
        if (full == NULL) {
            return NULL;
        }
        if (((size_t)full_n > n) && (memcmp(full, r, n) == 0)) {
            Py_INCREF(self->full_reason);
            return self->full_reason;
        }
    }
    return PyUnicode_DecodeUTF8(r, (Py_ssize_t)n, "replace");
}

static int get_int(PyObject *obj, PyObject *name, long long *out)
{
    PyObject *v = PyObject_GetAttr(obj, name);
    if (v == NULL) {
        return -1;
    }
    *out = PyLong_AsLongLong(v);
    Py_DECREF(v);
    return ((*out == -1) && PyErr_Occurred()) ? -1 : 0;
}

/* The slot of the request most recently put in flight. */
static const urb_slot_t *newest_slot(const urb_core_t *core)
{
    unsigned const k = ((unsigned)core->m.head + (unsigned)core->m.count - 1u) % URB_MATCHER_SLOTS;
    return &core->m.slot[k];
}

/* ----- the type --------------------------------------------------------------------------------- */

static int core_traverse(native_core_t *self, visitproc visit, void *arg)
{
    Py_VISIT(self->status_of);
    Py_VISIT(self->flag_of);
    Py_VISIT(self->trace);
    Py_VISIT(self->completed);
    if (self->ready) {
        for (urb_transfer_t *t = self->core.q_head; t != NULL; t = t->next) {
            Py_VISIT(((native_xfer_t *)t)->py);
        }
        for (urb_transfer_t *t = self->core.m.done_head; t != NULL; t = t->next) {
            Py_VISIT(((native_xfer_t *)t)->py);
        }
        for (unsigned i = 0u; i < self->core.m.count; i++) {
            urb_transfer_t *t = self->core.m.slot[(self->core.m.head + i) % URB_MATCHER_SLOTS].t;
            if (t != NULL) {
                Py_VISIT(((native_xfer_t *)t)->py);
            }
        }
    }
    return 0;
}

static int core_clear(native_core_t *self)
{
    native_pump_join(self); /* its thread uses the core being released */
    native_release_all(self);
    self->ready = false; /* a cleared object (a reference cycle being collected) refuses every call */
    Py_CLEAR(self->status_of);
    Py_CLEAR(self->flag_of);
    Py_CLEAR(self->full_reason);
    Py_CLEAR(self->trace);
    Py_CLEAR(self->completed);
    return 0;
}

static void core_dealloc(native_core_t *self)
{
    PyObject_GC_UnTrack(self);
    core_clear(self);
    (void)pthread_cond_destroy(&self->ready_cond);
    (void)pthread_mutex_destroy(&self->lock);
    while (self->free_list != NULL) {
        native_xfer_t *x = self->free_list;
        self->free_list = x->free_next;
        PyMem_Free(x);
    }
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *core_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    (void)args;
    (void)kwds;
    native_core_t *self = (native_core_t *)type->tp_alloc(type, 0);
    if (self != NULL) {
        pthread_condattr_t attr;
        bool const made = (pthread_condattr_init(&attr) == 0) &&
                          (pthread_condattr_setclock(&attr, CLOCK_MONOTONIC) == 0) &&
                          (pthread_cond_init(&self->ready_cond, &attr) == 0);
        if (!made || (pthread_mutex_init(&self->lock, NULL) != 0)) {
            PyErr_SetString(PyExc_OSError, "cannot create the native core's mutex and condition");
            PyObject_GC_UnTrack(self);
            Py_TYPE(self)->tp_free((PyObject *)self);
            return NULL;
        }
        (void)pthread_condattr_destroy(&attr);
        self->pump.fd = -1;
        self->pump.wake_fd = -1;
        self->trace = Py_None;
        Py_INCREF(Py_None);
        self->completed = PyList_New(0);
        if (self->completed == NULL) {
            Py_DECREF(self);
            return NULL;
        }
    }
    return (PyObject *)self;
}

/* _setup(kind, window, timeout_ns, lost_after_ns, lost_after_timeouts, placeholder_ns, resync_gap_ns,
 *        max_batch, batch_bytes, status_members, flag_members) */
static PyObject *core_setup(native_core_t *self, PyObject *args)
{
    int kind = 0, window = 0, max_batch = 0, batch_bytes = 0;
    long long timeout_ns = 0, lost_after_ns = 0, lost_after_timeouts = 0, placeholder_ns = 0, resync_gap_ns = 0;
    PyObject *status_of = NULL, *flag_of = NULL;
    if (!PyArg_ParseTuple(args, "iiLLLLLiiO!O!", &kind, &window, &timeout_ns, &lost_after_ns, &lost_after_timeouts,
                          &placeholder_ns, &resync_gap_ns, &max_batch, &batch_bytes, &PyTuple_Type, &status_of,
                          &PyDict_Type, &flag_of)) {
        return NULL;
    }
    if (self->ready) {
        PyErr_SetString(PyExc_RuntimeError, "the native core is set up already");
        return NULL;
    }
    urb_core_config_t cfg;
    urb_core_default_config(&cfg, (urb_link_kind_t)kind);
    int const in_range = (window >= 0) && (window <= 255) && (max_batch >= 0) && (max_batch <= 255) &&
                         (batch_bytes >= 0) && (batch_bytes <= 65535) && (lost_after_timeouts >= 0) &&
                         (lost_after_timeouts <= (long long)UINT32_MAX);
    if (in_range) {
        cfg.window = (uint8_t)window;
        cfg.timeout_ns = timeout_ns;
        cfg.lost_after_ns = lost_after_ns;
        cfg.lost_after_timeouts = (uint32_t)lost_after_timeouts;
        cfg.placeholder_ns = placeholder_ns;
        cfg.resync_gap_ns = resync_gap_ns;
        cfg.max_batch = (uint8_t)max_batch;
        cfg.batch_bytes = (uint16_t)batch_bytes;
    }
    if (!in_range || (urb_core_init(&self->core, (urb_link_kind_t)kind, &cfg) != URB_HOST_OK)) {
        PyErr_SetString(PyExc_ValueError, "the C core does not take these settings (see urb_core_config_t in "
                                          "host/c/include/urb_host_core.h for their ranges)");
        return NULL;
    }
    Py_INCREF(status_of);
    Py_INCREF(flag_of);
    self->status_of = status_of;
    self->flag_of = flag_of;
    self->ready = true;
    Py_RETURN_NONE;
}

static PyObject *core_submit(native_core_t *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (native_not_ready(self)) {
        return NULL;
    }
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "submit(t, now) takes 2 arguments");
        return NULL;
    }
    PyObject *py = args[0];
    long long const now = PyLong_AsLongLong(args[1]);
    if ((now == -1) && PyErr_Occurred()) {
        return NULL;
    }
    long long address = 0, mailbox = 0, length = 0, within = 0;
    if ((get_int(py, s_address, &address) < 0) || (get_int(py, s_mailbox, &mailbox) < 0) ||
        (get_int(py, s_length, &length) < 0) || (get_int(py, s_answer_within_ns, &within) < 0)) {
        return NULL;
    }
    PyObject *read_obj = PyObject_GetAttr(py, s_read);
    if (read_obj == NULL) {
        return NULL;
    }
    int const read = PyObject_IsTrue(read_obj);
    Py_DECREF(read_obj);
    if (read < 0) {
        return NULL;
    }
    Py_buffer data = {0};
    PyObject *data_obj = NULL;
    if (!read) {
        data_obj = PyObject_GetAttr(py, s_data);
        if ((data_obj == NULL) || (PyObject_GetBuffer(data_obj, &data, PyBUF_SIMPLE) < 0)) {
            Py_XDECREF(data_obj);
            return NULL;
        }
        length = data.len;
    }
    native_xfer_t *x = native_xfer_get(self);
    int32_t rc = URB_HOST_EINVAL;
    if ((x != NULL) && (address >= 0) && (address <= 255) && (mailbox >= 0) && (mailbox <= 255) && (length >= 0) &&
        (length <= 255)) {
        rc = read ? urb_transfer_read(&x->t, (uint8_t)address, (uint8_t)mailbox, (uint8_t)length)
                  : urb_transfer_write(&x->t, (uint8_t)address, (uint8_t)mailbox, data.buf, (uint8_t)length);
        if (rc == URB_HOST_OK) {
            rc = urb_transfer_set_answer_within(&x->t, within);
        }
        if (rc == URB_HOST_OK) {
            x->py = py;
            x->cycle_item = -1;
            x->sent_unmarked = false;
            Py_INCREF(py);
            rc = urb_core_submit(&self->core, &x->t, now);
        }
    }
    if (data_obj != NULL) {
        PyBuffer_Release(&data);
        Py_DECREF(data_obj);
    }
    if (x == NULL) {
        return NULL;
    }
    if (rc != URB_HOST_OK) {
        native_xfer_put(self, x);
        PyErr_Format(PyExc_ValueError,
                     "cannot submit this request: address %lld (0..127), mailbox %lld (0..7), length %lld (1..32), "
                     "answer_within_ns %lld (0..3600 s) must be in range",
                     address, mailbox, length, within);
        return NULL;
    }
    if (native_collect(self, NULL) < 0) {
        return NULL;
    }
    if ((self->trace != Py_None) && !self->core.lost) {
        PyObject *one = PyTuple_Pack(1, py);
        int const trc = (one == NULL) ? -1 : native_trace_event(self, s_submit, now, one);
        Py_XDECREF(one);
        if (trc < 0) {
            return NULL;
        }
    }
    Py_RETURN_NONE;
}

static int parse_data_now(PyObject *const *args, Py_ssize_t nargs, Py_buffer *data, long long *now)
{
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "takes (data, now)");
        return -1;
    }
    *now = PyLong_AsLongLong(args[1]);
    if ((*now == -1) && PyErr_Occurred()) {
        return -1;
    }
    return PyObject_GetBuffer(args[0], data, PyBUF_SIMPLE);
}

static PyObject *core_receive(native_core_t *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer data;
    long long now = 0;
    if (native_not_ready(self) || (parse_data_now(args, nargs, &data, &now) < 0)) {
        return NULL;
    }
    int32_t const rc = urb_core_receive(&self->core, data.buf, (size_t)data.len, now);
    PyBuffer_Release(&data);
    if (rc != URB_HOST_OK) {
        PyErr_SetString(PyExc_TypeError, "receive() is for an RS232 core; a USB core takes receive_batch()");
        return NULL;
    }
    if (native_collect(self, NULL) < 0) {
        return NULL;
    }
    Py_RETURN_NONE;
}

static PyObject *core_receive_batch(native_core_t *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer data;
    long long now = 0;
    if (native_not_ready(self) || (parse_data_now(args, nargs, &data, &now) < 0)) {
        return NULL;
    }
    bool const traced = (self->trace != Py_None) && !self->core.lost && (data.len > 0) && !self->core.flushing;
    int32_t const rc = urb_core_receive_batch(&self->core, data.buf, (size_t)data.len, now);
    PyBuffer_Release(&data);
    if (rc != URB_HOST_OK) {
        PyErr_SetString(PyExc_TypeError, "receive_batch() is for a USB core; an RS232 core takes receive()");
        return NULL;
    }
    PyObject *answered = traced ? PyList_New(0) : NULL;
    if ((traced && (answered == NULL)) || (native_collect(self, answered) < 0)) {
        Py_XDECREF(answered);
        return NULL;
    }
    if (traced) { /* UsbUplink.tla UsbRead: the requests its IN transfer answered, in order */
        PyObject *items = PyList_AsTuple(answered);
        Py_DECREF(answered);
        int const trc = (items == NULL) ? -1 : native_trace_event(self, s_read_event, now, items);
        Py_XDECREF(items);
        if (trc < 0) {
            return NULL;
        }
    }
    Py_RETURN_NONE;
}

static PyObject *core_poll(native_core_t *self, PyObject *arg)
{
    long long const now = PyLong_AsLongLong(arg);
    if (native_not_ready(self) || ((now == -1) && PyErr_Occurred())) {
        return NULL;
    }
    (void)urb_core_poll(&self->core, now);
    if (native_collect(self, NULL) < 0) {
        return NULL;
    }
    Py_RETURN_NONE;
}

static PyObject *core_frames_to_send(native_core_t *self, PyObject *arg)
{
    long long const now = PyLong_AsLongLong(arg);
    if (native_not_ready(self) || ((now == -1) && PyErr_Occurred())) {
        return NULL;
    }
    PyObject *out = PyList_New(0);
    if (out == NULL) {
        return NULL;
    }
    for (;;) {
        uint8_t frame[URB_REQUEST_MAX];
        native_xfer_t *head = (native_xfer_t *)self->core.q_head;
        int32_t const n = urb_core_next_frame(&self->core, now, frame, sizeof frame);
        if (n <= 0) {
            if (n < 0) {
                Py_DECREF(out);
                PyErr_SetString(PyExc_TypeError, "frames_to_send() is for an RS232 core; a USB core takes frame_out()");
                return NULL;
            }
            if (native_collect(self, NULL) < 0) {
                Py_DECREF(out);
                return NULL;
            }
            return out;
        }
        PyObject *b = PyBytes_FromStringAndSize((const char *)frame, n);
        const urb_slot_t *slot = newest_slot(&self->core);
        if ((b == NULL) || (PyList_Append(out, b) < 0) || (native_mark_sent(head, slot->due_ns, slot->expires_ns) < 0)) {
            Py_XDECREF(b);
            Py_DECREF(out);
            return NULL;
        }
        Py_DECREF(b);
    }
}

static PyObject *core_frame_out(native_core_t *self, PyObject *arg)
{
    long long const now = PyLong_AsLongLong(arg);
    if (native_not_ready(self) || ((now == -1) && PyErr_Occurred())) {
        return NULL;
    }
    /* the requests that may go in this batch: at most max_batch (<= 15) from the queue's head */
    native_xfer_t *candidates[URB_MAX_WINDOW];
    unsigned n_candidates = 0u;
    for (urb_transfer_t *t = self->core.q_head; (t != NULL) && (n_candidates < URB_MAX_WINDOW); t = t->next) {
        candidates[n_candidates++] = (native_xfer_t *)t;
    }
    uint8_t buf[URB_USB_BATCH_MAX];
    unsigned const before = self->core.m.count;
    int32_t const n = urb_core_frame_out(&self->core, now, buf, sizeof buf);
    if (n < 0) {
        PyErr_SetString(PyExc_TypeError, "frame_out() is for a USB core; an RS232 core takes frames_to_send()");
        return NULL;
    }
    if (native_collect(self, NULL) < 0) {
        return NULL;
    }
    if (n == 0) {
        Py_RETURN_NONE;
    }
    unsigned sent = 0u;
    while ((sent < n_candidates) && (candidates[sent]->t.state == URB_XFER_IN_FLIGHT)) {
        sent++;
    }
    /* they are the newest `sent` slots of the ring, in sending order */
    unsigned const first = self->core.m.count - sent;
    for (unsigned i = 0u; i < sent; i++) {
        const urb_slot_t *slot = &self->core.m.slot[(self->core.m.head + first + i) % URB_MATCHER_SLOTS];
        if (native_mark_sent(candidates[i], slot->due_ns, slot->expires_ns) < 0) {
            return NULL;
        }
    }
    (void)before;
    if (self->trace != Py_None) { /* UsbUplink.tla UsbWrite */
        PyObject *batch = PyTuple_New((Py_ssize_t)sent);
        if (batch == NULL) {
            return NULL;
        }
        for (unsigned i = 0u; i < sent; i++) {
            Py_INCREF(candidates[i]->py);
            PyTuple_SET_ITEM(batch, (Py_ssize_t)i, candidates[i]->py);
        }
        int const trc = native_trace_event(self, s_write, now, batch);
        Py_DECREF(batch);
        if (trc < 0) {
            return NULL;
        }
    }
    return PyBytes_FromStringAndSize((const char *)buf, n);
}

static PyObject *core_take_completed(native_core_t *self, PyObject *unused)
{
    (void)unused;
    if (native_not_ready(self) || (native_collect(self, NULL) < 0)) { /* the pump's completions wait in the C core */
        return NULL;
    }
    PyObject *fresh = PyList_New(0);
    if (fresh == NULL) {
        return NULL;
    }
    PyObject *out = self->completed;
    self->completed = fresh;
    Py_ssize_t const n = PyList_GET_SIZE(out);
    if ((self->trace != Py_None) && (n > 0)) { /* UsbUplink.tla Callback: at the last one's completion */
        PyObject *items = PyList_AsTuple(out);
        PyObject *when = PyObject_GetAttr(PyList_GET_ITEM(out, n - 1), s_completed_ns);
        long long const last_ns = (when == NULL) ? -1 : PyLong_AsLongLong(when);
        Py_XDECREF(when);
        int const trc = ((items == NULL) || PyErr_Occurred()) ? -1 : native_trace_event(self, s_callback, last_ns, items);
        Py_XDECREF(items);
        if (trc < 0) {
            Py_DECREF(out);
            return NULL;
        }
    }
    return out;
}

static PyObject *core_next_deadline(native_core_t *self, PyObject *unused)
{
    (void)unused;
    return native_not_ready(self) ? NULL : time_or_none(urb_core_next_deadline(&self->core));
}

int native_set_full_reason(native_core_t *self, PyObject *reason)
{
    if (!PyUnicode_Check(reason)) {
        PyErr_SetString(PyExc_TypeError, "a lost reason is a str");
        return -1;
    }
    Py_INCREF(reason);
    Py_XSETREF(self->full_reason, reason);
    return 0;
}

static PyObject *core_link_lost(native_core_t *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (native_not_ready(self)) {
        return NULL;
    }
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "link_lost(now, reason) takes 2 arguments");
        return NULL;
    }
    long long const now = PyLong_AsLongLong(args[0]);
    if ((now == -1) && PyErr_Occurred()) {
        return NULL;
    }
    const char *reason = PyUnicode_Check(args[1]) ? PyUnicode_AsUTF8(args[1]) : NULL;
    if (reason == NULL) {
        if (!PyErr_Occurred()) {
            PyErr_SetString(PyExc_TypeError, "a lost reason is a str");
        }
        return NULL;
    }
    if (!self->core.lost && (native_set_full_reason(self, args[1]) < 0)) { /* already lost: nothing changes */
        return NULL;
    }
    urb_core_link_lost(&self->core, now, reason);
    if (native_collect(self, NULL) < 0) {
        return NULL;
    }
    Py_RETURN_NONE;
}

static PyObject *core_reset(native_core_t *self, PyObject *arg)
{
    long long const now = PyLong_AsLongLong(arg);
    if (native_not_ready(self) || ((now == -1) && PyErr_Occurred())) {
        return NULL;
    }
    urb_core_reset(&self->core, now);
    if (native_collect(self, NULL) < 0) {
        return NULL;
    }
    Py_RETURN_NONE;
}

static PyObject *core_start_drain(native_core_t *self, PyObject *arg)
{
    long long const now = PyLong_AsLongLong(arg);
    if (native_not_ready(self) || ((now == -1) && PyErr_Occurred())) {
        return NULL;
    }
    urb_ns_t const until = urb_core_start_drain(&self->core, now);
    if (native_collect(self, NULL) < 0) {
        return NULL;
    }
    return time_or_none(until);
}

static PyObject *core_drained(native_core_t *self, PyObject *unused)
{
    (void)unused;
    return native_not_ready(self) ? NULL : PyBool_FromLong(urb_core_drained(&self->core));
}

static PyObject *core_hand_over(native_core_t *self, PyObject *arg)
{
    long long const until = PyLong_AsLongLong(arg);
    if (native_not_ready(self) || ((until == -1) && PyErr_Occurred())) {
        return NULL;
    }
    urb_core_hand_over(&self->core, until);
    Py_RETURN_NONE;
}

static PyObject *core_busy_until(native_core_t *self, PyObject *unused)
{
    (void)unused;
    return native_not_ready(self) ? NULL : time_or_none(urb_core_busy_until(&self->core));
}

static PyObject *core_set_window_raw(native_core_t *self, PyObject *arg)
{
    long const w = PyLong_AsLong(arg);
    if (native_not_ready(self) || ((w == -1) && PyErr_Occurred())) {
        return NULL;
    }
    if ((w < 1) || (w > (long)URB_MAX_WINDOW) || (urb_core_set_window(&self->core, (uint8_t)w) != URB_HOST_OK)) {
        PyErr_Format(PyExc_ValueError, "window = %ld: must be 1..%u", w, URB_MAX_WINDOW);
        return NULL;
    }
    Py_RETURN_NONE;
}

static PyObject *core_busy(native_core_t *self, PyObject *unused)
{
    (void)unused;
    return native_not_ready(self) ? NULL : PyBool_FromLong(urb_core_busy(&self->core));
}

/* Every method and accessor runs with the core's lock held (the pump's thread shares the core),
 * after the whole reason of a loss the pump found was adopted. */
int native_locked_enter(native_core_t *self)
{
    native_core_lock(self);
    if (self->pump.reason_pending && (native_adopt_pump_reason(self) < 0)) {
        native_core_unlock(self);
        return -1;
    }
    return 0;
}

#define LOCKED_FAST(fn)                                                                          \
    static PyObject *fn##_locked(native_core_t *self, PyObject *const *args, Py_ssize_t nargs)  \
    {                                                                                            \
        if (native_locked_enter(self) < 0) {                                                            \
            return NULL;                                                                         \
        }                                                                                        \
        PyObject *const out = fn(self, args, nargs);                                             \
        native_core_unlock(self);                                                                \
        return out;                                                                              \
    }
#define LOCKED_ONE(fn)                                                                           \
    static PyObject *fn##_locked(native_core_t *self, PyObject *arg)                             \
    {                                                                                            \
        if (native_locked_enter(self) < 0) {                                                            \
            return NULL;                                                                         \
        }                                                                                        \
        PyObject *const out = fn(self, arg);                                                     \
        native_core_unlock(self);                                                                \
        return out;                                                                              \
    }
LOCKED_FAST(core_submit)
LOCKED_FAST(core_receive)
LOCKED_FAST(core_receive_batch)
LOCKED_FAST(core_link_lost)
LOCKED_FAST(native_cycle_submit)
LOCKED_ONE(core_poll)
LOCKED_ONE(core_frames_to_send)
LOCKED_ONE(core_frame_out)
LOCKED_ONE(core_take_completed)
LOCKED_ONE(core_next_deadline)
LOCKED_ONE(core_reset)
LOCKED_ONE(core_start_drain)
LOCKED_ONE(core_drained)
LOCKED_ONE(core_hand_over)
LOCKED_ONE(core_busy_until)
LOCKED_ONE(core_set_window_raw)
LOCKED_ONE(core_busy)

static PyObject *core_setup_locked(native_core_t *self, PyObject *args)
{
    if (self->pump.running) {
        PyErr_SetString(PyExc_RuntimeError, "the native core is set up already");
        return NULL;
    }
    return core_setup(self, args);
}

static PyMethodDef core_methods[] = {
    {"_setup", (PyCFunction)core_setup_locked, METH_VARARGS, "Initialise the C core (NativeRs232Core/NativeUsbCore do)."},
    {"submit", (PyCFunction)(void (*)(void))core_submit_locked, METH_FASTCALL, "submit(t, now): queue a request."},
    {"receive", (PyCFunction)(void (*)(void))core_receive_locked, METH_FASTCALL, "receive(data, now): RS232 bytes."},
    {"receive_batch", (PyCFunction)(void (*)(void))core_receive_batch_locked, METH_FASTCALL,
     "receive_batch(data, now): one USB IN transfer."},
    {"poll", (PyCFunction)core_poll_locked, METH_O, "poll(now): timeouts, idle gap, lost-bridge rules."},
    {"frames_to_send", (PyCFunction)core_frames_to_send_locked, METH_O, "frames_to_send(now) -> list[bytes] (RS232)."},
    {"frame_out", (PyCFunction)core_frame_out_locked, METH_O, "frame_out(now) -> bytes | None (USB)."},
    {"take_completed", (PyCFunction)core_take_completed_locked, METH_NOARGS, "Transfers completed since the last call."},
    {"next_deadline", (PyCFunction)core_next_deadline_locked, METH_NOARGS, "When poll next has something to do."},
    {"link_lost", (PyCFunction)(void (*)(void))core_link_lost_locked, METH_FASTCALL, "link_lost(now, reason)."},
    {"reset", (PyCFunction)core_reset_locked, METH_O, "reset(now): forget the lost state."},
    {"start_drain", (PyCFunction)core_start_drain_locked, METH_O, "start_drain(now) -> int | None."},
    {"drained", (PyCFunction)core_drained_locked, METH_NOARGS, "Nothing left to wait for after start_drain."},
    {"hand_over", (PyCFunction)core_hand_over_locked, METH_O, "hand_over(until_ns)."},
    {"busy_until", (PyCFunction)core_busy_until_locked, METH_NOARGS, "The latest lifetime in flight, or None."},
    {"_set_window", (PyCFunction)core_set_window_raw_locked, METH_O, "Set the window (1..15)."},
    {"busy", (PyCFunction)core_busy_locked, METH_NOARGS, "Requests queued or in flight."},
    {"_pump_start", (PyCFunction)native_pump_start, METH_VARARGS,
     "_pump_start(fd, name, frame_ns, handover_port, handover_dir): run the uplink on a C thread (frame_ns 0 on RS232)."},
    {"_pump_open", (PyCFunction)native_pump_open, METH_VARARGS,
     "_pump_open(fd, name, frame_ns, handover_port, handover_dir): USB I/O serviced by the caller (no thread)."},
    {"_pump_service", (PyCFunction)native_pump_service, METH_NOARGS,
     "_pump_service() -> bool: one pass of _pump_open's I/O without waiting (GIL released); False once it ended."},
    {"_pump_notify", (PyCFunction)native_pump_notify, METH_NOARGS, "RS232: wake the pump (requests were queued)."},
    {"_pump_stop", (PyCFunction)native_pump_stop, METH_NOARGS, "Stop and join the pump's thread."},
    {"_pump_wait", (PyCFunction)native_pump_wait, METH_O,
     "_pump_wait(timeout_s) -> bool: wait (GIL released) for completions or a kick; True when there are some."},
    {"_pump_kick", (PyCFunction)native_pump_kick, METH_NOARGS, "Wake a _pump_wait."},
    {"_pump_running", (PyCFunction)native_pump_running, METH_NOARGS, "The pump's thread runs its I/O."},
    {"_has_completed", (PyCFunction)native_has_completed, METH_NOARGS, "Completions wait to be taken."},
    {"_cycle_submit", (PyCFunction)(void (*)(void))native_cycle_submit_locked, METH_FASTCALL,
     "_cycle_submit(state, now, refusals): every item of a CycleState at once (_native_cycle.c)."},
    {"_new_cycle_state", (PyCFunction)native_new_cycle_state, METH_O, "_new_cycle_state(specs) -> CycleState."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject native_core_type = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "urb.managers._native.Core",
    .tp_basicsize = sizeof(native_core_t),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_doc = "The C protocol core of one bridge (host/c/core); use NativeRs232Core or NativeUsbCore.",
    .tp_new = core_new,
    .tp_dealloc = (destructor)core_dealloc,
    .tp_traverse = (traverseproc)core_traverse,
    .tp_clear = (inquiry)core_clear,
    .tp_methods = core_methods,
    .tp_getset = native_core_getset,
};

static struct PyModuleDef native_module = {
    PyModuleDef_HEAD_INIT, .m_name = "urb.managers._native",
    .m_doc = "The C protocol core of host/c/core for the Python host library (host/urb/managers/native.py).",
    .m_size = -1,
};

int native_intern_names(const native_name_t *names, size_t count)
{
    for (size_t i = 0u; i < count; i++) {
        if (*names[i].slot == NULL) {
            *names[i].slot = PyUnicode_InternFromString(names[i].text);
            if (*names[i].slot == NULL) {
                return -1;
            }
        }
    }
    return 0;
}

static int intern_all(void)
{
    native_name_t const names[] = {
        {&s_address, "address"}, {&s_mailbox, "mailbox"}, {&s_read, "read"}, {&s_length, "length"},
        {&s_data, "data"}, {&s_answer_within_ns, "answer_within_ns"}, {&s_completed_ns, "completed_ns"},
        {&s_submit, "submit"}, {&s_write, "write"}, {&s_read_event, "read"}, {&s_callback, "callback"},
    };
    return native_intern_names(names, sizeof names / sizeof names[0]);
}

PyMODINIT_FUNC PyInit__native(void)
{
    if ((intern_all() < 0) || (native_xfer_intern() < 0) || (PyType_Ready(&native_core_type) < 0) || (PyType_Ready(&native_cycle_type) < 0)) {
        return NULL;
    }
    PyObject *m = PyModule_Create(&native_module);
    if (m == NULL) {
        return NULL;
    }
    Py_INCREF(&native_core_type);
    Py_INCREF(&native_cycle_type);
    if ((PyModule_AddObject(m, "CycleState", (PyObject *)&native_cycle_type) < 0) ||
        (PyModule_AddObject(m, "Core", (PyObject *)&native_core_type) < 0) ||
        (PyModule_AddStringConstant(m, "FINGERPRINT", URB_NATIVE_FINGERPRINT) < 0) ||
        (PyModule_AddIntConstant(m, "REASON_MAX", (long)URB_REASON_MAX) < 0)) {
        Py_DECREF(&native_core_type);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
