/*
 * i2c.h: a shared I2C bus with one master (the bridge) and many slaves (nodes), byte-timed.
 *
 * TIMING (t_bit = 1 / bitrate: 2.5 us at 400 kb/s; every constant below is a multiple of it, so
 * wire times can be checked by hand):
 *   START from idle        1.0 t_bit    (SDA falls with SCL high, then the hold time)
 *   repeated START         1.5 t_bit    (SCL low half, SCL high setup half, SDA falls, hold half)
 *   one byte + ACK bit     9.0 t_bit    (22.5 us at 400 kb/s) + clock stretching
 *   STOP                   1.0 t_bit    (SCL rises with SDA low, SDA rises)
 *   bus free after STOP    t_buf before the next START: the minimum of the bit rate's mode
 *                          (UM10204: 1.3 us Fast-mode, 4.7 us Standard-mode, 0.5 us Fast-mode Plus)
 * A master operation starts when the master issues it (its interrupt latency is the caller's
 * business: the bridge HAL calls the firmware after its own latency) but not before the previous
 * operation ended.
 *
 * CLOCK STRETCHING. After the 8th bit of a byte a slave receiving it holds SCL low until its
 * interrupt handler has run: the ACK bit starts at max over addressed slaves of
 * (t8 + irq latency + handler time). Before a byte a slave transmits, it holds SCL low until its
 * handler has loaded the data register (requested right after the previous ACK). The handlers run
 * at their ISR instant; `t_hw` passed to them is the bus instant that raised the interrupt (what
 * an input capture would latch). Every slave interrupt is raised (isr_window called) at its bus
 * instant, from an event then when the master issued the operation earlier (the 8th bit of a
 * written byte, a STOP or repeated START): a slave's MCU reserves its interrupts in time order.
 *
 * BIT ERRORS ON THE ACK BIT. Of a written byte: the master sees the inverted ACK (the slave keeps
 * its own view). Of a read byte: a slave that sees NACK for the master's ACK releases SDA until the
 * STOP, so the master's further reads return 0xFF; a slave that sees ACK for the master's NACK
 * loads its next byte (its data index advances), but the STOP is still modelled as clean (a real
 * slave would hold SDA low if that byte began with a 0 bit: not modelled).
 *
 * GENERAL CALL (address byte 0x00): every powered slave with `general_call` set receives it and
 * the bytes that follow, each at its own ISR instant; the bus waits for the slowest.
 *
 * FAULTS: bit errors at rate `ber` per wire bit (8 data + ACK per byte; a corrupted address
 * reaches the wrong slave or none); SDA or SCL held low from now until a time (or forever), SDA
 * optionally released after N clock pulses (a slave stuck mid-byte, cured by the nine-pulse bus
 * clear). With SCL held low, operations in progress stall (no completion event: the master's
 * timeout must notice); with SDA low, a START fails and a written byte loses arbitration at its
 * first 1 bit (URBSIM_I2C_ERROR), reads return 0x00.
 */
#ifndef URBSIM_I2C_H
#define URBSIM_I2C_H

#include <stdbool.h>
#include <stdint.h>

#include "clock.h"
#include "kernel.h"
#include "rng.h"
#include "trace.h"

#define URBSIM_I2C_MAX_SLAVES 64u

/** Completion events delivered to the master (the bridge port maps them to urb_i2c_event_t). */
enum {
    URBSIM_I2C_START = 0,
    URBSIM_I2C_ACK = 1,
    URBSIM_I2C_NACK = 2,
    URBSIM_I2C_BYTE = 3,
    URBSIM_I2C_ERROR = 4,
};

/** Line bits for lines()/drive() (values equal URB_I2C_SCL / URB_I2C_SDA). */
#define URBSIM_I2C_SCL 0x01u
#define URBSIM_I2C_SDA 0x02u

/** One slave on the bus. Handlers run at the slave's ISR instant (kernel time). */
typedef struct {
    void *ctx;
    uint8_t address;     /**< 7-bit address */
    bool general_call;   /**< receives address 0x00 */
    bool powered;        /**< unpowered slaves neither ACK nor stretch */
    uint64_t gen;        /**< bumped on power loss: pending handler calls are dropped */
    /** Optional: decides whether the slave answers 7-bit address `address` (NULL: equality with
     *  `address`). Lets a faulty (babbling) device answer addresses not its own. */
    bool (*match)(void *ctx, uint8_t address);
    /** When the slave's ISR for an interrupt raised at t_irq starts, and (in *end) when it is done
     *  (the stretch ends). Lets the device account for its own busy interrupts. Required. */
    urbsim_ns_t (*isr_window)(void *ctx, urbsim_ns_t t_irq, urbsim_ns_t *end);
    /** Address match; return true to ACK. `read`: the master reads next. */
    bool (*on_address)(void *ctx, bool read, bool general_call, urbsim_ns_t t_hw);
    /** A byte written by the master; return true to ACK. */
    bool (*on_rx)(void *ctx, uint8_t byte, urbsim_ns_t t_hw);
    /** The master is about to read a byte: return it. */
    uint8_t (*on_tx)(void *ctx, urbsim_ns_t t_hw);
    /** The master NACKed the byte just read (end of the read). */
    void (*on_tx_nack)(void *ctx, urbsim_ns_t t_hw);
    /** STOP (`repeated` false) or repeated START (true): the slave's part of the transaction is
     *  over. */
    void (*on_stop)(void *ctx, bool repeated, urbsim_ns_t t_hw);
} urbsim_i2c_slave_t;

/**
 * How each slave sees the bus's edges (hardware profiles; all 0, the default: every slave sees an
 * edge at its bus instant). A falling edge (SCL after the 8th bit and after the ACK, SDA of a
 * repeated START) drops linearly at the pull-down current, VDD to 0 in `fall_ns`; a rising one (SDA
 * of a STOP) rises through the pull-up with time constant `rise_tau_ns`. Each slave switches at its
 * own input threshold, drawn per slave uniformly in [vth_min, vth_max] x VDD, then passes its input
 * glitch filter (a delay drawn per slave in [filter_min_ns, filter_max_ns]) and its peripheral's
 * synchroniser (a delay drawn per edge in [sync_min_ns, sync_max_ns]). The slave's interrupt is
 * raised that much after the bus instant, and its `t_hw` is that instant (what it latches).
 * Modelling choice: the delay is charged like the entry latency, when the bus instant comes, so an
 * interrupt of the same MCU raised within it (at most a few hundred ns) is taken after this one.
 */
typedef struct {
    double fall_ns;        /**< VDD to 0 at the pull-down current: C VDD / I (0: instant) */
    double rise_tau_ns;    /**< pull-up time constant R C (0: instant) */
    double vth_min, vth_max;            /**< input thresholds, fractions of VDD, drawn per slave */
    double filter_min_ns, filter_max_ns; /**< input glitch filter's delay, drawn per slave */
    double sync_min_ns, sync_max_ns;     /**< synchroniser's delay, drawn per edge */
    uint64_t seed;         /**< the per-slave draws come from streams derived from it */
} urbsim_i2c_edges_t;

/** Master completion callback, at the bus instant the operation completed (no latency added). */
typedef void (*urbsim_i2c_master_fn)(void *ctx, int ev, uint8_t byte, urbsim_ns_t t_hw);

typedef struct {
    urbsim_kernel_t *k;
    urbsim_trace_t *tr;
    char name[32];
    double bitrate;
    urbsim_ns_t t_bit, t_start, t_rstart, t_stop, t_buf;
    urbsim_i2c_slave_t *slaves[URBSIM_I2C_MAX_SLAVES];
    uint32_t n_slaves;
    urbsim_i2c_master_fn master;
    void *master_ctx;
    /* transaction state */
    bool in_txn;          /**< a START was sent and no STOP yet */
    bool expect_address;  /**< the next write is an address byte */
    bool read_mode;       /**< the addressed slaves transmit */
    bool general;         /**< the current transaction is a general call */
    uint8_t active[URBSIM_I2C_MAX_SLAVES]; /**< indices of slaves that ACKed the address */
    uint64_t active_gen[URBSIM_I2C_MAX_SLAVES];
    uint32_t n_active;
    urbsim_ns_t ready_at;    /**< the previous operation ends here */
    urbsim_ns_t earliest;    /**< set by the master's port while its handler runs: operations it
                                  issues start no earlier (the handler's true instant) */
    urbsim_ns_t bus_free_at; /**< STOP + t_buf */
    urbsim_ns_t tx_ready;    /**< read: the slaves' data is loaded by then */
    uint8_t tx_byte;         /**< read: wired-AND of the active slaves' bytes */
    bool op_ack;             /**< accumulated ACK of the byte in flight */
    bool ack_flip;           /**< a bit error inverted the ACK bit of the byte in flight */
    bool master_ack;         /**< read in flight: the master ACKs it */
    bool addressing;         /**< write in flight is an address byte */
    urbsim_ns_t hw[URBSIM_I2C_MAX_SLAVES][6]; /**< bus instant of each slave's pending interrupt */
    uint8_t op_byte;         /**< the byte in flight as seen on the wire */
    int op_kind;             /**< operation in flight, -1 none */
    urbsim_ns_t op_start;
    uint64_t gen;            /**< bumped by abort: stale completions are dropped */
    /* faults and bit-banging */
    urbsim_ns_t sda_from, sda_until, scl_from, scl_until;
    uint32_t sda_pulses;     /**< >0: SDA is released after this many more SCL pulses */
    bool bitbang;
    uint8_t drive;           /**< master's bit-banged levels (1 = released) */
    double ber;
    urbsim_rng_t rng;
    uint64_t bits_to_error;
    /* statistics */
    uint64_t bytes, starts, stops, stretch_ns, busy_ns, flipped_bits, stalls;
    urbsim_ns_t txn_start;
    /* edges (urbsim_i2c_set_edges): per slave, its fixed delays and its synchroniser's stream */
    urbsim_i2c_edges_t edges;
    bool edges_on;
    double fall_delay_ns[URBSIM_I2C_MAX_SLAVES];
    double rise_delay_ns[URBSIM_I2C_MAX_SLAVES];
    urbsim_rng_t edge_rng[URBSIM_I2C_MAX_SLAVES];
} urbsim_i2c_bus_t;

/** Set up an idle bus at `bitrate` b/s. `rng` is the bus's fault stream (copied). */
void urbsim_i2c_init(urbsim_i2c_bus_t *b, urbsim_kernel_t *k, urbsim_trace_t *tr, const char *name,
                     double bitrate, const urbsim_rng_t *rng);

/** Attach a slave (kept by reference). Returns false when the bus is full. */
bool urbsim_i2c_attach(urbsim_i2c_bus_t *b, urbsim_i2c_slave_t *s);

/** Power a slave off (it stops answering at once, pending handler calls are dropped) or on. */
void urbsim_i2c_power(urbsim_i2c_bus_t *b, urbsim_i2c_slave_t *s, bool on);

/* Master operations (urb_i2c_hal_t semantics): exactly one completion per start/write/read,
 * delivered through b->master later, never from inside the call; stop has no completion. */
void urbsim_i2c_start(urbsim_i2c_bus_t *b);
void urbsim_i2c_write(urbsim_i2c_bus_t *b, uint8_t byte);
void urbsim_i2c_read(urbsim_i2c_bus_t *b, bool ack);
void urbsim_i2c_stop(urbsim_i2c_bus_t *b);
/** Abandon the operation in flight: no completion of it will be delivered. */
void urbsim_i2c_abort(urbsim_i2c_bus_t *b);
/** Line levels now (URBSIM_I2C_SCL | URBSIM_I2C_SDA bits set when high). */
uint8_t urbsim_i2c_lines(urbsim_i2c_bus_t *b);
/** Bit-bang: set the master's open-drain outputs now (set bit = released). */
void urbsim_i2c_drive(urbsim_i2c_bus_t *b, uint8_t lines);
/** End bit-banging; the controller is re-initialised and idle. */
void urbsim_i2c_release(urbsim_i2c_bus_t *b);

/** Set how the slaves see the bus's edges (see urbsim_i2c_edges_t): draws each slave's threshold and
 *  filter delay, for the slaves attached now and later. All-zero edges restore instant edges. */
void urbsim_i2c_set_edges(urbsim_i2c_bus_t *b, const urbsim_i2c_edges_t *edges);
/** The delay from a bus edge to slave `idx`'s peripheral seeing it: a rising edge (STOP) or a
 *  falling one; draws the synchroniser's delay. 0 when edges are instant. */
urbsim_ns_t urbsim_i2c_edge_delay(urbsim_i2c_bus_t *b, uint32_t idx, bool rising);

/* Faults */
void urbsim_i2c_set_ber(urbsim_i2c_bus_t *b, double ber);
/** Hold SDA low from now until `until` (URBSIM_NEVER: until cleared); `pulses` > 0 releases it
 *  after that many SCL pulses of a bus clear. */
void urbsim_i2c_stick_sda(urbsim_i2c_bus_t *b, urbsim_ns_t until, uint32_t pulses);
/** Hold SCL low from now until `until` (URBSIM_NEVER: forever). */
void urbsim_i2c_stick_scl(urbsim_i2c_bus_t *b, urbsim_ns_t until);

/** Duration of a byte with its ACK and no stretching (9 bit times). */
urbsim_ns_t urbsim_i2c_byte_ns(const urbsim_i2c_bus_t *b);

#endif /* URBSIM_I2C_H */
