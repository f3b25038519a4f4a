/*
 * The pump of urb.managers._native: an uplink's I/O on a C thread (issue #38). This file has what
 * both uplinks' pumps share (starting and stopping the thread, the dispatcher's wait, a loss found
 * by the thread, the hand-over record, what was sent written back to the Python transfers) and the
 * USB pump; the RS232 pump's loop is _native_pump_rs232.c.
 *
 * The USB pump replaces the Python frame thread and transfer reader of USBManager over a
 * CharDeviceTransport (usb.py).
 *
 * The thread does what those two did, with the same rules and the same clock
 * (CLOCK_MONOTONIC, time.monotonic_ns): at every 1-ms boundary (absolute, an overslept boundary
 * skipped, never a burst) the core's timeouts are applied (urb_core_poll) and ONE batch is taken
 * (urb_core_frame_out) and written with one write(); every IN transfer read from the descriptor is
 * given to the core as it arrives (urb_core_receive_batch). Before a write the port's hand-over
 * record is made to cover the requests in flight (handover.py's PortHandover.cover, in C). A
 * failed write declares the bridge lost ("<name>: [Errno N] <text>", the text Python gives the
 * OSError) and ends the thread; the end of the IN stream or a failed read ends the reading only,
 * as CharDeviceTransport's reader does. A descriptor closed under the thread (POLLNVAL) is lost at
 * once, with the text of the write that would fail next (EBADF), and ends the thread.
 *
 * It never takes the GIL: completed transfers stay in the C core's completion list, and the
 * dispatcher's wait (_pump_wait) returns once per batch; the Python objects get their outcome
 * when the dispatcher takes them (take_completed, one GIL hold for the whole batch). What it sent
 * (sequence number, sending time, deadline, lifetime) is written to each Python transfer then too.
 *
 * A cyclic USBManager (usb.py, cyclic=True) runs the same steps without the thread: _pump_open sets
 * the pump up, and each _pump_service (the application's service(), GIL released) reads the IN
 * transfers that arrived, applies the deadlines and writes the batch when a 1-ms boundary has
 * passed, in pump_main's order.
 */
#include "_native.h"

#include <errno.h>
#include <limits.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

/* IN transfers one _pump_service reads at most. */
#define NATIVE_SERVICE_READS 8u

urb_ns_t native_monotonic_ns(void)
{
    struct timespec ts;
    (void)clock_gettime(CLOCK_MONOTONIC, &ts);
    return ((urb_ns_t)ts.tv_sec * URB_NS_PER_S) + (urb_ns_t)ts.tv_nsec;
}

/* The dispatcher has something to take (lock held): a kick, or a completion other than an item of
 * a polled cycle (whose owner takes it: _native_cycle.c). */
static bool has_work(const native_core_t *self)
{
    if (self->pump.kicked) {
        return true;
    }
    for (const urb_transfer_t *t = self->core.m.done_head; t != NULL; t = t->next) {
        if (!native_cycle_item_polled((const native_xfer_t *)t)) {
            return true;
        }
    }
    return false;
}

void native_pump_wake_dispatcher(native_core_t *self)
{
    if (self->core.closing && urb_core_drained(&self->core)) {
        self->pump.kicked = true;
    }
    if (has_work(self)) {
        (void)pthread_cond_signal(&self->ready_cond);
    }
}

void native_pump_note_sent(native_core_t *self, native_xfer_t *x, unsigned k)
{
    const urb_slot_t *slot = &self->core.m.slot[(self->core.m.head + k) % URB_MATCHER_SLOTS];
    x->sent_unmarked = true;
    x->due_ns = slot->due_ns;
    x->expires_ns = slot->expires_ns;
}

void native_pump_cover(native_pump_t *p, urb_ns_t until, urb_ns_t now)
{
    if (p->has_handover && (until != URB_NEVER) && (until != URB_NO_TIME)) {
        (void)urb_handover_cover(&p->handover, until, now);
        if (p->handover.warned && !p->handover_warned) {
            p->handover_warned = true;
            (void)fprintf(stderr, "%s\n", p->handover.error);
        }
    }
}

void native_pump_lost(native_core_t *self, const char *format, ...)
{
    native_pump_t *p = &self->pump;
    (void)pthread_mutex_lock(&self->lock);
    int const used = snprintf(p->reason_text, sizeof p->reason_text, "%s: ", p->name);
    if ((used > 0) && ((size_t)used < sizeof p->reason_text)) {
        va_list args;
        va_start(args, format);
        (void)vsnprintf(p->reason_text + used, sizeof p->reason_text - (size_t)used, format, args);
        va_end(args);
    }
    urb_core_link_lost(&self->core, native_monotonic_ns(), p->reason_text);
    p->reason_pending = true;
    p->io_ended = true;
    p->kicked = true;
    native_pump_wake_dispatcher(self);
    (void)pthread_mutex_unlock(&self->lock);
}

/* One 1-ms boundary: timeouts, one batch written. Returns false when the write failed (the bridge
 * is then lost and the thread ends). */
static bool pump_frame(native_core_t *self, uint8_t *buf, size_t cap)
{
    native_pump_t *p = &self->pump;
    urb_ns_t const now = native_monotonic_ns();
    (void)pthread_mutex_lock(&self->lock);
    (void)urb_core_poll(&self->core, now);
    native_xfer_t *candidates[URB_MAX_WINDOW];
    unsigned n_candidates = 0u;
    for (urb_transfer_t *t = self->core.q_head; (t != NULL) && (n_candidates < URB_MAX_WINDOW); t = t->next) {
        candidates[n_candidates++] = (native_xfer_t *)t;
    }
    int32_t const n = urb_core_frame_out(&self->core, now, buf, cap);
    unsigned sent = 0u;
    while ((n > 0) && (sent < n_candidates) && (candidates[sent]->t.state == URB_XFER_IN_FLIGHT)) {
        sent++;
    }
    unsigned const first = self->core.m.count - sent; /* the newest `sent` slots, in sending order */
    for (unsigned i = 0u; i < sent; i++) {
        native_pump_note_sent(self, candidates[i], first + i);
    }
    urb_ns_t const until = urb_core_busy_until(&self->core);
    native_pump_wake_dispatcher(self);
    (void)pthread_mutex_unlock(&self->lock);
    if (n <= 0) {
        return true;
    }
    native_pump_cover(p, until, now);
    ssize_t wrote;
    do {
        wrote = write(p->fd, buf, (size_t)n);
    } while ((wrote < 0) && (errno == EINTR));
    if (wrote >= 0) {
        return true;
    }
    int const code = errno;
    native_pump_lost(self, "[Errno %d] %s", code, strerror(code));
    return false;
}

/* One IN transfer, if the descriptor has one. Returns false when the IN stream ended. */
static bool pump_read(native_core_t *self, uint8_t *buf, size_t cap)
{
    ssize_t const got = read(self->pump.fd, buf, cap);
    if (got < 0) {
        return (errno == EINTR) || (errno == EAGAIN) || (errno == EWOULDBLOCK);
    }
    if (got == 0) {
        return false;
    }
    (void)pthread_mutex_lock(&self->lock);
    (void)urb_core_receive_batch(&self->core, buf, (size_t)got, native_monotonic_ns());
    native_pump_wake_dispatcher(self);
    (void)pthread_mutex_unlock(&self->lock);
    return true;
}

/* Whether `revents` says the descriptor was closed under the thread (POLLNVAL, which ppoll would
 * report at once from then on); if so the bridge is lost, worded as the Python writer thread words
 * its next write's failure, and the thread is to end. */
static bool pump_descriptor_closed(native_core_t *self, short revents)
{
    if ((revents & POLLNVAL) == 0) {
        return false;
    }
    native_pump_lost(self, "[Errno %d] %s", EBADF, strerror(EBADF));
    return true;
}

/* The first frame boundary after `now`. */
static urb_ns_t boundary_after(urb_ns_t now, urb_ns_t period)
{
    return ((now / period) + 1) * period;
}

/* The boundary after `boundary`, which was just served at `now`: an overslept one is skipped (the
 * next after `now`), never made up in a burst. */
static urb_ns_t next_boundary(urb_ns_t boundary, urb_ns_t now, urb_ns_t period)
{
    boundary += period;
    return (boundary > now) ? boundary : boundary_after(now, period);
}

/* The IN transfers that arrived while nobody read, without waiting: at most `max` of them (so that
 * a babbling device cannot hold a caller's tick); *reading turns false when the IN stream ended.
 * Returns false when the descriptor was closed under the pump (the bridge is then lost). */
static bool pump_drain(native_core_t *self, bool *reading, uint8_t *buf, size_t cap, unsigned max)
{
    if (!*reading) {
        return true;
    }
    struct pollfd fds = {self->pump.fd, POLLIN, 0};
    unsigned reads = 0u;
    while (*reading && (reads < max) && (poll(&fds, 1u, 0) > 0) && ((fds.revents & (POLLIN | POLLHUP | POLLERR)) != 0)) {
        *reading = pump_read(self, buf, cap);
        reads++;
    }
    return !pump_descriptor_closed(self, fds.revents);
}

static void *pump_main(void *arg)
{
    native_core_t *self = arg;
    native_pump_t *p = &self->pump;
    uint8_t in[4096];
    uint8_t out[URB_USB_BATCH_MAX];
    bool reading = true;
    urb_ns_t next_frame = boundary_after(native_monotonic_ns(), p->frame_ns);
    while (!p->stop) {
        urb_ns_t const wait = next_frame - native_monotonic_ns();
        if (wait > 0) {
            struct pollfd fds = {p->fd, POLLIN, 0};
            struct timespec const ts = {(time_t)(wait / URB_NS_PER_S), (long)(wait % URB_NS_PER_S)};
            int const ready = ppoll(&fds, reading ? 1u : 0u, &ts, NULL);
            if ((ready > 0) && pump_descriptor_closed(self, fds.revents)) {
                break;
            }
            if ((ready > 0) && ((fds.revents & (POLLIN | POLLHUP | POLLERR)) != 0)) {
                reading = pump_read(self, in, sizeof in);
            }
            continue;
        }
        /* what arrived while this thread was not running answers before the timeouts apply */
        if (!pump_drain(self, &reading, in, sizeof in, UINT_MAX)) {
            break;
        }
        next_frame = next_boundary(next_frame, native_monotonic_ns(), p->frame_ns);
        if (!pump_frame(self, out, sizeof out)) {
            break;
        }
    }
    return NULL;
}

int native_adopt_pump_reason(native_core_t *self)
{
    PyObject *text = PyUnicode_DecodeUTF8(self->pump.reason_text, (Py_ssize_t)strlen(self->pump.reason_text),
                                          "replace");
    if (text == NULL) {
        return -1;
    }
    self->pump.reason_pending = false;
    int const rc = native_set_full_reason(self, text);
    Py_DECREF(text);
    return rc;
}

/* Parses the arguments of _pump_start and _pump_open and sets the pump's fields up (no thread yet).
 * Returns 0, or -1 with a Python error. */
static int pump_configure(native_core_t *self, PyObject *args)
{
    int fd = -1;
    const char *name = NULL;
    long long frame_ns = 0;
    const char *port = NULL;
    const char *directory = NULL;
    if (!PyArg_ParseTuple(args, "isLzz", &fd, &name, &frame_ns, &port, &directory)) {
        return -1;
    }
    if (!self->ready) {
        PyErr_SetString(PyExc_RuntimeError, "the pump drives a core that is set up (NativeUsbCore, NativeRs232Core)");
        return -1;
    }
    if (self->pump.running || self->pump.serviced) {
        PyErr_SetString(PyExc_RuntimeError, "the pump runs already (stop it first)");
        return -1;
    }
    bool const usb = self->core.kind == URB_LINK_USB;
    if ((fd < 0) || (usb ? (frame_ns <= 0) : (frame_ns != 0))) {
        PyErr_SetString(PyExc_ValueError, "the pump needs an open descriptor, and a frame period above 0 on USB (0 on RS232)");
        return -1;
    }
    native_pump_t *p = &self->pump;
    urb_handover_t *handover = &p->handover;
    if ((port != NULL) && (urb_handover_init(handover, port, directory) != URB_HOST_OK)) {
        PyErr_Format(PyExc_ValueError, "%s: the port's hand-over record path is too long", port);
        return -1;
    }
    if (!usb && (p->wake_fd < 0)) { /* kept until the core is released: a _pump_notify may still write to it */
        p->wake_fd = eventfd(0u, EFD_NONBLOCK | EFD_CLOEXEC);
        if (p->wake_fd < 0) {
            (void)PyErr_SetFromErrno(PyExc_OSError);
            return -1;
        }
    } else if (!usb) {
        uint64_t stale;
        (void)read(p->wake_fd, &stale, sizeof stale); /* what the last run left */
    }
    native_core_lock(self);
    p->fd = fd;
    p->notified = false;
    p->frame_ns = frame_ns;
    (void)snprintf(p->name, sizeof p->name, "%s", name);
    p->has_handover = port != NULL;
    p->handover_warned = false;
    p->stop = false;
    p->kicked = false;
    p->io_ended = false;
    native_core_unlock(self);
    return 0;
}

PyObject *native_pump_start(native_core_t *self, PyObject *args)
{
    if (pump_configure(self, args) < 0) {
        return NULL;
    }
    native_pump_t *p = &self->pump;
    bool const usb = self->core.kind == URB_LINK_USB;
    int const rc = pthread_create(&p->thread, NULL, usb ? pump_main : native_rs232_pump_main, self);
    if (rc != 0) {
        errno = rc;
        return PyErr_SetFromErrno(PyExc_OSError);
    }
    (void)pthread_setname_np(p->thread, "urb-pump"); /* what /proc/<pid>/task/<tid>/comm shows */
    p->running = true;
    Py_RETURN_NONE;
}

PyObject *native_pump_open(native_core_t *self, PyObject *args)
{
    if (self->ready && (self->core.kind != URB_LINK_USB)) {
        PyErr_SetString(PyExc_ValueError, "_pump_open services a USB core (RS232 runs its pump on a thread)");
        return NULL;
    }
    if (pump_configure(self, args) < 0) {
        return NULL;
    }
    native_pump_t *p = &self->pump;
    p->serviced = true;
    p->reading = true;
    p->next_frame = boundary_after(native_monotonic_ns(), p->frame_ns);
    Py_RETURN_NONE;
}

/* One service of a USB pump opened by _pump_open, without waiting: the IN transfers that arrived
 * (at most NATIVE_SERVICE_READS, so that a babbling device cannot hold the caller), then the
 * deadlines, and the batch when a 1-ms boundary has passed since the last one (one batch per call,
 * an overslept boundary skipped as pump_main skips it). The same steps in the same order as
 * pump_main, only driven by the caller's tick instead of the thread's wake-ups. Returns false once
 * the I/O ended (a failed write or a closed descriptor: the bridge is lost). */
static bool pump_service_pass(native_core_t *self)
{
    native_pump_t *p = &self->pump;
    uint8_t in[4096];
    uint8_t out[URB_USB_BATCH_MAX];
    if (!pump_drain(self, &p->reading, in, sizeof in, NATIVE_SERVICE_READS)) {
        return false;
    }
    urb_ns_t const now = native_monotonic_ns();
    if (now < p->next_frame) {
        (void)pthread_mutex_lock(&self->lock);
        (void)urb_core_poll(&self->core, now);
        (void)pthread_mutex_unlock(&self->lock);
        return true;
    }
    p->next_frame = next_boundary(p->next_frame, now, p->frame_ns);
    return pump_frame(self, out, sizeof out);
}

PyObject *native_pump_service(native_core_t *self, PyObject *unused)
{
    (void)unused;
    native_pump_t *p = &self->pump;
    if (!p->serviced) {
        PyErr_SetString(PyExc_RuntimeError, "_pump_service: the pump is not open for service (_pump_open first)");
        return NULL;
    }
    native_core_lock(self);
    bool on = !p->io_ended;
    native_core_unlock(self);
    if (on) {
        Py_BEGIN_ALLOW_THREADS
        on = pump_service_pass(self);
        Py_END_ALLOW_THREADS
    }
    return PyBool_FromLong(on);
}

/* Tells the thread to stop and wakes it (an RS232 pump may wait on its descriptors without a
 * deadline). */
static void pump_signal_stop(native_pump_t *p)
{
    p->stop = true;
    if (p->wake_fd >= 0) {
        uint64_t const one = 1u;
        (void)write(p->wake_fd, &one, sizeof one);
    }
}

void native_pump_join(native_core_t *self)
{
    self->pump.serviced = false;
    if (self->pump.running) {
        pump_signal_stop(&self->pump);
        (void)pthread_join(self->pump.thread, NULL);
        self->pump.running = false;
    }
    if (self->pump.wake_fd >= 0) { /* the core is being released: no method can notify any more */
        (void)close(self->pump.wake_fd);
        self->pump.wake_fd = -1;
    }
}

PyObject *native_pump_stop(native_core_t *self, PyObject *unused)
{
    (void)unused;
    self->pump.serviced = false;
    if (self->pump.running) {
        pump_signal_stop(&self->pump);
        Py_BEGIN_ALLOW_THREADS
        (void)pthread_join(self->pump.thread, NULL);
        Py_END_ALLOW_THREADS
        self->pump.running = false;
    }
    Py_RETURN_NONE;
}

PyObject *native_pump_notify(native_core_t *self, PyObject *unused)
{
    (void)unused;
    native_pump_t *p = &self->pump;
    if (!p->running || (p->wake_fd < 0)) {
        Py_RETURN_NONE;
    }
    native_core_lock(self);
    bool const first = !p->notified; /* one write until the thread has taken it: a burst is one wake-up */
    p->notified = true;
    native_core_unlock(self);
    if (first) { /* after the unlock: the woken thread takes the lock at once */
        uint64_t const one = 1u;
        (void)write(p->wake_fd, &one, sizeof one);
    }
    Py_RETURN_NONE;
}

PyObject *native_pump_wait(native_core_t *self, PyObject *arg)
{
    double const timeout_s = PyFloat_AsDouble(arg);
    if ((timeout_s == -1.0) && PyErr_Occurred()) {
        return NULL;
    }
    if (PyList_GET_SIZE(self->completed) > 0) {
        Py_RETURN_TRUE;
    }
    bool work = false;
    Py_BEGIN_ALLOW_THREADS
    struct timespec deadline;
    (void)clock_gettime(CLOCK_MONOTONIC, &deadline);
    urb_ns_t const ns = (urb_ns_t)deadline.tv_nsec + ((timeout_s > 0.0) ? (urb_ns_t)(timeout_s * 1e9) : 0);
    deadline.tv_sec += (time_t)(ns / URB_NS_PER_S);
    deadline.tv_nsec = (long)(ns % URB_NS_PER_S);
    (void)pthread_mutex_lock(&self->lock);
    while (!has_work(self)) {
        if (pthread_cond_timedwait(&self->ready_cond, &self->lock, &deadline) == ETIMEDOUT) {
            break;
        }
    }
    work = has_work(self);
    self->pump.kicked = false;
    (void)pthread_mutex_unlock(&self->lock);
    Py_END_ALLOW_THREADS
    return PyBool_FromLong(work);
}

PyObject *native_pump_kick(native_core_t *self, PyObject *unused)
{
    (void)unused;
    native_core_lock(self);
    self->pump.kicked = true;
    (void)pthread_cond_signal(&self->ready_cond);
    native_core_unlock(self);
    Py_RETURN_NONE;
}

PyObject *native_pump_running(native_core_t *self, PyObject *unused)
{
    (void)unused;
    native_core_lock(self);
    bool const on = (self->pump.running || self->pump.serviced) && !self->pump.io_ended;
    native_core_unlock(self);
    return PyBool_FromLong(on);
}

PyObject *native_has_completed(native_core_t *self, PyObject *unused)
{
    (void)unused;
    if (PyList_GET_SIZE(self->completed) > 0) {
        Py_RETURN_TRUE;
    }
    native_core_lock(self);
    bool const some = self->core.m.done_head != NULL;
    native_core_unlock(self);
    return PyBool_FromLong(some);
}
