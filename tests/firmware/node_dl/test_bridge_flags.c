/*
 * The bridge firmware (urb_bridge_t, unchanged) on each downlink HAL: I2C, CAN and RS485
 * (topology.h), with the real nodes behind it, answering uplink requests. Each failure kind of a
 * node or bus must reach the host with the status (the error flag) the bridge reports for the same
 * failure on I2C (urb_downlink.h's I2C contract, spec/schema/README.md):
 *
 *   failure                                  I2C                CAN                   RS485               status
 *   node absent (never answered)             address NACK       no answer             silence             NO_NODE
 *   present node goes silent                 address NACK       no answer             silence             NO_NODE
 *   answer corrupted                         read check         transfer CRC          frame check         CHECKSUM
 *   bus unusable                             SDA held low       bus-off               babbling node       BUS_STUCK
 *   request cut on the bus                   -                  -                     collision (echo)    BUS_STUCK
 *   request's check garbled                  check byte NACK    -                     collision, last     CHECKSUM
 *
 * and after each fault ends, the same request succeeds again. Witness: topo_t.injected counts the
 * faults that took effect. Seeded bugs (mk/node_downlinks.mk): URB_MUTANT_CAN_BUSOFF_AS_TIMEOUT,
 * URB_MUTANT_RS485_SILENCE_AS_TIMEOUT, URB_MUTANT_RS485_NO_ECHO_CHECK (firmware/downlink/) and
 * URB_MUTANT_NO_PROBE (firmware/bridge/bridge.c) each make this program fail.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "topology.h"
#include "urb_bridge.h"
#include "urb_core.h"

#define BYTE_US 87u /* one uplink byte at 115200 Bd */
#define ABSENT (TOPO_FIRST_ADDRESS + 5u)

typedef struct {
    topo_t topo;
    urb_bridge_t bridge;
    urb_bridge_hal_t hal;
    uint32_t hb_period, hb_next;
    uint8_t tx[512];
    size_t tx_len;
    uint8_t seq;
} bridge_rig_t;

static bridge_rig_t rig;

static uint32_t b_now(void *ctx)
{
    return ((bridge_rig_t *)ctx)->topo.now;
}
static void b_heartbeat(void *ctx, uint32_t period_us)
{
    bridge_rig_t *r = (bridge_rig_t *)ctx;
    r->hb_period = period_us;
    r->hb_next = r->topo.now + period_us;
}
static void b_kick(void *ctx)
{
    (void)ctx; /* rig_step drains the UART ring */
}

static void rig_step(void)
{
    topo_advance(&rig.topo);
    if ((rig.hb_period != 0u) && ((int32_t)(rig.topo.now - rig.hb_next) >= 0)) {
        rig.hb_next += rig.hb_period;
        urb_bridge_heartbeat(&rig.bridge);
    }
    urb_bridge_poll(&rig.bridge);
    uint8_t byte;
    while (urb_bridge_uart_tx_pop(&rig.bridge, &byte)) {
        if (rig.tx_len < sizeof rig.tx) {
            rig.tx[rig.tx_len++] = byte;
        }
    }
}

static void rig_run(uint32_t us)
{
    uint32_t const end = rig.topo.now + us;
    while ((int32_t)(rig.topo.now - end) < 0) {
        rig_step();
    }
}

static void rig_init(topo_kind_t kind)
{
    memset(&rig, 0, sizeof rig);
    assert_true(topo_init(&rig.topo, kind));
    rig.hal = (urb_bridge_hal_t){&rig, b_now, b_heartbeat, b_kick, NULL};
    urb_bridge_config_t cfg;
    urb_bridge_default_config(&cfg);
    assert_int_equal(urb_bridge_init(&rig.bridge, &cfg, &rig.hal, &rig.topo.dl), 0);
    for (int i = 0; (i < 2000000) && !(urb_bridge_idle(&rig.bridge) && rig.bridge.stats.scans > 0u); i++) {
        rig_step(); /* the initial scan of the whole address range */
    }
    assert_true(rig.bridge.stats.scans > 0u);
    assert_true(urb_bridge_present(&rig.bridge, TOPO_FIRST_ADDRESS));
    assert_true(urb_bridge_present(&rig.bridge, TOPO_FIRST_ADDRESS + 1u));
}

/* Sends one read request on the uplink and returns the status of its response. */
static int host_read(uint8_t address, uint8_t mailbox, uint8_t length)
{
    uint8_t frame[8];
    urb_uplink_read_request_t q = {address, mailbox, ++rig.seq, length};
    int32_t const n = urb_uplink_read_request_encode(&q, frame, sizeof frame);
    assert_true(n > 0);
    rig.tx_len = 0u;
    for (int32_t i = 0; i < n; i++) {
        rig_run(BYTE_US);
        urb_bridge_uart_rx(&rig.bridge, frame[i], rig.topo.now);
    }
    for (int i = 0; i < 400; i++) {
        rig_run(500u);
        if (rig.tx_len >= 2u) {
            size_t const ok_len = 1u + length + urb_link_check_size(1u + (size_t)length);
            urb_uplink_response_t r;
            if (urb_uplink_response_decode(&r, rig.tx, 2u) == 2) {
                assert_int_equal(r.seq, rig.seq);
                return r.status;
            }
            if ((rig.tx_len >= ok_len) && (urb_uplink_response_decode(&r, rig.tx, ok_len) == (int32_t)ok_len)) {
                assert_int_equal(r.seq, rig.seq);
                return r.status;
            }
        }
    }
    fail_msg("no response within 200 ms to a read of %u/%u (%u bytes sent back)", address, mailbox, (unsigned)rig.tx_len);
    return -1;
}

/* The failure kinds every downlink shares; the same statuses as on I2C. */
static void check_failures(topo_kind_t kind)
{
    rig_init(kind);
    uint8_t const a = TOPO_FIRST_ADDRESS;
    assert_int_equal(host_read(a, 1u, 8u), URB_STATUS_OK);
    /* no answer: an absent node */
    assert_int_equal(host_read(ABSENT, 0u, 25u), URB_STATUS_NO_NODE);
    /* a present node goes silent: probed, then reported absent */
    rig.topo.fault.mute[1] = true;
    assert_int_equal(host_read((uint8_t)(a + 1u), 1u, 8u), URB_STATUS_NO_NODE);
    assert_false(urb_bridge_present(&rig.bridge, (uint8_t)(a + 1u)));
    rig.topo.fault.mute[1] = false;
    assert_int_equal(host_read((uint8_t)(a + 1u), 0u, 25u), URB_STATUS_OK);
    /* the answer corrupted (CAN: the second frame of the 25-byte identification, under the transfer CRC) */
    uint32_t const before = rig.topo.injected;
    rig.topo.fault.corrupt_rx = (kind == TOPO_CAN) ? 2u : 3u;
    assert_int_equal(host_read(a, 0u, 25u), URB_STATUS_CHECKSUM);
    assert_true(rig.topo.injected > before); /* witness */
    assert_int_equal(host_read(a, 0u, 25u), URB_STATUS_OK);
    /* the bus unusable: SDA held / bus-off / a babbler */
    rig.topo.fault.bus_fault = true;
    assert_int_equal(host_read(a, 1u, 8u), URB_STATUS_BUS_STUCK);
    rig.topo.fault.bus_fault = false;
    rig_run(20000u); /* CAN: recovery, 128 x 11 bits; RS485: silence again */
    assert_int_equal(host_read(a, 1u, 8u), URB_STATUS_OK);
    assert_true(rig.topo.injected > before + 1u);
}

static void test_i2c(void **state)
{
    (void)state;
    check_failures(TOPO_I2C);
}
static void test_can(void **state)
{
    (void)state;
    check_failures(TOPO_CAN);
}
static void test_rs485(void **state)
{
    (void)state;
    check_failures(TOPO_RS485);
    /* a collision cuts the request (address, select, check): not executed, the flag of a stuck bus */
    uint32_t const before = rig.topo.injected;
    rig.topo.fault.collide = 2u;
    assert_int_equal(host_read(TOPO_FIRST_ADDRESS, 1u, 8u), URB_STATUS_BUS_STUCK);
    assert_int_equal(rig.topo.injected, before + 1u);
    /* on the request's last byte the node's check decides: as a corrupted I2C check byte */
    rig.topo.fault.collide = 3u;
    assert_int_equal(host_read(TOPO_FIRST_ADDRESS, 1u, 8u), URB_STATUS_CHECKSUM);
    assert_int_equal(rig.topo.injected, before + 2u);
    assert_int_equal(host_read(TOPO_FIRST_ADDRESS, 1u, 8u), URB_STATUS_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_i2c),
        cmocka_unit_test(test_can),
        cmocka_unit_test(test_rs485),
    };
    return cmocka_run_group_tests_name("bridge_flags", tests, NULL, NULL);
}
