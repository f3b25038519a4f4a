/*
 * Shared fixture for the node library's cmocka tests (see node_fixture.h).
 */
#include "node_fixture.h"

#include <string.h>

#include "urb_core.h"
#include "urb_runtime.h"

void (*fx_step_hook)(urb_node_t *node, uint8_t step, void *ctx);
void *fx_step_ctx;

void urb_node_test_step(urb_node_t *node, uint8_t step)
{
    if (fx_step_hook != NULL) {
        fx_step_hook(node, step, fx_step_ctx);
    }
}

static fixture_t *fx_of(void *user)
{
    return (fixture_t *)user;
}

static void h_bootup(urb_node_t *node, void *user)
{
    fixture_t *fx = fx_of(user);
    fx->bootups++;
    int rc = urb_node_set_class(node, fx->class_id);
    int r2 = urb_node_set_index(node, fx->index);
    int r3 = urb_node_set_fingerprint(node, fx->fingerprint);
    if (rc == URB_NODE_OK) {
        rc = r2;
    }
    if (rc == URB_NODE_OK) {
        rc = r3;
    }
    for (uint8_t n = 1u; n < URB_NODE_MAILBOXES; n++) {
        if (fx->in_sizes[n] != 0u) {
            int const r = urb_node_setup_inbox(node, n, fx->in_sizes[n]);
            if (rc == URB_NODE_OK) {
                rc = r;
            }
        }
        if (fx->out_sizes[n] != 0u) {
            int const r = urb_node_setup_outbox(node, n, fx->out_sizes[n]);
            if (rc == URB_NODE_OK) {
                rc = r;
            }
        }
    }
    fx->bootup_rc = rc;
    if (fx->on_bootup != NULL) {
        fx->on_bootup(fx);
    }
}

static void h_init(urb_node_t *node, void *user)
{
    (void)node;
    fx_of(user)->inits++;
}

static void h_reset(urb_node_t *node, void *user)
{
    (void)node;
    fx_of(user)->resets++;
}

static void h_idle(urb_node_t *node, void *user)
{
    (void)node;
    fx_of(user)->idles++;
}

static void h_update(urb_node_t *node, void *user)
{
    fixture_t *fx = fx_of(user);
    fx->updates++;
    if (fx->on_update != NULL) {
        fx->on_update(fx);
        return;
    }
    /* default: "acquire" for update_work ticks, then publish outbox 1 if it exists */
    uint8_t *buf = NULL;
    if (urb_node_outbox_size(node, 1u) != 0u && urb_node_lock_outbox(node, 1u, &buf) == URB_NODE_OK) {
        memset(buf, (int)(fx->updates & 0xFFu), urb_node_outbox_size(node, 1u));
        fx->port.now_offset = fx->update_work;
        (void)urb_node_release_outbox(node, 1u);
        fx->port.now_offset = 0u;
    }
}

static void h_signal(urb_node_t *node, void *user, uint8_t signal)
{
    (void)node;
    fx_of(user)->signals++;
    fx_of(user)->last_signal = signal;
}

static void h_fault(urb_node_t *node, void *user, urb_node_fault_t fault)
{
    (void)node;
    fixture_t *fx = fx_of(user);
    if ((unsigned)fault <= URB_NODE_FAULT_CODES) {
        fx->faults[fault]++;
    }
    fx->last_fault = fault;
}

void fx_defaults(fixture_t *fx)
{
    memset(fx, 0, sizeof *fx);
    urb_hal_hosted_init(&fx->port, 1000u, true);
    urb_node_config_default(&fx->cfg);
    fx->cfg.i2c_address = 0x21u;
    fx->cfg.fw_major = 1u;
    fx->cfg.fw_minor = 2u;
    fx->cfg.fw_patch = 3u;
    fx->hooks = (urb_node_hooks_t){h_bootup, h_init, h_reset, h_idle, h_update, h_signal, h_fault};
    fx->class_id = 0x42u;
    fx->index = 5u;
    fx->fingerprint = 0xDEADBEEFu;
    fx->in_sizes[1] = 2u;
    fx->in_sizes[2] = 20u;
    fx->out_sizes[1] = 6u;
    fx->out_sizes[2] = 20u;
}

int fx_start(fixture_t *fx)
{
    return urb_node_init(&fx->node, &fx->port.hal, &fx->hooks, fx, &fx->cfg, fx->storage, (uint16_t)FX_STORAGE);
}

int fx_write_raw(urb_node_t *node, const uint8_t *bytes, size_t n, bool stop)
{
    int nacked = FX_ALL_ACKED;
    if (urb_node_i2c_event(node, URB_I2C_ADDR_WRITE, 0u) != URB_I2C_ACK) {
        nacked = 0;
    } else {
        for (size_t i = 0u; i < n; i++) {
            if (urb_node_i2c_event(node, URB_I2C_RX_BYTE, bytes[i]) != URB_I2C_ACK) {
                nacked = (int)i;
                break;
            }
        }
    }
    if (stop) {
        (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    }
    return nacked;
}

size_t fx_frame(uint8_t *out, uint8_t m, const uint8_t *data, size_t len, uint8_t corrupt)
{
    out[0] = (uint8_t)(m & 7u);
    memcpy(out + 1, data, len);
    uint32_t const check = urb_link_check(NULL, 0u, out, len + 1u);
    size_t const cl = urb_link_check_size(len + 1u);
    for (size_t k = 0u; k < cl; k++) {
        out[1u + len + k] = (uint8_t)(check >> (8u * k));
    }
    out[len + cl] ^= corrupt;
    return 1u + len + cl;
}

int fx_write(urb_node_t *node, uint8_t m, const uint8_t *data, size_t len)
{
    uint8_t frame[40];
    size_t const n = fx_frame(frame, m, data, len, 0u);
    return fx_write_raw(node, frame, n, true);
}

bool fx_select(urb_node_t *node, uint8_t m)
{
    uint8_t const sel = (uint8_t)(0x80u | m);
    return fx_write_raw(node, &sel, 1u, true) == FX_ALL_ACKED;
}

void fx_read(urb_node_t *node, uint8_t *out, size_t n)
{
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
    for (size_t i = 0u; i < n; i++) {
        out[i] = (uint8_t)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
    }
    (void)urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
}

bool fx_read_checked(urb_node_t *node, uint8_t m, uint8_t size, uint8_t *data)
{
    uint8_t buf[40];
    size_t const cl = urb_link_check_size(1u + (size_t)size);
    if (!fx_select(node, m)) {
        return false;
    }
    fx_read(node, buf, size + cl);
    uint8_t const sel = (uint8_t)(0x80u | m);
    uint32_t const check = urb_link_check(&sel, 1u, buf, size);
    memcpy(data, buf, size);
    for (size_t k = 0u; k < cl; k++) {
        if (buf[size + k] != (uint8_t)(check >> (8u * k))) {
            return false;
        }
    }
    return true;
}

void fx_sync(urb_node_t *node, uint8_t counter)
{
    (void)urb_node_i2c_event(node, URB_I2C_GENERAL_CALL, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_RX_BYTE, URB_SYNC_MAGIC);
    (void)urb_node_i2c_event(node, URB_I2C_RX_BYTE, counter);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
}

int fx_command(urb_node_t *node, uint8_t opcode, uint8_t arg, uint16_t period_us, uint16_t lead_us)
{
    urb_command_t const cmd = {opcode, arg, period_us, lead_us};
    uint8_t buf[URB_COMMAND_SIZE];
    (void)urb_command_encode(&cmd, buf, sizeof buf);
    return fx_write(node, 0u, buf, sizeof buf);
}

uint16_t fake_motor_encoder(void *c) { return ((fake_motor_t *)c)->encoder; }
int16_t fake_motor_current(void *c) { return ((fake_motor_t *)c)->current; }
int16_t fake_motor_voltage(void *c) { return ((fake_motor_t *)c)->voltage; }
int16_t fake_motor_temp(void *c) { return ((fake_motor_t *)c)->temp; }
bool fake_motor_hall(void *c) { return ((fake_motor_t *)c)->hall; }

void fake_motor_drive(void *c, int16_t mv)
{
    ((fake_motor_t *)c)->drive = mv;
    ((fake_motor_t *)c)->drives++;
}
