/*
 * The event loop and the managers (host/urb/managers/base.py ThreadedManager, rs232.py, usb.py,
 * api.py URBInterface): ports in an epoll set, the cores fed with the monotonic clock, callbacks
 * dispatched outside the lock. Embedding and threading rules: urb_loop.h.
 */
#define _GNU_SOURCE /* epoll_pwait2: a timeout in ns (Linux 5.11, glibc 2.35) */
#include "urb_loop.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include "urb_host_internal.h"

#define READ_CHUNK 4096u
#define EVENTS 16
#define THREAD_WAIT_NS (100LL * URB_NS_PER_MS)

/* ----- small helpers ------------------------------------------------------------------------- */

static void lock(urb_loop_t *loop) { (void)pthread_mutex_lock(&loop->lock); }
static void unlock(urb_loop_t *loop) { (void)pthread_mutex_unlock(&loop->lock); }

static bool in_callback(const urb_loop_t *loop)
{
    return loop->in_dispatch && pthread_equal(pthread_self(), loop->dispatcher);
}

static void wake(urb_loop_t *loop)
{
    uint64_t one = 1u;
    (void)!write(loop->wakefd, &one, sizeof one);
}

static void say(char *err, size_t size, const char *text)
{
    if ((err != NULL) && (size > 0u)) {
        (void)snprintf(err, size, "%s", text);
    }
}

static void log_text(urb_loop_t *loop, const char *text)
{
    if (loop->log != NULL) {
        loop->log(text, loop->log_user);
    } else {
        (void)fprintf(stderr, "%s\n", text);
    }
}

static urb_ns_t next_boundary(urb_ns_t now) { return (now / URB_USB_FRAME_NS + 1) * URB_USB_FRAME_NS; }

/* ----- init and teardown ------------------------------------------------------------------------ */

static int32_t watch(urb_loop_t *loop, int fd, uint32_t events, uint64_t tag, int op)
{
    struct epoll_event ev;
    memset(&ev, 0, sizeof ev);
    ev.events = events;
    ev.data.u64 = tag;
    return (epoll_ctl(loop->epfd, op, fd, &ev) == 0) ? URB_HOST_OK : URB_HOST_EIO;
}

#define TAG_WAKE 1000u
#define TAG_TIMER 1001u

int32_t urb_loop_init(urb_loop_t *loop, const urb_schema_t *schema)
{
    if (loop == NULL) {
        return URB_HOST_EINVAL;
    }
    memset(loop, 0, sizeof *loop);
    loop->epfd = epoll_create1(EPOLL_CLOEXEC);
    loop->wakefd = eventfd(0u, EFD_NONBLOCK | EFD_CLOEXEC);
    loop->timerfd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    if ((loop->epfd < 0) || (loop->wakefd < 0) || (loop->timerfd < 0) ||
        (watch(loop, loop->wakefd, EPOLLIN, TAG_WAKE, EPOLL_CTL_ADD) != URB_HOST_OK) ||
        /* edge-triggered: each expiry is reported once, so the timerfd is never read */
        (watch(loop, loop->timerfd, EPOLLIN | EPOLLET, TAG_TIMER, EPOLL_CTL_ADD) != URB_HOST_OK)) {
        int const fds[3] = {loop->epfd, loop->wakefd, loop->timerfd};
        for (size_t i = 0u; i < 3u; i++) {
            if (fds[i] >= 0) {
                (void)close(fds[i]);
            }
        }
        return URB_HOST_EIO;
    }
    (void)pthread_mutex_init(&loop->lock, NULL);
    (void)pthread_cond_init(&loop->changed, NULL);
    urb_system_init(&loop->system, schema);
    return URB_HOST_OK;
}

void urb_loop_set_lost_callback(urb_loop_t *loop, urb_lost_fn fn, void *user)
{
    if (loop != NULL) {
        lock(loop);
        loop->on_lost = fn;
        loop->lost_user = user;
        unlock(loop);
    }
}

void urb_loop_set_log(urb_loop_t *loop, urb_log_fn fn, void *user)
{
    if (loop != NULL) {
        lock(loop);
        loop->log = fn;
        loop->log_user = user;
        unlock(loop);
    }
}

const char *urb_manager_lost_reason(urb_manager_t *m)
{
    return (m == NULL) ? NULL : urb_core_lost_reason(&m->core);
}

const char *urb_manager_name(const urb_manager_t *m)
{
    return (m == NULL) ? "" : m->path;
}

int urb_loop_fd(const urb_loop_t *loop)
{
    return (loop == NULL) ? -1 : loop->epfd;
}

/* ----- the dispatch batch: completions taken under the lock, run outside it -------------------- */

typedef struct {
    urb_transfer_t *head;
    urb_transfer_t *tail;
    urb_manager_t *notice;        /* a lost notice to give ... */
    urb_transfer_t *notice_before; /* ... before this transfer (NULL: after the last) */
    char reason[URB_REASON_MAX];
} batch_t;

static void batch_append(batch_t *b, urb_transfer_t *t)
{
    t->next = NULL;
    if (b->tail == NULL) {
        b->head = t;
    } else {
        b->tail->next = t;
    }
    b->tail = t;
}

/* Moves m's completions into b; when the core has just found the bridge lost, the lost notice goes
 * before the first request that loss failed (base.BusManager._queue_completed). */
static void collect(urb_manager_t *m, batch_t *b)
{
    bool notice = false;
    if (!m->core.lost) {
        m->lost_noted = false;
    } else if (!m->lost_noted) {
        m->lost_noted = true;
        notice = true;
        b->notice = m;
        b->notice_before = NULL;
        urbh_copy_reason(b->reason, m->core.lost_reason);
    }
    urb_transfer_t *t;
    while ((t = urb_core_take_completed(&m->core)) != NULL) {
        if (notice && ((t->flags & URB_FLAG_BRIDGE_LOST) != 0u)) {
            b->notice_before = t;
            notice = false;
        }
        m->completed++;
        m->failed += (t->flags != URB_FLAG_NONE) ? 1u : 0u;
        batch_append(b, t);
    }
}

static bool is_discovery_transfer(const urb_manager_t *m, const urb_transfer_t *t)
{
    return t->user == (const void *)&m->discovery;
}

static void pump(urb_manager_t *m, urb_ns_t now);

/* Runs one batch's callbacks (lock NOT held on entry; discovery's own callbacks take it). */
static size_t run_batch(urb_loop_t *loop, batch_t *b)
{
    size_t ran = 0u;
    urb_transfer_t *t = b->head;
    while ((t != NULL) || (b->notice != NULL)) {
        if ((b->notice != NULL) && (t == b->notice_before)) {
            if (loop->on_lost != NULL) {
                loop->on_lost(b->notice, b->reason, loop->lost_user);
            }
            b->notice = NULL;
            continue;
        }
        urb_transfer_t *next = t->next;
        t->next = NULL;
        t->callback_ns = urb_now_ns();
        urb_manager_t *m = NULL;
        for (uint32_t i = 0u; i < loop->manager_count; i++) {
            if (is_discovery_transfer(&loop->managers[i], t)) {
                m = &loop->managers[i];
            }
        }
        if (m != NULL) { /* discovery submits to the core: under the lock, then its frames go out */
            lock(loop);
            t->on_done(t, t->user);
            pump(m, urb_now_ns());
            unlock(loop);
        } else if (t->on_done != NULL) {
            t->on_done(t, t->user); /* t is the caller's again */
        }
        ran++;
        t = next;
    }
    return ran;
}

/* ----- port I/O (lock held) ------------------------------------------------------------------- */

static void io_lost(urb_manager_t *m, urb_ns_t now, int code)
{
    char reason[URB_REASON_MAX + URB_PATH_MAX];
    if ((code == EIO) || (code == 0) || (code == ENXIO) || (code == ENODEV)) {
        (void)snprintf(reason, sizeof reason, "%s: I/O error: the device was unplugged, or the bridge process ended",
                       m->path);
    } else {
        (void)snprintf(reason, sizeof reason, "%s: %s", m->path, strerror(code));
    }
    urb_core_link_lost(&m->core, now, reason);
    if (m->open) {
        (void)epoll_ctl(m->loop->epfd, EPOLL_CTL_DEL, m->fd, NULL); /* no more reads until reconnect */
    }
}

static void note_sending(urb_manager_t *m, urb_ns_t now)
{
    if (!m->use_handover) {
        return;
    }
    urb_ns_t const until = urb_core_busy_until(&m->core);
    bool const warned = m->handover.warned;
    if ((until != URB_NO_TIME) && (urb_handover_cover(&m->handover, until, now) != URB_HOST_OK) && !warned) {
        log_text(m->loop, m->handover.error);
    }
}

/* Writes bytes to the port; what it does not take now waits in m->out for EPOLLOUT. */
static void write_bytes(urb_manager_t *m, const uint8_t *data, size_t n, urb_ns_t now)
{
    if (m->out_len == 0u) {
        ssize_t w = write(m->fd, data, n);
        if ((w < 0) && ((errno == EAGAIN) || (errno == EINTR))) {
            w = 0;
        }
        if (w < 0) {
            io_lost(m, now, errno);
            return;
        }
        data += w;
        n -= (size_t)w;
        if (n == 0u) {
            return;
        }
        (void)watch(m->loop, m->fd, EPOLLIN | EPOLLOUT, m->index, EPOLL_CTL_MOD);
    }
    if (m->out_len + n <= URB_MANAGER_OUT) { /* the window bounds it: 15 frames of at most 37 bytes */
        memcpy(m->out + m->out_len, data, n);
        m->out_len += n;
    }
}

static void flush_out(urb_manager_t *m, urb_ns_t now)
{
    if (m->out_len == 0u) {
        return;
    }
    ssize_t const w = write(m->fd, m->out, m->out_len);
    if (w < 0) {
        if ((errno != EAGAIN) && (errno != EINTR)) {
            io_lost(m, now, errno);
        }
        return;
    }
    memmove(m->out, m->out + w, m->out_len - (size_t)w);
    m->out_len -= (size_t)w;
    if (m->out_len == 0u) {
        (void)watch(m->loop, m->fd, EPOLLIN, m->index, EPOLL_CTL_MOD);
    }
}

/* RS232: every frame the window lets go, the record written first, all of them in one write() (the
 * frames lie back to back in `frames`: the wire carries the same bytes as one write per frame). */
static void pump_rs232(urb_manager_t *m, urb_ns_t now)
{
    uint8_t frames[URB_MAX_WINDOW * URB_REQUEST_MAX];
    size_t count = 0u;
    size_t used = 0u;
    int32_t n;
    while ((count < URB_MAX_WINDOW) &&
           ((n = urb_core_next_frame(&m->core, now, frames + used, sizeof frames - used)) > 0)) {
        count++;
        used += (size_t)n;
    }
    if (count == 0u) {
        return;
    }
    note_sending(m, now); /* a process killed right after the write must leave a record covering it */
    write_bytes(m, frames, used, now);
}

/* USB: one OUT transfer at each 1-ms boundary while the core has something to send or fetch. */
static void tick_usb(urb_manager_t *m, urb_ns_t now)
{
    if (!urb_core_wants_frame(&m->core)) {
        m->next_frame_ns = 0;
        return;
    }
    if (m->next_frame_ns == 0) {
        m->next_frame_ns = next_boundary(now);
        return;
    }
    if (now < m->next_frame_ns) {
        return;
    }
    m->next_frame_ns += URB_USB_FRAME_NS;
    if (m->next_frame_ns <= now) { /* overslept: skip to the next boundary, never burst */
        m->next_frame_ns = next_boundary(now);
    }
    uint8_t batch[URB_USB_BATCH_MAX];
    int32_t const n = urb_core_frame_out(&m->core, now, batch, sizeof batch);
    if (n > 0) {
        note_sending(m, now);
        ssize_t const w = write(m->fd, batch, (size_t)n);
        if ((w < 0) && (errno != EAGAIN) && (errno != EINTR)) {
            io_lost(m, now, errno); /* an unplugged device fails its OUT transfer */
        }
    }
}

static void pump(urb_manager_t *m, urb_ns_t now)
{
    if (!m->open || m->core.lost) {
        return;
    }
    if (m->kind == URB_LINK_RS232) {
        pump_rs232(m, now);
    } else {
        tick_usb(m, now);
    }
}

/* Reads what the readiness event announced, without the read that would end in EAGAIN: the ports
 * are level-triggered in the epoll set, so whatever is still queued reports the port ready again at
 * the next wait. USB: one read (one IN transfer, of any length); RS232: until a read returns fewer
 * bytes than asked (the tty had no more at that instant). */
static void read_port(urb_manager_t *m, urb_ns_t now)
{
    uint8_t buf[READ_CHUNK];
    while (m->open) { /* a core lost to silence still counts what comes as stray */
        ssize_t const got = read(m->fd, buf, sizeof buf);
        if (got > 0) {
            if (m->kind != URB_LINK_RS232) {
                (void)urb_core_receive_batch(&m->core, buf, (size_t)got, now); /* one read = one IN transfer */
                return;
            }
            (void)urb_core_receive(&m->core, buf, (size_t)got, now);
            if ((size_t)got < sizeof buf) {
                return;
            }
            continue;
        }
        if ((got < 0) && (errno == EINTR)) {
            continue;
        }
        if ((got < 0) && (errno == EAGAIN)) {
            return;
        }
        io_lost(m, now, (got == 0) ? 0 : errno); /* readable but no data: the other end is gone */
        return;
    }
}

/* ----- deadlines --------------------------------------------------------------------------------- */

static urb_ns_t next_deadline_locked(urb_loop_t *loop, urb_ns_t now)
{
    urb_ns_t next = (loop->refused_head != NULL) ? now : URB_NEVER;
    for (uint32_t i = 0u; i < loop->manager_count; i++) {
        urb_manager_t *m = &loop->managers[i];
        if (m->wake_pending) {
            next = now;
        }
        urb_ns_t d = urb_core_next_deadline(&m->core);
        if ((m->kind == URB_LINK_USB) && m->open && urb_core_wants_frame(&m->core)) {
            urb_ns_t const f = (m->next_frame_ns == 0) ? next_boundary(now) : m->next_frame_ns;
            d = (f < d) ? f : d;
        }
        next = (d < next) ? d : next;
    }
    return next;
}

urb_ns_t urb_loop_next_deadline(urb_loop_t *loop)
{
    if (loop == NULL) {
        return URB_NEVER;
    }
    lock(loop);
    urb_ns_t const next = next_deadline_locked(loop, urb_now_ns());
    unlock(loop);
    return next;
}

/* Arms the timerfd, one-shot, at `deadline` (URB_NEVER: disarmed), unless it is armed there already.
 * It is edge-triggered in the epoll set: an expiry is reported once and the timerfd is never read.
 * Lock held. */
static void arm_timer(urb_loop_t *loop, urb_ns_t deadline)
{
    urb_ns_t const want = (deadline == URB_NEVER) ? 0 : ((deadline < 1) ? 1 : deadline);
    if (want == loop->armed_ns) {
        return;
    }
    struct itimerspec its;
    memset(&its, 0, sizeof its);
    its.it_value.tv_sec = (time_t)(want / URB_NS_PER_S);
    its.it_value.tv_nsec = (long)(want % URB_NS_PER_S);
    if (timerfd_settime(loop->timerfd, TFD_TIMER_ABSTIME, &its, NULL) == 0) {
        loop->armed_ns = want;
    }
}

/* After a submission moved the loop's deadline: whoever waits for the loop must wake by the new
 * deadline. A thread waiting inside urb_loop_run_once, or an application polling urb_loop_fd(), is
 * woken by the timer, brought forward only when it would fire later (no eventfd write and read, no
 * early wake-up); an application that runs urb_loop_run_once with a timeout itself and is not
 * waiting in it now computes its next wait afresh. Lock held. */
static void cover_deadline(urb_loop_t *loop, urb_ns_t now)
{
    if (loop->self_waits && (loop->waiting_until == 0)) {
        return;
    }
    urb_ns_t const deadline = next_deadline_locked(loop, now);
    urb_ns_t const armed = (loop->armed_ns == 0) ? URB_NEVER : loop->armed_ns;
    urb_ns_t const waking = (loop->self_waits && (loop->waiting_until < armed)) ? loop->waiting_until : armed;
    if (deadline < waking) {
        arm_timer(loop, deadline);
    }
}

/* Waits for the epoll set's events up to `wait` ns (negative: no limit): epoll_pwait2's timeout
 * counts in ns; before Linux 5.11 epoll_wait's counts in ms, rounded up (the timerfd in the set still
 * wakes it at the loop's own deadline). */
static int wait_events(urb_loop_t *loop, struct epoll_event *ev, urb_ns_t wait)
{
    if (!loop->ms_waits) {
        struct timespec ts = {(time_t)(wait / URB_NS_PER_S), (long)(wait % URB_NS_PER_S)};
        int const n = epoll_pwait2(loop->epfd, ev, EVENTS, (wait < 0) ? NULL : &ts, NULL);
        if ((n >= 0) || (errno != ENOSYS)) {
            return n;
        }
        loop->ms_waits = true;
    }
    int const ms = (wait < 0) ? -1 : (int)((wait + URB_NS_PER_MS - 1) / URB_NS_PER_MS);
    return epoll_wait(loop->epfd, ev, EVENTS, ms);
}

/* ----- one step ---------------------------------------------------------------------------------- */

/* Handles what one wait returned (lock held): drains the wake-up eventfd, notes the timer's expiry,
 * flushes and reads the ports. Returns whether a USB port was read: it may hold another IN transfer. */
static bool take_events(urb_loop_t *loop, const struct epoll_event *ev, int n, urb_ns_t now)
{
    bool usb_read = false;
    for (int i = 0; i < n; i++) {
        uint64_t const tag = ev[i].data.u64;
        if (tag == TAG_WAKE) {
            uint64_t drain;
            (void)!read(loop->wakefd, &drain, sizeof drain);
        } else if (tag == TAG_TIMER) {
            if (loop->armed_ns <= now) {
                loop->armed_ns = 0; /* it fired */
            }
        } else if (tag < loop->manager_count) {
            urb_manager_t *m = &loop->managers[tag];
            if ((ev[i].events & EPOLLOUT) != 0u) {
                flush_out(m, now);
            }
            if ((ev[i].events & (EPOLLIN | EPOLLHUP | EPOLLERR)) != 0u) {
                read_port(m, now);
                usb_read = usb_read || (m->kind == URB_LINK_USB);
            }
        }
    }
    return usb_read;
}

/* Everything due after the input was taken: timeouts and the lost-bridge rules, frames out, then the
 * callbacks (outside the lock). Lock held on entry, released on return. Returns the callbacks run. */
static int32_t dispatch_due(urb_loop_t *loop, urb_ns_t now)
{
    batch_t batches[URB_LOOP_MAX_MANAGERS + 1u];
    memset(batches, 0, sizeof batches);
    for (uint32_t i = 0u; i < loop->manager_count; i++) {
        urb_manager_t *m = &loop->managers[i];
        m->wake_pending = false;
        if (!m->registered) {
            continue;
        }
        (void)urb_core_poll(&m->core, now);
        pump(m, now);
        collect(m, &batches[i]);
    }
    batches[URB_LOOP_MAX_MANAGERS].head = loop->refused_head; /* host refusals, in submission order */
    batches[URB_LOOP_MAX_MANAGERS].tail = loop->refused_tail;
    loop->refused_head = loop->refused_tail = NULL;
    loop->in_dispatch = true;
    loop->dispatcher = pthread_self();
    unlock(loop);

    size_t ran = 0u;
    for (uint32_t i = 0u; i <= URB_LOOP_MAX_MANAGERS; i++) {
        ran += run_batch(loop, &batches[i]);
    }

    lock(loop);
    loop->in_dispatch = false;
    if (!loop->self_waits) { /* an application polls urb_loop_fd() until the next deadline */
        arm_timer(loop, next_deadline_locked(loop, urb_now_ns()));
    }
    (void)pthread_cond_broadcast(&loop->changed);
    unlock(loop);
    return (int32_t)ran;
}

static int32_t run_once(urb_loop_t *loop, urb_ns_t timeout_ns)
{
    lock(loop);
    urb_ns_t now = urb_now_ns();
    urb_ns_t const deadline = next_deadline_locked(loop, now);
    urb_ns_t wait = timeout_ns;
    if (deadline != URB_NEVER) {
        urb_ns_t const left = (deadline > now) ? deadline - now : 0;
        wait = ((wait < 0) || (left < wait)) ? left : wait;
    }
    if (loop->ms_waits && (deadline > now)) {
        arm_timer(loop, deadline); /* epoll_wait's ms would overshoot it */
    }
    urb_ns_t const until = (wait < 0) ? URB_NEVER : now + wait;
    loop->waiting_until = (until > loop->waiting_until) ? until : loop->waiting_until; /* the latest waiter's */
    loop->waiters++;
    unlock(loop);

    struct epoll_event ev[EVENTS];
    int n = wait_events(loop, ev, wait);
    if (n < 0) {
        n = 0; /* EINTR: a signal; do what is due */
    }

    lock(loop);
    loop->waiters--;
    if (loop->waiters == 0u) {
        loop->waiting_until = 0;
    }
    now = urb_now_ns();
    (void)take_events(loop, ev, n, now);
    return dispatch_due(loop, now);
}

/* Is the calling thread allowed to run the loop (not inside a callback, not beside the loop's thread)? */
static bool may_run(const urb_loop_t *loop)
{
    return !in_callback(loop) && !(loop->thread_running && !pthread_equal(pthread_self(), loop->thread));
}

int32_t urb_loop_service(urb_loop_t *loop)
{
    if (loop == NULL) {
        return URB_HOST_EINVAL;
    }
    if (!may_run(loop)) {
        return URB_HOST_ESTATE;
    }
    lock(loop); /* held throughout: nothing below waits */
    loop->self_waits = true; /* the application wakes itself at its period: no timer for it */
    struct epoll_event ev[EVENTS];
    bool again = true;
    for (uint32_t pass = 0u; again && (pass < URB_LOOP_SERVICE_PASSES); pass++) {
        int const n = wait_events(loop, ev, 0); /* what is ready now: a zero timeout */
        again = (n > 0) && take_events(loop, ev, n, urb_now_ns()); /* a USB port read: ask again */
    }
    return dispatch_due(loop, urb_now_ns());
}

int32_t urb_loop_run_once(urb_loop_t *loop, urb_ns_t timeout_ns)
{
    if (loop == NULL) {
        return URB_HOST_EINVAL;
    }
    if (!may_run(loop)) {
        return URB_HOST_ESTATE;
    }
    lock(loop);
    loop->self_waits = (timeout_ns != 0); /* 0: the application polls urb_loop_fd() (urb_loop.h) */
    unlock(loop);
    return run_once(loop, timeout_ns);
}

static void *thread_main(void *arg)
{
    urb_loop_t *loop = arg;
    while (!loop->stop) {
        (void)run_once(loop, THREAD_WAIT_NS);
    }
    return NULL;
}

int32_t urb_loop_start_thread(urb_loop_t *loop)
{
    if (loop == NULL) {
        return URB_HOST_EINVAL;
    }
    if (loop->thread_running) {
        return URB_HOST_ESTATE;
    }
    loop->stop = false;
    lock(loop);
    loop->self_waits = true; /* only its thread waits for the loop */
    unlock(loop);
    if (pthread_create(&loop->thread, NULL, thread_main, loop) != 0) {
        return URB_HOST_EIO;
    }
    loop->thread_running = true;
    return URB_HOST_OK;
}

int32_t urb_loop_stop_thread(urb_loop_t *loop)
{
    if (loop == NULL) {
        return URB_HOST_EINVAL;
    }
    if (in_callback(loop)) {
        return URB_HOST_ESTATE;
    }
    if (loop->thread_running) {
        loop->stop = true;
        wake(loop);
        (void)pthread_join(loop->thread, NULL);
        loop->thread_running = false;
        lock(loop);
        loop->self_waits = false; /* the application may poll urb_loop_fd() again */
        arm_timer(loop, next_deadline_locked(loop, urb_now_ns()));
        unlock(loop);
    }
    return URB_HOST_OK;
}

/* Waits (lock held) until `done(arg)` or the monotonic deadline: runs the loop itself, or waits
 * for its thread. Returns whether done. */
static bool wait_until(urb_loop_t *loop, bool (*done)(const void *), const void *arg, urb_ns_t deadline)
{
    for (;;) {
        if (done(arg)) {
            return true;
        }
        urb_ns_t const now = urb_now_ns();
        if (now >= deadline) {
            return false;
        }
        if (loop->thread_running) {
            struct timespec ts;
            (void)clock_gettime(CLOCK_REALTIME, &ts); /* pthread_cond_timedwait's default clock */
            urb_ns_t const step = (deadline - now < THREAD_WAIT_NS) ? deadline - now : THREAD_WAIT_NS;
            urb_ns_t const abs = (urb_ns_t)ts.tv_sec * URB_NS_PER_S + ts.tv_nsec + step;
            ts.tv_sec = (time_t)(abs / URB_NS_PER_S);
            ts.tv_nsec = (long)(abs % URB_NS_PER_S);
            (void)pthread_cond_timedwait(&loop->changed, &loop->lock, &ts);
        } else {
            unlock(loop);
            (void)run_once(loop, deadline - now);
            lock(loop);
        }
    }
}

/* ----- managers ------------------------------------------------------------------------------------ */

static int32_t register_manager(urb_loop_t *loop, urb_link_kind_t kind, int fd, bool own_fd, const char *path,
                                uint32_t baud, const urb_core_config_t *cfg, urb_manager_t **out)
{
    urb_manager_t *m = &loop->managers[loop->manager_count];
    memset(m, 0, sizeof *m);
    if (urb_core_init(&m->core, kind, cfg) != URB_HOST_OK) {
        return URB_HOST_EINVAL;
    }
    m->loop = loop;
    m->index = (uint8_t)loop->manager_count;
    m->kind = (uint8_t)kind;
    m->fd = fd;
    m->own_fd = own_fd;
    m->baud = baud;
    (void)snprintf(m->path, sizeof m->path, "%s", path);
    urb_discovery_init(&m->discovery);
    if (watch(loop, fd, EPOLLIN, m->index, EPOLL_CTL_ADD) != URB_HOST_OK) {
        return URB_HOST_EIO;
    }
    m->open = true;
    m->registered = true;
    if (own_fd && (urb_handover_init(&m->handover, path, NULL) == URB_HOST_OK)) {
        m->use_handover = true;
        urb_ns_t const until = urb_handover_predecessor_until(&m->handover, urb_now_ns());
        if (until != URB_NO_TIME) {
            urb_core_hand_over(&m->core, until); /* Bridge.tla HostRestart */
        }
    }
    loop->manager_count++;
    if (out != NULL) {
        *out = m;
    }
    return URB_HOST_OK;
}

static int32_t add_by_path(urb_loop_t *loop, urb_link_kind_t kind, const char *path, uint32_t baud,
                           const urb_core_config_t *cfg, urb_manager_t **out, char *err, size_t err_size)
{
    if ((loop == NULL) || (path == NULL)) {
        return URB_HOST_EINVAL;
    }
    urb_core_t probe;
    if (urb_core_init(&probe, kind, cfg) != URB_HOST_OK) {
        say(err, err_size, "invalid core settings (urb_core_config_t): see urb_host_core.h for the ranges");
        return URB_HOST_EINVAL;
    }
    lock(loop);
    if (loop->manager_count >= URB_LOOP_MAX_MANAGERS) {
        unlock(loop);
        say(err, err_size, "too many bridges for one loop (URB_LOOP_MAX_MANAGERS); build with a larger value");
        return URB_HOST_ENOSPC;
    }
    int fd = -1;
    int32_t rc = (kind == URB_LINK_RS232) ? urb_serial_open(path, baud, &fd, NULL, err, err_size)
                                          : urb_usbdev_open(path, &fd, err, err_size);
    if (rc == URB_HOST_OK) {
        rc = register_manager(loop, kind, fd, true, path, baud, cfg, out);
        if (rc != URB_HOST_OK) {
            (void)close(fd);
            say(err, err_size, "the port could not be added to the event loop (epoll)");
        }
    }
    unlock(loop);
    return rc;
}

int32_t urb_loop_add_rs232(urb_loop_t *loop, const char *path, uint32_t baud, const urb_core_config_t *cfg,
                           urb_manager_t **out, char *err, size_t err_size)
{
    return add_by_path(loop, URB_LINK_RS232, path, baud, cfg, out, err, err_size);
}

int32_t urb_loop_add_usb(urb_loop_t *loop, const char *path, const urb_core_config_t *cfg, urb_manager_t **out,
                         char *err, size_t err_size)
{
    return add_by_path(loop, URB_LINK_USB, path, 0u, cfg, out, err, err_size);
}

int32_t urb_loop_add_usb_fd(urb_loop_t *loop, int fd, const char *name, const urb_core_config_t *cfg,
                            urb_manager_t **out)
{
    if ((loop == NULL) || (fd < 0) || (name == NULL)) {
        return URB_HOST_EINVAL;
    }
    lock(loop);
    int32_t rc = (loop->manager_count >= URB_LOOP_MAX_MANAGERS)
                     ? URB_HOST_ENOSPC
                     : register_manager(loop, URB_LINK_USB, fd, false, name, 0u, cfg, out);
    unlock(loop);
    return rc;
}

/* Completes what m's core completed at once, running the callbacks on this thread (no dispatcher
 * will: m is closed). Lock held on entry and on return. */
static void dispatch_inline(urb_loop_t *loop, urb_manager_t *m)
{
    batch_t b;
    memset(&b, 0, sizeof b);
    collect(m, &b);
    unlock(loop);
    (void)run_batch(loop, &b);
    lock(loop);
}

/* urb_loop_submit with the lock held (on entry and on return). */
static int32_t submit_locked(urb_loop_t *loop, urb_manager_t *m, urb_transfer_t *t)
{
    urb_ns_t const now = urb_now_ns();
    bool const was_busy = urb_core_busy(&m->core);
    int32_t const rc = urb_core_submit(&m->core, t, now);
    if (rc == URB_HOST_OK) {
        m->submitted++;
        if (m->closed) {
            dispatch_inline(loop, m);
        } else {
            pump(m, now); /* RS232: written from this thread when the window allows */
            if (m->core.lost) {
                m->wake_pending = true; /* completed at once: the loop must dispatch it */
                wake(loop);
            } else if (!was_busy) {
                cover_deadline(loop, now); /* a timeout, or USB's first frame boundary */
            }
        }
    }
    return rc;
}

int32_t urb_loop_submit(urb_loop_t *loop, urb_manager_t *m, urb_transfer_t *t)
{
    if ((loop == NULL) || (m == NULL) || (m->loop != loop)) {
        return URB_HOST_EINVAL;
    }
    lock(loop);
    int32_t const rc = submit_locked(loop, m, t);
    unlock(loop);
    return rc;
}

/* ----- discovery ------------------------------------------------------------------------------------ */

static void discovered(urb_discovery_t *d, void *user)
{
    urb_manager_t *m = user; /* lock held: discovery callbacks run under it */
    if ((d->outcome == URB_DISCOVERY_DONE) && (urb_system_merge(&m->loop->system, m->index, d) == URB_HOST_OK)) {
        m->discovered = true;
    }
    if (m->on_discovered != NULL) {
        urb_discovered_fn fn = m->on_discovered;
        m->on_discovered = NULL;
        unlock(m->loop);
        fn(m, d, m->discovered_user);
        lock(m->loop);
    }
}

int32_t urb_loop_start_discovery(urb_loop_t *loop, urb_manager_t *m, bool rescan, urb_discovered_fn on_done,
                                 void *user)
{
    if ((loop == NULL) || (m == NULL) || (m->loop != loop)) {
        return URB_HOST_EINVAL;
    }
    lock(loop);
    int32_t rc = URB_HOST_ESTATE;
    if (!m->closed && (m->discovery.outcome != URB_DISCOVERY_RUNNING)) {
        m->on_discovered = on_done;
        m->discovered_user = user;
        urb_ns_t const now = urb_now_ns();
        rc = urb_discovery_start(&m->discovery, &m->core, loop->system.schema, rescan, discovered, m, now);
        pump(m, now);
        m->wake_pending = true;
        wake(loop);
    }
    unlock(loop);
    return rc;
}

static bool discovery_over(const void *arg)
{
    return urb_discovery_finished((const urb_discovery_t *)arg);
}

int32_t urb_loop_discover(urb_loop_t *loop, urb_manager_t *m, bool rescan, urb_ns_t timeout_ns, char *err,
                          size_t err_size)
{
    if ((loop == NULL) || (m == NULL) || (m->loop != loop) || (timeout_ns < 0)) {
        return URB_HOST_EINVAL;
    }
    if (in_callback(loop)) {
        say(err, err_size, "a blocking URB call inside a callback would deadlock the dispatcher; submit a request "
                           "with a callback instead");
        return URB_HOST_ESTATE;
    }
    int32_t rc = urb_loop_start_discovery(loop, m, rescan, NULL, NULL);
    if (rc != URB_HOST_OK) {
        say(err, err_size, "the bridge is closed or already discovering");
        return rc;
    }
    lock(loop);
    bool const done = wait_until(loop, discovery_over, &m->discovery, urb_now_ns() + timeout_ns);
    if (!done) {
        unlock(loop);
        (void)urb_loop_close_manager(loop, m, false); /* its transfers complete: nothing is left behind */
        if ((err != NULL) && (err_size > 0u)) {
            (void)snprintf(err, err_size,
                           "discovery on %s did not finish within %.1f s: check that the bridge is powered and "
                           "connected (the manager was closed; urb_loop_reconnect reopens it)",
                           m->path, (double)timeout_ns / 1e9);
        }
        return URB_HOST_EIO;
    }
    if (m->discovery.outcome != URB_DISCOVERY_DONE) {
        (void)urb_discovery_describe(&m->discovery, m->path, err, err_size);
        rc = URB_HOST_ENOTFOUND;
    } else if (!m->discovered) {
        say(err, err_size, "the system table is full (URB_SYSTEM_MAX_ROWS rows); build with a larger value");
        rc = URB_HOST_ENOSPC;
    }
    unlock(loop);
    return rc;
}

/* ----- nodes -------------------------------------------------------------------------------------- */

int32_t urb_loop_find_node(urb_loop_t *loop, uint8_t class_id, uint8_t index, urb_node_t *out, char *err,
                           size_t err_size)
{
    if ((loop == NULL) || (out == NULL)) {
        return URB_HOST_EINVAL;
    }
    lock(loop);
    urb_find_t why;
    int32_t const row = urb_system_find(&loop->system, class_id, index, &why);
    if (row < 0) {
        const char *names[URB_LOOP_MAX_MANAGERS];
        size_t count = 0u;
        for (uint32_t i = 0u; i < loop->manager_count; i++) {
            names[count++] = loop->managers[i].path;
        }
        if ((err != NULL) && (err_size > 0u)) {
            (void)urb_system_describe_find(&loop->system, class_id, index, why, names, count, err, err_size);
        }
        unlock(loop);
        return URB_HOST_ENOTFOUND;
    }
    memset(out, 0, sizeof *out);
    out->loop = loop;
    out->row = (uint32_t)row;
    out->manager = loop->system.rows[row].bridge;
    unlock(loop);
    return URB_HOST_OK;
}

int32_t urb_loop_node_at(urb_loop_t *loop, urb_manager_t *m, uint8_t address, urb_node_t *out)
{
    if ((loop == NULL) || (m == NULL) || (m->loop != loop) || (out == NULL) || (address > 127u)) {
        return URB_HOST_EINVAL;
    }
    memset(out, 0, sizeof *out);
    out->loop = loop;
    out->manager = m->index;
    if (address == URB_BRIDGE_ADDRESS) {
        out->bridge = true;
        return URB_HOST_OK;
    }
    lock(loop);
    int32_t const row = urb_system_at(&loop->system, m->index, address);
    if (row >= 0) {
        urb_node_row_t const *r = &loop->system.rows[row];
        out->row = (uint32_t)row;
        out->own_layout = (r->type == NULL) || ((r->flags & URB_NODE_MISMATCH) != 0u);
    }
    unlock(loop);
    return (row >= 0) ? URB_HOST_OK : URB_HOST_ENOTFOUND;
}

const urb_node_row_t *urb_node_row(const urb_node_t *node)
{
    if ((node == NULL) || (node->loop == NULL) || node->bridge || (node->row >= URB_SYSTEM_MAX_ROWS)) {
        return NULL;
    }
    return &node->loop->system.rows[node->row];
}

uint8_t urb_node_mailbox_size(const urb_node_t *node, bool outbox, uint8_t mailbox)
{
    if ((node == NULL) || (mailbox > 7u)) {
        return 0u;
    }
    if (node->bridge) {
        return outbox ? urb_schema_bridge()->outbox_sizes[mailbox] : urb_schema_bridge()->inbox_sizes[mailbox];
    }
    const urb_node_row_t *r = urb_node_row(node);
    if (r == NULL) {
        return 0u;
    }
    if (node->own_layout || (r->type == NULL)) {
        uint8_t const s = outbox ? r->ident.outbox_sizes[mailbox] : r->ident.inbox_sizes[mailbox];
        return (s <= URB_HOST_MAILBOX_MAX) ? s : 0u;
    }
    return outbox ? r->type->outbox_sizes[mailbox] : r->type->inbox_sizes[mailbox];
}

int32_t urb_node_submit(const urb_node_t *node, urb_transfer_t *t)
{
    if ((node == NULL) || (node->loop == NULL) || (t == NULL) || (node->manager >= node->loop->manager_count)) {
        return URB_HOST_EINVAL;
    }
    urb_loop_t *loop = node->loop;
    urb_manager_t *m = &loop->managers[node->manager];
    if (urb_transfer_owned(t)) {
        return URB_HOST_EBUSY;
    }
    lock(loop);
    urb_flags_t refused;
    if (node->bridge) {
        uint8_t const size = urb_node_mailbox_size(node, t->read, (uint8_t)(t->mailbox & 7u));
        refused = ((size == 0u) || (size != t->length) || (t->mailbox > 7u)) ? URB_FLAG_HOST_SIZE_MISMATCH : URB_FLAG_NONE;
        t->address = URB_BRIDGE_ADDRESS;
    } else {
        refused = urb_system_refusal(&loop->system, node->row, node->own_layout, t->read, t->mailbox, t->length);
        t->address = loop->system.rows[node->row].address;
    }
    if (refused == URB_FLAG_NONE) {
        int32_t const rc = submit_locked(loop, m, t);
        unlock(loop);
        return rc;
    }
    if ((t->length < 1u) || (t->length > URB_HOST_MAILBOX_MAX)) {
        unlock(loop);
        return URB_HOST_EINVAL;
    }
    /* refused on the host, nothing sent: completes like any request, at the next dispatch */
    urb_ns_t const now = urb_now_ns();
    t->submitted_ns = now;
    t->sent_ns = URB_NO_TIME;
    t->completed_ns = now;
    t->callback_ns = URB_NO_TIME;
    t->seq = -1;
    t->status = -1;
    t->response_len = 0u;
    t->flags = refused;
    t->lost_reason[0] = '\0';
    t->state = URB_XFER_DONE;
    t->next = NULL;
    m->submitted++;
    m->completed++;
    m->failed++;
    if (m->closed) {
        unlock(loop);
        t->callback_ns = urb_now_ns();
        if (t->on_done != NULL) {
            t->on_done(t, t->user);
        }
        return URB_HOST_OK;
    }
    if (loop->refused_tail == NULL) {
        loop->refused_head = t;
    } else {
        loop->refused_tail->next = t;
    }
    loop->refused_tail = t;
    wake(loop);
    unlock(loop);
    return URB_HOST_OK;
}

/* ----- close, reconnect, destroy -------------------------------------------------------------------- */

static bool drained(const void *arg)
{
    return urb_core_drained(&((const urb_manager_t *)arg)->core);
}

int32_t urb_loop_close_manager(urb_loop_t *loop, urb_manager_t *m, bool drain)
{
    if ((loop == NULL) || (m == NULL) || (m->loop != loop)) {
        return URB_HOST_EINVAL;
    }
    if (drain && in_callback(loop)) {
        return URB_HOST_ESTATE;
    }
    lock(loop);
    if (m->closed) {
        unlock(loop);
        return URB_HOST_OK;
    }
    if (drain) { /* Closing drains: late responses must not reach the next process */
        urb_ns_t const deadline = urb_core_start_drain(&m->core, urb_now_ns());
        if (deadline != URB_NO_TIME) {
            (void)wait_until(loop, drained, m, deadline);
        }
        (void)urb_core_poll(&m->core, urb_now_ns());
    }
    urb_ns_t const now = urb_now_ns();
    m->lost_noted = true; /* a close is not a loss to report */
    urb_core_link_lost(&m->core, now, URBH_CLOSED_REASON);
    if (m->use_handover && (urb_handover_settle(&m->handover, urb_core_busy_until(&m->core), now) != URB_HOST_OK) &&
        m->handover.error[0] != '\0') {
        log_text(loop, m->handover.error);
    }
    if (m->open) {
        (void)epoll_ctl(loop->epfd, EPOLL_CTL_DEL, m->fd, NULL);
        if (m->own_fd) {
            (void)close(m->fd);
        }
        m->open = false;
    }
    m->out_len = 0u;
    m->next_frame_ns = 0;
    m->closed = true;
    dispatch_inline(loop, m);
    unlock(loop);
    return URB_HOST_OK;
}

int32_t urb_loop_reconnect(urb_loop_t *loop, urb_manager_t *m, char *err, size_t err_size)
{
    if ((loop == NULL) || (m == NULL) || (m->loop != loop)) {
        return URB_HOST_EINVAL;
    }
    if (!m->own_fd) {
        say(err, err_size, "this USB manager runs on a descriptor of the caller's: reopen it and add a new manager");
        return URB_HOST_ESTATE;
    }
    lock(loop);
    if (m->open) {
        (void)epoll_ctl(loop->epfd, EPOLL_CTL_DEL, m->fd, NULL);
        (void)close(m->fd);
        m->open = false;
    }
    char text[URB_PATH_MAX + 256u];
    int fd = -1;
    int32_t const rc = (m->kind == URB_LINK_RS232) ? urb_serial_open(m->path, m->baud, &fd, NULL, text, sizeof text)
                                                   : urb_usbdev_open(m->path, &fd, text, sizeof text);
    urb_ns_t const now = urb_now_ns();
    if (rc != URB_HOST_OK) { /* the manager stays lost, saying why */
        char reason[URB_REASON_MAX + URB_PATH_MAX + 256u];
        (void)snprintf(reason, sizeof reason, "reconnect failed: %s", text);
        urb_core_link_lost(&m->core, now, reason);
        urbh_copy_reason(m->core.lost_reason, reason);
        m->closed = true;
        dispatch_inline(loop, m);
        unlock(loop);
        if ((err != NULL) && (err_size > 0u)) {
            (void)snprintf(err, err_size, "%s The bridge stays lost (requests complete BRIDGE_LOST); call "
                           "urb_loop_reconnect again once the %s is back.", text,
                           (m->kind == URB_LINK_RS232) ? "port" : "device");
        }
        return URB_HOST_EIO;
    }
    m->fd = fd;
    m->out_len = 0u;
    m->next_frame_ns = 0;
    if (watch(loop, fd, EPOLLIN, m->index, EPOLL_CTL_ADD) != URB_HOST_OK) {
        (void)close(fd);
        unlock(loop);
        say(err, err_size, "the port could not be added to the event loop (epoll)");
        return URB_HOST_EIO;
    }
    m->open = true;
    m->closed = false;
    urb_core_reset(&m->core, now); /* Bridge.tla HostReopen */
    dispatch_inline(loop, m);
    m->lost_noted = false;
    unlock(loop);
    return URB_HOST_OK;
}

void urb_loop_destroy(urb_loop_t *loop)
{
    if (loop == NULL) {
        return;
    }
    (void)urb_loop_stop_thread(loop);
    for (uint32_t i = 0u; i < loop->manager_count; i++) {
        (void)urb_loop_close_manager(loop, &loop->managers[i], false);
    }
    lock(loop);
    batch_t refused;
    memset(&refused, 0, sizeof refused);
    refused.head = loop->refused_head;
    loop->refused_head = loop->refused_tail = NULL;
    unlock(loop);
    (void)run_batch(loop, &refused); /* every request ends in exactly one callback */
    (void)close(loop->timerfd);
    (void)close(loop->wakefd);
    (void)close(loop->epfd);
    (void)pthread_cond_destroy(&loop->changed);
    (void)pthread_mutex_destroy(&loop->lock);
    memset(loop, 0, sizeof *loop);
    loop->epfd = loop->wakefd = loop->timerfd = -1;
}
