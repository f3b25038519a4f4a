/* i2c.c: byte-timed I2C bus with clock stretching, general call and line faults. See i2c.h.
 * The per-byte trace calls test their category first: urbsim_trace is variadic, so it is never
 * inlined, and a call per byte costs more than the byte's bookkeeping when tracing is off. */
#include "i2c.h"

#include <math.h>
#include <string.h>

/* Event kinds (arg bits 8..15). */
enum { EV_ADDR, EV_RX, EV_TX, EV_TX_NACK, EV_STOP, EV_RSTART, EV_DONE };
/* Operations in flight (op_kind). */
enum { OP_START, OP_WRITE, OP_READ, OP_ERROR };

#define SLAVE_ARG(idx, kind, gen) ((uint64_t)(idx) | ((uint64_t)(kind) << 8) | ((gen) << 16))
#define DONE_ARG(gen) (((uint64_t)EV_DONE << 8) | ((gen) << 16))
#define ARG_GEN(arg) ((arg) >> 16)
#define GEN_MASK 0xFFFFFFFFFFFFull

void urbsim_i2c_init(urbsim_i2c_bus_t *b, urbsim_kernel_t *k, urbsim_trace_t *tr, const char *name,
                     double bitrate, const urbsim_rng_t *rng)
{
    memset(b, 0, sizeof *b);
    b->k = k;
    b->tr = tr;
    strncpy(b->name, name, sizeof b->name - 1u);
    b->bitrate = bitrate;
    b->t_bit = (urbsim_ns_t)llround(1e9 / bitrate);
    b->t_start = b->t_bit;
    b->t_rstart = (b->t_bit * 3u) / 2u;
    b->t_stop = b->t_bit;
    /* Bus free time between a STOP and a START, UM10204 Table 10: 4.7 us in Standard-mode (up to
     * 100 kb/s), 1.3 us in Fast-mode (400 kb/s), 0.5 us in Fast-mode Plus (1 Mb/s). */
    b->t_buf = bitrate <= 100e3 ? 4700u : bitrate <= 400e3 ? 1300u : 500u;
    b->op_kind = -1;
    b->sda_until = b->scl_until = 0;
    b->drive = URBSIM_I2C_SCL | URBSIM_I2C_SDA;
    b->rng = *rng;
    b->bits_to_error = UINT64_MAX;
}

urbsim_ns_t urbsim_i2c_byte_ns(const urbsim_i2c_bus_t *b)
{
    return 9u * b->t_bit;
}

/* Slave idx's own threshold and filter delay, from its stream (derived from the seed and its index). */
static void draw_edges(urbsim_i2c_bus_t *b, uint32_t idx)
{
    const urbsim_i2c_edges_t *e = &b->edges;
    urbsim_rng_t *r = &b->edge_rng[idx];
    urbsim_rng_derive(r, e->seed, "i2c/edge", idx);
    double vth = e->vth_min + (e->vth_max - e->vth_min) * urbsim_rng_uniform(r);
    double filter = e->filter_min_ns + (e->filter_max_ns - e->filter_min_ns) * urbsim_rng_uniform(r);
    /* falling: linear from VDD to 0 over fall_ns, crossing vth at (1 - vth) fall_ns; rising: RC
     * from 0, crossing vth at -tau ln(1 - vth) */
    b->fall_delay_ns[idx] = (1.0 - vth) * e->fall_ns + filter;
    b->rise_delay_ns[idx] = (vth < 1.0 ? -e->rise_tau_ns * log(1.0 - vth) : 0.0) + filter;
}

void urbsim_i2c_set_edges(urbsim_i2c_bus_t *b, const urbsim_i2c_edges_t *edges)
{
    b->edges = *edges;
    b->edges_on = edges->fall_ns > 0.0 || edges->rise_tau_ns > 0.0 || edges->filter_max_ns > 0.0 ||
                  edges->sync_max_ns > 0.0;
    for (uint32_t i = 0; i < b->n_slaves; i++) {
        if (b->edges_on) {
            draw_edges(b, i);
        } else {
            b->fall_delay_ns[i] = b->rise_delay_ns[i] = 0.0;
        }
    }
}

urbsim_ns_t urbsim_i2c_edge_delay(urbsim_i2c_bus_t *b, uint32_t idx, bool rising)
{
    if (!b->edges_on) {
        return 0;
    }
    const urbsim_i2c_edges_t *e = &b->edges;
    double d = rising ? b->rise_delay_ns[idx] : b->fall_delay_ns[idx];
    if (e->sync_max_ns > 0.0) {
        d += e->sync_min_ns + (e->sync_max_ns - e->sync_min_ns) * urbsim_rng_uniform(&b->edge_rng[idx]);
    }
    return (urbsim_ns_t)(int64_t)(d + 0.5);
}

bool urbsim_i2c_attach(urbsim_i2c_bus_t *b, urbsim_i2c_slave_t *s)
{
    if (b->n_slaves >= URBSIM_I2C_MAX_SLAVES) {
        return false;
    }
    if (b->edges_on) {
        draw_edges(b, b->n_slaves);
    }
    b->slaves[b->n_slaves++] = s;
    return true;
}

void urbsim_i2c_power(urbsim_i2c_bus_t *b, urbsim_i2c_slave_t *s, bool on)
{
    (void)b;
    if (s->powered && !on) {
        s->gen++;
    }
    s->powered = on;
}

void urbsim_i2c_set_ber(urbsim_i2c_bus_t *b, double ber)
{
    b->ber = ber;
    b->bits_to_error = urbsim_rng_geometric(&b->rng, ber);
}

static bool sda_stuck(const urbsim_i2c_bus_t *b, urbsim_ns_t t)
{
    return t >= b->sda_from && t < b->sda_until;
}

static bool scl_stuck(const urbsim_i2c_bus_t *b, urbsim_ns_t t)
{
    return t >= b->scl_from && t < b->scl_until;
}

void urbsim_i2c_stick_sda(urbsim_i2c_bus_t *b, urbsim_ns_t until, uint32_t pulses)
{
    b->sda_from = b->k->now;
    b->sda_until = until;
    b->sda_pulses = pulses;
    urbsim_trace(b->tr, URBSIM_TR_FAULT, b->k->now, b->name, "sda_stuck",
                 ",\"until\":%llu,\"pulses\":%u", (unsigned long long)until, pulses);
}

void urbsim_i2c_stick_scl(urbsim_i2c_bus_t *b, urbsim_ns_t until)
{
    b->scl_from = b->k->now;
    b->scl_until = until;
    urbsim_trace(b->tr, URBSIM_TR_FAULT, b->k->now, b->name, "scl_stuck", ",\"until\":%llu",
                 (unsigned long long)until);
}

/* Pass the 9 wire bits of a byte (8 data MSB first, then ACK) through the bit-error process.
 * Returns the byte as received; *ack_flip tells whether the ACK bit was inverted. */
static uint8_t wire(urbsim_i2c_bus_t *b, uint8_t byte, bool *ack_flip)
{
    *ack_flip = false;
    if (b->bits_to_error == UINT64_MAX) {
        return byte;
    }
    uint64_t bits = 9;
    while (b->bits_to_error <= bits) {
        uint64_t pos = 9u - bits + b->bits_to_error - 1u; /* 0..7 data (MSB first), 8 ACK */
        bits -= b->bits_to_error;
        if (pos < 8u) {
            byte ^= (uint8_t)(0x80u >> pos);
        } else {
            *ack_flip = !*ack_flip;
        }
        b->flipped_bits++;
        b->bits_to_error = urbsim_rng_geometric(&b->rng, b->ber);
    }
    if (b->bits_to_error != UINT64_MAX) {
        b->bits_to_error -= bits;
    }
    return byte;
}

static void ev_slave(void *ctx, uint64_t arg, urbsim_ns_t now);
static void ev_done(void *ctx, uint64_t arg, urbsim_ns_t now);
static void ev_bit8(void *ctx, uint64_t arg, urbsim_ns_t now);
static void ev_end(void *ctx, uint64_t arg, urbsim_ns_t now);

/* The earliest instant a new operation may start clocking. */
static urbsim_ns_t op_begin(const urbsim_i2c_bus_t *b)
{
    urbsim_ns_t t = b->k->now > b->ready_at ? b->k->now : b->ready_at;
    return t > b->earliest ? t : b->earliest;
}

/* Schedule the master completion of the operation in flight at t_done. */
static void schedule_done(urbsim_i2c_bus_t *b, int kind, urbsim_ns_t t0, urbsim_ns_t t_done)
{
    b->op_kind = kind;
    b->op_start = t0;
    /* SCL held low (now or later during the operation): the clock cannot advance while it is. */
    if (b->scl_until > t0 && b->scl_from <= t_done) {
        b->stalls++;
        if (b->scl_until == URBSIM_NEVER) {
            b->ready_at = URBSIM_NEVER; /* no completion, ever: the master's timeout notices */
            return;
        }
        urbsim_ns_t from = b->scl_from > t0 ? b->scl_from : t0;
        t_done += b->scl_until - from;
        b->op_start = b->scl_until;
    }
    b->ready_at = t_done;
    urbsim_kernel_at(b->k, t_done, ev_done, b, DONE_ARG(b->gen & GEN_MASK));
}

/* Raise slave idx's interrupt for `kind` at bus instant t_irq. Returns when its handler is done,
 * which is when it releases SCL. */
static urbsim_ns_t raise_irq(urbsim_i2c_bus_t *b, uint32_t idx, int kind, urbsim_ns_t t_irq)
{
    urbsim_i2c_slave_t *s = b->slaves[idx];
    t_irq += urbsim_i2c_edge_delay(b, idx, kind == EV_STOP); /* the slave sees the edge this late */
    urbsim_ns_t end = t_irq;
    urbsim_ns_t start = s->isr_window(s->ctx, t_irq, &end);
    b->hw[idx][kind] = t_irq;
    urbsim_kernel_at(b->k, start, ev_slave, b, SLAVE_ARG(idx, kind, s->gen & GEN_MASK));
    return end > t_irq ? end : t_irq;
}

static bool slave_live(const urbsim_i2c_bus_t *b, uint32_t j)
{
    const urbsim_i2c_slave_t *s = b->slaves[b->active[j]];
    return s->powered && s->gen == b->active_gen[j];
}

static void ev_slave(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    urbsim_i2c_bus_t *b = ctx;
    uint32_t idx = (uint32_t)(arg & 0xFFu);
    int kind = (int)((arg >> 8) & 0xFFu);
    urbsim_i2c_slave_t *s = b->slaves[idx];
    (void)now;
    if (!s->powered || (s->gen & GEN_MASK) != ARG_GEN(arg)) {
        return; /* lost power since the interrupt was raised */
    }
    urbsim_ns_t t_hw = b->hw[idx][kind];
    switch (kind) {
    case EV_ADDR:
        if (s->on_address(s->ctx, b->read_mode, b->general, t_hw)) {
            b->op_ack = true;
            b->active_gen[b->n_active] = s->gen;
            b->active[b->n_active++] = (uint8_t)idx;
        }
        break;
    case EV_RX:
        if (s->on_rx(s->ctx, b->op_byte, t_hw)) {
            b->op_ack = true;
        }
        break;
    case EV_TX:
        b->tx_byte &= s->on_tx(s->ctx, t_hw);
        break;
    case EV_TX_NACK:
        s->on_tx_nack(s->ctx, t_hw);
        break;
    default:
        s->on_stop(s->ctx, kind == EV_RSTART, t_hw);
        break;
    }
}

/* After an ACKed address (read) or an ACKed read byte: every active slave must load its next byte. */
static void request_tx(urbsim_i2c_bus_t *b, urbsim_ns_t t)
{
    b->tx_byte = 0xFFu; /* nobody driving SDA reads as 1s */
    b->tx_ready = t;
    for (uint32_t j = 0; j < b->n_active; j++) {
        if (slave_live(b, j)) {
            urbsim_ns_t end = raise_irq(b, b->active[j], EV_TX, t);
            if (end > b->tx_ready) {
                b->tx_ready = end;
            }
        }
    }
}

static void ev_done(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    urbsim_i2c_bus_t *b = ctx;
    if (ARG_GEN(arg) != (b->gen & GEN_MASK) || b->op_kind < 0) {
        return; /* aborted */
    }
    /* SCL was pulled low after the operation was scheduled: the operation stalls. */
    if (b->scl_from > b->op_start && b->scl_from < now && b->scl_until > b->scl_from) {
        b->stalls++;
        if (b->scl_until == URBSIM_NEVER) {
            b->ready_at = URBSIM_NEVER;
            return;
        }
        urbsim_ns_t t_done = b->scl_until + (now - b->scl_from);
        b->op_start = b->scl_until;
        b->ready_at = t_done;
        urbsim_kernel_at(b->k, t_done, ev_done, b, arg);
        return;
    }
    int kind = b->op_kind;
    b->op_kind = -1;
    switch (kind) {
    case OP_START:
        if (urbsim_trace_on(b->tr, URBSIM_TR_BUS)) {
            urbsim_trace(b->tr, URBSIM_TR_BUS, now, b->name, "start", "%s", "");
        }
        b->master(b->master_ctx, URBSIM_I2C_START, 0, now);
        break;
    case OP_WRITE: {
        bool ack = b->op_ack != b->ack_flip;
        if (sda_stuck(b, now)) {
            ack = true; /* SDA low during the ACK bit reads as ACK */
        }
        if (urbsim_trace_on(b->tr, URBSIM_TR_BUS)) {
            urbsim_trace(b->tr, URBSIM_TR_BUS, now, b->name, "w", ",\"byte\":%u,\"ack\":%u", b->op_byte, ack ? 1u : 0u);
        }
        if (b->addressing && b->read_mode && ack) {
            request_tx(b, now);
        }
        b->master(b->master_ctx, ack ? URBSIM_I2C_ACK : URBSIM_I2C_NACK, 0, now);
        break;
    }
    case OP_READ: {
        uint8_t byte = b->read_mode ? b->tx_byte : 0xFFu;
        if (sda_stuck(b, b->op_start)) {
            byte = 0x00u;
        }
        b->op_byte = wire(b, byte, &b->ack_flip);
        bool seen_ack = b->master_ack != b->ack_flip;
        if (urbsim_trace_on(b->tr, URBSIM_TR_BUS)) {
            urbsim_trace(b->tr, URBSIM_TR_BUS, now, b->name, "r", ",\"byte\":%u,\"ack\":%u", b->op_byte,
                         b->master_ack ? 1u : 0u);
        }
        if (seen_ack) {
            request_tx(b, now);
        } else {
            b->tx_byte = 0xFFu; /* the slaves saw a NACK: they release SDA until the STOP */
            for (uint32_t j = 0; j < b->n_active; j++) {
                if (slave_live(b, j)) {
                    raise_irq(b, b->active[j], EV_TX_NACK, now);
                }
            }
        }
        b->master(b->master_ctx, URBSIM_I2C_BYTE, b->op_byte, now);
        break;
    }
    default:
        urbsim_trace(b->tr, URBSIM_TR_BUS, now, b->name, "error", "%s", "");
        b->master(b->master_ctx, URBSIM_I2C_ERROR, 0, now);
        break;
    }
}

/* The slaves' part of the transaction ends at bus instant t (STOP or repeated START): their
 * interrupts are raised at t, from an event at t when t is still to come. Interrupts are reserved on
 * a slave's MCU (urbsim_mcu_isr) in the order of their instants: one reserved ahead of time would
 * hold back an interrupt of that MCU that comes before it (a timer) and would not see a handler
 * running when it comes. */
static void end_slaves_now(urbsim_i2c_bus_t *b, urbsim_ns_t t, bool repeated)
{
    for (uint32_t j = 0; j < b->n_active; j++) {
        if (slave_live(b, j)) {
            raise_irq(b, b->active[j], repeated ? EV_RSTART : EV_STOP, t);
        }
    }
    b->n_active = 0;
}

static void end_slaves(urbsim_i2c_bus_t *b, urbsim_ns_t t, bool repeated)
{
    if (t <= b->k->now) {
        end_slaves_now(b, t, repeated);
        return;
    }
    /* The condition happens on the wire whatever the master does meanwhile: not tied to b->gen. The
     * active list stays until then (nothing is addressed before t: the next address byte is issued
     * after the START that follows). */
    urbsim_kernel_at(b->k, t, ev_end, b, repeated ? 1u : 0u);
}

static void ev_end(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    end_slaves_now(ctx, now, arg != 0u);
}

void urbsim_i2c_start(urbsim_i2c_bus_t *b)
{
    urbsim_ns_t t0 = op_begin(b);
    bool repeated = b->in_txn;
    if (!repeated && t0 < b->bus_free_at) {
        t0 = b->bus_free_at;
    }
    if (sda_stuck(b, t0)) {
        schedule_done(b, OP_ERROR, t0, t0 + b->t_bit); /* bus busy: no START possible */
        return;
    }
    urbsim_ns_t dur = repeated ? b->t_rstart : b->t_start;
    if (repeated) {
        end_slaves(b, t0 + dur, true);
    } else {
        b->in_txn = true;
        b->txn_start = t0;
        b->starts++;
    }
    b->expect_address = true;
    b->read_mode = false;
    b->general = false;
    schedule_done(b, OP_START, t0, t0 + dur);
}

void urbsim_i2c_write(urbsim_i2c_bus_t *b, uint8_t byte)
{
    urbsim_ns_t t0 = op_begin(b);
    if (!b->in_txn) {
        schedule_done(b, OP_ERROR, t0, t0 + b->t_bit);
        return;
    }
    if (sda_stuck(b, t0) && byte != 0u) {
        /* Arbitration is lost at the first 1 bit the master sends and reads back as 0. */
        uint32_t i = 0;
        while (!(byte & (0x80u >> i))) {
            i++;
        }
        schedule_done(b, OP_ERROR, t0, t0 + (i + 1u) * b->t_bit);
        return;
    }
    b->bytes++;
    b->op_byte = wire(b, byte, &b->ack_flip);
    b->op_ack = false;
    b->addressing = b->expect_address;
    if (b->expect_address) {
        b->expect_address = false;
        b->n_active = 0;
        b->read_mode = (b->op_byte & 1u) != 0u;
        b->general = b->op_byte == 0x00u;
    }
    /* The receivers' interrupts come at the 8th bit (t8): raised then, by ev_bit8, which schedules
     * the completion after their clock stretching and the ACK bit. Until then the operation is in
     * flight from t0 and ends no earlier than t8 + t_bit. */
    urbsim_ns_t t8 = t0 + 8u * b->t_bit;
    b->op_kind = OP_WRITE;
    b->op_start = t0;
    b->ready_at = t8 + b->t_bit;
    urbsim_kernel_at(b->k, t8, ev_bit8, b, DONE_ARG(b->gen & GEN_MASK));
}

static void ev_bit8(void *ctx, uint64_t arg, urbsim_ns_t now)
{
    urbsim_i2c_bus_t *b = ctx;
    if (ARG_GEN(arg) != (b->gen & GEN_MASK) || b->op_kind != OP_WRITE) {
        return; /* aborted before the 8th bit: no slave saw the byte */
    }
    const urbsim_ns_t t8 = now;
    urbsim_ns_t stretch_end = t8;
    if (b->addressing) {
        for (uint32_t i = 0; i < b->n_slaves; i++) {
            urbsim_i2c_slave_t *s = b->slaves[i];
            bool match = b->general ? s->general_call
                                      : (s->match ? s->match(s->ctx, (uint8_t)(b->op_byte >> 1))
                                                  : s->address == (b->op_byte >> 1));
            if (s->powered && match) {
                urbsim_ns_t end = raise_irq(b, i, EV_ADDR, t8);
                stretch_end = end > stretch_end ? end : stretch_end;
            }
        }
    } else if (!b->read_mode) {
        for (uint32_t j = 0; j < b->n_active; j++) {
            if (slave_live(b, j)) {
                urbsim_ns_t end = raise_irq(b, b->active[j], EV_RX, t8);
                stretch_end = end > stretch_end ? end : stretch_end;
            }
        }
    }
    b->stretch_ns += stretch_end - t8;
    schedule_done(b, OP_WRITE, b->op_start, stretch_end + b->t_bit);
}

void urbsim_i2c_read(urbsim_i2c_bus_t *b, bool ack)
{
    urbsim_ns_t t0 = op_begin(b);
    if (!b->in_txn) {
        schedule_done(b, OP_ERROR, t0, t0 + b->t_bit);
        return;
    }
    if (b->read_mode && t0 < b->tx_ready) {
        b->stretch_ns += b->tx_ready - t0; /* the slave holds SCL until its data is loaded */
        t0 = b->tx_ready;
    }
    b->bytes++;
    b->master_ack = ack; /* the byte itself is sampled at the end (the slave may load it later) */
    b->addressing = false;
    schedule_done(b, OP_READ, t0, t0 + 9u * b->t_bit);
}

void urbsim_i2c_stop(urbsim_i2c_bus_t *b)
{
    urbsim_ns_t t0 = op_begin(b);
    if (!b->in_txn || t0 == URBSIM_NEVER || scl_stuck(b, t0) || sda_stuck(b, t0)) {
        return; /* nothing to stop, or the lines cannot make a STOP condition */
    }
    urbsim_ns_t t_end = t0 + b->t_stop;
    end_slaves(b, t_end, false);
    b->in_txn = false;
    b->stops++;
    b->busy_ns += t_end - b->txn_start;
    b->ready_at = t_end;
    b->bus_free_at = t_end + b->t_buf;
    b->op_kind = -1;
    if (urbsim_trace_on(b->tr, URBSIM_TR_BUS)) {
        urbsim_trace(b->tr, URBSIM_TR_BUS, t_end, b->name, "stop", "%s", "");
    }
}

void urbsim_i2c_abort(urbsim_i2c_bus_t *b)
{
    b->gen++;
    b->op_kind = -1;
    b->ready_at = b->k->now;
}

uint8_t urbsim_i2c_lines(urbsim_i2c_bus_t *b)
{
    urbsim_ns_t now = b->k->now;
    uint8_t l = URBSIM_I2C_SCL | URBSIM_I2C_SDA;
    if (scl_stuck(b, now)) {
        l &= (uint8_t)~URBSIM_I2C_SCL;
    }
    if (sda_stuck(b, now)) {
        l &= (uint8_t)~URBSIM_I2C_SDA;
    }
    if (b->bitbang) {
        l &= b->drive;
    }
    return l;
}

void urbsim_i2c_drive(urbsim_i2c_bus_t *b, uint8_t lines)
{
    urbsim_ns_t now = b->k->now;
    uint8_t before = urbsim_i2c_lines(b);
    b->bitbang = true;
    b->drive = lines & (URBSIM_I2C_SCL | URBSIM_I2C_SDA);
    uint8_t after = urbsim_i2c_lines(b);
    bool scl_rose = !(before & URBSIM_I2C_SCL) && (after & URBSIM_I2C_SCL);
    if (scl_rose && sda_stuck(b, now) && b->sda_pulses > 0u) {
        /* A slave stuck mid-byte shifts one bit per clock pulse and lets go of SDA at its end. */
        if (--b->sda_pulses == 0u) {
            b->sda_until = now;
            urbsim_trace(b->tr, URBSIM_TR_FAULT, now, b->name, "sda_released", "%s", "");
            after = urbsim_i2c_lines(b);
        }
    }
    bool sda_rose = !(before & URBSIM_I2C_SDA) && (after & URBSIM_I2C_SDA);
    if (sda_rose && (after & URBSIM_I2C_SCL)) {
        /* STOP condition: SDA rises while SCL is high. */
        end_slaves(b, now, false);
        if (b->in_txn) {
            b->in_txn = false;
            b->busy_ns += now - b->txn_start;
        }
        b->stops++;
        b->bus_free_at = now + b->t_buf;
        urbsim_trace(b->tr, URBSIM_TR_BUS, now, b->name, "stop", ",\"bitbang\":1");
    }
}

void urbsim_i2c_release(urbsim_i2c_bus_t *b)
{
    b->bitbang = false;
    b->drive = URBSIM_I2C_SCL | URBSIM_I2C_SDA;
    b->gen++;
    b->op_kind = -1;
    b->ready_at = b->k->now;
}
