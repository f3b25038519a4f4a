/*
 * urb_port.h: the Linux side of the uplinks: a serial port opened for URB (RS232), the USB
 * bridge's transfer device, and the port hand-over record shared with the Python library.
 * These functions make system calls; the protocol itself is urb_host_core.h. Every failure comes
 * with a one-paragraph message saying what happened and what to do (the Python library's words,
 * host/urb/managers/rs232.py port_error_message, usb.py CharDeviceTransport).
 *
 * Serial port settings (urb_serial_open), and what each buys:
 *   - O_NOCTTY: the port never becomes the process's controlling terminal (a bridge's bytes can
 *     not raise SIGINT/SIGHUP in the application);
 *   - O_NONBLOCK, then poll/epoll: reads return what is there at once; the event loop wakes on the
 *     first byte of a response, never on a byte count or a timer of the driver;
 *   - flock(LOCK_EX | LOCK_NB): one process per port, the lock pyserial's exclusive=True takes, so
 *     the C and Python libraries keep each other out (TIOCEXCL is not used: on a pseudo-terminal
 *     it outlives the process that set it while the bridge holds the master side);
 *   - raw mode (cfmakeraw: no echo, no line editing, no CR/LF translation, no signal characters,
 *     8 data bits), CLOCAL | CREAD, no parity, one stop bit (8N1), no hardware or software flow
 *     control: every byte is URB data, XON/XOFF values included;
 *   - VMIN = 1, VTIME = 0: a blocking read would return at the first byte (VTIME counts in 0.1 s
 *     and only adds latency); with O_NONBLOCK and poll they do not delay anything either way;
 *   - ASYNC_LOW_LATENCY through TIOCGSERIAL/TIOCSSERIAL where the driver has it: the 8250 UART
 *     driver hands received bytes to the line discipline at once instead of through a work
 *     queue, and FTDI USB adapters drop their latency timer from 16 ms to 1 ms, the difference
 *     between a 12-byte response arriving in ~1 ms and in ~16 ms. Drivers without it (a
 *     pseudo-terminal, many USB adapters) refuse the ioctl; that is not an error (urb_serial_open reports
 *     which);
 *   - tcflush(TCIFLUSH): bytes received before the open (a previous user's) are dropped.
 * Write each request frame with one write(): its bytes then leave back to back, which the bridge's
 * idle-gap rule needs (spec/schema/README.md, "RS232 resynchronisation").
 */
#ifndef URB_PORT_H
#define URB_PORT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_host_base.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * Opens `path` as a URB RS232 uplink at `baud` (a standard rate: 1200 .. 4000000) with the
 * settings above; *fd_out gets the descriptor (non-blocking, close-on-exec), which the caller
 * closes with urb_serial_close(); *low_latency (may be NULL) whether the driver took
 * ASYNC_LOW_LATENCY (false on a pseudo-terminal). Returns URB_HOST_OK; URB_HOST_EINVAL for NULL path/fd_out or a
 * baud rate Linux has no constant for; URB_HOST_EIO when the port cannot be used: err (if not
 * NULL) then says why and what to do (no such port, a directory, not a serial port, permission
 * denied, in use by another program). One open, one flock, two tcsetattr-family calls and up to
 * two ioctls; no memory.
 */
int32_t urb_serial_open(const char *path, uint32_t baud, int *fd_out, bool *low_latency, char *err,
                        size_t err_size);

/** Closes a port opened by urb_serial_open (the lock goes with it). Negative fd: nothing. */
void urb_serial_close(int fd);

/**
 * Opens the USB bridge's transfer device `path` (a kernel driver's character device: one write()
 * is one bulk-OUT transfer, one read() returns one bulk-IN transfer), read-write, non-blocking,
 * close-on-exec, locked with flock for this process (as the Python library locks it). Any
 * descriptor that keeps transfer boundaries works the same (a SOCK_SEQPACKET socket: pass it to
 * urb_loop_add_usb_fd instead). Returns URB_HOST_OK, URB_HOST_EINVAL for NULL arguments, or
 * URB_HOST_EIO with err saying what to do (driver not loaded, permissions, in use).
 */
int32_t urb_usbdev_open(const char *path, int *fd_out, char *err, size_t err_size);

/* ===== Port hand-over between processes (host/urb/managers/handover.py) ===================== */

/** How far beyond the newest request's lifetime the record is written while requests go out. */
#define URB_HANDOVER_AHEAD_NS URB_NS_PER_S
/** The longest a record makes the next process wait (a record further ahead is cut to this). */
#define URB_HANDOVER_MAX_WAIT_NS (10LL * URB_HANDOVER_AHEAD_NS)
#ifndef URB_PATH_MAX
#define URB_PATH_MAX 4096u
#endif

/**
 * The record of one port, for the process that has it open: a file `<port's absolute path, '/'
 * as '_'>.handover` in $URB_STATE_DIR, else $XDG_RUNTIME_DIR/urb, else $TMPDIR (or /tmp)/urb-<uid>,
 * holding until when (wall-clock ns, decimal, then a newline) responses to this process's requests
 * may still arrive. The same file and format as the Python library's PortHandover, so a C process
 * and a Python process hand a port over to each other. The record is advisory (same user, this
 * version of either library).
 */
typedef struct {
    char path[URB_PATH_MAX];  /**< The record file */
    bool written;             /**< The record says written_ns (monotonic) */
    urb_ns_t written_ns;
    bool warned;              /**< A write failed once (error says why); later failures are silent */
    char error[URB_PATH_MAX + 200u]; /**< The first failure, as the Python library words it */
} urb_handover_t;

/**
 * The record's path for `port` (`directory` NULL: the state directory from the environment).
 * Returns URB_HOST_OK, URB_HOST_EINVAL for NULL h/port, URB_HOST_ENOSPC for a path too long.
 * Reads the environment and getcwd (for a relative port); writes nothing.
 */
int32_t urb_handover_init(urb_handover_t *h, const char *port, const char *directory);

/**
 * When the previous process's responses are over, on the monotonic clock (now_ns is its current
 * value): URB_NO_TIME when there is no record (the previous process closed with a drain, or none
 * had the port); the record's instant, at most now + URB_HANDOVER_MAX_WAIT_NS; an unreadable
 * record counts as one written just now with the default lifetime (now + URB_PLACEHOLDER_NS).
 * Reads the file and the wall clock.
 */
urb_ns_t urb_handover_predecessor_until(const urb_handover_t *h, urb_ns_t now_ns);

/**
 * Responses to this process's requests may come until until_ns (monotonic): makes sure the record
 * says so, written ahead by URB_HANDOVER_AHEAD_NS (so at most about once a second). Call it before
 * a request is written (urb_core_busy_until() after urb_core_next_frame / _frame_out). Returns
 * URB_HOST_OK, or URB_HOST_EIO when the record cannot be written (h->error, once; the uplink works
 * without it).
 */
int32_t urb_handover_cover(urb_handover_t *h, urb_ns_t until_ns, urb_ns_t now_ns);

/**
 * At close: the exact instant the responses are over (URB_NO_TIME or an instant <= now: nothing
 * left in flight, the record is removed). Returns URB_HOST_OK or URB_HOST_EIO (h->error).
 */
int32_t urb_handover_settle(urb_handover_t *h, urb_ns_t until_ns, urb_ns_t now_ns);

/** The monotonic clock (CLOCK_MONOTONIC) in ns: the clock every port function and urb_loop use. */
urb_ns_t urb_now_ns(void);

/** Sleeps until `when` on urb_now_ns()'s clock (clock_nanosleep with TIMER_ABSTIME: a period kept
 *  this way does not drift), sleeping on after a signal; returns at once when `when` has passed. The
 *  wait of a cyclic program between its calls of urb_loop_service (urb_loop.h). */
void urb_sleep_until(urb_ns_t when);

#ifdef __cplusplus
}
#endif

#endif /* URB_PORT_H */
