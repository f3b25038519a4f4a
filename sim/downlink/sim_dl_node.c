/* A URB node on the CAN or RS485 downlink for the bus models of sim/urb_sim/fieldbus: the node
 * library (firmware/node: urb_node.c, urb_mailbox.c, urb_pll.c and the downlink adapter
 * urb_node_dl.c with urb_node_can.c / urb_node_rs485.c) running a SensoRHex application
 * (firmware/apps/sensorhex: motor, battery, IMU, IR) or the simulation's probe (sim_apps.c), the same
 * objects the I2C world's nodes run (all in build/sim/liburbsim.so). Only the port is the
 * simulation's:
 *   - the clock: ticks of 1 us (the downlink slaves time-stamp in microseconds), an ideal crystal,
 *     advanced by the bus model; the heartbeat compare fires when the model's time passes it, and the
 *     main loop (urb_node_poll) runs after every heartbeat and every bus event, taking no time;
 *   - the controller: sim_port.c's CAN FIFO or RS485 driver flags, driven by the model through ctypes;
 *   - the applications' hardware: a motor whose encoder, current and voltage the model sets before
 *     each update and whose drive it reads back; stationary battery, IMU and IR readings (the I2C
 *     world's have noise; here their traffic is what is measured, not their values);
 *   - an observer on the mailbox table urb_node_dl.c fills (urb_dl_mailbox_t): it copies the outbox
 *     buffer a read latches and the inbox the application's next lock sees after each committed
 *     write, so the model can check what the bridge got against the node library's own buffers.
 * Not firmware: a simulation harness (issue #39). */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "sim_app_bind.h"
#include "sim_devices.h"
#include "sim_downlink.h"
#include "urb_can_slave.h"
#include "urb_node.h"
#include "urb_node_can.h"
#include "urb_node_downlink.h"
#include "urb_node_internal.h"
#include "urb_node_rs485.h"
#include "urb_rs485_slave.h"

#define SIM_DL_PROBE_CLASS 0xF0u
#define SIM_DL_STORAGE 128u /* the largest layout here: a probe with 32 bytes out and in, double-buffered */

typedef struct {
    /* the node library and its application */
    urb_node_t node;
    urb_node_hal_t hal;
    urb_node_config_t cfg;
    sim_app_binding_t bound;
    sim_app_state_t apps;
    uint8_t storage[SIM_DL_STORAGE];
    /* the port: clock, heartbeat compare, controller */
    uint32_t now;
    uint32_t compare;
    bool compare_armed;
    uint32_t beats, syncs, last_sync_t;
    urb_node_can_t can;
    sim_can_port_t can_port;
    urb_node_rs485_t rs485;
    sim_rs485_port_t rs485_port;
    /* the motor's hardware */
    uint16_t encoder;
    int16_t current_ma, voltage_mv;
    int16_t drive_mv;
    bool drive_fresh;
    uint32_t drives, drive_t;
    /* the observer */
    urb_dl_mailbox_t lib;             /* urb_node_dl.c's steps, which the observer calls */
    uint8_t read_copy[URB_NODE_MAILBOXES][URB_NODE_MAX_SIZE];
    uint32_t reads[URB_NODE_MAILBOXES];
    uint8_t commit_copy[URB_NODE_MAILBOXES][URB_NODE_MAX_SIZE];
    uint32_t commits[URB_NODE_MAILBOXES];
} sim_dl_node_t;

static sim_dl_node_t *of_node(void *node)
{
    return (sim_dl_node_t *)(void *)((uint8_t *)node - offsetof(sim_dl_node_t, node));
}

/* ------------------------------------------------------------------ the node HAL */

static uint32_t hal_now(void *ctx)
{
    return ((const sim_dl_node_t *)ctx)->now;
}

static void hal_set_compare(void *ctx, uint32_t at)
{
    sim_dl_node_t *n = (sim_dl_node_t *)ctx;
    n->compare = at;
    n->compare_armed = true;
}

static void hal_set_address(void *ctx, uint8_t address)
{
    (void)ctx; /* the slave filters on urb_node_config_t.i2c_address itself */
    (void)address;
}

static void hal_mark(void *ctx, urb_node_mark_t mark)
{
    sim_dl_node_t *n = (sim_dl_node_t *)ctx;
    if (mark == URB_NODE_MARK_BEAT) {
        n->beats++;
    } else if (mark == URB_NODE_MARK_SYNC) {
        n->syncs++;
        n->last_sync_t = n->now;
    } else {
        /* the end of acquisition: nothing to record */
    }
}

/* ------------------------------------------------------------------ the applications' hardware */

static uint16_t motor_encoder(void *ctx) { return ((const sim_dl_node_t *)ctx)->encoder; }
static int16_t motor_current_ma(void *ctx) { return ((const sim_dl_node_t *)ctx)->current_ma; }
static int16_t motor_voltage_mv(void *ctx) { return ((const sim_dl_node_t *)ctx)->voltage_mv; }
static int16_t motor_temp_cdeg(void *ctx) { (void)ctx; return 2500; }
static bool motor_hall(void *ctx) { (void)ctx; return false; }

static void motor_drive_mv(void *ctx, int16_t mv)
{
    sim_dl_node_t *n = (sim_dl_node_t *)ctx;
    n->drive_mv = mv;
    n->drive_fresh = n->apps.motor.app.missed == 0u; /* this update took a new command */
    n->drive_t = n->now;
    n->drives++;
}

static bool batt_present(void *ctx, uint8_t pack) { (void)ctx; return pack < 3u; }
static uint16_t batt_voltage_mv(void *ctx, uint8_t pack) { (void)ctx; return (uint16_t)(12300u - 50u * pack); }
static int16_t batt_current_ma(void *ctx, uint8_t pack) { (void)ctx; (void)pack; return 1500; }
static int8_t batt_temp_c(void *ctx, uint8_t pack) { (void)ctx; return (int8_t)(28 + pack); }
static bool batt_charger(void *ctx) { (void)ctx; return false; }

static bool imu_read(void *ctx, sensorhex_imu_reading_t *out)
{
    (void)ctx;
    out->accel[0] = 0;
    out->accel[1] = 0;
    out->accel[2] = 9810;
    out->gyro[0] = out->gyro[1] = out->gyro[2] = 0;
    out->temp = 31;
    return true;
}

static uint16_t ir_distance_mm(void *ctx) { (void)ctx; return 800u; }
static uint8_t ir_strength(void *ctx) { (void)ctx; return 120u; }

/* Binds application `app` (SIM_APP_*: its state, hooks and the hardware above) and adjusts the node
 * configuration as it requires; false for an unknown application or a probe's sizes out of range. */
static bool bind_app(sim_dl_node_t *n, uint8_t app, uint8_t index, uint8_t out_size, uint8_t in_size)
{
    sim_app_state_t *s = &n->apps;
    switch (app) {
    case SIM_APP_PROBE:
        s->probe.class_id = SIM_DL_PROBE_CLASS;
        s->probe.index = index;
        s->probe.out_size = out_size;
        s->probe.in_size = in_size;
        if ((out_size < 1u) || (out_size > URB_NODE_MAX_SIZE) || (in_size > URB_NODE_MAX_SIZE)) {
            return false;
        }
        break;
    case SIM_APP_MOTOR:
        s->motor.io = (sensorhex_motor_io_t){.ctx = n, .encoder = motor_encoder, .current_ma = motor_current_ma,
                                             .voltage_mv = motor_voltage_mv, .case_temp_cdeg = motor_temp_cdeg,
                                             .hall = motor_hall, .drive_mv = motor_drive_mv};
        break;
    case SIM_APP_BATTERY:
        s->battery.io = (sensorhex_battery_io_t){.ctx = n, .present = batt_present, .voltage_mv = batt_voltage_mv,
                                                 .current_ma = batt_current_ma, .temp_c = batt_temp_c,
                                                 .charger = batt_charger};
        break;
    case SIM_APP_IMU:
        s->imu.io = (sensorhex_imu_io_t){.ctx = n, .read = imu_read};
        break;
    case SIM_APP_IR:
        s->ir.io = (sensorhex_ir_io_t){.ctx = n, .distance_mm = ir_distance_mm, .strength = ir_strength};
        break;
    default:
        return false;
    }
    return sim_app_bind(s, app, index, &n->cfg, &n->bound);
}

/* ------------------------------------------------------------------ the observer */

static const uint8_t *obs_read_begin(void *ctx, uint8_t m)
{
    sim_dl_node_t *n = of_node(ctx);
    const uint8_t *buf = n->lib.read_begin(ctx, m);
    uint8_t const size = n->lib.outbox_size(ctx, m);
    if ((buf != NULL) && (m < URB_NODE_MAILBOXES)) {
        memcpy(n->read_copy[m], buf, size); /* what the slave sends: the buffer this read latched */
        n->reads[m]++;
    }
    return buf;
}

static void obs_write_commit(void *ctx, uint8_t m)
{
    sim_dl_node_t *n = of_node(ctx);
    n->lib.write_commit(ctx, m);
    if (m < URB_NODE_MAILBOXES) { /* what the application's next lock returns: the front buffer */
        memcpy(n->commit_copy[m], urb_inbox_buf(&n->node, m, n->node.inbox[m].front), n->node.inbox[m].size);
        n->commits[m]++;
    }
}

/* The slave keeps *mb by reference: the observer replaces two of urb_node_dl.c's steps in it and
 * calls them itself (ctx stays the node). */
static void observe(sim_dl_node_t *n, urb_dl_mailbox_t *mb)
{
    n->lib = *mb;
    mb->read_begin = obs_read_begin;
    mb->write_commit = obs_write_commit;
}

/* ------------------------------------------------------------------ time */

static void main_loop(sim_dl_node_t *n)
{
    (void)urb_node_poll(&n->node);
    for (uint8_t i = 0u; (i < 16u) && urb_node_has_work(&n->node); i++) {
        (void)urb_node_poll(&n->node);
    }
}

/** Bytes to allocate for one node (the caller owns the memory). */
size_t sim_dl_node_size(void)
{
    return sizeof(sim_dl_node_t);
}

/** Runs the node up to `now_us`: every heartbeat compare due by then fires at its instant (the timer
 *  interrupt, then the main loop), and the main loop runs once more at `now_us`. Time never goes back. */
void sim_dl_node_run(sim_dl_node_t *n, uint32_t now_us)
{
    while (n->compare_armed && ((int32_t)(n->compare - now_us) <= 0)) {
        if ((int32_t)(n->compare - n->now) > 0) {
            n->now = n->compare;
        }
        n->compare_armed = false;
        urb_node_timer_event(&n->node);
        main_loop(n);
    }
    if ((int32_t)(now_us - n->now) > 0) {
        n->now = now_us;
    }
    main_loop(n);
}

/** Starts node `address` with application `app` (SIM_APP_*, sim_devices.h; the probe with `out_size` bytes in
 *  outbox 1 and `in_size` in inbox 1) at `now_us`: urb_node_init, which runs its bootup and puts it
 *  on the bus. `heartbeat_us` replaces the nominal heartbeat (the SYNC period) unless 0. Returns
 *  urb_node_init's result, or URB_NODE_ERR_ARG for an unknown application. */
int sim_dl_node_init(sim_dl_node_t *n, uint8_t app, uint8_t address, uint8_t out_size, uint8_t in_size,
                     uint16_t heartbeat_us, uint32_t now_us)
{
    memset(n, 0, sizeof(*n));
    n->now = now_us;
    urb_node_config_default(&n->cfg);
    if (!bind_app(n, app, address, out_size, in_size)) {
        return URB_NODE_ERR_ARG;
    }
    n->cfg.i2c_address = address;
    n->cfg.ticks_per_us = 1u;
    n->cfg.sync_enabled = 1u;
    if (heartbeat_us != 0u) {
        n->cfg.heartbeat_us = heartbeat_us;
    }
    n->hal.ctx = n;
    n->hal.now = hal_now;
    n->hal.set_compare = hal_set_compare;
    n->hal.sync_capture = NULL;
    n->hal.set_address = hal_set_address;
    n->hal.mark = hal_mark;
    n->hal.identify = NULL;
    return urb_node_init(&n->node, &n->hal, n->bound.hooks, n->bound.app, &n->cfg, n->storage, n->bound.storage_len);
}

/* ------------------------------------------------------------------ CAN */

/** Puts the started node on a CAN bus at `kbps` (urb_node_can_attach); false when refused. */
bool sim_dl_node_attach_can(sim_dl_node_t *n, uint16_t kbps)
{
    sim_can_port_init(&n->can_port);
    if (!urb_node_can_attach(&n->can, &n->node, &n->cfg, &n->can_port.hal, kbps)) {
        return false;
    }
    observe(n, &n->can.mb);
    return true;
}

/** A frame on the bus, received at `t_us` (its start of frame): the node runs up to then first. */
void sim_dl_node_can_rx(sim_dl_node_t *n, const urb_can_frame_t *frame, uint32_t t_us)
{
    sim_dl_node_run(n, t_us);
    urb_can_slave_rx(&n->can.slave, frame, t_us);
}

/** Takes the oldest frame the slave queued; false when none waits. */
bool sim_dl_node_can_take(sim_dl_node_t *n, urb_can_frame_t *out)
{
    return sim_can_port_take(&n->can_port, out);
}

/** A frame the node queued went through. */
void sim_dl_node_can_tx_done(sim_dl_node_t *n)
{
    urb_can_slave_tx_done(&n->can.slave);
}

/** The controller's urb_can_state_t as the bus model has it; a change is reported to the slave. */
void sim_dl_node_can_set_state(sim_dl_node_t *n, uint8_t state)
{
    if (state != n->can_port.state) {
        n->can_port.state = state;
        urb_can_slave_state(&n->can.slave, state);
    }
}

/** tx_abort() calls so far (an answer dropped for bus-off or a newer request). */
uint32_t sim_dl_node_can_aborts(const sim_dl_node_t *n)
{
    return n->can_port.aborts;
}

/* ------------------------------------------------------------------ RS485 */

/** Puts the started node on an RS485 line at `baud` (urb_node_rs485_attach), its receiver starting
 *  at `now_us`; silences other than the firmware's (Modbus RTU's fixed ones, for comparison) are
 *  given as t15_us / t35_us and replace urb_rs485_timing's. False when refused. */
bool sim_dl_node_attach_rs485(sim_dl_node_t *n, uint32_t baud, uint16_t t15_us, uint16_t t35_us, uint32_t now_us)
{
    sim_rs485_port_init(&n->rs485_port, true);
    if (!urb_node_rs485_attach(&n->rs485, &n->node, &n->cfg, &n->rs485_port.hal, baud, now_us)) {
        return false;
    }
    if ((t15_us != n->rs485.tm.t15_us) || (t35_us != n->rs485.tm.t35_us)) {
        n->rs485.tm.t15_us = t15_us;
        n->rs485.tm.t35_us = t35_us;
        if (!urb_rs485_slave_init(&n->rs485.slave, &n->rs485_port.hal, &n->rs485.mb, n->cfg.i2c_address,
                                  &n->rs485.tm, now_us)) {
            return false;
        }
    }
    observe(n, &n->rs485.mb);
    return true;
}

/** A byte heard on the line (stop bit at `t_us`): the node runs up to then first. */
void sim_dl_node_rs485_rx(sim_dl_node_t *n, uint8_t byte, uint32_t t_us)
{
    sim_dl_node_run(n, t_us);
    urb_rs485_slave_rx(&n->rs485.slave, byte, t_us);
}

/** The poll the slave asked for (its receiver's deadline). */
uint32_t sim_dl_node_rs485_wake_us(const sim_dl_node_t *n)
{
    return n->rs485_port.wake_us;
}

/** Time `now_us` has come: the node runs up to it, and the slave ends a frame and may answer. */
void sim_dl_node_rs485_poll(sim_dl_node_t *n, uint32_t now_us)
{
    sim_dl_node_run(n, now_us);
    urb_rs485_slave_poll(&n->rs485.slave, now_us);
}

/** The next byte of the answer while the driver is enabled: true and *byte, else false. */
bool sim_dl_node_rs485_tx_next(sim_dl_node_t *n, uint8_t *byte)
{
    if (!n->rs485_port.sending) {
        return false;
    }
    if (!urb_rs485_slave_tx_next(&n->rs485.slave, byte)) {
        n->rs485_port.sending = false;
        return false;
    }
    return true;
}

/* ------------------------------------------------------------------ observation */

/** The bytes the last read of outbox `m` latched (outbox m's size) and the reads so far (*count). */
const uint8_t *sim_dl_node_last_read(const sim_dl_node_t *n, uint8_t m, uint32_t *count)
{
    *count = n->reads[m & 7u];
    return n->read_copy[m & 7u];
}

/** Inbox `m` as the application's next lock sees it after the last committed write, and the
 *  committed writes so far (*count). */
const uint8_t *sim_dl_node_last_commit(const sim_dl_node_t *n, uint8_t m, uint32_t *count)
{
    *count = n->commits[m & 7u];
    return n->commit_copy[m & 7u];
}

/** SYNCs the node library time-stamped (URB_NODE_MARK_SYNC), the last one's stamp in *last_t. */
uint32_t sim_dl_node_syncs(const sim_dl_node_t *n, uint32_t *last_t)
{
    *last_t = n->last_sync_t;
    return n->syncs;
}

/** Heartbeats so far. */
uint32_t sim_dl_node_beats(const sim_dl_node_t *n)
{
    return n->beats;
}

/** The heartbeat PLL's urb_node_sync_t now (urb_node_sync_status). */
uint8_t sim_dl_node_sync_state(const sim_dl_node_t *n)
{
    urb_node_sync_status_t st;
    memset(&st, 0, sizeof st);
    urb_node_sync_status(&n->node, &st);
    return (uint8_t)st.state;
}

/** The hooks the node library calls (the application's object, for the same-objects check). */
const void *sim_dl_node_hooks(const sim_dl_node_t *n)
{
    return n->bound.hooks;
}

/** The motor's encoder count, current and voltage that the next update acquires. */
void sim_dl_node_motor_sample(sim_dl_node_t *n, uint16_t encoder, int16_t current_ma, int16_t voltage_mv)
{
    n->encoder = encoder;
    n->current_ma = current_ma;
    n->voltage_mv = voltage_mv;
}

/** Drives applied so far; the last one's value (*mv), whether its update took a new command (*fresh)
 *  and when (*t_us). */
uint32_t sim_dl_node_motor_drive(const sim_dl_node_t *n, int16_t *mv, bool *fresh, uint32_t *t_us)
{
    *mv = n->drive_mv;
    *fresh = n->drive_fresh;
    *t_us = n->drive_t;
    return n->drives;
}
