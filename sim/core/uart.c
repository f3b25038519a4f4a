/* uart.c: byte-timed 8N1 serial line with bit errors and byte loss. See uart.h. */
#include "uart.h"

#include <math.h>
#include <string.h>

void urbsim_uart_init(urbsim_uart_line_t *u, urbsim_kernel_t *k, urbsim_trace_t *tr, const char *name,
                      double baud, double divider_hz, urbsim_clock_t *tx_clock, const urbsim_rng_t *rng)
{
    memset(u, 0, sizeof *u);
    u->k = k;
    u->tr = tr;
    strncpy(u->name, name, sizeof u->name - 1u);
    u->baud = baud;
    u->divider_hz = divider_hz;
    u->tx_clock = tx_clock;
    u->rng = *rng;
    u->bits_to_error = UINT64_MAX;
}

double urbsim_uart_baud_actual(const urbsim_uart_line_t *u)
{
    if (u->divider_hz <= 0.0) {
        return u->baud;
    }
    double div = floor(u->divider_hz / (16.0 * u->baud) + 0.5);
    if (div < 1.0) {
        div = 1.0;
    }
    return u->divider_hz / (16.0 * div);
}

urbsim_ns_t urbsim_uart_char_ns(const urbsim_uart_line_t *u)
{
    return (urbsim_ns_t)llround(10.0 * 1e9 / urbsim_uart_baud_actual(u));
}

void urbsim_uart_set_faults(urbsim_uart_line_t *u, double ber, double loss)
{
    u->ber = ber;
    u->loss = loss;
    u->bits_to_error = urbsim_rng_geometric(&u->rng, ber);
}

/* Duration of `bits` bit times starting at t, in the sender's clock. */
static urbsim_ns_t bits_ns(urbsim_uart_line_t *u, urbsim_ns_t t, double bits)
{
    double nominal = bits * 1e9 / urbsim_uart_baud_actual(u);
    if (u->tx_clock == NULL) {
        return (urbsim_ns_t)llround(nominal);
    }
    /* A fast sender clock shortens its bits: divide by the clock's rate. */
    double rate = 1.0 + urbsim_clock_error_ppm(u->tx_clock, t) * 1e-6;
    return (urbsim_ns_t)llround(nominal / rate);
}

static void start_next(urbsim_uart_line_t *u, urbsim_ns_t now);

/* Event arg layout: generation in the high 55 bits, phase in bit 8, the byte in bits 0..7. */
#define ARG(gen, phase, byte) (((gen) << 9) | ((uint64_t)(phase) << 8) | (uint64_t)(byte))

/* Middle of the stop bit: the receiver sees the byte (after faults). */
static void ev_received(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    urbsim_uart_line_t *u = ctx;
    if ((arg >> 9) != (u->gen & 0x7FFFFFFFFFFFFFull)) {
        return;
    }
    uint8_t byte = (uint8_t)(arg & 0xFFu);
    uint32_t flags = 0;
    /* Bit errors: walk the geometric skip counter over the 10 wire bits of this character. */
    uint64_t bits = 10;
    while (u->bits_to_error <= bits) {
        uint64_t pos = 10u - bits + u->bits_to_error - 1u; /* 0 = start bit, 1..8 data, 9 stop */
        bits -= u->bits_to_error;
        if (pos == 0u || pos == 9u) {
            flags |= URBSIM_UART_FRAMING;
        } else {
            byte ^= (uint8_t)(1u << (pos - 1u));
            flags |= URBSIM_UART_CORRUPT;
        }
        u->bits_to_error = urbsim_rng_geometric(&u->rng, u->ber);
    }
    if (u->bits_to_error != UINT64_MAX) {
        u->bits_to_error -= bits;
    }
    if (flags & URBSIM_UART_FRAMING) {
        byte = (uint8_t)urbsim_rng_u64(&u->rng);
        u->framing++;
    } else if (flags & URBSIM_UART_CORRUPT) {
        u->corrupted++;
    }
    if (u->loss > 0.0 && urbsim_rng_uniform(&u->rng) < u->loss) {
        u->lost++;
        urbsim_trace(u->tr, URBSIM_TR_FAULT, now, u->name, "byte_lost", ",\"byte\":%u", (unsigned)(arg & 0xFFu));
        return;
    }
    if (flags) {
        urbsim_trace(u->tr, URBSIM_TR_FAULT, now, u->name, "byte_corrupt", ",\"sent\":%u,\"got\":%u,\"framing\":%u",
                     (unsigned)(arg & 0xFFu), byte, (flags & URBSIM_UART_FRAMING) ? 1u : 0u);
    }
    if (urbsim_trace_on(u->tr, URBSIM_TR_BUS)) { /* per byte: skip the variadic call when off */
        urbsim_trace(u->tr, URBSIM_TR_BUS, now, u->name, "rx", ",\"byte\":%u", byte);
    }
    u->delivered++;
    if (u->rx) {
        u->rx(u->rx_ctx, byte, flags & URBSIM_UART_FRAMING, now);
    }
}

/* End of the stop bit: the line is free; start the next queued byte. */
static void ev_free(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    urbsim_uart_line_t *u = ctx;
    if ((arg >> 9) != (u->gen & 0x7FFFFFFFFFFFFFull)) {
        return;
    }
    u->shifting = false;
    start_next(u, now);
}

static void start_next(urbsim_uart_line_t *u, urbsim_ns_t now)
{
    if (u->shifting || u->q_len == 0u) {
        return;
    }
    uint8_t byte = u->q[u->q_head];
    u->q_head = (u->q_head + 1u) & (URBSIM_UART_QUEUE - 1u);
    u->q_len--;
    u->shifting = true;
    u->sent++;
    uint64_t g = u->gen & 0x7FFFFFFFFFFFFFull;
    if (urbsim_trace_on(u->tr, URBSIM_TR_BUS)) {
        urbsim_trace(u->tr, URBSIM_TR_BUS, now, u->name, "tx", ",\"byte\":%u", byte);
    }
    urbsim_kernel_at(u->k, now + bits_ns(u, now, 9.5), ev_received, u, ARG(g, 0, byte));
    urbsim_kernel_at(u->k, now + bits_ns(u, now, 10.0), ev_free, u, ARG(g, 1, 0));
    if (u->q_len == 0u && u->on_txe) {
        u->on_txe(u->txe_ctx, now);
    }
}

uint32_t urbsim_uart_send(urbsim_uart_line_t *u, const uint8_t *data, uint32_t n)
{
    uint32_t done = 0;
    for (; done < n && u->q_len < URBSIM_UART_QUEUE; done++) {
        u->q[(u->q_head + u->q_len) & (URBSIM_UART_QUEUE - 1u)] = data[done];
        u->q_len++;
    }
    u->dropped_full += n - done;
    start_next(u, u->k->now);
    return done;
}

uint32_t urbsim_uart_pending(const urbsim_uart_line_t *u)
{
    return u->q_len + (u->shifting ? 1u : 0u);
}

void urbsim_uart_flush(urbsim_uart_line_t *u)
{
    u->q_len = 0;
    u->shifting = false;
    u->gen++;
}
