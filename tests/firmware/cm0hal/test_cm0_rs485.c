/*
 * cmocka tests of the STM32G0B1 USART RS485 port (firmware/hal/cortex-m0plus/urb_cm0_usart485.c) on
 * the host: the port runs against a RAM register block driven by a model of the USART's transmitter,
 * receiver and driver-enable output (usart_line.h). Checked: the register layout, the baud rate
 * divider, the driver enable (asserted before the first start bit, held between characters,
 * released only after the last stop bit, low while idle), the frame on the line and its echo, an
 * abort (the line released at once, nothing of the frame sent later), and the receive path
 * with its time stamps and its error counting.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "urb_cm0_usart485.h"
#include "usart_line.h"

#define KERNEL_HZ 48000000u

typedef struct {
    usart_line_t line;
    urb_cm0_rs485_t port;
    const uint8_t *tx;
    uint32_t tx_len, tx_pos;
    uint8_t rx[USART_LINE_MAX_BYTES];
    uint32_t rx_t[USART_LINE_MAX_BYTES];
    uint32_t n_rx;
    uint32_t wakes, last_wake;
    uint32_t locks;
} bench_t;

static bench_t bench;

static void on_rx(void *owner, uint8_t byte, uint32_t t_us)
{
    bench_t *b = (bench_t *)owner;
    usart_line_rdr_read(&b->line);
    if (b->n_rx < USART_LINE_MAX_BYTES) {
        b->rx[b->n_rx] = byte;
        b->rx_t[b->n_rx] = t_us;
    }
    b->n_rx++;
}

static bool on_tx_next(void *owner, uint8_t *byte)
{
    bench_t *b = (bench_t *)owner;
    if (b->tx_pos >= b->tx_len) {
        return false;
    }
    *byte = b->tx[b->tx_pos++];
    return true;
}

/* 1 Mb/s: one bit is one microsecond, sixteen model steps */
static uint32_t now_us(void *owner)
{
    return ((bench_t *)owner)->line.t / 16u;
}

static void wake_at(void *owner, uint32_t at_us)
{
    bench_t *b = (bench_t *)owner;
    b->wakes++;
    b->last_wake = at_us;
}

static void lock(void *owner, bool locked)
{
    bench_t *b = (bench_t *)owner;
    b->locks += locked ? 1u : 0u;
}

static int setup(void **state)
{
    (void)state;
    memset(&bench, 0, sizeof bench);
    bench.line.port = &bench.port;
    usart_line_reset(&bench.line);
    urb_cm0_rs485_owner_t const owner = {&bench, on_rx, on_tx_next, now_us, wake_at, lock};
    assert_true(urb_cm0_rs485_init(&bench.port, &bench.line.regs, &owner, KERNEL_HZ, 1000000u));
    usart_line_step(&bench.line); /* the flags init's ICR write clears */
    return 0;
}

static void test_register_layout(void **state)
{
    (void)state;
    assert_int_equal(offsetof(urb_cm0_usart_regs_t, cr3), 0x08u);
    assert_int_equal(offsetof(urb_cm0_usart_regs_t, brr), 0x0Cu);
    assert_int_equal(offsetof(urb_cm0_usart_regs_t, isr), 0x1Cu);
    assert_int_equal(offsetof(urb_cm0_usart_regs_t, icr), 0x20u);
    assert_int_equal(offsetof(urb_cm0_usart_regs_t, rdr), 0x24u);
    assert_int_equal(offsetof(urb_cm0_usart_regs_t, tdr), 0x28u);
    assert_int_equal(offsetof(urb_cm0_usart_regs_t, presc), 0x2Cu);
}

static void test_baud_rate_divider(void **state)
{
    (void)state;
    assert_int_equal(urb_cm0_rs485_brr(KERNEL_HZ, 1000000u), 48u);
    assert_int_equal(urb_cm0_rs485_brr(KERNEL_HZ, 500000u), 96u);
    assert_int_equal(urb_cm0_rs485_brr(KERNEL_HZ, 115200u), 417u); /* 416.67: the nearest, 0.08 % fast */
    assert_int_equal(urb_cm0_rs485_brr(16000000u, 1000000u), 16u);
    assert_int_equal(urb_cm0_rs485_brr(8000000u, 1000000u), 0u); /* below 16: out of reach */
    assert_int_equal(urb_cm0_rs485_brr(KERNEL_HZ, 0u), 0u);
    assert_int_equal(bench.line.regs.brr, 48u);
    /* a refused rate leaves the USART disabled */
    urb_cm0_rs485_owner_t const owner = {&bench, on_rx, on_tx_next, now_us, NULL, NULL};
    urb_cm0_rs485_t other;
    urb_cm0_usart_regs_t regs;
    memset(&regs, 0xFF, sizeof regs);
    assert_false(urb_cm0_rs485_init(&other, &regs, &owner, 8000000u, 1000000u));
    assert_int_equal(regs.cr1 & URB_CM0_USART_CR1_UE, 0u);
    assert_null(other.hal.wake_at);
    assert_null(other.hal.lock);
}

static void test_configuration(void **state)
{
    (void)state;
    urb_cm0_usart_regs_t const *r = &bench.line.regs;
    assert_int_equal(r->cr3 & (URB_CM0_USART_CR3_DEM | URB_CM0_USART_CR3_DEP), URB_CM0_USART_CR3_DEM);
    assert_int_equal((r->cr1 >> URB_CM0_USART_CR1_DEAT_SHIFT) & 0x1Fu, URB_CM0_RS485_DE_SIXTEENTHS);
    assert_int_equal((r->cr1 >> URB_CM0_USART_CR1_DEDT_SHIFT) & 0x1Fu, URB_CM0_RS485_DE_SIXTEENTHS);
    uint32_t const on = URB_CM0_USART_CR1_UE | URB_CM0_USART_CR1_RE | URB_CM0_USART_CR1_TE | URB_CM0_USART_CR1_RXNEIE;
    assert_int_equal(r->cr1 & on, on);
    assert_int_equal(r->cr1 & (URB_CM0_USART_CR1_TXEIE | URB_CM0_USART_CR1_TCIE), 0u);
    /* wake_at and lock are the owner's, passed through */
    bench.port.hal.wake_at(bench.port.hal.ctx, 1234u);
    assert_int_equal(bench.last_wake, 1234u);
    bench.port.hal.lock(bench.port.hal.ctx, true);
    assert_int_equal(bench.locks, 1u);
}

static void test_de_spans_the_frame(void **state)
{
    (void)state;
    static const uint8_t frame[] = {0x05u, 0x11u, 0xA5u, 0x5Au, 0xFFu};
    bench.tx = frame;
    bench.tx_len = sizeof frame;
    usart_line_run(&bench.line, 100u);
    assert_false(bench.line.de); /* idle: driver off */
    assert_int_equal(bench.line.de_rises, 0u);
    bench.port.hal.tx_start(bench.port.hal.ctx);
    assert_true(urb_cm0_rs485_sending(&bench.port));
    usart_line_run(&bench.line, 16u * 10u * (uint32_t)sizeof frame + 200u);
    /* the bytes, in order, on the line, and heard back */
    assert_int_equal(bench.line.n_sent, sizeof frame);
    assert_memory_equal(bench.line.sent, frame, sizeof frame);
    assert_int_equal(bench.n_rx, sizeof frame);
    assert_memory_equal(bench.rx, frame, sizeof frame);
    /* one DE pulse: asserted at least half a bit before the first start bit, released only after
     * the last stop bit, nothing in between */
    assert_int_equal(bench.line.de_rises, 1u);
    assert_int_equal(bench.line.de_falls, 1u);
    assert_true(bench.line.de_rise_t + 8u <= bench.line.first_start_t);
    assert_true(bench.line.de_fall_t > bench.line.last_stop_end_t);
    assert_int_equal(bench.line.last_stop_end_t - bench.line.first_start_t, 160u * sizeof frame);
    assert_false(bench.line.de);
    /* the port knows the frame ended only when the last stop bit was out */
    assert_false(urb_cm0_rs485_sending(&bench.port));
    assert_int_equal(bench.line.regs.cr1 & (URB_CM0_USART_CR1_TXEIE | URB_CM0_USART_CR1_TCIE), 0u);
    /* the echo's time stamps: one character (10 us at 1 Mb/s) apart */
    for (uint32_t i = 1u; i < sizeof frame; i++) {
        assert_int_equal(bench.rx_t[i] - bench.rx_t[i - 1u], 10u);
    }
}

static void test_sending_until_last_stop_bit(void **state)
{
    (void)state;
    static const uint8_t frame[] = {0x42u};
    bench.tx = frame;
    bench.tx_len = sizeof frame;
    bench.port.hal.tx_start(bench.port.hal.ctx);
    /* step until the port has been told there is nothing more (its TXE after the only byte) */
    uint32_t guard = 0u;
    while ((bench.line.regs.cr1 & URB_CM0_USART_CR1_TXEIE) != 0u) {
        usart_line_step(&bench.line);
        assert_true(++guard < 1000u);
    }
    assert_true(bench.line.n_sent == 0u);               /* the byte is still in the shift register */
    assert_true(urb_cm0_rs485_sending(&bench.port));     /* ... so the port is still sending */
    while (bench.line.n_sent == 0u) {
        usart_line_step(&bench.line);
        assert_true(urb_cm0_rs485_sending(&bench.port) || (bench.line.n_sent == 1u));
        assert_true(++guard < 1000u);
    }
    usart_line_run(&bench.line, 4u);
    assert_false(urb_cm0_rs485_sending(&bench.port));
    usart_line_run(&bench.line, 40u); /* past DEDT: the driver is off */
    assert_false(bench.line.de);
    /* a second frame goes out the same way */
    bench.tx_pos = 0u;
    bench.port.hal.tx_start(bench.port.hal.ctx);
    usart_line_run(&bench.line, 400u);
    assert_int_equal(bench.line.n_sent, 2u);
    assert_int_equal(bench.line.de_rises, 2u);
    assert_int_equal(bench.line.de_falls, 2u);
}

static void test_abort_stops_at_once(void **state)
{
    (void)state;
    static const uint8_t frame[] = {0x01u, 0x02u, 0x03u, 0x04u, 0x05u, 0x06u};
    bench.tx = frame;
    bench.tx_len = sizeof frame;
    bench.port.hal.tx_start(bench.port.hal.ctx);
    /* into the second character, with the third waiting in TDR */
    uint32_t guard = 0u;
    while (!((bench.line.n_sent == 1u) && (bench.line.regs.tdr != USART_LINE_TDR_EMPTY))) {
        usart_line_step(&bench.line);
        assert_true(++guard < 2000u);
    }
    usart_line_run(&bench.line, 20u);
    uint32_t const abort_t = bench.line.t;
    bench.port.hal.tx_abort(bench.port.hal.ctx);
    assert_false(urb_cm0_rs485_sending(&bench.port));
    assert_int_equal(bench.line.disables, 1u);
    usart_line_run(&bench.line, 1000u);
    assert_int_equal(bench.line.n_sent, 1u); /* the character being sent was cut, the waiting one dropped */
    assert_false(bench.line.de);
    assert_int_equal(bench.line.de_falls, 1u);
    assert_true(bench.line.de_fall_t <= abort_t + 1u); /* released at once */
    /* the receiver stayed on */
    uint32_t const heard = bench.n_rx;
    usart_line_receive(&bench.line, 0x3Cu);
    usart_line_run(&bench.line, 2u);
    assert_int_equal(bench.n_rx, heard + 1u);
    /* the next frame starts cleanly: no byte of the aborted one in front of it */
    bench.tx_pos = 0u;
    bench.port.hal.tx_start(bench.port.hal.ctx);
    usart_line_run(&bench.line, 16u * 10u * 8u);
    assert_int_equal(bench.line.n_sent, 1u + sizeof frame);
    assert_memory_equal(&bench.line.sent[1], frame, sizeof frame);
}

static void test_receive_with_time_stamps(void **state)
{
    (void)state;
    usart_line_run(&bench.line, 16u * 50u);
    usart_line_receive(&bench.line, 0x81u);
    usart_line_run(&bench.line, 16u * 10u);
    usart_line_receive(&bench.line, 0x7Eu);
    usart_line_run(&bench.line, 2u);
    assert_int_equal(bench.n_rx, 2u);
    assert_int_equal(bench.rx[0], 0x81u);
    assert_int_equal(bench.rx[1], 0x7Eu);
    assert_int_equal(bench.rx_t[0], 50u);
    assert_int_equal(bench.rx_t[1], 60u);
    assert_false(bench.line.de); /* receiving never drives */
}

static void test_overrun_counted_and_cleared(void **state)
{
    (void)state;
    bench.line.regs.cr1 &= ~URB_CM0_USART_CR1_RXNEIE; /* hold the interrupt off: two bytes pile up */
    usart_line_receive(&bench.line, 0x11u);
    usart_line_receive(&bench.line, 0x22u);
    bench.line.regs.isr |= URB_CM0_USART_ISR_FE;
    bench.line.regs.cr1 |= URB_CM0_USART_CR1_RXNEIE;
    usart_line_run(&bench.line, 3u);
    urb_cm0_rs485_stats_t st;
    urb_cm0_rs485_stats(&bench.port, &st);
    assert_int_equal(st.overruns, 1u);
    assert_int_equal(st.line_errors, 1u);
    assert_int_equal(bench.n_rx, 1u); /* the byte that was kept */
    assert_int_equal(bench.rx[0], 0x22u);
    assert_int_equal(bench.line.regs.isr & (URB_CM0_USART_ISR_ORE | URB_CM0_USART_ISR_FE), 0u);
    assert_true(bench.line.irqs <= 2u); /* the flags were cleared: no interrupt storm */
}

static void test_interrupt_sources_apart(void **state)
{
    (void)state;
    /* an overrun alone, then a framing error alone: each counted once, in its own counter */
    bench.line.regs.isr = URB_CM0_USART_ISR_ORE | URB_CM0_USART_ISR_TXE;
    urb_cm0_rs485_irq(&bench.port);
    bench.line.regs.isr = URB_CM0_USART_ISR_FE | URB_CM0_USART_ISR_TXE;
    urb_cm0_rs485_irq(&bench.port);
    urb_cm0_rs485_stats_t st;
    urb_cm0_rs485_stats(&bench.port, &st);
    assert_int_equal(st.overruns, 1u);
    assert_int_equal(st.line_errors, 1u);
    /* transmit interrupts enabled but their flags clear (TDR full, the character still going out):
     * a received byte is taken, nothing is pulled from the owner, sending goes on */
    static const uint8_t frame[] = {0x55u};
    bench.tx = frame;
    bench.tx_len = sizeof frame;
    bench.port.hal.tx_start(bench.port.hal.ctx);
    bench.line.regs.cr1 |= URB_CM0_USART_CR1_TCIE;
    bench.line.regs.isr = URB_CM0_USART_ISR_RXNE;
    bench.line.regs.rdr = 0x3Cu;
    urb_cm0_rs485_irq(&bench.port);
    assert_int_equal(bench.n_rx, 1u);
    assert_int_equal(bench.tx_pos, 0u);
    assert_true(urb_cm0_rs485_sending(&bench.port));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_register_layout, setup),
        cmocka_unit_test_setup(test_baud_rate_divider, setup),
        cmocka_unit_test_setup(test_configuration, setup),
        cmocka_unit_test_setup(test_de_spans_the_frame, setup),
        cmocka_unit_test_setup(test_sending_until_last_stop_bit, setup),
        cmocka_unit_test_setup(test_abort_stops_at_once, setup),
        cmocka_unit_test_setup(test_receive_with_time_stamps, setup),
        cmocka_unit_test_setup(test_overrun_counted_and_cleared, setup),
        cmocka_unit_test_setup(test_interrupt_sources_apart, setup),
    };
    return cmocka_run_group_tests_name("cm0_rs485", tests, NULL, NULL);
}
