/*
 * Single-node adapter (firmware/node/urb_single.c): the paper's URB_* calls and app_* hooks on the
 * one global node, end to end over the hosted HAL.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "node_fixture.h"
#include "urb_core.h"
#include "urb_single.h"

static struct {
    unsigned bootup, init, reset, idle, update, signal, fault;
    uint8_t last_signal;
    urb_node_fault_t last_fault;
    int setup_rc;
    uint8_t outbox_size;
    uint8_t last_command[2];
} app;

void app_bootup(void)
{
    app.bootup++;
    int rc = URB_SetClass(0x55u);
    rc |= URB_SetIndex(9u);
    rc |= URB_SetFingerprint(0x12345678u);
    rc |= URB_SetupInbox(1u, 2u);
    rc |= URB_SetupOutbox(1u, app.outbox_size);
    app.setup_rc = rc;
}

void app_init(void)
{
    app.init++;
}

void app_reset(void)
{
    app.reset++;
}

void app_idle(void)
{
    app.idle++;
}

void app_update(void)
{
    app.update++;
    const uint8_t *in = NULL;
    if (URB_LockInbox(1u, &in) == URB_NODE_NEW) {
        memcpy(app.last_command, in, 2u);
    }
    (void)URB_ReleaseInbox(1u);
    uint8_t *out = NULL;
    if (URB_LockOutbox(1u, &out) == URB_NODE_OK) {
        memset(out, (int)app.update, app.outbox_size);
        (void)URB_ReleaseOutbox(1u);
    }
}

void app_signal(uint8_t signal)
{
    app.signal++;
    app.last_signal = signal;
}

void app_fault(urb_node_fault_t fault)
{
    app.fault++;
    app.last_fault = fault;
}

static urb_hal_hosted_t port;
static urb_node_config_t cfg;

static int setup(void **state)
{
    (void)state;
    memset(&app, 0, sizeof app);
    app.outbox_size = 4u;
    urb_hal_hosted_init(&port, 0u, true);
    urb_node_config_default(&cfg);
    cfg.i2c_address = 0x30u;
    return 0;
}

/* lobster-trace: urb.MBX_012 */
static void paper_style_end_to_end(void **state)
{
    (void)state;
    assert_int_equal(URB_Start(&port.hal, &cfg), URB_NODE_OK);
    assert_int_equal(app.bootup, 1u);
    assert_int_equal(app.init, 1u);
    assert_int_equal(app.setup_rc, URB_NODE_OK);
    assert_int_equal(port.address, 0x30u);
    urb_node_t *node = URB_Node();
    assert_int_equal(urb_node_outbox_size(node, 1u), 4u);
    /* the bridge writes inbox 1; the next heartbeat's update sees it and publishes outbox 1 */
    uint8_t const cmd[2] = {0xAAu, 0x55u};
    uint8_t frame[8];
    size_t const n = fx_frame(frame, 1u, cmd, 2u, 0u);
    for (size_t i = 0u; i < n; i++) {
        if (i == 0u) {
            assert_int_equal(URB_I2cIsr(URB_I2C_ADDR_WRITE, 0u), URB_I2C_ACK);
        }
        assert_int_equal(URB_I2cIsr(URB_I2C_RX_BYTE, frame[i]), URB_I2C_ACK);
    }
    (void)URB_I2cIsr(URB_I2C_STOP, 0u);
    assert_false(URB_HasWork());
    port.now = port.compare;
    URB_TimerIsr();
    assert_true(URB_HasWork());
    assert_true((URB_Poll() & URB_NODE_POLL_UPDATE) != 0u);
    assert_int_equal(app.update, 1u);
    assert_memory_equal(app.last_command, cmd, 2u);
    uint8_t data[4];
    assert_true(fx_read_checked(node, 1u, 4u, data));
    assert_int_equal(data[0], 1u);
    /* commands reach app_reset / app_signal, faults app_fault */
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_SIGNAL, 4u, 0u, 0u), FX_ALL_ACKED);
    (void)URB_Poll();
    assert_int_equal(app.last_signal, 4u);
    assert_int_equal(fx_command(node, URB_COMMAND_CODE_RESET, 0u, 0u, 0u), FX_ALL_ACKED);
    (void)URB_Poll();
    assert_int_equal(app.reset, 1u);
    (void)URB_I2cIsr(URB_I2C_STUCK, 0u);
    (void)URB_Poll();
    assert_int_equal(app.last_fault, URB_NODE_FAULT_STUCK_BUS);
    assert_true(app.idle >= 3u);
}

static void setup_after_start_refused(void **state)
{
    (void)state;
    app.outbox_size = 32u;
    /* inbox 1 (2 B) + outbox 1 (32 B), double-buffered: 68 B fit the default 128 */
    assert_int_equal(URB_Start(&port.hal, &cfg), URB_NODE_OK);
    /* a second setup call after start is refused */
    assert_int_equal(URB_SetupOutbox(2u, 32u), URB_NODE_ERR_STATE);
    assert_int_equal(URB_SetClass(1u), URB_NODE_ERR_STATE);
    assert_int_equal(URB_SetIndex(1u), URB_NODE_ERR_STATE);
    assert_int_equal(URB_SetFingerprint(1u), URB_NODE_ERR_STATE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(paper_style_end_to_end, setup),
        cmocka_unit_test_setup(setup_after_start_refused, setup),
    };
    return cmocka_run_group_tests_name("node_single", tests, NULL, NULL);
}
