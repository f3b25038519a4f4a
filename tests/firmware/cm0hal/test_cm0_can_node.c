/*
 * cmocka tests of the FDCAN port with the node library's CAN build behind it, wired as
 * firmware/hal/cortex-m0plus/node_dl_cm0.c wires them: the bridge's frames are put into the RAM
 * message RAM's Rx FIFO 0, the port's interrupt hands them to the CAN slave, and the slave's answer
 * is read back from the Tx FIFO elements the port wrote, one frame per Tx event the test reports (the
 * slave gets the port's HAL through a wrapper that advances the Tx FIFO's put index after each
 * request, as the controller does when TXBAR is written).
 * Checked end to end through the registers: a write of inbox 1 stored and answered OK, the
 * identification read answered with outbox 0 (25 bytes in 4 frames, CRC and toggles right), and a
 * bus-off handed to the slave, which asks the port to recover.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "echo_app.h"
#include "urb_can.h"
#include "urb_cm0_fdcan.h"
#include "urb_node.h"
#include "urb_node_can.h"

#define NODE_ADDRESS 1u
#define BOX_SIZE 8u
#define CCCR_INIT 0x1u
#define PSR_EP 0x20u
#define PSR_BO 0x80u
#define IR_RF0N 0x1u
#define IR_TEFN 0x400u
#define IR_BO 0x80000u

typedef struct {
    urb_cm0_fdcan_regs_t regs;
    urb_cm0_fdcan_ram_t ram;
    urb_cm0_can_t port;
    urb_node_t node;
    urb_node_hal_t hal;
    urb_node_can_t can;
    echo_app_t app;
    uint8_t storage[4u * BOX_SIZE];
    uint32_t now;
    uint32_t rx_put;  /* next Rx FIFO 0 element the test fills */
    uint32_t tx_get;  /* next Tx FIFO element the test takes */
    uint32_t pending; /* frames requested, not yet taken */
    urb_can_hal_t wrap; /* the port's HAL, with the controller's answer to each request added */
} bench_t;

static bench_t bench;

static uint32_t node_now(void *ctx)
{
    return ((bench_t *)ctx)->now;
}

static void node_compare(void *ctx, uint32_t at)
{
    (void)ctx;
    (void)at;
}

static void node_address(void *ctx, uint8_t address)
{
    (void)ctx;
    (void)address;
}

/* the glue's callbacks (node_dl_cm0.c) */
static void slave_rx(void *owner, const urb_can_frame_t *frame, uint32_t t_us)
{
    urb_can_slave_rx(&((urb_node_can_t *)owner)->slave, frame, t_us);
}

static void slave_tx_done(void *owner)
{
    urb_can_slave_tx_done(&((urb_node_can_t *)owner)->slave);
}

static void slave_state(void *owner, uint8_t state)
{
    urb_can_slave_state(&((urb_node_can_t *)owner)->slave, state);
}

/* The Tx FIFO status as the controller shows it with `pending` requests after the get index. */
static void txfqs_update(void)
{
    uint32_t const put = (bench.tx_get + bench.pending) % 3u;
    uint32_t const full = (bench.pending == 3u) ? (1u << 21) : 0u;
    bench.regs.txfqs = (put << 16) | (bench.tx_get << 8) | full | (3u - bench.pending);
}

/* A TXBAR write makes the controller advance its put index: a RAM block cannot, so the slave is given
 * the port's HAL through this wrapper, which plays that part after each accepted request. */
static bool wrap_tx(void *ctx, const urb_can_frame_t *frame)
{
    (void)ctx;
    uint32_t const put = (bench.tx_get + bench.pending) % 3u;
    bench.regs.txbar = 0u;
    if (!bench.port.hal.tx(bench.port.hal.ctx, frame)) {
        return false;
    }
    assert_int_equal(bench.regs.txbar, 1u << put); /* requested in the element the status named */
    bench.pending++;
    txfqs_update();
    return true;
}

static uint32_t port_now(void *owner)
{
    (void)owner;
    return bench.now;
}

static int setup(void **state)
{
    (void)state;
    memset(&bench, 0, sizeof bench);
    bench.now = 1000u;
    urb_cm0_can_owner_t const owner = {&bench.can, slave_rx, slave_tx_done, slave_state, port_now};
    assert_true(urb_cm0_can_init(&bench.port, &bench.regs, &bench.ram, &owner, 48000000u, 1000u));
    bench.hal.ctx = &bench;
    bench.hal.now = node_now;
    bench.hal.set_compare = node_compare;
    bench.hal.set_address = node_address;
    urb_node_config_t cfg;
    urb_node_config_default(&cfg);
    cfg.i2c_address = NODE_ADDRESS;
    cfg.ticks_per_us = 1u;
    bench.app.class_id = 0x42u;
    bench.app.fingerprint = 0x00C0FFEEu;
    bench.app.in_size[1] = BOX_SIZE;
    bench.app.out_size[1] = BOX_SIZE;
    assert_int_equal(urb_node_init(&bench.node, &bench.hal, &echo_app_hooks, &bench.app, &cfg, bench.storage,
                                   (uint16_t)sizeof bench.storage),
                     URB_NODE_OK);
    bench.wrap = bench.port.hal;
    bench.wrap.tx = wrap_tx;
    txfqs_update();
    assert_true(urb_node_can_attach(&bench.can, &bench.node, &cfg, &bench.wrap, 1000u));
    return 0;
}

/* The controller received `data[len]` on `id`: one Rx FIFO 0 element and the interrupt. */
static void bus_frame(uint16_t id, const uint8_t *data, uint8_t len)
{
    urb_cm0_fdcan_element_t *e = &bench.ram.rx_fifo0[bench.rx_put];
    uint32_t w[2] = {0u, 0u};
    for (uint8_t i = 0u; i < len; i++) {
        w[i / 4u] |= (uint32_t)data[i] << (8u * (i % 4u));
    }
    e->word[0] = (uint32_t)id << 18;
    e->word[1] = (uint32_t)len << 16;
    e->word[2] = w[0];
    e->word[3] = w[1];
    bench.regs.rxf0s = 1u | (bench.rx_put << 8);
    bench.regs.ir = IR_RF0N;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.regs.rxf0a, bench.rx_put);
    bench.rx_put = (bench.rx_put + 1u) % 3u;
    bench.regs.rxf0s = bench.rx_put << 8;
}

/* Sends a whole transfer to the node, frame by frame. */
static void bus_transfer(uint16_t id, const uint8_t *payload, uint8_t len, uint8_t tid)
{
    urb_can_tx_t tx;
    uint8_t data[8];
    urb_can_tx_init(&tx, payload, len, tid);
    for (uint8_t n = urb_can_tx_next(&tx, data); n != 0u; n = urb_can_tx_next(&tx, data)) {
        bus_frame(id, data, n);
    }
}

/* Takes the oldest frame the port queued, if any, and reports it sent (its Tx event, the interrupt). */
static bool bus_take(urb_can_frame_t *f)
{
    if (bench.pending == 0u) {
        return false;
    }
    urb_cm0_fdcan_element_t const *e = &bench.ram.tx_buffer[bench.tx_get];
    f->id = (uint16_t)((e->word[0] >> 18) & 0x7FFu);
    f->len = (uint8_t)((e->word[1] >> 16) & 0xFu);
    for (uint8_t i = 0u; i < 8u; i++) {
        f->data[i] = (uint8_t)((i < 4u ? e->word[2] : e->word[3]) >> (8u * (i % 4u)));
    }
    bench.ram.tx_event[2u * bench.tx_get + 1u] = e->word[1] & 0xFF000000u; /* the element's marker */
    bench.regs.txefs = 1u | (bench.tx_get << 8);
    bench.tx_get = (bench.tx_get + 1u) % 3u;
    bench.pending--;
    txfqs_update();
    bench.regs.ir = IR_TEFN;
    urb_cm0_can_irq(&bench.port);
    return true;
}

static void test_write_inbox_through_the_registers(void **state)
{
    (void)state;
    static const uint8_t payload[BOX_SIZE] = {1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u};
    bus_transfer(urb_can_id(NODE_ADDRESS, 1u, false, URB_CAN_REQUEST), payload, BOX_SIZE, 5u);
    urb_can_frame_t f;
    assert_true(bus_take(&f));
    assert_int_equal(f.id, urb_can_id(NODE_ADDRESS, 1u, false, URB_CAN_RESPONSE));
    assert_int_equal(f.len, 1u); /* an empty transfer: OK, stored */
    assert_int_equal(f.data[0], URB_CAN_TAIL_START | URB_CAN_TAIL_END | URB_CAN_TAIL_TOGGLE | 5u);
    assert_false(bus_take(&f));
    const uint8_t *in = NULL;
    assert_int_equal(urb_node_lock_inbox(&bench.node, 1u, &in), URB_NODE_NEW);
    assert_memory_equal(in, payload, BOX_SIZE);
    assert_int_equal(urb_node_release_inbox(&bench.node, 1u), URB_NODE_OK);
}

static void test_identification_read_through_the_registers(void **state)
{
    (void)state;
    bus_transfer(urb_can_id(NODE_ADDRESS, 0u, true, URB_CAN_REQUEST), NULL, 0u, 9u);
    urb_can_rx_t rx;
    urb_can_rx_reset(&rx);
    uint8_t out[32];
    urb_can_frame_t f;
    uint32_t frames = 0u;
    urb_can_rx_result_t r = URB_CAN_RX_MORE;
    while (bus_take(&f)) {
        frames++;
        assert_true(frames <= 5u);
        assert_int_equal(f.id, urb_can_id(NODE_ADDRESS, 0u, true, URB_CAN_RESPONSE));
        r = urb_can_rx_frame(&rx, f.data, f.len, out, (uint8_t)sizeof out);
    }
    assert_int_equal(r, URB_CAN_RX_DONE);
    assert_int_equal(frames, urb_can_frames(URB_NODE_OUTBOX0_SIZE)); /* 25 bytes + CRC: 4 frames */
    assert_int_equal(urb_can_rx_len(&rx), URB_NODE_OUTBOX0_SIZE);
    assert_int_equal(urb_can_rx_tid(&rx), 9u);
    assert_false(urb_can_slave_sending(&bench.can.slave));
}

static void test_bus_off_reaches_the_slave_and_recovers(void **state)
{
    (void)state;
    bench.regs.psr = PSR_EP | PSR_BO;
    bench.regs.cccr |= CCCR_INIT; /* the controller's doing at bus-off */
    bench.regs.ir = IR_BO;
    urb_cm0_can_irq(&bench.port);
    urb_can_slave_stats_t st;
    urb_can_slave_stats(&bench.can.slave, &st);
    assert_int_equal(st.bus_off, 1u);
    assert_int_equal(bench.regs.cccr & CCCR_INIT, 0u); /* the slave asked for the recovery */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_write_inbox_through_the_registers, setup),
        cmocka_unit_test_setup(test_identification_read_through_the_registers, setup),
        cmocka_unit_test_setup(test_bus_off_reaches_the_slave_and_recovers, setup),
    };
    return cmocka_run_group_tests_name("cm0_can_node", tests, NULL, NULL);
}
