/*
 * SensoRHex motor driver node (see sensorhex_motor.h).
 */
#include "sensorhex_motor.h"

#include <stddef.h>

#include "urb_sensorhex.h"

#define MOTOR_FW_MAJOR 1u
#define MOTOR_FW_MINOR 0u
#define MOTOR_FW_PATCH 0u

static int32_t clamp32(int32_t v, int32_t lo, int32_t hi)
{
    return (v < lo) ? lo : ((v > hi) ? hi : v);
}

static int32_t motor_abs32(int32_t v)
{
    return (v < 0) ? -v : v; /* callers pass values far from INT32_MIN */
}

void sensorhex_motor_defaults(sensorhex_motor_config_t *cfg, uint8_t index)
{
    cfg->index = index;
    cfg->update_hz = 1000u;
    cfg->current_limit_ma = 10000; /* 10 A continuous, 20 A peak (paper Fig. 17) */
    cfg->temp_limit_cdeg = 8000;   /* 80 degC */
    cfg->voltage_limit_mv = 12000u;
    cfg->command_timeout = 50u;    /* 50 ms at 1 kHz */
    cfg->status_divider = 100u;    /* 10 Hz, the schema's rate */
}

static void motor_reset_state(sensorhex_motor_t *app)
{
    app->mode = (uint8_t)URB_MOTOR_MODE_DISABLED;
    app->command_mv = 0;
    app->applied_mv = 0;
    app->kp = 0u;
    app->kd = 0u;
    app->target = app->position;
    app->limit_mv = app->cfg.voltage_limit_mv;
    app->missed = 0u;
    app->overcurrent = 0u;
    app->overtemp = 0u;
    app->status_count = 0u;
}

void sensorhex_motor_setup(sensorhex_motor_t *app, const sensorhex_motor_io_t *io, const sensorhex_motor_config_t *cfg)
{
    app->io = io;
    app->cfg = *cfg;
    app->position = 0;
    app->prev_position = 0;
    app->last_raw = 0u;
    app->have_raw = 0u;
    app->faults = 0u;
    motor_reset_state(app);
}

void sensorhex_motor_node_config(urb_node_config_t *cfg)
{
    cfg->update_divider = 1u;
    cfg->fw_major = MOTOR_FW_MAJOR;
    cfg->fw_minor = MOTOR_FW_MINOR;
    cfg->fw_patch = MOTOR_FW_PATCH;
}

static void motor_bootup(urb_node_t *node, void *user)
{
    sensorhex_motor_t const *app = user;
    (void)urb_node_set_class(node, URB_NODE_MOTOR_DRIVER_CLASS);
    (void)urb_node_set_index(node, app->cfg.index);
    (void)urb_node_set_fingerprint(node, URB_NODE_MOTOR_DRIVER_FINGERPRINT);
    (void)urb_node_setup_outbox(node, URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_FEEDBACK, URB_NODE_MOTOR_DRIVER_OUTBOX1_SIZE);
    (void)urb_node_setup_outbox(node, URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_STATUS, URB_NODE_MOTOR_DRIVER_OUTBOX2_SIZE);
    (void)urb_node_setup_inbox(node, URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_COMMAND, URB_NODE_MOTOR_DRIVER_INBOX1_SIZE);
    (void)urb_node_setup_inbox(node, URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_CONFIG, URB_NODE_MOTOR_DRIVER_INBOX2_SIZE);
}

static void motor_stop(sensorhex_motor_t *app)
{
    app->applied_mv = 0;
    app->io->drive_mv(app->io->ctx, 0);
}

static void motor_init(urb_node_t *node, void *user)
{
    (void)node;
    motor_stop(user); /* the bridge is off until a command says otherwise */
}

static void motor_reset(urb_node_t *node, void *user)
{
    (void)node;
    sensorhex_motor_t *app = user;
    motor_reset_state(app);
    motor_stop(app);
}

/* Reads the two inboxes: a fresh command resets the missed counter, a fresh config applies. */
static void motor_inputs(urb_node_t *node, sensorhex_motor_t *app)
{
    const uint8_t *data = NULL;
    int rc = urb_node_lock_inbox(node, URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_COMMAND, &data);
    bool fresh = false;
    if (rc == URB_NODE_NEW) {
        urb_motor_command_t cmd;
        if (urb_motor_command_decode(&cmd, data, URB_MOTOR_COMMAND_SIZE) >= 0) {
            app->command_mv = cmd.voltage;
            fresh = true;
        }
    }
    if (rc >= 0) {
        (void)urb_node_release_inbox(node, URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_COMMAND);
    }
    if (fresh) {
        app->missed = 0u;
    } else if (app->missed < 0xFFFFu) {
        app->missed++; /* 16 bits: counts past the largest timeout (255), so 255 still cuts */
    } else {
        /* saturated: stays at 0xFFFF, past every timeout */
    }
    rc = urb_node_lock_inbox(node, URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_CONFIG, &data);
    if (rc == URB_NODE_NEW) {
        urb_motor_config_t mc;
        if (urb_motor_config_decode(&mc, data, URB_MOTOR_CONFIG_SIZE) >= 0) {
            app->mode = mc.mode;
            app->kp = mc.kp;
            app->kd = mc.kd;
            app->target = mc.target;
            app->limit_mv = mc.voltage_limit;
        }
    }
    if (rc >= 0) {
        (void)urb_node_release_inbox(node, URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_CONFIG);
    }
}

/* Local PD loop in mV: kp is 0.0001 V/count, kd 1e-6 V*s/count (MotorConfig). */
static int32_t motor_pd(const sensorhex_motor_t *app)
{
    int32_t const err = clamp32(app->target - app->position, -32767, 32767);
    int32_t const delta = clamp32(app->position - app->prev_position, -32767, 32767);
    int32_t const lim = (int32_t)app->limit_mv;
    /* P: kp * 1e-4 V * err * 1000 mV/V = kp * err / 10 (|kp * err| < 2^31 by the clamps) */
    int32_t const p = clamp32(((int32_t)app->kp * err) / 10, -lim, lim);
    /* D: kd * 1e-6 * (delta * rate) * 1000 = kd * delta * rate / 1000, limited to +-lim. The rate
     * factor would overflow int32 (|kd * delta / 1000| reaches 2147418, the rate 65535), so the
     * magnitude is limited first, then multiplied in 32 unsigned bits (<= 65535 * 65535): the exact
     * value, clamped, as before wherever that did not overflow. No 64-bit multiply on Cortex-M0+. */
    int32_t const q = ((int32_t)app->kd * delta) / 1000;
    uint32_t mag = (uint32_t)motor_abs32(q);
    mag = ((mag > (uint32_t)lim) ? (uint32_t)lim : mag) * app->cfg.update_hz;
    mag = (mag > (uint32_t)lim) ? (uint32_t)lim : mag;
    int32_t const d = (q < 0) ? -(int32_t)mag : (int32_t)mag;
    return p - d;
}

static void motor_update(urb_node_t *node, void *user)
{
    sensorhex_motor_t *app = user;
    sensorhex_motor_io_t const *io = app->io;
    /* 1. acquire */
    uint16_t const raw = io->encoder(io->ctx);
    int16_t const current = io->current_ma(io->ctx);
    int16_t const voltage = io->voltage_mv(io->ctx);
    app->prev_position = app->position;
    if (app->have_raw != 0u) {
        /* modular difference as a signed step (at most +-32767 counts per update) */
        uint16_t const step = (uint16_t)(raw - app->last_raw);
        app->position += (step < 0x8000u) ? (int32_t)step : (int32_t)step - 65536;
    }
    app->last_raw = raw;
    app->have_raw = 1u;
    /* 2. publish the feedback: the release marks the end of acquisition (t_acq) */
    uint8_t *out = NULL;
    if (urb_node_lock_outbox(node, URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_FEEDBACK, &out) == URB_NODE_OK) {
        urb_motor_feedback_t const fb = {raw, current, voltage};
        (void)urb_motor_feedback_encode(&fb, out, URB_MOTOR_FEEDBACK_SIZE);
        (void)urb_node_release_outbox(node, URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_FEEDBACK);
    }
    /* 3. commands */
    motor_inputs(node, app);
    /* 4. protection and control */
    int16_t const temp = io->case_temp_cdeg(io->ctx);
    bool const hot = temp > app->cfg.temp_limit_cdeg;
    bool const over = motor_abs32(current) > (int32_t)app->cfg.current_limit_ma;
    bool const cut = hot || (motor_abs32(current) > (2 * (int32_t)app->cfg.current_limit_ma));
    if (hot) {
        app->overtemp = 1u;
    }
    if (over) {
        app->overcurrent = 1u;
    }
    int32_t u = 0;
    if (app->mode == (uint8_t)URB_MOTOR_MODE_VOLTAGE) {
        bool const timed_out = (app->cfg.command_timeout != 0u) && (app->missed > app->cfg.command_timeout);
        u = timed_out ? 0 : app->command_mv;
    } else if (app->mode == (uint8_t)URB_MOTOR_MODE_LOCAL_PD) {
        u = motor_pd(app);
    } else {
        /* DISABLED: drive 0 */
    }
    u = clamp32(u, -(int32_t)app->limit_mv, (int32_t)app->limit_mv);
    if (cut) {
        u = 0;
    }
    app->applied_mv = (int16_t)clamp32(u, INT16_MIN, INT16_MAX);
    io->drive_mv(io->ctx, app->applied_mv);
    /* 5. slow status */
    app->status_count++;
    if (app->status_count >= app->cfg.status_divider) {
        uint8_t *st = NULL;
        if (urb_node_lock_outbox(node, URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_STATUS, &st) == URB_NODE_OK) {
            uint8_t const missed = (app->missed > 0xFFu) ? 0xFFu : (uint8_t)app->missed; /* saturates at 255 */
            urb_motor_status_t const ms = {temp, app->mode, io->hall(io->ctx), app->overcurrent != 0u,
                                           app->overtemp != 0u, missed};
            (void)urb_motor_status_encode(&ms, st, URB_MOTOR_STATUS_SIZE);
            (void)urb_node_release_outbox(node, URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_STATUS);
            app->status_count = 0u;
            app->overcurrent = 0u; /* latched "since the last status" */
            app->overtemp = 0u;
        }
    }
}

static void motor_signal(urb_node_t *node, void *user, uint8_t signal)
{
    (void)node;
    sensorhex_motor_t *app = user;
    if (signal == 1u) { /* calibrate: the current shaft position becomes 0 */
        app->position = 0;
        app->prev_position = 0;
        app->target = 0;
    }
}

static void motor_fault(urb_node_t *node, void *user, urb_node_fault_t fault)
{
    (void)node;
    (void)fault;
    sensorhex_motor_t *app = user;
    app->faults++; /* reported to the CPU through Identification.fault by the library */
}

const urb_node_hooks_t sensorhex_motor_hooks = {motor_bootup, motor_init,   motor_reset, NULL,
                                                motor_update, motor_signal, motor_fault};
