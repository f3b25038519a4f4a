/*
 * urb_loop.h: the real-time runtime for Linux: bridges on serial ports and USB devices, discovery,
 * the system table, and an event loop you embed in your own (one file descriptor to poll and the
 * next deadline) or run on a thread of its own. It drives the sans-IO cores of urb_host_core.h
 * with the monotonic clock and the descriptors of urb_port.h, as the Python library's
 * RS232Manager / USBManager / URBInterface do (host/urb/README.md), with the same rules: every
 * submitted request ends in exactly one callback; a failure is a flag, never an exception; no
 * retransmission.
 *
 * Embedding (one thread does everything; callbacks run inside urb_loop_run_once):
 *
 *     urb_loop_t *loop = ...;                       // caller-owned, ~0.4 MiB: static or heap
 *     urb_loop_init(loop, NULL);
 *     urb_manager_t *m;  char err[512];
 *     if (urb_loop_add_rs232(loop, "/dev/ttyS0", 115200, NULL, &m, err, sizeof err) != URB_HOST_OK) fail(err);
 *     if (urb_loop_discover(loop, m, true, 3 * URB_NS_PER_S, err, sizeof err) != URB_HOST_OK) fail(err);
 *     urb_node_t motor;
 *     if (urb_loop_find_node(loop, URB_NODE_MOTOR_DRIVER_CLASS, 0, &motor, err, sizeof err) != URB_HOST_OK) fail(err);
 *     ...
 *     for (;;) {                                     // a control loop at 1 kHz, nothing else to wait on
 *         urb_ns_t now = urb_now_ns();
 *         urb_loop_run_once(loop, next_tick > now ? next_tick - now : 0);  // input, deadlines, callbacks
 *         if (urb_now_ns() >= next_tick) { control(); next_tick += URB_NS_PER_MS; }
 *     }
 * urb_loop_run_once(loop, timeout) waits itself (epoll_pwait2, the timeout in ns) until input, the
 * loop's next deadline or the timeout: one system call per wake-up. A program with descriptors of
 * its own polls the loop's descriptor with them instead, and then calls urb_loop_run_once with 0:
 *     struct pollfd p = {urb_loop_fd(loop), POLLIN, 0};
 *     for (;;) {                                     // your loop: add your own descriptors
 *         urb_ns_t wait = urb_loop_next_deadline(loop) - urb_now_ns();
 *         poll(&p, 1, wait <= 0 ? 0 : (int)((wait + 999999) / 1000000));
 *         urb_loop_run_once(loop, 0);               // never blocks with a 0 timeout
 *     }
 * The loop's descriptor is an epoll set holding the ports, a wake-up eventfd and a timerfd. Each
 * urb_loop_run_once(loop, 0) arms the timerfd at the next deadline before it returns, and a
 * submission from any thread brings it forward when it needs an earlier wake-up, so polling
 * urb_loop_fd() alone (with no timeout) is enough: it becomes readable when a byte arrives, when
 * a deadline is due (a timeout, a USB frame), and when another thread's submission needs the loop.
 * After urb_loop_run_once with a timeout, the loop counts on being called again and leaves the
 * timerfd alone (a program that switches to polling calls urb_loop_run_once(loop, 0) first). On
 * Linux before 5.11 (no epoll_pwait2) the timeouts count in ms, rounded up; the timerfd still wakes
 * the loop at its own deadlines.
 *
 * A cyclic control program (a fixed period, e.g. 1 kHz: the pattern of an EtherCAT master such as
 * SOEM: send, then at the next tick receive everything that came) wakes once per period and
 * services the loop there, without waiting in it:
 *     urb_ns_t next_tick = (urb_now_ns() / URB_NS_PER_MS + 1) * URB_NS_PER_MS;  // on the USB frame grid
 *     for (;;) {
 *         urb_sleep_until(next_tick);    // the program's only wait: one wake-up per period
 *         urb_loop_service(loop);        // what came during the period, deadlines, frames, callbacks
 *         control(); submit...;          // RS232 frames go out now, USB ones at the next boundary
 *         next_tick += URB_NS_PER_MS;
 *     }
 * urb_loop_service never waits: a response that arrives during the period is not a wake-up (with
 * urb_loop_run_once every USB IN transfer and RS232 response is one; measured for the SensoRHex load
 * in bench/README.md: 2.4 wake-ups per ms against 1). The price is latency: a callback runs at the
 * first service after its response arrived (up to one period later than urb_loop_run_once would
 * run it), a timeout or a lost bridge at the first service after its deadline (up to one period
 * late), and a USB batch goes out at the first service at or after each 1-ms boundary (one per
 * call: a period longer than 1 ms sends fewer batches). A program that only reads its responses at
 * its tick sees the same data either way: what arrives during period k is used at tick k+1 with
 * both. Chained requests (submitted from a callback) go out up to a period later, and an RS232
 * bridge's window frees only at a service (at most `window` requests per period). Keep the tick on
 * the 1-ms grid (as above): then each USB batch leaves at the tick the requests were made for.
 * Between services other threads may submit (their RS232 frames are written at once); nothing wakes
 * the program for them.
 *
 * Or on a thread of its own: urb_loop_start_thread(loop); callbacks then run on that thread, and
 * any thread may submit.
 *
 * Threads: every urb_loop_* and urb_node_* function may be called from any thread (a mutex
 * serialises them); callbacks run without the mutex held and may submit. A blocking call
 * (urb_loop_discover, urb_loop_close_manager with drain) inside a callback returns
 * URB_HOST_ESTATE: it would wait for callbacks that cannot run.
 *
 * Memory: everything is in urb_loop_t (no heap); the OS resources are 3 descriptors plus one per
 * bridge.
 */
#ifndef URB_LOOP_H
#define URB_LOOP_H

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_discovery.h"
#include "urb_host_base.h"
#include "urb_host_core.h"
#include "urb_port.h"
#include "urb_transfer.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifndef URB_LOOP_MAX_MANAGERS
#define URB_LOOP_MAX_MANAGERS 4u  /**< Bridges per loop (override with -D; ~45 KiB each) */
#endif
#ifndef URB_LOOP_SERVICE_PASSES
#define URB_LOOP_SERVICE_PASSES 4u /**< urb_loop_service: IN transfers read per USB port and call, at most */
#endif
#define URB_MANAGER_OUT 1024u     /**< RS232: bytes of frames waiting for a writable port */

typedef struct urb_loop urb_loop_t;
typedef struct urb_manager urb_manager_t;

/** Told once per loss that a manager found its bridge lost (an I/O error, silence, timeouts in a
 *  row), before the callbacks of the requests that loss fails. Not for a close. */
typedef void (*urb_lost_fn)(urb_manager_t *m, const char *reason, void *user);
/** Where the loop's warnings go (a hand-over record it cannot write). Default: stderr. */
typedef void (*urb_log_fn)(const char *text, void *user);
/** Called once when urb_loop_start_discovery finishes (outcome in d->outcome). */
typedef void (*urb_discovered_fn)(urb_manager_t *m, const urb_discovery_t *d, void *user);

/** One bridge on one uplink. Read it through the functions below. */
struct urb_manager {
    urb_loop_t *loop;
    uint8_t index;                  /**< Bridge number in the system table */
    uint8_t kind;                   /**< urb_link_kind_t */
    bool registered;
    bool open;                      /**< The descriptor is open and in the epoll set */
    bool closed;                    /**< Closed by the application: submissions complete at once */
    bool own_fd;                    /**< The loop opened the descriptor (and closes it) */
    bool use_handover;              /**< Opened by path: keeps a hand-over record */
    bool lost_noted;                /**< The current loss was reported (or must not be: a close) */
    bool discovered;                /**< A discovery succeeded: its nodes are in the system table */
    bool wake_pending;
    int fd;
    uint32_t baud;
    char path[URB_PATH_MAX];        /**< The port (the name in messages) */
    urb_core_t core;
    urb_handover_t handover;
    urb_ns_t next_frame_ns;         /**< USB: the next 1-ms frame boundary (0: not ticking) */
    size_t out_len;
    uint8_t out[URB_MANAGER_OUT];   /**< RS232: frame bytes the port did not take yet */
    urb_discovery_t discovery;
    urb_discovered_fn on_discovered;
    void *discovered_user;
    uint64_t submitted;             /**< Requests submitted (refusals included) */
    uint64_t completed;             /**< Callbacks run */
    uint64_t failed;                /**< ... with a flag */
};

/** A node found by discovery (or the bridge itself): what requests are addressed to. */
typedef struct {
    urb_loop_t *loop;
    uint32_t row;      /**< System table row (unused for the bridge) */
    uint8_t manager;   /**< Bridge number */
    bool own_layout;   /**< Mailbox sizes from the node's own identification (node_at: UNKNOWN_CLASS,
                            MISMATCH), not the schema's */
    bool bridge;       /**< The bridge itself (address 0) */
} urb_node_t;

struct urb_loop {
    pthread_mutex_t lock;
    pthread_cond_t changed;         /**< Signalled after every dispatch (blocking calls wait on it) */
    int epfd;
    int wakefd;
    int timerfd;
    urb_ns_t armed_ns;              /**< The timerfd's expiry (0: disarmed or fired) */
    urb_ns_t waiting_until;         /**< Threads wait in urb_loop_run_once until then at the
                                         latest (0: none) */
    uint32_t waiters;               /**< ... how many (a blocking call's wait may join the application's) */
    bool self_waits;                /**< Every wait is urb_loop_run_once's own (its thread, or the
                                         application's calls with a timeout): no timerfd needed */
    bool ms_waits;                  /**< No epoll_pwait2 (Linux < 5.11): waits count in ms */
    uint32_t manager_count;
    urb_manager_t managers[URB_LOOP_MAX_MANAGERS];
    urb_system_t system;
    urb_transfer_t *refused_head;   /**< Host refusals waiting for their callback */
    urb_transfer_t *refused_tail;
    urb_lost_fn on_lost;
    void *lost_user;
    urb_log_fn log;
    void *log_user;
    pthread_t thread;
    bool thread_running;
    volatile bool stop;
    bool in_dispatch;
    pthread_t dispatcher;           /**< The thread running callbacks (valid while in_dispatch) */
};

/**
 * Initialises `loop` for the node types of `schema` (NULL: urb_schema_default()). Creates the
 * epoll set, an eventfd and a timerfd. Returns URB_HOST_OK, URB_HOST_EINVAL for loop == NULL,
 * URB_HOST_EIO when the kernel refuses a descriptor (nothing is left open). O(size of the loop).
 */
int32_t urb_loop_init(urb_loop_t *loop, const urb_schema_t *schema);

/**
 * Stops the loop's thread, closes every manager without draining (requests complete
 * BRIDGE_LOST "closed by the application", their callbacks run here) and closes the descriptors.
 * The loop may be initialised again afterwards. Nothing happens for NULL.
 */
void urb_loop_destroy(urb_loop_t *loop);

/**
 * Opens the serial port `path` at `baud` (urb_serial_open) for a bridge on RS232 with the core
 * settings `cfg` (NULL: the defaults) and registers it; *out (may be NULL) gets the manager. If
 * a previous process left a hand-over record for the port, nothing is sent before its instant.
 * Returns URB_HOST_OK; URB_HOST_EINVAL for NULL loop/path or a bad cfg; URB_HOST_ENOSPC when
 * URB_LOOP_MAX_MANAGERS are registered; URB_HOST_EIO with err saying why and what to do.
 */
int32_t urb_loop_add_rs232(urb_loop_t *loop, const char *path, uint32_t baud, const urb_core_config_t *cfg,
                           urb_manager_t **out, char *err, size_t err_size);

/** The same for the USB bridge's transfer device `path` (urb_usbdev_open). */
int32_t urb_loop_add_usb(urb_loop_t *loop, const char *path, const urb_core_config_t *cfg, urb_manager_t **out,
                         char *err, size_t err_size);

/**
 * A USB bridge behind a descriptor the caller opened and keeps owning (it stays open after the
 * manager is closed), e.g. one end of a SOCK_SEQPACKET socketpair: every write() is one OUT
 * transfer, every read() one IN transfer. It must be non-blocking. `name` names it in messages.
 * No hand-over record. Errors as urb_loop_add_usb (URB_HOST_EINVAL for fd < 0 or name NULL).
 */
int32_t urb_loop_add_usb_fd(urb_loop_t *loop, int fd, const char *name, const urb_core_config_t *cfg,
                            urb_manager_t **out);

/**
 * Discovers the bridge of `m` and merges its nodes into the system table (add_bus_manager), waiting
 * up to timeout_ns: runs the loop itself, or waits for the loop's thread. Returns URB_HOST_OK;
 * URB_HOST_EINVAL for NULL arguments; URB_HOST_ESTATE inside a callback or while m is closed or
 * discovering; URB_HOST_ENOTFOUND when no bridge answered or its scan map could not be read, and
 * URB_HOST_EIO when it did not finish in time: err then says why and what to check. Blocking.
 */
int32_t urb_loop_discover(urb_loop_t *loop, urb_manager_t *m, bool rescan, urb_ns_t timeout_ns, char *err,
                          size_t err_size);

/**
 * Starts discovering `m` without waiting (start_discovery): `on_done(m, d, user)` runs once, on
 * the dispatching thread, after the nodes were merged into the system table (if it succeeded).
 * Returns URB_HOST_OK, URB_HOST_EINVAL, or URB_HOST_ESTATE while one is running or m is closed.
 */
int32_t urb_loop_start_discovery(urb_loop_t *loop, urb_manager_t *m, bool rescan, urb_discovered_fn on_done,
                                 void *user);

/**
 * Submits a transfer to bridge `m` as it is (its address and mailbox taken as given; urb_node_submit
 * checks them against the node first). Its callback runs exactly once, on the dispatching thread;
 * for a closed manager it completes BRIDGE_LOST at once and its callback runs inside this call.
 * RS232 frames are written from the calling thread when the window allows (lowest latency).
 * Returns URB_HOST_OK, or the errors of urb_core_submit (then no callback comes). O(w).
 */
int32_t urb_loop_submit(urb_loop_t *loop, urb_manager_t *m, urb_transfer_t *t);

/** The node of class `class_id` and `index` (find_node). Returns URB_HOST_OK, or URB_HOST_ENOTFOUND
 *  with err saying why (not discovered, duplicate, built from another schema, unknown class). */
int32_t urb_loop_find_node(urb_loop_t *loop, uint8_t class_id, uint8_t index, urb_node_t *out, char *err,
                           size_t err_size);

/** The node that answered at `address` of bridge `m`, whatever its flags (node_at); address 0 is
 *  the bridge. URB_HOST_OK or URB_HOST_ENOTFOUND. */
int32_t urb_loop_node_at(urb_loop_t *loop, urb_manager_t *m, uint8_t address, urb_node_t *out);

/**
 * Submits `t` (built with urb_transfer_read/_write; its address is replaced by the node's) to
 * the node. The host refuses, without sending anything, a request to a node no longer discovered
 * (URB_FLAG_UNKNOWN_NODE), built from another schema (URB_FLAG_FINGERPRINT_MISMATCH) or to a
 * mailbox the layout does not have or of another size (URB_FLAG_HOST_SIZE_MISMATCH): the callback
 * then runs with that flag at the next dispatch, like any completion. Returns as urb_loop_submit.
 */
int32_t urb_node_submit(const urb_node_t *node, urb_transfer_t *t);

/** The size of mailbox `mailbox` of the node's layout (0: none); for building requests. */
uint8_t urb_node_mailbox_size(const urb_node_t *node, bool outbox, uint8_t mailbox);

/** The node's system-table row (NULL for the bridge or an invalid node). */
const urb_node_row_t *urb_node_row(const urb_node_t *node);

/** The loop's descriptor: poll it for POLLIN, then call urb_loop_run_once(loop, 0). -1 for NULL. */
int urb_loop_fd(const urb_loop_t *loop);

/** When urb_loop_run_once next has something to do without input (a timeout, a USB frame, a
 *  refusal to call back: then now), on urb_now_ns()'s clock; URB_NEVER when nothing is pending. */
urb_ns_t urb_loop_next_deadline(urb_loop_t *loop);

/**
 * Waits up to timeout_ns (0: not at all; negative: until something happens) for input or the next
 * deadline, then does everything due: reads the ports, feeds the cores, applies timeouts and the
 * lost-bridge rules, writes frames (a USB batch at each 1-ms boundary), and runs the callbacks
 * (the lost listener first). A USB port is read once per readiness (one IN transfer) and an RS232
 * port until a read returns less than asked; what is still queued is read at the next call. With
 * timeout_ns 0 it also arms the loop's timer for a program polling urb_loop_fd() (see above).
 * Returns the number of callbacks run, URB_HOST_EINVAL for NULL, URB_HOST_ESTATE when the loop's
 * thread runs (only it may call this) or inside a callback.
 */
int32_t urb_loop_run_once(urb_loop_t *loop, urb_ns_t timeout_ns);

/**
 * Services the loop once without waiting (a cyclic program's call, once per period: see the top of
 * this file for the pattern and its latency): reads everything the ports have queued (asking the
 * kernel again while a USB port gave an IN transfer, at most URB_LOOP_SERVICE_PASSES times, so that
 * no transfer waits behind another), then does what urb_loop_run_once does after its wait: feeds
 * the cores, applies timeouts and the lost-bridge rules, writes what is due (a USB batch once the
 * frame boundary is reached) and runs the callbacks (the lost listener first). Every submitted
 * request still ends in exactly one callback. It arms no timer: the program's own period wakes it.
 * Returns the number of callbacks run, URB_HOST_EINVAL for NULL, URB_HOST_ESTATE when the loop's
 * thread runs or inside a callback. O(ready descriptors + requests due).
 */
int32_t urb_loop_service(urb_loop_t *loop);

/** Runs the loop on a new thread (callbacks run there) until urb_loop_stop_thread. Returns
 *  URB_HOST_OK, URB_HOST_ESTATE when already running, URB_HOST_EIO when no thread could be made. */
int32_t urb_loop_start_thread(urb_loop_t *loop);

/** Stops and joins the loop's thread (not from inside a callback: URB_HOST_ESTATE). */
int32_t urb_loop_stop_thread(urb_loop_t *loop);

/**
 * Closes manager `m` (BusManager.close): with `drain`, first waits (running the loop) until the
 * requests in flight are answered or their lifetime is over, so that their late responses cannot
 * reach the next process to open the bridge; then everything still pending completes BRIDGE_LOST
 * ("closed by the application"), the hand-over record says until when responses may still come
 * (removed after a drain), and the descriptor is closed. Later submissions complete at once.
 * Returns URB_HOST_OK, URB_HOST_EINVAL, or URB_HOST_ESTATE for a draining close inside a callback.
 */
int32_t urb_loop_close_manager(urb_loop_t *loop, urb_manager_t *m, bool drain);

/**
 * After a loss: reopens the uplink (same path) and resets the protocol (placeholders kept), then
 * rediscovers with urb_loop_discover. When the port cannot be opened, returns URB_HOST_EIO with
 * err, and the manager stays lost ("reconnect failed: ..."); call it again later. USB managers
 * on a caller's descriptor: URB_HOST_ESTATE (reopen it yourself and add a new manager).
 */
int32_t urb_loop_reconnect(urb_loop_t *loop, urb_manager_t *m, char *err, size_t err_size);

/** Sets the lost listener (NULL: none). */
void urb_loop_set_lost_callback(urb_loop_t *loop, urb_lost_fn fn, void *user);
/** Sets where warnings go (NULL: stderr). */
void urb_loop_set_log(urb_loop_t *loop, urb_log_fn fn, void *user);

/** Why the bridge of m is lost, or NULL while usable. The text stays valid until the next call on
 *  the loop from another thread; copy it if you keep it. */
const char *urb_manager_lost_reason(urb_manager_t *m);
/** The port path or name of m. */
const char *urb_manager_name(const urb_manager_t *m);

#ifdef __cplusplus
}
#endif

#endif /* URB_LOOP_H */
