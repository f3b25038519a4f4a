/*
 * The RS232 pump of urb.managers._native (issue #38): a serial port's I/O on a C thread, in place
 * of RS232Manager's Python reader and writer threads (rs232.py), with the same rules:
 *
 * - what the port delivers goes to the core as it arrives (urb_core_receive: matching, hunting past
 *   corrupt bytes), then the core's timeouts, idle-gap and lost-bridge rules apply (urb_core_poll),
 *   then every request frame the window lets go is taken (urb_core_next_frame) and written with ONE
 *   write() each (the bridge's idle-gap rule needs a frame's bytes back to back), after the port's
 *   hand-over record was made to cover the requests in flight (PortHandover.cover);
 * - the thread sleeps until the port has bytes, the core's next deadline (urb_core_next_deadline:
 *   a timeout, a placeholder's lifetime, the idle gap, the silence rule, the end of a hand-over) or
 *   a wake-up from Python (_pump_notify after a submission, or the stop), where the Python reader
 *   woke every READ_POLL_S;
 * - a failed read, the end of the port's input (a pty whose other end closed, an unplugged
 *   adapter) or a failed write declares the bridge lost with the reason the Python threads give
 *   ("<port>: " + rs232.describe_io_error of pyserial's exception) and ends the thread.
 *
 * Completed transfers stay in the C core until the dispatcher takes them (_native_pump.c).
 */
#include "_native.h"

#include <errno.h>
#include <poll.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* rs232.describe_io_error's text for EIO and for a port that reports data and returns none. */
#define UNPLUGGED_TEXT "I/O error: the device was unplugged, or the bridge process ended"
/* rs232.open_serial's write_timeout: pyserial gives up on a write the port does not take this long. */
#define WRITE_TIMEOUT_NS (1000LL * 1000LL * 1000LL)
/* The Python reader's cadence (rs232.READ_POLL_S): a deadline a step left in the past is retried
 * this much later, never spun on. */
#define RETRY_NS (2LL * 1000LL * 1000LL)

/* The request frames one step took, in sending order (at most a window's). */
typedef struct {
    uint8_t bytes[URB_MAX_WINDOW][URB_REQUEST_MAX];
    int32_t size[URB_MAX_WINDOW];
    unsigned count;
} frames_t;

/* One step of the core at one instant: `got` bytes read (0: none), the timeouts, the frames that may
 * go. Returns the instant of the next step (the core's next deadline) and, in *until, the lifetime
 * the hand-over record must cover before the frames are written. */
static urb_ns_t step(native_core_t *self, const uint8_t *in, size_t got, frames_t *out, urb_ns_t *until)
{
    out->count = 0u;
    (void)pthread_mutex_lock(&self->lock);
    urb_ns_t const now = native_monotonic_ns();
    if (got > 0u) {
        (void)urb_core_receive(&self->core, in, got, now);
    }
    (void)urb_core_poll(&self->core, now);
    self->pump.notified = false; /* what Python queued until now goes in this step */
    while (out->count < URB_MAX_WINDOW) {
        native_xfer_t *const head = (native_xfer_t *)self->core.q_head;
        int32_t const n = urb_core_next_frame(&self->core, now, out->bytes[out->count], URB_REQUEST_MAX);
        if (n <= 0) {
            break;
        }
        native_pump_note_sent(self, head, self->core.m.count - 1u); /* the newest slot */
        out->size[out->count++] = n;
    }
    *until = urb_core_busy_until(&self->core);
    urb_ns_t next = urb_core_next_deadline(&self->core);
    native_pump_wake_dispatcher(self);
    (void)pthread_mutex_unlock(&self->lock);
    if (next <= now) {
        next = now + RETRY_NS;
    }
    return next;
}

/* Waits until the port may take more bytes or the write timeout `give_up` passes; false then. */
static bool wait_writable(int fd, urb_ns_t give_up)
{
    for (;;) {
        urb_ns_t const left = give_up - native_monotonic_ns();
        if (left <= 0) {
            return false;
        }
        struct pollfd fds = {fd, POLLOUT, 0};
        struct timespec const ts = {(time_t)(left / URB_NS_PER_S), (long)(left % URB_NS_PER_S)};
        int const ready = ppoll(&fds, 1u, &ts, NULL);
        if (ready > 0) {
            return true;
        }
        if ((ready < 0) && (errno != EINTR)) {
            return true; /* the write that follows says what is wrong */
        }
    }
}

/* Writes one frame whole, as pyserial's Serial.write (partial writes continued, a port that takes
 * nothing for WRITE_TIMEOUT_NS gives up). Returns false when the bridge was declared lost. */
static bool write_frame(native_core_t *self, const uint8_t *buf, size_t n)
{
    int const fd = self->pump.fd;
    urb_ns_t const give_up = native_monotonic_ns() + WRITE_TIMEOUT_NS;
    size_t done = 0u;
    while (done < n) {
        ssize_t const wrote = write(fd, buf + done, n - done);
        if (wrote > 0) {
            done += (size_t)wrote;
            continue;
        }
        int const code = errno;
        if ((wrote < 0) && (code != EAGAIN) && (code != EWOULDBLOCK) && (code != EINTR)) {
            if (code == EIO) {
                native_pump_lost(self, UNPLUGGED_TEXT);
            } else {
                native_pump_lost(self, "write failed: [Errno %d] %s", code, strerror(code));
            }
            return false;
        }
        if (!wait_writable(fd, give_up)) {
            native_pump_lost(self, "Write timeout");
            return false;
        }
    }
    return true;
}

/* Reads what the port has (0: nothing yet). Returns -1 when the bridge was declared lost. */
static ssize_t read_port(native_core_t *self, uint8_t *buf, size_t cap)
{
    ssize_t const got = read(self->pump.fd, buf, cap);
    if (got > 0) {
        return got;
    }
    int const code = errno;
    if ((got < 0) && ((code == EAGAIN) || (code == EWOULDBLOCK) || (code == EINTR))) {
        return 0;
    }
    if ((got == 0) || (code == EIO)) { /* pyserial: "device reports readiness to read but returned no data" */
        native_pump_lost(self, UNPLUGGED_TEXT);
    } else {
        native_pump_lost(self, "[Errno %d] %s", code, strerror(code));
    }
    return -1;
}

void *native_rs232_pump_main(void *arg)
{
    native_core_t *self = arg;
    native_pump_t *p = &self->pump;
    uint8_t in[4096];
    frames_t out;
    urb_ns_t next = native_monotonic_ns(); /* a first step at once: what was queued before the start goes */
    while (!p->stop) {
        struct pollfd fds[2] = {{p->fd, POLLIN, 0}, {p->wake_fd, POLLIN, 0}};
        urb_ns_t const wait = (next == URB_NEVER) ? -1 : next - native_monotonic_ns();
        struct timespec const ts = {(time_t)((wait > 0) ? (wait / URB_NS_PER_S) : 0),
                                    (long)((wait > 0) ? (wait % URB_NS_PER_S) : 0)};
        int const ready = ppoll(fds, 2u, (next == URB_NEVER) ? NULL : &ts, NULL);
        if (p->stop) {
            break;
        }
        if ((ready > 0) && ((fds[1].revents & POLLIN) != 0)) {
            uint64_t count;
            (void)read(p->wake_fd, &count, sizeof count);
        }
        ssize_t got = 0;
        if ((ready > 0) && ((fds[0].revents & (POLLIN | POLLHUP | POLLERR | POLLNVAL)) != 0)) {
            got = read_port(self, in, sizeof in); /* a closed descriptor (POLLNVAL) fails the read: lost */
            if (got < 0) {
                break;
            }
        }
        urb_ns_t until = URB_NO_TIME;
        next = step(self, in, (size_t)got, &out, &until);
        if (out.count > 0u) {
            native_pump_cover(p, until, native_monotonic_ns());
        }
        bool written = true;
        for (unsigned i = 0u; written && (i < out.count); i++) {
            written = write_frame(self, out.bytes[i], (size_t)out.size[i]);
        }
        if (!written) {
            break;
        }
    }
    return NULL;
}
