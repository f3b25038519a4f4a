/*
 * SensoRHex node applications (firmware/apps/sensorhex) on the node library and the hosted HAL,
 * with fake sensors behind their io interfaces; mailbox contents checked with the generated
 * decoders.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "node_fixture.h"
#include "sensorhex_battery.h"
#include "sensorhex_imu.h"
#include "sensorhex_ir.h"
#include "sensorhex_motor.h"
#include "urb_core.h"
#include "urb_sensorhex.h"

#define PERIOD 48000u

typedef struct {
    urb_node_t node;
    urb_hal_hosted_t port;
    urb_node_config_t cfg;
    uint8_t storage[64];
} rig_t;

static void rig_start(rig_t *r, const urb_node_hooks_t *hooks, void *app, void (*node_config)(urb_node_config_t *))
{
    memset(r, 0, sizeof *r);
    urb_hal_hosted_init(&r->port, 0u, true);
    urb_node_config_default(&r->cfg);
    r->cfg.i2c_address = 0x40u;
    node_config(&r->cfg);
    assert_int_equal(urb_node_init(&r->node, &r->port.hal, hooks, app, &r->cfg, r->storage, sizeof r->storage),
                     URB_NODE_OK);
}

/* n heartbeats, polling after each. */
static void beats(rig_t *r, unsigned n)
{
    for (unsigned i = 0u; i < n; i++) {
        (void)urb_hal_hosted_advance(&r->port, &r->node, PERIOD);
        (void)urb_node_poll(&r->node);
    }
}

static urb_identification_t identification(rig_t *r)
{
    uint8_t data[25];
    assert_true(fx_read_checked(&r->node, 0u, 25u, data));
    urb_identification_t id;
    assert_int_equal(urb_identification_decode(&id, data, 25u), 25);
    return id;
}

/* The bridge's read of outbox m, begun (its first byte clocked out) and held open: the interrupt
 * keeps that buffer (MailboxOutbox.tla IsrReadBegin) until end_read(). */
static void hold_read(urb_node_t *node, uint8_t m)
{
    assert_true(fx_select(node, m));
    (void)urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u);
}

static void end_read(urb_node_t *node)
{
    (void)urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u);
    (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
}

/* Step hook: the bridge commits a write to inbox `inbox` right after each AppLockClaim of that
 * inbox, so every attempt of the application's lock fails its front check: BUSY. */
typedef struct {
    uint8_t inbox;
    const uint8_t *data;
    size_t len;
    unsigned writes;
} lander_t;

static void lands_at_claim(urb_node_t *node, uint8_t step, void *ctx)
{
    lander_t *l = ctx;
    if ((step == URB_STEP_IN_CLAIM) && (node->inbox[l->inbox].app_idx != URB_NONE)) {
        assert_int_equal(fx_write(node, l->inbox, l->data, l->len), FX_ALL_ACKED);
        l->writes++;
    }
}

/* ===== Motor ================================================================================ */

static fake_motor_t fm;
static const sensorhex_motor_io_t motor_io = FAKE_MOTOR_IO(&fm);
static sensorhex_motor_t motor;
static rig_t rig;

static int motor_setup(void **state)
{
    (void)state;
    memset(&fm, 0, sizeof fm);
    fm.temp = 2500;
    sensorhex_motor_config_t cfg;
    sensorhex_motor_defaults(&cfg, 3u);
    sensorhex_motor_setup(&motor, &motor_io, &cfg);
    rig_start(&rig, &sensorhex_motor_hooks, &motor, sensorhex_motor_node_config);
    return 0;
}

static void motor_command(int16_t mv)
{
    urb_motor_command_t const c = {mv};
    uint8_t buf[URB_MOTOR_COMMAND_SIZE];
    assert_int_equal(urb_motor_command_encode(&c, buf, sizeof buf), (int)sizeof buf);
    assert_int_equal(fx_write(&rig.node, 1u, buf, sizeof buf), FX_ALL_ACKED);
}

static void motor_config(uint8_t mode, uint16_t kp, uint16_t kd, int32_t target, uint16_t limit)
{
    urb_motor_config_t const c = {mode, kp, kd, target, limit};
    uint8_t buf[URB_MOTOR_CONFIG_SIZE];
    assert_int_equal(urb_motor_config_encode(&c, buf, sizeof buf), (int)sizeof buf);
    assert_int_equal(fx_write(&rig.node, 2u, buf, sizeof buf), FX_ALL_ACKED);
}

static urb_motor_feedback_t motor_feedback(void)
{
    uint8_t data[6];
    assert_true(fx_read_checked(&rig.node, 1u, 6u, data));
    urb_motor_feedback_t fb;
    assert_int_equal(urb_motor_feedback_decode(&fb, data, 6u), 6);
    return fb;
}

static urb_motor_status_t motor_status(void)
{
    uint8_t data[4];
    assert_true(fx_read_checked(&rig.node, 2u, 4u, data));
    urb_motor_status_t st;
    assert_int_equal(urb_motor_status_decode(&st, data, 4u), 4);
    return st;
}

static void motor_identifies(void **state)
{
    (void)state;
    urb_identification_t const id = identification(&rig);
    assert_int_equal(id.class_id, URB_NODE_MOTOR_DRIVER_CLASS);
    assert_int_equal(id.index, 3u);
    assert_int_equal(id.fingerprint, URB_NODE_MOTOR_DRIVER_FINGERPRINT);
    assert_memory_equal(id.inbox_sizes, urb_node_motor_driver_inbox_sizes, 8u);
    assert_memory_equal(id.outbox_sizes, urb_node_motor_driver_outbox_sizes, 8u);
    assert_int_equal(fm.drive, 0); /* app_init stops the motor */
    assert_true(fm.drives >= 1u);
}

static void motor_feedback_every_update(void **state)
{
    (void)state;
    fm.encoder = 1234u;
    fm.current = -1500;
    fm.voltage = 6000;
    beats(&rig, 1u);
    urb_motor_feedback_t fb = motor_feedback();
    assert_int_equal(fb.encoder, 1234u);
    assert_int_equal(fb.current, -1500);
    assert_int_equal(fb.voltage, 6000);
    fm.encoder = 1300u;
    beats(&rig, 1u);
    fb = motor_feedback();
    assert_int_equal(fb.encoder, 1300u);
    assert_true(rig.node.acq_ticks < 2u * 48u); /* the release marked the end of acquisition (+1 us guard) */
    assert_int_equal(rig.port.mark_count[URB_NODE_MARK_ACQ_END], 2u);
}

static void motor_voltage_mode_and_timeout(void **state)
{
    (void)state;
    motor_config(URB_MOTOR_MODE_VOLTAGE, 0u, 0u, 0, 6000u);
    motor_command(4500);
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 4500);
    motor_command(-9000); /* beyond the 6 V limit */
    beats(&rig, 1u);
    assert_int_equal(fm.drive, -6000);
    /* no fresh command for more than command_timeout updates: cut */
    beats(&rig, 50u);
    assert_int_equal(fm.drive, -6000);
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 0);
    motor_command(1000);
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 1000);
    /* the slow status (every 100 updates) reports mode and missed commands */
    beats(&rig, 100u);
    urb_motor_status_t const st = motor_status();
    assert_int_equal(st.mode, URB_MOTOR_MODE_VOLTAGE);
    assert_int_equal(st.case_temp, 2500);
    assert_true(st.missed_commands > 0u);
}

static void motor_local_pd(void **state)
{
    (void)state;
    fm.encoder = 0u;
    beats(&rig, 1u);
    motor_config(URB_MOTOR_MODE_LOCAL_PD, 100u, 0u, 1000, 12000u); /* kp 0.01 V/count */
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 10000); /* 0.01 V/count * 1000 counts */
    /* moving toward the target at 20 counts/update = 20000 counts/s, kd 1e-4 V*s/count: -2 V */
    motor_config(URB_MOTOR_MODE_LOCAL_PD, 100u, 100u, 1000, 12000u);
    fm.encoder = 20u;
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 9800 - 2000);
    /* encoder wrap: 65530 -> 10 is +16 counts, not -65520 */
    fm.encoder = 65530u;
    beats(&rig, 1u);
    fm.encoder = 10u;
    beats(&rig, 1u);
    assert_int_equal(motor.position, 10); /* 20, then -26 (to 65530 = -6), then +16 */
    assert_int_equal(motor.position - motor.prev_position, 16);
    /* calibration signal: the position becomes 0 */
    assert_int_equal(fx_command(&rig.node, URB_COMMAND_CODE_SIGNAL, 1u, 0u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(&rig.node);
    assert_int_equal(motor.position, 0);
}

/* Starts the motor app with a changed setting (the fixture's motor_setup uses the defaults). */
static void motor_restart(uint8_t command_timeout, uint16_t update_hz)
{
    sensorhex_motor_config_t cfg;
    sensorhex_motor_defaults(&cfg, 3u);
    cfg.command_timeout = command_timeout;
    cfg.update_hz = update_hz;
    sensorhex_motor_setup(&motor, &motor_io, &cfg);
    rig_start(&rig, &sensorhex_motor_hooks, &motor, sensorhex_motor_node_config);
}

/* command_timeout 255, the largest the u8 setting takes: 255 updates without a command keep the
 * drive, the 256th cuts it (as 50 cuts at the 51st); the status still saturates at 255. Before the
 * fix the counter saturated at 255 and the drive was never cut (review F5). */
static void motor_timeout_255_cuts(void **state)
{
    (void)state;
    motor_restart(255u, 1000u);
    motor_config(URB_MOTOR_MODE_VOLTAGE, 0u, 0u, 0, 6000u);
    motor_command(4500);
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 4500);
    beats(&rig, 255u);
    assert_int_equal(fm.drive, 4500);
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 0);
    beats(&rig, 2000u); /* stays cut; the counter keeps counting past 255 */
    assert_int_equal(fm.drive, 0);
    assert_int_equal(motor_status().missed_commands, 255u);
    motor_command(1000); /* a fresh command drives again */
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 1000);
}

/* command_timeout 0 never cuts, however long the silence. */
static void motor_timeout_0_never(void **state)
{
    (void)state;
    motor_restart(0u, 1000u);
    motor_config(URB_MOTOR_MODE_VOLTAGE, 0u, 0u, 0, 6000u);
    motor_command(4500);
    beats(&rig, 1u);
    beats(&rig, 70000u); /* beyond the 16-bit counter's saturation */
    assert_int_equal(fm.drive, 4500);
    assert_int_equal(motor.missed, 0xFFFFu);
}

/* The D term at update_hz 2000 with kd and delta at their extremes: (kd * delta / 1000) * rate is
 * 2147385 * 2000, beyond int32 (undefined behaviour, UBSan aborts: review F6); it must clamp to the
 * limit. A small D term at the same rate is unchanged: kd 100, 20 counts/update -> 2 * 2000. */
static void motor_pd_fast_rate_no_overflow(void **state)
{
    (void)state;
    motor_restart(50u, 2000u);
    fm.encoder = 0u;
    beats(&rig, 1u);
    motor_config(URB_MOTOR_MODE_LOCAL_PD, 0u, 65535u, 0, 12000u);
    beats(&rig, 1u);
    fm.encoder = 32767u; /* +32767 counts in one update */
    beats(&rig, 1u);
    assert_int_equal(fm.drive, -12000);
    fm.encoder = 0u; /* -32767: the other sign */
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 12000);
    motor_config(URB_MOTOR_MODE_LOCAL_PD, 0u, 100u, 0, 12000u);
    fm.encoder = 20u;
    beats(&rig, 1u);
    assert_int_equal(fm.drive, -4000);
}

static void motor_protection(void **state)
{
    (void)state;
    motor_config(URB_MOTOR_MODE_VOLTAGE, 0u, 0u, 0, 12000u);
    motor_command(3000);
    fm.current = 12000; /* over the 10 A limit: flag, keep driving */
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 3000);
    fm.current = 21000; /* over twice the limit: cut */
    motor_command(3000);
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 0);
    fm.current = 0;
    fm.temp = 9000; /* 90 degC */
    motor_command(3000);
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 0);
    fm.temp = 2500;
    fm.hall = true;
    beats(&rig, 97u);
    urb_motor_status_t st = motor_status();
    assert_true(st.overcurrent);
    assert_true(st.overtemp);
    assert_true(st.hall);
    beats(&rig, 100u); /* latched until a status was published */
    st = motor_status();
    assert_false(st.overcurrent);
    assert_false(st.overtemp);
    /* RESET: back to DISABLED, motor off */
    motor_command(3000);
    beats(&rig, 1u);
    assert_int_equal(fx_command(&rig.node, URB_COMMAND_CODE_RESET, 0u, 0u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(&rig.node);
    assert_int_equal(fm.drive, 0);
    assert_int_equal(motor.mode, URB_MOTOR_MODE_DISABLED);
    /* a fault reaches the app */
    (void)urb_node_i2c_event(&rig.node, URB_I2C_STUCK, 0u);
    (void)urb_node_poll(&rig.node);
    assert_int_equal(motor.faults, 1u);
    /* an invalid config (reserved bits set) is ignored */
    uint8_t raw[URB_MOTOR_CONFIG_SIZE] = {0x05u};
    assert_int_equal(fx_write(&rig.node, 2u, raw, sizeof raw), FX_ALL_ACKED);
    beats(&rig, 1u);
    assert_int_equal(motor.mode, URB_MOTOR_MODE_DISABLED);
}

/* An update whose outbox lock finds the bridge still reading the buffer it would fill (BUSY) skips
 * publishing; the first update after the read publishes again: the host never sees a torn or a
 * skipped-then-stale value. Feedback (every update) and status (every 100th; its counter waits). */
static void motor_skips_a_busy_outbox(void **state)
{
    (void)state;
    fm.encoder = 1u;
    beats(&rig, 1u);           /* feedback in buffer A */
    hold_read(&rig.node, 1u);  /* the bridge reads A */
    fm.encoder = 2u;
    beats(&rig, 1u);           /* B published */
    fm.encoder = 3u;
    beats(&rig, 1u);           /* A still read: BUSY, nothing published */
    end_read(&rig.node);
    assert_int_equal(motor_feedback().encoder, 2u);
    fm.encoder = 4u;
    beats(&rig, 1u);
    assert_int_equal(motor_feedback().encoder, 4u);

    beats(&rig, 100u);         /* a status published, its counter restarted */
    hold_read(&rig.node, 2u);
    beats(&rig, 200u);         /* the next one published, the one after that BUSY: its counter waits */
    assert_true(motor.status_count >= 100u);
    end_read(&rig.node);
    beats(&rig, 1u);
    assert_int_equal(motor.status_count, 0u);
}

/* A lock of the command or configuration inbox that stays BUSY (the bridge writes it again during
 * every attempt) keeps the previous command and configuration for this update; the next update reads
 * the newest ones. */
static void motor_busy_inboxes(void **state)
{
    (void)state;
    motor_config(URB_MOTOR_MODE_VOLTAGE, 0u, 0u, 0, 6000u);
    motor_command(1000);
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 1000);
    uint8_t cmd[URB_MOTOR_COMMAND_SIZE];
    urb_motor_command_t const c = {2000};
    assert_int_equal(urb_motor_command_encode(&c, cmd, sizeof cmd), (int)sizeof cmd);
    lander_t l = {1u, cmd, sizeof cmd, 0u};
    fx_step_hook = lands_at_claim;
    fx_step_ctx = &l;
    beats(&rig, 1u);
    fx_step_hook = NULL;
    assert_int_equal(l.writes, 3u);
    assert_int_equal(fm.drive, 1000); /* no fresh command this update */
    beats(&rig, 1u);
    assert_int_equal(fm.drive, 2000);

    uint8_t mc[URB_MOTOR_CONFIG_SIZE];
    urb_motor_config_t const off = {URB_MOTOR_MODE_DISABLED, 0u, 0u, 0, 6000u};
    assert_int_equal(urb_motor_config_encode(&off, mc, sizeof mc), (int)sizeof mc);
    l = (lander_t){2u, mc, sizeof mc, 0u};
    fx_step_hook = lands_at_claim;
    fx_step_ctx = &l;
    motor_command(2500);
    beats(&rig, 1u);
    fx_step_hook = NULL;
    assert_int_equal(l.writes, 3u);
    assert_int_equal(motor.mode, URB_MOTOR_MODE_VOLTAGE); /* the new configuration waits */
    assert_int_equal(fm.drive, 2500);
    beats(&rig, 1u);
    assert_int_equal(motor.mode, URB_MOTOR_MODE_DISABLED);
}

/* Only signal 1 (calibrate) means something to the motor: another signal changes nothing. */
static void motor_other_signals_ignored(void **state)
{
    (void)state;
    fm.encoder = 0u;
    beats(&rig, 1u);
    fm.encoder = 100u;
    beats(&rig, 1u);
    int32_t const position = motor.position;
    assert_true(position != 0);
    assert_int_equal(fx_command(&rig.node, URB_COMMAND_CODE_SIGNAL, 2u, 0u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(&rig.node);
    assert_int_equal(motor.position, position);
}

/* ===== Battery ============================================================================== */

typedef struct {
    bool present[3];
    uint16_t mv[3];
    int16_t ma[3];
    int8_t temp[3];
    bool charger;
} fake_battery_t;

static fake_battery_t fb_;
static bool fb_present(void *c, uint8_t p) { return ((fake_battery_t *)c)->present[p]; }
static uint16_t fb_mv(void *c, uint8_t p) { return ((fake_battery_t *)c)->mv[p]; }
static int16_t fb_ma(void *c, uint8_t p) { return ((fake_battery_t *)c)->ma[p]; }
static int8_t fb_temp(void *c, uint8_t p) { return ((fake_battery_t *)c)->temp[p]; }
static bool fb_charger(void *c) { return ((fake_battery_t *)c)->charger; }

static void battery_status(void **state)
{
    (void)state;
    static const sensorhex_battery_io_t io = {&fb_, fb_present, fb_mv, fb_ma, fb_temp, fb_charger};
    sensorhex_battery_t app;
    sensorhex_battery_config_t cfg;
    sensorhex_battery_defaults(&cfg, 0u);
    sensorhex_battery_setup(&app, &io, &cfg);
    fb_ = (fake_battery_t){{true, true, false}, {12600u, 10000u, 0u}, {1000, 2000, 0}, {30, 35, 0}, true};
    rig_start(&rig, &sensorhex_battery_hooks, &app, sensorhex_battery_node_config);
    beats(&rig, 9u);
    uint8_t data[19];
    assert_true(fx_read_checked(&rig.node, 1u, 19u, data));
    assert_int_equal(data[0], 0u); /* nothing yet: updates at 100 Hz */
    beats(&rig, 1u);
    assert_true(fx_read_checked(&rig.node, 1u, 19u, data));
    urb_battery_status_t st;
    assert_int_equal(urb_battery_status_decode(&st, data, 19u), 19);
    assert_int_equal(st.packs[0].voltage, 12600u);
    assert_int_equal(st.packs[0].charge, 100u);
    assert_int_equal(st.packs[1].current, 2000);
    assert_int_equal(st.packs[1].temp, 35);
    assert_int_equal(st.packs[1].charge, 5u); /* (10000 + 2 A * 30 mOhm - 9900) / 2700 */
    assert_false(st.packs[2].present);
    assert_int_equal(st.packs[2].voltage, 0u);
    assert_true(st.low); /* pack 1 below 10.5 V */
    assert_true(st.charging);
    assert_int_equal(sensorhex_battery_charge(&cfg, 9000u, 0), 0u);
    assert_int_equal(sensorhex_battery_charge(&cfg, 11250u, 0), 50u);
    sensorhex_battery_config_t flat = cfg; /* a misconfigured curve (full <= empty): 0 %, no division by 0 */
    flat.full_mv = flat.empty_mv;
    assert_int_equal(sensorhex_battery_charge(&flat, 11250u, 0), 0u);
    /* the bridge still reading the status buffer the next update would fill: that update skips */
    hold_read(&rig.node, 1u);
    fb_.mv[0] = 12000u;
    beats(&rig, 10u);
    fb_.mv[0] = 11000u;
    beats(&rig, 10u);
    end_read(&rig.node);
    assert_true(fx_read_checked(&rig.node, 1u, 19u, data));
    assert_int_equal(urb_battery_status_decode(&st, data, 19u), 19);
    assert_int_equal(st.packs[0].voltage, 12000u);
    beats(&rig, 10u);
    assert_true(fx_read_checked(&rig.node, 1u, 19u, data));
    assert_int_equal(urb_battery_status_decode(&st, data, 19u), 19);
    assert_int_equal(st.packs[0].voltage, 11000u);
    (void)urb_node_i2c_event(&rig.node, URB_I2C_STUCK, 0u);
    (void)urb_node_poll(&rig.node);
    assert_int_equal(app.faults, 1u);
}

/* ===== IMU ================================================================================== */

typedef struct {
    int16_t base;
    unsigned reads;
    bool none;
} fake_imu_t;

static fake_imu_t fi;
static bool fi_read(void *c, sensorhex_imu_reading_t *out)
{
    fake_imu_t *f = c;
    if (f->none) {
        return false;
    }
    int16_t const v = (int16_t)(f->base + (int16_t)(f->reads % 2u) * 10); /* alternates base, base + 10 */
    for (int a = 0; a < 3; a++) {
        out->accel[a] = v;
        out->gyro[a] = (int16_t)-v;
    }
    out->temp = 25;
    f->reads++;
    return true;
}

static void imu_oversamples(void **state)
{
    (void)state;
    static const sensorhex_imu_io_t io = {&fi, fi_read};
    sensorhex_imu_t app;
    sensorhex_imu_config_t cfg;
    sensorhex_imu_defaults(&cfg, 1u);
    sensorhex_imu_setup(&app, &io, &cfg);
    fi = (fake_imu_t){9810, 0u, false};
    rig_start(&rig, &sensorhex_imu_hooks, &app, sensorhex_imu_node_config);
    for (int i = 0; i < 20; i++) {
        (void)urb_node_poll(&rig.node); /* idle: oversampling, at most 8 readings */
    }
    assert_int_equal(fi.reads, 8u);
    beats(&rig, 10u);
    uint8_t data[14];
    assert_true(fx_read_checked(&rig.node, 1u, 14u, data));
    urb_imu_sample_t s;
    assert_int_equal(urb_imu_sample_decode(&s, data, 14u), 14);
    assert_int_equal(s.accel[0], 9815); /* the mean of 9810 and 9820 */
    assert_int_equal(s.gyro[2], -9815);
    assert_int_equal(s.temp, 25);
    assert_int_equal(s.sample, 0u);
    beats(&rig, 10u);
    assert_true(fx_read_checked(&rig.node, 1u, 14u, data));
    assert_int_equal(urb_imu_sample_decode(&s, data, 14u), 14);
    assert_int_equal(s.sample, 1u);
    /* no reading available: the previous sample stays published */
    fi.none = true;
    app.count = 0u;
    beats(&rig, 10u);
    assert_true(fx_read_checked(&rig.node, 1u, 14u, data));
    assert_int_equal(urb_imu_sample_decode(&s, data, 14u), 14);
    assert_int_equal(s.sample, 1u);
    /* oversample 1: read once in the update; RESET restarts the counter */
    sensorhex_imu_config_t one = {1u, 0u};
    sensorhex_imu_setup(&app, &io, &one);
    assert_int_equal(app.cfg.oversample, 1u);
    one.oversample = 99u;
    sensorhex_imu_setup(&app, &io, &one);
    assert_int_equal(app.cfg.oversample, 16u);
    assert_int_equal(fx_command(&rig.node, URB_COMMAND_CODE_RESET, 0u, 0u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(&rig.node);
    assert_int_equal(app.sample, 0u);
    /* a fault reaches the app */
    (void)urb_node_i2c_event(&rig.node, URB_I2C_STUCK, 0u);
    (void)urb_node_poll(&rig.node);
    assert_int_equal(app.faults, 1u);
}

/* An IMU update that finds the bridge reading the buffer it would fill skips that sample's publication. */
static void imu_skips_a_busy_outbox(void **state)
{
    (void)state;
    static const sensorhex_imu_io_t io = {&fi, fi_read};
    sensorhex_imu_t app;
    sensorhex_imu_config_t cfg;
    sensorhex_imu_defaults(&cfg, 1u);
    sensorhex_imu_setup(&app, &io, &cfg);
    fi = (fake_imu_t){100, 0u, false};
    rig_start(&rig, &sensorhex_imu_hooks, &app, sensorhex_imu_node_config);
    beats(&rig, 10u); /* sample 0 published */
    hold_read(&rig.node, 1u);
    beats(&rig, 20u); /* sample 1 published, sample 2 skipped */
    end_read(&rig.node);
    uint8_t data[14];
    urb_imu_sample_t s;
    assert_true(fx_read_checked(&rig.node, 1u, 14u, data));
    assert_int_equal(urb_imu_sample_decode(&s, data, 14u), 14);
    assert_int_equal(s.sample, 1u);
    beats(&rig, 10u);
    assert_true(fx_read_checked(&rig.node, 1u, 14u, data));
    assert_int_equal(urb_imu_sample_decode(&s, data, 14u), 14);
    assert_true(s.sample > 1u);
}

/* ===== IR distance ========================================================================== */

typedef struct {
    uint16_t mm;
    uint8_t strength;
} fake_ir_t;

static fake_ir_t fir;
static uint16_t fir_mm(void *c) { return ((fake_ir_t *)c)->mm; }
static uint8_t fir_strength(void *c) { return ((fake_ir_t *)c)->strength; }

static urb_ir_range_t ir_read(void)
{
    uint8_t data[4];
    assert_true(fx_read_checked(&rig.node, 1u, 4u, data));
    urb_ir_range_t r;
    assert_int_equal(urb_ir_range_decode(&r, data, 4u), 4);
    return r;
}

static void ir_median_and_validity(void **state)
{
    (void)state;
    static const sensorhex_ir_io_t io = {&fir, fir_mm, fir_strength};
    sensorhex_ir_t app;
    sensorhex_ir_config_t cfg;
    sensorhex_ir_defaults(&cfg, 0u);
    sensorhex_ir_setup(&app, &io, &cfg);
    rig_start(&rig, &sensorhex_ir_hooks, &app, sensorhex_ir_node_config);
    fir = (fake_ir_t){500u, 80u};
    beats(&rig, 10u);
    urb_ir_range_t r = ir_read();
    assert_int_equal(r.distance, 500u);
    assert_true(r.valid);
    fir.mm = 4000u; /* one spike */
    beats(&rig, 10u);
    fir.mm = 510u;
    beats(&rig, 10u);
    r = ir_read();
    assert_int_equal(r.distance, 510u); /* median of 500, 4000, 510 */
    fir.mm = 4000u;
    beats(&rig, 10u);
    fir.mm = 4000u;
    beats(&rig, 10u);
    r = ir_read();
    assert_int_equal(r.distance, 4000u);
    assert_false(r.valid); /* out of range */
    fir = (fake_ir_t){600u, 5u};
    beats(&rig, 30u);
    r = ir_read();
    assert_false(r.valid); /* weak return */
    assert_int_equal(r.strength, 5u);
    fir = (fake_ir_t){50u, 80u};
    beats(&rig, 30u);
    r = ir_read();
    assert_int_equal(r.distance, 50u);
    assert_false(r.valid); /* closer than the sensor's range */
    /* the bridge still reading the buffer the next update would fill: the updates skip until it ends */
    fir.mm = 700u;
    beats(&rig, 30u);
    hold_read(&rig.node, 1u);
    fir.mm = 800u;
    beats(&rig, 30u); /* median 700 published, then 800 twice skipped */
    end_read(&rig.node);
    assert_int_equal(ir_read().distance, 700u);
    beats(&rig, 10u);
    assert_int_equal(ir_read().distance, 800u);
    assert_int_equal(sensorhex_ir_median3(3u, 1u, 2u), 2u);
    assert_int_equal(sensorhex_ir_median3(1u, 3u, 2u), 2u);
    assert_int_equal(sensorhex_ir_median3(2u, 3u, 1u), 2u);
    assert_int_equal(sensorhex_ir_median3(2u, 1u, 3u), 2u);
    assert_int_equal(fx_command(&rig.node, URB_COMMAND_CODE_RESET, 0u, 0u, 0u), FX_ALL_ACKED);
    (void)urb_node_poll(&rig.node);
    assert_int_equal(app.filled, 0u);
    (void)urb_node_i2c_event(&rig.node, URB_I2C_STUCK, 0u);
    (void)urb_node_poll(&rig.node);
    assert_int_equal(app.faults, 1u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(motor_identifies, motor_setup),
        cmocka_unit_test_setup(motor_feedback_every_update, motor_setup),
        cmocka_unit_test_setup(motor_voltage_mode_and_timeout, motor_setup),
        cmocka_unit_test_setup(motor_local_pd, motor_setup),
        cmocka_unit_test_setup(motor_protection, motor_setup),
        cmocka_unit_test_setup(motor_timeout_255_cuts, motor_setup),
        cmocka_unit_test_setup(motor_timeout_0_never, motor_setup),
        cmocka_unit_test_setup(motor_pd_fast_rate_no_overflow, motor_setup),
        cmocka_unit_test_setup(motor_skips_a_busy_outbox, motor_setup),
        cmocka_unit_test_setup(motor_busy_inboxes, motor_setup),
        cmocka_unit_test_setup(motor_other_signals_ignored, motor_setup),
        cmocka_unit_test(battery_status),
        cmocka_unit_test(imu_oversamples),
        cmocka_unit_test(imu_skips_a_busy_outbox),
        cmocka_unit_test(ir_median_and_validity),
    };
    return cmocka_run_group_tests_name("sensorhex_apps", tests, NULL, NULL);
}
