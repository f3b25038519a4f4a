/*
 * cmocka tests of the STM32G0B1 FDCAN port (firmware/hal/cortex-m0plus/urb_cm0_fdcan.c) on the host:
 * the port is given a RAM register block and a RAM message RAM at the part's layout, the test plays
 * the controller (fills Rx FIFO and Tx event elements, sets the FIFO status and the status bits).
 * Checked: the layouts' offsets, the bit timing for 1 Mb/s,
 * 500 and 250 kb/s, the initialisation, a frame queued into the Tx FIFO element (identifier, DLC,
 * bytes, event request), an Rx FIFO element delivered with its start-of-frame time and acknowledged
 * before the owner sees it, frame-sent reports from the Tx event FIFO (none for frames aborted),
 * the error state (bus-off before error-passive) and the recovery, the interrupt lock.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "urb_cm0_fdcan.h"

#define KERNEL_HZ 48000000u
#define ACK_NONE 0xFFFFFFFFu

/* register bits the tests check, from RM0444 (independent of the port's own constants) */
#define CCCR_INIT 0x1u
#define PSR_EP 0x20u
#define PSR_BO 0x80u
#define IR_RF0N 0x1u
#define IR_TEFN 0x400u
#define IR_EP 0x20000u
#define IR_BO 0x80000u
#define T1_EFC 0x800000u

typedef struct {
    urb_cm0_fdcan_regs_t regs;
    urb_cm0_fdcan_ram_t ram;
    urb_cm0_can_t port;
    uint32_t now;
    urb_can_frame_t rx[8];
    uint32_t rx_t[8];
    uint32_t n_rx;
    uint32_t tx_done;
    uint8_t states[8];
    uint32_t n_states;
    uint32_t ack_seen[8]; /* RXF0A / TXEFA as the owner's callback found it */
} bench_t;

static bench_t bench;

static void on_rx(void *owner, const urb_can_frame_t *frame, uint32_t t_us)
{
    bench_t *b = (bench_t *)owner;
    assert_true(b->n_rx < 8u);
    b->ack_seen[b->n_rx] = b->regs.rxf0a;
    b->rx[b->n_rx] = *frame;
    b->rx_t[b->n_rx] = t_us;
    b->n_rx++;
    b->regs.rxf0a = ACK_NONE;
}

static void on_tx_done(void *owner)
{
    bench_t *b = (bench_t *)owner;
    assert_true(b->tx_done < 8u);
    b->ack_seen[b->tx_done] = b->regs.txefa;
    b->tx_done++;
    b->regs.txefa = ACK_NONE;
}

static void on_state(void *owner, uint8_t state)
{
    bench_t *b = (bench_t *)owner;
    assert_true(b->n_states < 8u);
    b->states[b->n_states++] = state;
}

static uint32_t now_us(void *owner)
{
    return ((bench_t *)owner)->now;
}

static int setup_at(uint32_t kbps)
{
    memset(&bench, 0, sizeof bench);
    bench.regs.rxf0a = ACK_NONE;
    bench.regs.txefa = ACK_NONE;
    urb_cm0_can_owner_t const owner = {&bench, on_rx, on_tx_done, on_state, now_us};
    return urb_cm0_can_init(&bench.port, &bench.regs, &bench.ram, &owner, KERNEL_HZ, kbps) ? 0 : -1;
}

static int setup(void **state)
{
    (void)state;
    return setup_at(1000u);
}

/* Puts a classic frame into Rx FIFO 0 element `idx` with start-of-frame stamp `rxts`. */
static void put_rx(uint32_t idx, uint32_t r0, uint32_t dlc, uint32_t rxts, uint32_t w2, uint32_t w3)
{
    bench.ram.rx_fifo0[idx].word[0] = r0;
    bench.ram.rx_fifo0[idx].word[1] = (dlc << 16) | rxts;
    bench.ram.rx_fifo0[idx].word[2] = w2;
    bench.ram.rx_fifo0[idx].word[3] = w3;
}

/* lobster-trace: urb.DLK_008 */
static void test_layouts(void **state)
{
    (void)state;
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, cccr), 0x018u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, nbtp), 0x01Cu);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, tscv), 0x024u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, ecr), 0x040u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, psr), 0x044u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, ir), 0x050u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, ile), 0x05Cu);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, rxgfc), 0x080u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, rxf0s), 0x090u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, rxf0a), 0x094u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, txbc), 0x0C0u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, txbar), 0x0CCu);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, txefs), 0x0E4u);
    assert_int_equal(offsetof(urb_cm0_fdcan_regs_t, txefa), 0x0E8u);
    assert_int_equal(offsetof(urb_cm0_fdcan_ram_t, ext_filter), 0x070u);
    assert_int_equal(offsetof(urb_cm0_fdcan_ram_t, rx_fifo0), 0x0B0u);
    assert_int_equal(offsetof(urb_cm0_fdcan_ram_t, rx_fifo1), 0x188u);
    assert_int_equal(offsetof(urb_cm0_fdcan_ram_t, tx_event), 0x260u);
    assert_int_equal(offsetof(urb_cm0_fdcan_ram_t, tx_buffer), 0x278u);
    assert_int_equal(sizeof(urb_cm0_fdcan_ram_t), URB_CM0_SRAMCAN_BYTES);
}

/* The rate and sample point an NBTP value gives, decoded as RM0444 defines the fields. */
static void check_nbtp(uint32_t nbtp, uint32_t kernel_hz, uint32_t kbps)
{
    uint32_t const sjw = (nbtp >> 25) + 1u;
    uint32_t const brp = ((nbtp >> 16) & 0x1FFu) + 1u;
    uint32_t const tseg1 = ((nbtp >> 8) & 0xFFu) + 1u;
    uint32_t const tseg2 = (nbtp & 0x7Fu) + 1u;
    uint32_t const tq = 1u + tseg1 + tseg2;
    assert_int_equal(kernel_hz, brp * tq * kbps * 1000u);   /* exactly the rate */
    assert_int_equal(((1u + tseg1) * 1000u) / tq, 875u);    /* sample point 87.5 % */
    assert_true((sjw >= 1u) && (sjw <= tseg2));
    assert_true((tq >= 8u) && (tq <= 25u));
}

static void test_bit_timing(void **state)
{
    (void)state;
    static const struct {
        uint32_t kbps;
        uint32_t nbtp;
    } want[] = {
        {1000u, (2u << 25) | (1u << 16) | (19u << 8) | 2u}, /* brp 2, 24 tq = 1 + 20 + 3, sjw 3 */
        {500u, (2u << 25) | (3u << 16) | (19u << 8) | 2u},  /* brp 4 */
        {250u, (2u << 25) | (7u << 16) | (19u << 8) | 2u},  /* brp 8 */
    };
    for (size_t i = 0u; i < sizeof want / sizeof want[0]; i++) {
        urb_cm0_can_timing_t t;
        assert_true(urb_cm0_can_timing(KERNEL_HZ, want[i].kbps, &t));
        assert_int_equal(urb_cm0_can_nbtp(&t), want[i].nbtp);
        check_nbtp(urb_cm0_can_nbtp(&t), KERNEL_HZ, want[i].kbps);
        assert_int_equal(setup_at(want[i].kbps), 0);
        assert_int_equal(bench.regs.nbtp, want[i].nbtp);
    }
    /* other clocks: 64 MHz and 16 MHz give exact rates too */
    static const uint32_t clocks[] = {64000000u, 16000000u};
    static const uint32_t rates[] = {1000u, 500u, 250u};
    for (size_t c = 0u; c < 2u; c++) {
        for (size_t r = 0u; r < 3u; r++) {
            urb_cm0_can_timing_t t;
            assert_true(urb_cm0_can_timing(clocks[c], rates[r], &t));
            check_nbtp(urb_cm0_can_nbtp(&t), clocks[c], rates[r]);
        }
    }
    /* few quanta: phase 2 stays at its minimum of 2 (8 MHz, 1 Mb/s: 8 tq = 1 + 5 + 2) */
    urb_cm0_can_timing_t t;
    assert_true(urb_cm0_can_timing(8000000u, 1000u, &t));
    assert_int_equal(t.brp, 1u);
    assert_int_equal(t.tseg1, 5u);
    assert_int_equal(t.tseg2, 2u);
    assert_int_equal(t.sjw, 2u);
    /* no exact timing: refused, and init refuses the rate */
    assert_false(urb_cm0_can_timing(KERNEL_HZ, 333u, &t));
    assert_false(urb_cm0_can_timing(4000000u, 1000u, &t));
    assert_false(urb_cm0_can_timing(KERNEL_HZ, 0u, &t));
    assert_false(urb_cm0_can_timing(KERNEL_HZ, 1000u, NULL));
    assert_false(urb_cm0_can_timing(0u, 1000u, &t));       /* no clock: prescaler 0 */
    assert_false(urb_cm0_can_timing(KERNEL_HZ, 1u, &t));   /* 1 kb/s: the prescaler would pass 512 */
    assert_int_equal(setup_at(333u), -1);
    assert_int_equal(bench.regs.cccr & CCCR_INIT, CCCR_INIT); /* left in initialisation mode */
    /* an exact timing but no whole number of microseconds per bit (the time stamps' unit) */
    assert_true(urb_cm0_can_timing(KERNEL_HZ, 300u, &t));
    assert_int_equal(setup_at(300u), -1);
    assert_int_equal(setup_at(0u), -1);
}

static void test_init_joins_the_bus(void **state)
{
    (void)state;
    assert_int_equal(bench.regs.cccr & 0x303u, 0u);         /* INIT, CCE, FDOE, BRSE clear */
    assert_int_equal(bench.regs.cccr & 0x40u, 0u);          /* DAR clear: automatic retransmission */
    assert_int_equal(bench.regs.txbc & (1u << 24), 0u);     /* Tx FIFO mode: frames leave in order */
    assert_int_equal(bench.regs.rxgfc & 0x30u, 0u);         /* non-matching 11-bit frames to Rx FIFO 0 */
    assert_int_equal(bench.regs.rxgfc & 0x3u, 0x3u);        /* remote frames rejected */
    uint32_t const ie = IR_RF0N | IR_TEFN | IR_BO | IR_EP;
    assert_int_equal(bench.regs.ie & ie, ie);
    assert_int_equal(bench.regs.ils, 0u);
    assert_int_equal(bench.regs.ile, 1u);
    assert_non_null(bench.port.hal.tx);
    assert_non_null(bench.port.hal.tx_abort);
    assert_non_null(bench.port.hal.recover);
    assert_non_null(bench.port.hal.state);
}

static void test_tx_frame_in_fifo_element(void **state)
{
    (void)state;
    urb_can_frame_t f = {0x5A3u, 7u, {0x11u, 0x22u, 0x33u, 0x44u, 0x55u, 0x66u, 0x77u, 0xEEu}};
    bench.regs.txfqs = 1u << 16; /* put index 1 */
    assert_true(bench.port.hal.tx(bench.port.hal.ctx, &f));
    urb_cm0_fdcan_element_t const *e = &bench.ram.tx_buffer[1];
    assert_int_equal(e->word[0], 0x5A3u << 18);   /* standard identifier in ID[28:18], XTD, RTR clear */
    assert_int_equal((e->word[1] >> 16) & 0xFu, 7u); /* DLC */
    assert_int_equal(e->word[1] & T1_EFC, T1_EFC);  /* a Tx event is stored: the frame-sent report */
    assert_int_equal(e->word[1] & (3u << 20), 0u);  /* classic format, no bit-rate switch */
    assert_int_equal(e->word[2], 0x44332211u);      /* byte 0 in the least significant byte */
    assert_int_equal(e->word[3], 0x00776655u);      /* the eighth byte is beyond len: not sent */
    assert_int_equal(bench.regs.txbar, 1u << 1);
    assert_int_equal(bench.ram.tx_buffer[0].word[0], 0u);
    /* a full FIFO refuses and writes nothing */
    bench.regs.txbar = 0u;
    bench.regs.txfqs = (1u << 21) | (2u << 16);
    f.id = 0x001u;
    assert_false(bench.port.hal.tx(bench.port.hal.ctx, &f));
    assert_int_equal(bench.regs.txbar, 0u);
    assert_int_equal(bench.ram.tx_buffer[2].word[0], 0u);
    /* a put index the FIFO does not have (a controller not configured): refused */
    bench.regs.txfqs = 3u << 16;
    assert_false(bench.port.hal.tx(bench.port.hal.ctx, &f));
    assert_int_equal(bench.regs.txbar, 0u);
}

/* lobster-trace: urb.DLK_008 */
static void test_rx_element_delivered_and_acknowledged(void **state)
{
    (void)state;
    put_rx(2u, 0x123u << 18, 8u, 0u, 0x04030201u, 0x08070605u);
    put_rx(0u, 0x7FFu << 18, 2u, 0u, 0x0000BBAAu, 0u);
    bench.regs.rxf0s = 2u | (2u << 8); /* two elements, oldest at index 2 */
    bench.regs.ir = IR_RF0N;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_rx, 2u);
    assert_int_equal(bench.rx[0].id, 0x123u);
    assert_int_equal(bench.rx[0].len, 8u);
    static const uint8_t bytes[] = {1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u};
    assert_memory_equal(bench.rx[0].data, bytes, 8u);
    assert_int_equal(bench.rx[1].id, 0x7FFu);
    assert_int_equal(bench.rx[1].len, 2u);
    assert_int_equal(bench.rx[1].data[0], 0xAAu);
    assert_int_equal(bench.rx[1].data[1], 0xBBu);
    /* each element was acknowledged by its index before its owner saw it */
    assert_int_equal(bench.ack_seen[0], 2u);
    assert_int_equal(bench.ack_seen[1], 0u);
    assert_int_equal(bench.regs.ir, IR_RF0N); /* the flag was written back (write 1 to clear) */
}

static void test_rx_time_stamp_is_start_of_frame(void **state)
{
    (void)state;
    /* 1 Mb/s: the stamp counter counts microseconds; the frame started 130 bits before now */
    bench.now = 500000u;
    bench.regs.tscv = 1000u;
    put_rx(0u, 0x010u << 18, 1u, 870u, 0x5Au, 0u);
    bench.regs.rxf0s = 1u;
    bench.regs.ir = IR_RF0N;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_rx, 1u);
    assert_int_equal(bench.rx_t[0], 500000u - 130u);
    /* across the 16-bit counter's wrap, at 250 kb/s (4 us per bit) */
    assert_int_equal(setup_at(250u), 0);
    bench.now = 100u; /* and across the microsecond clock's wrap */
    bench.regs.tscv = 0x0010u;
    put_rx(1u, 0x010u << 18, 1u, 0xFFF0u, 0x5Au, 0u);
    bench.regs.rxf0s = 1u | (1u << 8);
    bench.regs.ir = IR_RF0N;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_rx, 1u);
    assert_int_equal(bench.rx_t[0], (uint32_t)(100u - 32u * 4u));
}

static void test_not_urb_frames_dropped_but_acknowledged(void **state)
{
    (void)state;
    put_rx(0u, (1u << 30) | 0x1234567u, 8u, 0u, 0u, 0u); /* 29-bit */
    bench.regs.rxf0s = 1u;
    bench.regs.ir = IR_RF0N;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_rx, 0u);
    assert_int_equal(bench.regs.rxf0a, 0u);
    put_rx(1u, 0x100u << 18, 8u, 0u, 0u, 0u);
    bench.ram.rx_fifo0[1].word[1] |= 1u << 21; /* an FD frame */
    bench.regs.rxf0s = 1u | (1u << 8);
    bench.regs.ir = IR_RF0N;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_rx, 0u);
    assert_int_equal(bench.regs.rxf0a, 1u);
}

static void events(uint32_t first, uint32_t n, const uint32_t *marker);

static void test_fifo_status_bounds(void **state)
{
    (void)state;
    /* a classic frame with DLC 9..15 carries 8 bytes */
    put_rx(0u, 0x200u << 18, 15u, 0u, 0x44332211u, 0x88776655u);
    bench.regs.rxf0s = 1u;
    bench.regs.ir = IR_RF0N;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_rx, 1u);
    assert_int_equal(bench.rx[0].len, 8u);
    /* a fill level above the FIFO's 3 elements: at most 3 taken per interrupt */
    for (uint32_t i = 0u; i < 3u; i++) {
        put_rx(i, 0x201u << 18, 1u, 0u, i, 0u);
    }
    bench.n_rx = 0u;
    bench.regs.rxf0s = 5u;
    bench.regs.ir = IR_RF0N;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_rx, 3u);
    /* a get index the FIFO does not have: nothing taken */
    bench.n_rx = 0u;
    bench.regs.rxf0s = 1u | (3u << 8);
    bench.regs.ir = IR_RF0N;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_rx, 0u);
    /* the same bounds on the Tx event FIFO */
    urb_can_frame_t f = {0x100u, 1u, {9u}};
    assert_true(bench.port.hal.tx(bench.port.hal.ctx, &f));
    uint32_t const mm = bench.ram.tx_buffer[0].word[1] >> 24;
    uint32_t const markers[] = {mm, mm, mm};
    events(0u, 3u, markers);
    bench.regs.txefs = 7u; /* fill level 7 */
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.tx_done, 3u);
    bench.regs.txefs = 1u | (3u << 8);
    bench.regs.ir = IR_TEFN;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.tx_done, 3u);
}

/* The controller sent `n` frames: their events, with the marker the port gave each, in the FIFO. */
static void events(uint32_t first, uint32_t n, const uint32_t *marker)
{
    for (uint32_t i = 0u; i < n; i++) {
        bench.ram.tx_event[2u * ((first + i) % 3u) + 1u] = (marker[i] << 24) | (1u << 22);
    }
    bench.regs.txefs = n | (first << 8);
    bench.regs.ir = IR_TEFN;
}

static void test_tx_events_report_each_frame_once(void **state)
{
    (void)state;
    urb_can_frame_t f = {0x100u, 1u, {9u}};
    assert_true(bench.port.hal.tx(bench.port.hal.ctx, &f));
    uint32_t const mm = bench.ram.tx_buffer[0].word[1] >> 24;
    uint32_t const markers[] = {mm, mm};
    events(2u, 2u, markers);
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.tx_done, 2u);
    assert_int_equal(bench.ack_seen[0], 2u); /* acknowledged, oldest first (index 2, then 0) */
    assert_int_equal(bench.ack_seen[1], 0u);
    /* no new entry flag: nothing is reported */
    bench.regs.ir = 0u;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.tx_done, 2u);
}

static void test_abort_drops_late_event(void **state)
{
    (void)state;
    urb_can_frame_t f = {0x100u, 1u, {9u}};
    bench.regs.txfqs = 0u;
    assert_true(bench.port.hal.tx(bench.port.hal.ctx, &f));
    uint32_t const before = bench.ram.tx_buffer[0].word[1] >> 24;
    bench.regs.txbrp = 0x5u;
    bench.port.hal.tx_abort(bench.port.hal.ctx);
    assert_int_equal(bench.regs.txbcr, 0x5u); /* every pending request cancelled */
    /* the frame was already on the bus and completed: its event has the old marker */
    events(0u, 1u, &before);
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.tx_done, 0u);
    assert_int_equal(bench.regs.txefa, 0u); /* acknowledged all the same */
    urb_cm0_can_stats_t st;
    urb_cm0_can_stats(&bench.port, &st);
    assert_int_equal(st.stale_events, 1u);
    /* a frame queued after the abort is reported */
    assert_true(bench.port.hal.tx(bench.port.hal.ctx, &f));
    uint32_t const after = bench.ram.tx_buffer[0].word[1] >> 24;
    assert_int_not_equal(after, before);
    events(1u, 1u, &after);
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.tx_done, 1u);
    assert_int_equal(bench.ack_seen[0], 1u);
}

static void test_bus_off_state(void **state)
{
    (void)state;
    assert_int_equal(bench.port.hal.state(bench.port.hal.ctx), URB_CAN_ERROR_ACTIVE);
    bench.regs.psr = PSR_EP;
    bench.regs.ir = IR_EP;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.port.hal.state(bench.port.hal.ctx), URB_CAN_ERROR_PASSIVE);
    /* bus-off: the controller keeps EP set (TEC > 255) and sets BO, and INIT */
    bench.regs.psr = PSR_EP | PSR_BO;
    bench.regs.cccr |= CCCR_INIT;
    bench.regs.ir = IR_BO;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.port.hal.state(bench.port.hal.ctx), URB_CAN_BUS_OFF);
    assert_int_equal(bench.n_states, 2u);
    assert_int_equal(bench.states[0], URB_CAN_ERROR_PASSIVE);
    assert_int_equal(bench.states[1], URB_CAN_BUS_OFF);
    /* the same state again is not reported again */
    bench.regs.ir = IR_BO;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_states, 2u);
    /* recovery: leaving INIT starts the 128 x 11 recessive bits; back to active afterwards */
    bench.port.hal.recover(bench.port.hal.ctx);
    assert_int_equal(bench.regs.cccr & CCCR_INIT, 0u);
    bench.regs.psr = 0u;
    bench.regs.ir = IR_BO;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_states, 3u);
    assert_int_equal(bench.states[2], URB_CAN_ERROR_ACTIVE);
    /* a recovery asked for without bus-off (the master's clear): INIT entered and left again */
    bench.regs.cccr = 0u;
    bench.port.hal.recover(bench.port.hal.ctx);
    assert_int_equal(bench.regs.cccr & CCCR_INIT, 0u);
    /* an owner without on_state: the state is tracked, nothing reported */
    bench.port.owner.on_state = NULL;
    bench.regs.psr = PSR_BO;
    bench.regs.ir = IR_BO;
    urb_cm0_can_irq(&bench.port);
    assert_int_equal(bench.n_states, 3u);
    assert_int_equal(bench.port.hal.state(bench.port.hal.ctx), URB_CAN_BUS_OFF);
}

/* lobster-trace: urb.DLK_008 */
static void test_lost_elements_counted(void **state)
{
    (void)state;
    bench.regs.ir = 0x4u; /* RF0L: Rx FIFO 0 was full, a frame was lost */
    urb_cm0_can_irq(&bench.port);
    bench.regs.ir = 0x1000u; /* TEFL: a Tx event was lost */
    urb_cm0_can_irq(&bench.port);
    urb_cm0_can_stats_t st;
    urb_cm0_can_stats(&bench.port, &st);
    assert_int_equal(st.rx_lost, 1u);
    assert_int_equal(st.events_lost, 1u);
    assert_int_equal(bench.n_rx, 0u);
    assert_int_equal(bench.tx_done, 0u);
}

static void test_lock_masks_the_line(void **state)
{
    (void)state;
    bench.port.hal.lock(bench.port.hal.ctx, true);
    assert_int_equal(bench.regs.ile, 0u);
    bench.port.hal.lock(bench.port.hal.ctx, false);
    assert_int_equal(bench.regs.ile, 1u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_layouts, setup),
        cmocka_unit_test_setup(test_bit_timing, setup),
        cmocka_unit_test_setup(test_init_joins_the_bus, setup),
        cmocka_unit_test_setup(test_tx_frame_in_fifo_element, setup),
        cmocka_unit_test_setup(test_rx_element_delivered_and_acknowledged, setup),
        cmocka_unit_test_setup(test_rx_time_stamp_is_start_of_frame, setup),
        cmocka_unit_test_setup(test_not_urb_frames_dropped_but_acknowledged, setup),
        cmocka_unit_test_setup(test_fifo_status_bounds, setup),
        cmocka_unit_test_setup(test_tx_events_report_each_frame_once, setup),
        cmocka_unit_test_setup(test_abort_drops_late_event, setup),
        cmocka_unit_test_setup(test_bus_off_state, setup),
        cmocka_unit_test_setup(test_lost_elements_counted, setup),
        cmocka_unit_test_setup(test_lock_masks_the_line, setup),
    };
    return cmocka_run_group_tests_name("cm0_can", tests, NULL, NULL);
}
