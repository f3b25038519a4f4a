/*
 * Eva environment of the bridge firmware: board and I2C HALs whose every answer is arbitrary
 * (Frama_C_*_interval), the real I2C master as the downlink, and an arbitrary configuration.
 * Each proofs/framac/eva_bridge_<entry>/main.c drives its entry point with arbitrary inputs in an
 * unbounded loop, so Eva's fixpoint covers every sequence of inputs.
 */
#ifndef EVA_BRIDGE_ENV_H
#define EVA_BRIDGE_ENV_H

#include "__fc_builtin.h"
#include "urb_bridge.h"
#include "urb_downlink.h"

static uint32_t eva_now_us(void *ctx)
{
    (void)ctx;
    return Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu);
}

static void eva_heartbeat_period(void *ctx, uint32_t period_us)
{
    (void)ctx;
    (void)period_us;
}

static void eva_uart_tx_kick(void *ctx)
{
    (void)ctx;
}

static void eva_mark(void *ctx, uint8_t id, bool level)
{
    (void)ctx;
    (void)id;
    (void)level;
}

/* I2C controller operations: their completion is an event the driver delivers (arbitrary). */
static void eva_i2c_op(void *ctx)
{
    (void)ctx;
}

static void eva_i2c_write(void *ctx, uint8_t byte)
{
    (void)ctx;
    (void)byte;
}

static void eva_i2c_read(void *ctx, bool ack)
{
    (void)ctx;
    (void)ack;
}

static uint8_t eva_i2c_lines(void *ctx)
{
    (void)ctx;
    return Frama_C_unsigned_char_interval(0u, URB_I2C_SCL | URB_I2C_SDA);
}

static void eva_i2c_drive(void *ctx, uint8_t lines)
{
    (void)ctx;
    (void)lines;
}

/* Everything one bridge or master needs, each object on its own (a stray write Eva cannot bound stays in
 * its object and shows up as an alarm there instead of reaching a neighbour). */
static urb_bridge_t eva_bridge;
static urb_i2c_master_t eva_master;
static urb_bridge_hal_t eva_hal;
static urb_i2c_hal_t eva_i2c;
static urb_downlink_t eva_dl;

/* Initialises eva_master on the arbitrary I2C HAL with an arbitrary timeout and bus-clear clock,
 * and eva_dl as its downlink interface. */
static void eva_master_start(void)
{
    eva_i2c.ctx = NULL;
    eva_i2c.start = eva_i2c_op;
    eva_i2c.write = eva_i2c_write;
    eva_i2c.read = eva_i2c_read;
    eva_i2c.stop = eva_i2c_op;
    eva_i2c.abort = eva_i2c_op;
    eva_i2c.lines = eva_i2c_lines;
    eva_i2c.drive = eva_i2c_drive;
    eva_i2c.release = eva_i2c_op;
    urb_i2c_master_config_t mcfg;
    urb_i2c_master_default_config(&mcfg);
    mcfg.timeout_us = Frama_C_unsigned_int_interval(1u, 0xFFFFFFFFu);
    mcfg.clear_half_us = Frama_C_unsigned_short_interval(0u, 0xFFFFu);
    urb_i2c_master_init(&eva_master, &eva_i2c, &mcfg);
    urb_i2c_master_downlink(&eva_master, &eva_dl);
}

/* A downlink that keeps the contract of urb_downlink.h and nothing more: begin() accepts or
 * refuses arbitrarily, reads a WRITE's `length` bytes and fills a READ's with arbitrary bytes (so
 * a buffer the bridge passes that is shorter than `length` raises an alarm); poll() reports BUSY,
 * IDLE or any final status of the running transaction. The I2C master behind this interface is
 * eva_bridge_i2c's unit; here the bridge's own state stays precise. */
static bool eva_dl_running;

/* Reads a WRITE's or fills a READ's `length` bytes at `data` (at most 32: the downlink clamps). */
static void eva_dl_transfer(uint8_t op, uint8_t *data, uint8_t length)
{
    /* loop bound: 32 bytes */
    for (uint8_t i = 0u; (i < length) && (i < 32u); i++) {
        if (op == URB_DL_READ) {
            data[i] = Frama_C_unsigned_char_interval(0u, 255u);
        } else {
            (void)data[i];
        }
    }
}

static bool eva_dl_begin(void *ctx, const urb_downlink_txn_t *t, uint32_t now_us)
{
    (void)ctx;
    (void)now_us;
    if (eva_dl_running || (Frama_C_nondet(0, 1) == 0)) {
        return false;
    }
    if ((t->op == URB_DL_READ) || (t->op == URB_DL_WRITE)) {
        /* The bridge passes the payload of its oldest pending data slot (any of 16) or its
         * identification buffer. Through the pointer as given, a store at `data + i` has an offset
         * Eva can only bound by an interval spanning every slot, headers included, and would make
         * the header bytes of all 16 slots arbitrary. Each slot from a branch of its own instead:
         * the test of equality reduces the pointer to that one slot, so the store stays inside its
         * payload. The same bytes are transferred either way. */
        /* loop bound: URB_BRIDGE_FIFO_MAX slots */
        for (uint8_t k = 0u; k < URB_BRIDGE_FIFO_MAX; k++) {
            if (t->data == eva_bridge.slots[k].data) {
                eva_dl_transfer(t->op, eva_bridge.slots[k].data, t->length);
                eva_dl_running = true;
                return true;
            }
        }
        eva_dl_transfer(t->op, t->data, t->length);
    }
    eva_dl_running = true;
    return true;
}

static int8_t eva_dl_poll(void *ctx, uint32_t now_us)
{
    (void)ctx;
    (void)now_us;
    if (!eva_dl_running) {
        return URB_DOWNLINK_IDLE;
    }
    int8_t const r = (int8_t)Frama_C_interval(URB_DOWNLINK_IDLE, URB_STATUS_NODE_BUSY);
    if (r != URB_DOWNLINK_BUSY) {
        eva_dl_running = false; /* IDLE too: a downlink that lost the transaction */
    }
    return r;
}

/* Initialises eva_bridge on the contract downlink with an arbitrary configuration (the data-slot
 * depth at its maximum, see eva_alarms.md); returns the result of urb_bridge_init. */
static int32_t eva_bridge_start(void)
{
    eva_dl.ctx = NULL;
    eva_dl.kind = (uint8_t)URB_DOWNLINK_KIND_I2C;
    eva_dl.bitrate_kbps = Frama_C_unsigned_short_interval(0u, 0xFFFFu);
    eva_dl.first_address = (uint8_t)URB_I2C_FIRST_ADDRESS; /* the I2C master's range: init cannot fail */
    eva_dl.last_address = (uint8_t)URB_I2C_LAST_ADDRESS;
    eva_dl.begin = eva_dl_begin;
    eva_dl.poll = eva_dl_poll;
    eva_hal.ctx = NULL;
    eva_hal.now_us = eva_now_us;
    eva_hal.heartbeat_period = eva_heartbeat_period;
    eva_hal.uart_tx_kick = eva_uart_tx_kick;
    eva_hal.mark = (Frama_C_nondet(0, 1) != 0) ? eva_mark : NULL;
    urb_bridge_config_t cfg;
    urb_bridge_default_config(&cfg);
    cfg.baud = Frama_C_unsigned_int_interval(1u, 0xFFFFFFFFu);
    cfg.idle_gap_us = Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu);
    cfg.heartbeat_us = Frama_C_unsigned_short_interval(0u, 0xFFFFu);
    cfg.scan_at_start = Frama_C_nondet(0, 1) != 0;
    return urb_bridge_init(&eva_bridge, &cfg, &eva_hal, &eva_dl);
}

/* Runs `stmt` from a call site of its own for each transaction kind of the master: Eva analyses a
 * call with the join of the states reaching its call site, and the join of a READ into a 25-byte
 * scan buffer with a WRITE of 32 bytes from a data slot would lose which buffer goes with which
 * length. Splitting the call sites keeps that relation without changing what runs. */
#define EVA_BY_OP(stmt)                                                                            \
    do {                                                                                          \
        switch (eva_master.op) {                                                                  \
        case URB_DL_READ: stmt; break;                                                            \
        case URB_DL_WRITE: stmt; break;                                                           \
        case URB_DL_SYNC: stmt; break;                                                            \
        case URB_DL_CLEAR: stmt; break;                                                           \
        default: stmt; break;                                                                     \
        }                                                                                         \
    } while (0)

/* One arbitrary I2C event with an arbitrary byte, as the controller interrupt delivers it. */
static void eva_i2c_event(void)
{
    urb_i2c_event_t const ev = (urb_i2c_event_t)Frama_C_interval(URB_I2C_EV_START, URB_I2C_EV_ERROR);
    urb_i2c_master_event(&eva_master, ev, Frama_C_unsigned_char_interval(0u, 255u));
}

#endif /* EVA_BRIDGE_ENV_H */
