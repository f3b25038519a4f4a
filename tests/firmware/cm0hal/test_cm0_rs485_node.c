/*
 * cmocka tests of the USART RS485 port with the node library's RS485 build behind it, wired as
 * firmware/hal/cortex-m0plus/node_dl_cm0.c wires them, on the USART model of usart_line.h at 1 Mb/s:
 * the bridge's request arrives byte by byte on the line, the silence deadline the slave asks for
 * (wake_at, TIM2 CC2 on the part) calls its poll, and its answer leaves through the port with the
 * driver enabled around it. Checked end to end through the registers: a write of inbox 1 stored and
 * answered OK, the identification read answered with outbox 0, and the DE pulse of each answer
 * (after the request's silence, before the answer's first start bit, after its last stop bit).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "echo_app.h"
#include "urb_cm0_usart485.h"
#include "urb_core.h"
#include "urb_node.h"
#include "urb_node_rs485.h"
#include "urb_rs485_wire.h"
#include "usart_line.h"

#define NODE_ADDRESS 5u
#define BOX_SIZE 8u
#define BAUD 1000000u

typedef struct {
    usart_line_t line;
    urb_cm0_rs485_t port;
    urb_node_t node;
    urb_node_hal_t hal;
    urb_node_rs485_t rs485;
    echo_app_t app;
    uint8_t storage[4u * BOX_SIZE];
    bool armed;
    uint32_t deadline;
} bench_t;

static bench_t bench;

/* 1 Mb/s: a microsecond is sixteen model steps */
static uint32_t now_us(void)
{
    return bench.line.t / 16u;
}

static uint32_t node_now(void *ctx)
{
    (void)ctx;
    return now_us();
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

/* the glue's callbacks (node_dl_cm0.c); reading RDR clears RXNE, which the model is told */
static void slave_rx(void *owner, uint8_t byte, uint32_t t_us)
{
    usart_line_rdr_read(&bench.line);
    urb_rs485_slave_rx(&((urb_node_rs485_t *)owner)->slave, byte, t_us);
}

static bool slave_tx_next(void *owner, uint8_t *byte)
{
    return urb_rs485_slave_tx_next(&((urb_node_rs485_t *)owner)->slave, byte);
}

static uint32_t port_now(void *owner)
{
    (void)owner;
    return now_us();
}

static void wake_at(void *owner, uint32_t at_us)
{
    (void)owner;
    bench.armed = true;
    bench.deadline = at_us;
}

/* Runs the line for `us` microseconds, with the silence timer's interrupt. */
static void run_us(uint32_t us)
{
    for (uint32_t i = 0u; i < 16u * us; i++) {
        usart_line_step(&bench.line);
        if (bench.armed && ((int32_t)(now_us() - bench.deadline) >= 0)) {
            bench.armed = false;
            urb_rs485_slave_poll(&bench.rs485.slave, now_us());
        }
    }
}

static int setup(void **state)
{
    (void)state;
    memset(&bench, 0, sizeof bench);
    bench.line.port = &bench.port;
    usart_line_reset(&bench.line);
    urb_cm0_rs485_owner_t const owner = {&bench.rs485, slave_rx, slave_tx_next, port_now, wake_at, NULL};
    assert_true(urb_cm0_rs485_init(&bench.port, &bench.line.regs, &owner, 48000000u, BAUD));
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
    assert_true(urb_node_rs485_attach(&bench.rs485, &bench.node, &cfg, &bench.port.hal, BAUD, now_us()));
    run_us(100u); /* the start-up silence */
    return 0;
}

/* The bridge sends `frame` back to back; returns the time its last stop bit ended (model steps). */
static uint32_t bus_request(const uint8_t *frame, int32_t len)
{
    assert_true(len > 0);
    for (int32_t i = 0; i < len; i++) {
        usart_line_receive(&bench.line, frame[i]);
        run_us(10u);
    }
    return bench.line.t;
}

/* The node's answer as it went onto the line, decoded. */
static void answer(urb_rs485_response_t *r)
{
    assert_true(bench.line.n_sent > 0u);
    assert_int_equal(urb_rs485_response_decode(r, bench.line.sent, bench.line.n_sent), (int32_t)bench.line.n_sent);
}

static void check_de_around_the_answer(uint32_t request_end)
{
    assert_int_equal(bench.line.de_rises, 1u);
    assert_int_equal(bench.line.de_falls, 1u);
    assert_true(bench.line.de_rise_t > request_end + 16u * 35u); /* after t3.5 of silence (35 us) */
    assert_true(bench.line.de_rise_t + 8u <= bench.line.first_start_t);
    assert_true(bench.line.de_fall_t > bench.line.last_stop_end_t);
    assert_false(bench.line.de);
    assert_false(urb_cm0_rs485_sending(&bench.port));
}

static void test_write_inbox_through_the_usart(void **state)
{
    (void)state;
    urb_rs485_request_t req;
    memset(&req, 0, sizeof req);
    req.address = NODE_ADDRESS;
    req.select.mailbox = 1u;
    req.data_len = BOX_SIZE;
    for (uint8_t i = 0u; i < BOX_SIZE; i++) {
        req.data[i] = (uint8_t)(0xA0u + i);
    }
    uint8_t frame[URB_RS485_MAX_FRAME];
    uint32_t const end = bus_request(frame, urb_rs485_request_encode(&req, frame, sizeof frame));
    run_us(300u);
    urb_rs485_response_t r;
    answer(&r);
    assert_int_equal(r.status, URB_STATUS_OK);
    assert_int_equal(r.mailbox, 1u);
    assert_int_equal(r.data_len, 0u);
    check_de_around_the_answer(end);
    const uint8_t *in = NULL;
    assert_int_equal(urb_node_lock_inbox(&bench.node, 1u, &in), URB_NODE_NEW);
    assert_memory_equal(in, req.data, BOX_SIZE);
    assert_int_equal(urb_node_release_inbox(&bench.node, 1u), URB_NODE_OK);
}

static void test_identification_read_through_the_usart(void **state)
{
    (void)state;
    urb_rs485_request_t req;
    memset(&req, 0, sizeof req);
    req.address = NODE_ADDRESS;
    req.select.mailbox = 0u;
    req.select.read = true;
    uint8_t frame[URB_RS485_MAX_FRAME];
    uint32_t const end = bus_request(frame, urb_rs485_request_encode(&req, frame, sizeof frame));
    run_us(600u);
    urb_rs485_response_t r;
    answer(&r);
    assert_int_equal(r.status, URB_STATUS_OK);
    assert_int_equal(r.mailbox, 0u);
    assert_int_equal(r.data_len, URB_NODE_OUTBOX0_SIZE);
    check_de_around_the_answer(end);
    assert_false(urb_rs485_slave_sending(&bench.rs485.slave));
}

static void test_other_node_gets_no_answer(void **state)
{
    (void)state;
    urb_rs485_request_t req;
    memset(&req, 0, sizeof req);
    req.address = NODE_ADDRESS + 1u;
    req.select.mailbox = 0u;
    req.select.read = true;
    uint8_t frame[URB_RS485_MAX_FRAME];
    (void)bus_request(frame, urb_rs485_request_encode(&req, frame, sizeof frame));
    run_us(600u);
    assert_int_equal(bench.line.n_sent, 0u);
    assert_int_equal(bench.line.de_rises, 0u); /* the driver never came on */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_write_inbox_through_the_usart, setup),
        cmocka_unit_test_setup(test_identification_read_through_the_usart, setup),
        cmocka_unit_test_setup(test_other_node_gets_no_answer, setup),
    };
    return cmocka_run_group_tests_name("cm0_rs485_node", tests, NULL, NULL);
}
