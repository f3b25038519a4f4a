/*
 * _native.h: what the parts of urb.managers._native share: the C core object (_native.c: the
 * protocol core as a CPython type; _native_attrs.c: its attributes; _native_xfer.c: its C transfers
 * and their hand-back to the Python ones) and its pump (_native_pump.c: the uplink's I/O on a C
 * thread, so that Python only sees completed transfers, in batches; the RS232 pump's loop is
 * _native_pump_rs232.c).
 *
 * Threads: the core object's methods run with the GIL; the pump's thread never takes it. Both
 * reach `core` only with `lock` held (the methods through core_lock, which waits for the mutex
 * with the GIL released, so that a Python thread waiting for it never blocks the others). The
 * pump leaves completed transfers in the core's completion list and signals `ready`; the Python
 * side hands them back to their Python objects in one go (`_pump_wait`, then `take_completed`).
 */
#ifndef URB_NATIVE_H
#define URB_NATIVE_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <pthread.h>
#include <stdbool.h>

#include "urb_host_core.h"
#include "urb_port.h"

typedef struct native_xfer {
    urb_transfer_t t;          /* first: a urb_transfer_t * of ours is a native_xfer_t * */
    PyObject *py;              /* the Python Transfer, or the CycleState of a cycle item (a strong
                                  reference while the core owns t) */
    int32_t cycle_item;        /* -1: py is a Transfer; else the index of the item in the CycleState */
    struct native_xfer *free_next;
    bool sent_unmarked;        /* sent by the pump: seq, sent_ns, due_ns and expires_ns are written to
                                  the Python transfer when it is handed back (the pump has no GIL) */
    urb_ns_t due_ns;           /* its slot's deadline and lifetime when the pump sent it */
    urb_ns_t expires_ns;
} native_xfer_t;

#define NATIVE_NAME_MAX 256u
#define NATIVE_LOCK_SPINS 200u /* tries of the core's lock before waiting for it without the GIL */
#define NATIVE_REASON_TEXT_MAX (NATIVE_NAME_MAX + 128u)

/* The uplink's I/O on a C thread (USB: a transfer descriptor, one write per OUT transfer and one
 * read per IN transfer, as CharDeviceTransport; RS232: a serial port's descriptor, one write per
 * request frame, as RS232Manager's writer). The settings are written before the thread starts,
 * `stop` by Python and read by the thread; the fields marked below are guarded by the core's lock
 * (native_core_t.lock). */
typedef struct {
    pthread_t thread;
    bool running;              /* a thread was started and not joined (Python side only) */
    volatile bool stop;
    int fd;
    int wake_fd;               /* RS232: an eventfd that wakes the thread (a submission, the stop), open from
                                  the first start until the core is released; -1 before and on USB */
    urb_ns_t frame_ns;         /* USB: the frame period (0 on RS232: frames go when the window lets them) */
    char name[NATIVE_NAME_MAX];    /* the manager's name, for the lost reason of an I/O error */
    bool has_handover;
    urb_handover_t handover;   /* the port's hand-over record, covered before every write */
    bool handover_warned;
    /* USB serviced by the caller (_pump_open/_pump_service, a cyclic manager: no thread) */
    bool serviced;             /* _pump_open set the fields up; _pump_stop clears it */
    bool reading;              /* the IN stream has not ended */
    urb_ns_t next_frame;       /* the next 1-ms boundary at which a batch goes out */
    /* guarded by the core's lock */
    bool kicked;               /* Python queued something for its dispatcher: wake it */
    bool notified;             /* RS232: wake_fd was written and the thread has not taken it yet */
    bool io_ended;             /* the thread stopped on a write error (the core is lost) */
    bool reason_pending;       /* reason_text holds the whole reason of that loss for Python */
    char reason_text[NATIVE_REASON_TEXT_MAX];
} native_pump_t;

typedef struct {
    PyObject_HEAD
    urb_core_t core;
    bool ready;                /* _setup succeeded */
    native_xfer_t *free_list;
    PyObject *status_of;       /* tuple: Status member by value 0..8 */
    PyObject *flag_of;         /* dict: int -> ErrorFlag member */
    PyObject *full_reason;     /* the caller's whole lost reason (str), or NULL */
    PyObject *trace;           /* None, or a list the USB pipeline's steps are appended to */
    PyObject *completed;       /* list: transfers completed (their outcome written), not yet taken */
    pthread_mutex_t lock;      /* guards core and the pump's shared fields */
    pthread_cond_t ready_cond; /* signalled when the pump completed transfers or Python kicked */
    native_pump_t pump;
} native_core_t;

/* 1 with a RuntimeError when the core was not set up (or was cleared), else 0. */
int native_not_ready(const native_core_t *self);
/* The text of the C core's lost reason `r`: the caller's whole text when r is its cut (a new reference). */
PyObject *native_reason_text(native_core_t *self, const char *r);
/* Takes the core's lock for a method or an attribute and adopts a loss the pump found; 0, or -1 with
 * a Python error (then the lock is not held). */
int native_locked_enter(native_core_t *self);
/* The type's attributes (_native_attrs.c). */
extern PyGetSetDef native_core_getset[];

/* Takes the core's lock (waiting with the GIL released when another thread holds it). GIL held. */
void native_core_lock(native_core_t *self);
/* Releases it. */
void native_core_unlock(native_core_t *self);
/* The whole reason of a loss the pump found, given to the core object as a caller's reason would
 * be (lock and GIL held). Returns 0, or -1 with a Python error. */
int native_adopt_pump_reason(native_core_t *self);
/* Sets the caller's whole lost reason (a str): see reason_text in _native.c. */
int native_set_full_reason(native_core_t *self, PyObject *reason);

/* The pump's methods (_native_pump.c), in the core type's method table. */
PyObject *native_pump_start(native_core_t *self, PyObject *args);
PyObject *native_pump_stop(native_core_t *self, PyObject *unused);
PyObject *native_pump_wait(native_core_t *self, PyObject *arg);
PyObject *native_pump_kick(native_core_t *self, PyObject *unused);
PyObject *native_pump_running(native_core_t *self, PyObject *unused);
PyObject *native_pump_notify(native_core_t *self, PyObject *unused);
PyObject *native_pump_open(native_core_t *self, PyObject *args);
PyObject *native_pump_service(native_core_t *self, PyObject *unused);
PyObject *native_has_completed(native_core_t *self, PyObject *unused);
/* Interned attribute names: each part interns the ones it uses at module import. */
typedef struct {
    PyObject **slot;
    const char *text;
} native_name_t;
/* Interns every name of `names` whose slot is still NULL; 0, or -1 with a Python error. */
int native_intern_names(const native_name_t *names, size_t count);

/* The C transfers and their hand-back to the Python transfers (_native_xfer.c). */
/* Interns the attribute names the hand-back writes; 0, or -1 with a Python error. */
int native_xfer_intern(void);
/* A C transfer from the core object's free list (uninitialised; NULL with MemoryError), and back
 * (dropping its reference `py`). */
native_xfer_t *native_xfer_get(native_core_t *self);
void native_xfer_put(native_core_t *self, native_xfer_t *x);
/* Writes what ResponseMatcher-side `_send` sets (seq, sent_ns, due_ns, expires_ns, garbage) on the
 * Python transfer of x, just put on the wire; 0, or -1 with a Python error. */
int native_mark_sent(native_xfer_t *x, urb_ns_t due_ns, urb_ns_t expires_ns);
/* Appends (what, now, items) to the core object's trace list; 0, or -1 with a Python error. */
int native_trace_event(native_core_t *self, PyObject *what, urb_ns_t now, PyObject *items);
/* Hands every transfer the C core completed back to its Python object, keeping it in `completed`
 * until take_completed; those answered by a response also go to `answered` unless it is NULL.
 * 0, or -1 with a Python error. */
int native_collect(native_core_t *self, PyObject *answered);
/* Completes everything the core still owns (BRIDGE_LOST) and drops the references: teardown. */
void native_release_all(native_core_t *self);

/* The cycle state (_native_cycle.c): a fixed set of requests submitted at once, one completion. */
#define NATIVE_CYCLE_MAX 1024
typedef struct native_cycle native_cycle_t;
extern PyTypeObject native_cycle_type;
/* _cycle_submit(state, now, refusals), in the core type's method table (called with the lock held). */
PyObject *native_cycle_submit(native_core_t *self, PyObject *const *args, Py_ssize_t nargs);
/* _new_cycle_state(specs): a CycleState of this module's type. */
PyObject *native_new_cycle_state(native_core_t *self, PyObject *specs);
/* Writes the outcome of the completed cycle item `x` into its CycleState (the caller then returns x
 * to the free list). 1 when it was the state's last pending item, 0 if not, -1 with a Python error. */
int native_cycle_item_done(native_core_t *core, native_xfer_t *x);
/* `x` is an item of a polled cycle (no on_done: its owner collects it, the dispatcher need not wake).
 * Reads no Python object: the pump's thread calls it, with the core's lock held. */
bool native_cycle_item_polled(const native_xfer_t *x);

/* Stops and joins the pump's thread if one runs (GIL held; the thread never needs it). */
void native_pump_join(native_core_t *self);

/* What both pumps' threads use (_native_pump.c; no GIL). CLOCK_MONOTONIC (time.monotonic_ns). */
urb_ns_t native_monotonic_ns(void);
/* After a step of the core (lock held): wakes the dispatcher when the step completed transfers, or
 * when a draining close has nothing left to wait for (what BusManager._drain waits for). */
void native_pump_wake_dispatcher(native_core_t *self);
/* The thread put x in flight in ring slot head + k (lock held): what it sent (seq, sending time, the
 * slot's deadline and lifetime) is written to the Python transfer when it is handed back. */
void native_pump_note_sent(native_core_t *self, native_xfer_t *x, unsigned k);
/* Before a write: the port's hand-over record covers `until` (the latest lifetime in flight; no
 * effect without a record or for URB_NEVER/URB_NO_TIME); a failure to write it is said once. */
void native_pump_cover(native_pump_t *p, urb_ns_t until, urb_ns_t now);
/* The thread's uplink failed: the core is lost with the reason "<name>: <format...>" (printf-style),
 * which Python adopts whole; the dispatcher wakes. Takes the lock. */
void native_pump_lost(native_core_t *self, const char *format, ...) __attribute__((format(printf, 2, 3)));
/* The RS232 pump's thread (_native_pump_rs232.c), started by native_pump_start on an RS232 core. */
void *native_rs232_pump_main(void *arg);

#endif /* URB_NATIVE_H */
