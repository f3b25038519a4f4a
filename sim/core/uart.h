/*
 * uart.h: one direction of an asynchronous serial line (8N1), byte-timed.
 *
 * A full-duplex RS232 link is two urbsim_uart_line_t, one per direction. The sender queues bytes;
 * the line shifts them out back to back, each taking 10 bit times (start, 8 data, stop) of the
 * SENDER's bit clock:
 *
 *   bit time = 1 / baud_actual, stretched by the sender clock's frequency error,
 *   baud_actual = divider_hz / (16 * round(divider_hz / (16 * baud)))   (16x oversampling UART;
 *                 divider_hz = 0 means an exact baud, e.g. a PC's 1.8432 MHz UART crystal).
 *
 * The receiver's "byte received" instant is the middle of the stop bit (start + 9.5 bit times),
 * when real UARTs set RXNE; the line is free for the next start bit at start + 10 bit times. The
 * receiver's own interrupt latency is added by whoever consumes the callback (a HAL).
 *
 * Faults (all draws from the line's own random stream):
 *   bit errors at rate `ber` per bit on the wire (start and stop bits included): a flipped data
 *     bit corrupts the byte; a flipped start or stop bit is a framing error: the byte is delivered
 *     with URBSIM_UART_FRAMING set and random contents (what a receiver that lost bit sync sees);
 *   byte loss at probability `loss` per byte: the byte never reaches the receiver (overrun).
 */
#ifndef URBSIM_UART_H
#define URBSIM_UART_H

#include <stdbool.h>
#include <stdint.h>

#include "clock.h"
#include "kernel.h"
#include "rng.h"
#include "trace.h"

#define URBSIM_UART_QUEUE 4096u /**< bytes the sender may queue (power of two) */
#define URBSIM_UART_FRAMING 1u  /**< rx flag: framing error (start or stop bit corrupted) */
#define URBSIM_UART_CORRUPT 2u  /**< rx flag, for traces only: a data bit was flipped (the receiver
                                     cannot know this; HALs must not look at it) */

/** Receiver callback: one byte at the middle of its stop bit. */
typedef void (*urbsim_uart_rx_fn)(void *ctx, uint8_t byte, uint32_t flags, urbsim_ns_t t);
/** Sender callback, "transmit data register empty": the last queued byte moved into the shift
 *  register and started on the wire, so the sender may queue the next one now and it will follow
 *  back to back (as a UART's TXE interrupt allows). */
typedef void (*urbsim_uart_txe_fn)(void *ctx, urbsim_ns_t t);

typedef struct {
    urbsim_kernel_t *k;
    urbsim_trace_t *tr;
    char name[32];
    double baud;               /**< nominal */
    double divider_hz;         /**< clock of the baud divider, 0 = exact */
    urbsim_clock_t *tx_clock;  /**< sender's clock (bit timing), NULL = ideal */
    urbsim_uart_rx_fn rx;
    void *rx_ctx;
    urbsim_uart_txe_fn on_txe;
    void *txe_ctx;
    uint8_t q[URBSIM_UART_QUEUE];
    uint32_t q_head, q_len;
    bool shifting;             /**< a byte is on the wire */
    uint64_t gen;              /**< bumped by urbsim_uart_flush: stale events are ignored */
    /* faults */
    double ber, loss;
    urbsim_rng_t rng;
    uint64_t bits_to_error;    /**< bits until the next flipped bit (geometric) */
    /* statistics */
    uint64_t sent, delivered, corrupted, framing, lost, dropped_full;
} urbsim_uart_line_t;

/** Set up an idle line. `rng` is the line's own fault stream (copied). */
void urbsim_uart_init(urbsim_uart_line_t *u, urbsim_kernel_t *k, urbsim_trace_t *tr, const char *name,
                      double baud, double divider_hz, urbsim_clock_t *tx_clock, const urbsim_rng_t *rng);

/** Actual baud rate after divider quantization (before the sender's clock error). */
double urbsim_uart_baud_actual(const urbsim_uart_line_t *u);

/** Nominal duration of one 10-bit character in ns (no clock error), rounded to nearest. */
urbsim_ns_t urbsim_uart_char_ns(const urbsim_uart_line_t *u);

/** Queue bytes for transmission; they start as soon as the line is free. Returns the number
 *  queued (fewer than n when the queue is full; the rest count as dropped_full). */
uint32_t urbsim_uart_send(urbsim_uart_line_t *u, const uint8_t *data, uint32_t n);

/** Bytes queued or on the wire. */
uint32_t urbsim_uart_pending(const urbsim_uart_line_t *u);

/** Discard the queue and the byte on the wire (sender reset or power loss). */
void urbsim_uart_flush(urbsim_uart_line_t *u);

/** Set fault rates (bit error rate per wire bit, byte loss probability). */
void urbsim_uart_set_faults(urbsim_uart_line_t *u, double ber, double loss);

#endif /* URBSIM_UART_H */
