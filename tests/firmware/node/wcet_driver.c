/*
 * Worst-case instruction counts of the node's interrupt handlers (make wcet-node): every
 * scenario brings a node into the state where one handler call does the most work it can, then
 * makes exactly that call inside a `wcet_*` function. tests/firmware/node/wcet.py runs this under
 * valgrind --tool=callgrind --toggle-collect='wcet_*' and reports each wrapper's inclusive count
 * (the handler plus the hosted HAL calls it makes: now(), set_compare(), mark()).
 *
 * Built with the production library (no URB_NODE_TESTING hooks) at -O2.
 */
#include <stdio.h>
#include <string.h>

#include "node_fixture.h"
#include "urb_core.h"

#define NOINLINE __attribute__((noinline, noclone)) /* and -fno-ipa-icf: one wrapper per scenario */

static fixture_t fx;
static volatile uint16_t sink;

static urb_node_t *fresh(void)
{
    fx_defaults(&fx); /* inbox 2 and outbox 2 have 20 bytes: the CRC-16 tier, the costlier one */
    fx.cfg.max_gap = 255u;
    if (fx_start(&fx) != URB_NODE_OK) {
        fprintf(stderr, "wcet: node init failed\n");
    }
    return &fx.node;
}

/* A complete, checked write of inbox 2 waiting for its STOP. */
static void pending_write(urb_node_t *node, uint8_t corrupt, size_t cut)
{
    uint8_t data[20];
    for (uint8_t i = 0u; i < 20u; i++) {
        data[i] = (uint8_t)(0x5Au ^ i);
    }
    uint8_t frame[40];
    size_t const n = fx_frame(frame, 2u, data, 20u, corrupt);
    (void)fx_write_raw(node, frame, n - cut, false);
}

static uint8_t last_check_byte(void)
{
    uint8_t data[20];
    for (uint8_t i = 0u; i < 20u; i++) {
        data[i] = (uint8_t)(0x5Au ^ i);
    }
    uint8_t frame[40];
    size_t const n = fx_frame(frame, 2u, data, 20u, 0u);
    return frame[n - 1u];
}

/* A complete read of outbox 0 (Identification: 25 bytes + CRC-16), not yet ended. */
static void complete_id_read(urb_node_t *node)
{
    (void)fx_select(node, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
    for (size_t i = 0u; i < 27u; i++) {
        (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    }
}

/* ----- I2C events ----- */

NOINLINE static void wcet_i2c_restart_commits(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_ADDR_WRITE, 0u); /* repeated START: commit, then select */
}

NOINLINE static void wcet_i2c_stop_commits(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_STOP, 0u);
}

NOINLINE static void wcet_i2c_rx_select(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x02u); /* CRC-16 tier: init + one byte */
}

NOINLINE static void wcet_i2c_rx_first_data(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x11u); /* IsrWriteBegin + IsrWriteByte + CRC */
}

NOINLINE static void wcet_i2c_rx_refused(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x11u); /* IsrWriteBegin refuses: fault + NACK */
}

NOINLINE static void wcet_i2c_rx_last_check_bad(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x00u); /* abort + CHECKSUM fault + NACK */
}

NOINLINE static void wcet_i2c_rx_last_check_ok(urb_node_t *node, uint8_t byte)
{
    sink = urb_node_i2c_event(node, URB_I2C_RX_BYTE, byte);
}

NOINLINE static void wcet_i2c_rx_extra_byte(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x00u); /* long write: abort + NACK */
}

NOINLINE static void wcet_i2c_rx_in_read(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x00u); /* a byte received while sending: the read ends */
}

NOINLINE static void wcet_i2c_addr_read_ends_read(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u); /* ends a complete id read, begins another */
}

NOINLINE static void wcet_i2c_tx_data(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
}

NOINLINE static void wcet_i2c_tx_check(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
}

NOINLINE static void wcet_i2c_tx_nack(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u);
}

NOINLINE static void wcet_i2c_general_call(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_GENERAL_CALL, 0u);
}

NOINLINE static void wcet_i2c_sync_counter_track(urb_node_t *node, uint8_t counter)
{
    sink = urb_node_i2c_event(node, URB_I2C_RX_BYTE, counter); /* gap > 1: one division, eq. 1 + eq. 2 */
}

NOINLINE static void wcet_i2c_sync_counter_acquire(urb_node_t *node, uint8_t counter)
{
    sink = urb_node_i2c_event(node, URB_I2C_RX_BYTE, counter);
}

NOINLINE static void wcet_i2c_stuck(urb_node_t *node)
{
    sink = urb_node_i2c_event(node, URB_I2C_STUCK, 0u);
}

/* ----- heartbeat timer ----- */

NOINLINE static void wcet_timer_beat(urb_node_t *node)
{
    urb_node_timer_event(node);
}

NOINLINE static void wcet_timer_request(urb_node_t *node)
{
    urb_node_timer_event(node); /* applies a SYNC_CONFIG request (two multiplications), update due */
}

NOINLINE static void wcet_timer_lost_sync(urb_node_t *node)
{
    urb_node_timer_event(node); /* declares LOST_SYNC (a fault count), update due */
}

/* Locks the PLL (20 SYNCs, one per heartbeat) and leaves the node right after a heartbeat. */
static void lock(urb_node_t *node)
{
    for (uint8_t k = 1u; k <= 20u; k++) {
        (void)urb_hal_hosted_advance(&fx.port, node, fx.port.compare - fx.port.now);
        (void)urb_node_poll(node);
        fx.port.capture = fx.port.now + 100u;
        fx.port.now += 2000u;
        fx_sync(node, k);
    }
}

int main(void)
{
    urb_node_t *node;

    node = fresh();
    pending_write(node, 0u, 0u);
    wcet_i2c_restart_commits(node);

    node = fresh();
    pending_write(node, 0u, 0u);
    wcet_i2c_stop_commits(node);

    node = fresh();
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_WRITE, 0u);
    wcet_i2c_rx_select(node);

    node = fresh();
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_WRITE, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x02u);
    wcet_i2c_rx_first_data(node);

    node = fresh();
    {
        const uint8_t *held = NULL;
        pending_write(node, 0u, 0u); /* commit one, then the app holds it */
        (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
        (void)urb_node_lock_inbox(node, 2u, &held);
        pending_write(node, 0u, 0u); /* the second lands in the other buffer */
        (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
        (void)urb_node_i2c_event(node, URB_I2C_ADDR_WRITE, 0u);
        (void)urb_node_i2c_event(node, URB_I2C_RX_BYTE, 0x02u);
        wcet_i2c_rx_refused(node);
    }

    node = fresh();
    pending_write(node, 0x00u, 1u); /* all but the last check byte */
    wcet_i2c_rx_last_check_bad(node);

    node = fresh();
    pending_write(node, 0x00u, 1u);
    wcet_i2c_rx_last_check_ok(node, last_check_byte());

    node = fresh();
    pending_write(node, 0x00u, 0u);
    wcet_i2c_rx_extra_byte(node);

    node = fresh();
    complete_id_read(node);
    wcet_i2c_addr_read_ends_read(node);
    wcet_i2c_tx_data(node);
    for (size_t i = 1u; i < 25u; i++) {
        (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    }
    wcet_i2c_tx_check(node);
    (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    wcet_i2c_tx_nack(node);

    node = fresh();
    complete_id_read(node);
    wcet_i2c_rx_in_read(node); /* then a misplaced received byte */

    node = fresh();
    wcet_i2c_general_call(node);

    node = fresh();
    lock(node);
    (void)urb_hal_hosted_advance(&fx.port, node, fx.port.compare - fx.port.now);
    (void)urb_node_poll(node);
    fx.port.capture = fx.port.now + 100u + 2u * 48000u; /* two SYNCs missed: gap 3 */
    fx.port.now += 2000u;
    (void)urb_node_i2c_event(node, URB_I2C_GENERAL_CALL, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_RX_BYTE, URB_SYNC_MAGIC);
    wcet_i2c_sync_counter_track(node, 23u);

    node = fresh();
    (void)urb_hal_hosted_advance(&fx.port, node, fx.port.compare - fx.port.now);
    fx.port.capture = fx.port.now + 100u;
    fx.port.now += 2000u;
    (void)urb_node_i2c_event(node, URB_I2C_GENERAL_CALL, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_RX_BYTE, URB_SYNC_MAGIC);
    wcet_i2c_sync_counter_acquire(node, 1u);

    node = fresh();
    pending_write(node, 0u, 3u);
    wcet_i2c_stuck(node);

    node = fresh();
    fx.port.now = fx.port.compare;
    wcet_timer_beat(node);

    node = fresh();
    lock(node);
    for (int i = 0; i < 9; i++) { /* nine quiet heartbeats: the tenth declares LOST_SYNC */
        (void)urb_hal_hosted_advance(&fx.port, node, fx.port.compare - fx.port.now);
        (void)urb_node_poll(node);
    }
    fx.port.now = fx.port.compare;
    wcet_timer_lost_sync(node);
    if (fx.node.isr_faults[URB_NODE_FAULT_LOST_SYNC - 1u] == 0u) {
        fprintf(stderr, "wcet: the lost-sync scenario did not declare LOST_SYNC\n");
        return 1;
    }

    node = fresh();
    (void)fx_command(node, URB_COMMAND_CODE_SYNC_CONFIG, 1u, 1000u, 40u);
    (void)urb_node_poll(node); /* posts the request */
    fx.port.now = fx.port.compare;
    wcet_timer_request(node);
    if (node->pll.fixed_lead != 40u * 48u) {
        fprintf(stderr, "wcet: the request scenario did not apply the request\n");
        return 1;
    }
    printf("wcet driver: 19 scenarios run\n");
    return 0;
}
