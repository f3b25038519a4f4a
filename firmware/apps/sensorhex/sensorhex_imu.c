/*
 * SensoRHex inertial measurement node (see sensorhex_imu.h).
 */
#include "sensorhex_imu.h"

#include <stddef.h>

#include "urb_sensorhex.h"

#define IMU_MAX_OVERSAMPLE 16u

void sensorhex_imu_defaults(sensorhex_imu_config_t *cfg, uint8_t index)
{
    cfg->index = index;
    cfg->oversample = 8u;
}

static void imu_clear(sensorhex_imu_t *app)
{
    /* bound: 7 channels */
    for (uint8_t c = 0u; c < 7u; c++) {
        app->sum[c] = 0;
    }
    app->count = 0u;
}

void sensorhex_imu_setup(sensorhex_imu_t *app, const sensorhex_imu_io_t *io, const sensorhex_imu_config_t *cfg)
{
    app->io = io;
    app->cfg = *cfg;
    if (app->cfg.oversample == 0u) {
        app->cfg.oversample = 1u;
    }
    if (app->cfg.oversample > IMU_MAX_OVERSAMPLE) {
        app->cfg.oversample = IMU_MAX_OVERSAMPLE;
    }
    app->sample = 0u;
    app->faults = 0u;
    imu_clear(app);
}

void sensorhex_imu_node_config(urb_node_config_t *cfg)
{
    cfg->update_divider = 10u;
    cfg->fw_major = 1u;
    cfg->fw_minor = 0u;
    cfg->fw_patch = 0u;
}

/* Adds one reading to the running sums (|sum| <= 16 * 32768: no overflow). */
static void imu_take(sensorhex_imu_t *app)
{
    sensorhex_imu_reading_t r;
    if ((app->count >= app->cfg.oversample) || !app->io->read(app->io->ctx, &r)) {
        return;
    }
    /* bound: 3 axes */
    for (uint8_t a = 0u; a < 3u; a++) {
        app->sum[a] += r.accel[a];
        app->sum[3u + a] += r.gyro[a];
    }
    app->sum[6] += r.temp;
    app->count++;
}

static void imu_bootup(urb_node_t *node, void *user)
{
    sensorhex_imu_t const *app = user;
    (void)urb_node_set_class(node, URB_NODE_IMU_CLASS);
    (void)urb_node_set_index(node, app->cfg.index);
    (void)urb_node_set_fingerprint(node, URB_NODE_IMU_FINGERPRINT);
    (void)urb_node_setup_outbox(node, URB_NODE_IMU_OUTBOX_IMU_SAMPLE, URB_NODE_IMU_OUTBOX1_SIZE);
}

static void imu_idle(urb_node_t *node, void *user)
{
    (void)node;
    imu_take(user);
}

static void imu_update(urb_node_t *node, void *user)
{
    sensorhex_imu_t *app = user;
    if (app->count == 0u) {
        imu_take(app); /* nothing oversampled yet: read once now */
    }
    if (app->count == 0u) {
        return; /* the sensor has nothing new: keep the previous sample published */
    }
    int32_t const n = (int32_t)app->count;
    urb_imu_sample_t s;
    /* bound: 3 axes */
    for (uint8_t a = 0u; a < 3u; a++) {
        s.accel[a] = (int16_t)(app->sum[a] / n); /* a mean of int16 values fits int16 */
        s.gyro[a] = (int16_t)(app->sum[3u + a] / n);
    }
    s.temp = (int8_t)(app->sum[6] / n);
    s.sample = app->sample;
    uint8_t *out = NULL;
    if (urb_node_lock_outbox(node, URB_NODE_IMU_OUTBOX_IMU_SAMPLE, &out) == URB_NODE_OK) {
        (void)urb_imu_sample_encode(&s, out, URB_IMU_SAMPLE_SIZE);
        (void)urb_node_release_outbox(node, URB_NODE_IMU_OUTBOX_IMU_SAMPLE);
        app->sample++;
        imu_clear(app);
    }
}

static void imu_reset(urb_node_t *node, void *user)
{
    (void)node;
    sensorhex_imu_t *app = user;
    app->sample = 0u;
    imu_clear(app);
}

static void imu_fault(urb_node_t *node, void *user, urb_node_fault_t fault)
{
    (void)node;
    (void)fault;
    ((sensorhex_imu_t *)user)->faults++;
}

const urb_node_hooks_t sensorhex_imu_hooks = {imu_bootup, NULL, imu_reset, imu_idle, imu_update, NULL, imu_fault};
