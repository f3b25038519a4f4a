/*
 * sensorhex_io_sim.c: the SensoRHex applications' hardware (sensorhex_*_io_t) in the simulation.
 *
 * Every function samples at the calling instant (kernel time: the end of the node's acquisition,
 * node_hal_sim.h). The motor driver sees the motor-and-leg model (sim/core/motor.h) with its PWM
 * ripple and ADC noise; the battery, IMU and IR nodes see simple stationary signals with noise
 * (their values are not what the experiments measure: their traffic is).
 */
#include <math.h>

#include "node_hal_sim.h"

/* ---------------------------------------------------------------- motor */

static sim_node_t *N(void *ctx) { return (sim_node_t *)ctx; }

static uint16_t motor_encoder(void *ctx)
{
    return urbsim_motor_encoder(&N(ctx)->plant, N(ctx)->k->now);
}

static int16_t clamp16(double v)
{
    return (int16_t)(v > 32767.0 ? 32767.0 : (v < -32768.0 ? -32768.0 : v));
}

static int16_t motor_current_ma(void *ctx)
{
    return clamp16(floor(urbsim_motor_sense_current(&N(ctx)->plant, N(ctx)->k->now) * 1000.0 + 0.5));
}

static int16_t motor_voltage_mv(void *ctx)
{
    return clamp16(floor(urbsim_motor_sense_voltage(&N(ctx)->plant, N(ctx)->k->now) * 1000.0 + 0.5));
}

static int16_t motor_temp_cdeg(void *ctx)
{
    return clamp16(floor(urbsim_motor_temperature(&N(ctx)->plant, N(ctx)->k->now) * 100.0 + 0.5));
}

static bool motor_hall(void *ctx)
{
    /* The calibration magnet: within 2 degrees of leg angle 0 (mod 2 pi). */
    double a = urbsim_motor_leg_angle(&N(ctx)->plant, N(ctx)->k->now);
    double r = fmod(fabs(a), 2.0 * 3.14159265358979323846);
    return r < 0.035 || r > 2.0 * 3.14159265358979323846 - 0.035;
}

static void motor_drive_mv(void *ctx, int16_t mv)
{
    sim_node_t *n = N(ctx);
    urbsim_motor_drive(&n->plant, n->k->now, (double)mv / 1000.0);
    /* log the applied value (offset binary) for the loop-delay measurement, and whether this
     * update took a new command (the application counts updates without one in `missed`) */
    uint32_t const fresh = n->app_state.motor.app.missed == 0u ? SIM_DRIVE_FRESH : 0u;
    sim_log_put(&n->log, n->k->now, SIM_MARK_DRIVE, (uint32_t)((int32_t)mv + 0x8000) | fresh);
}

/* ---------------------------------------------------------------- battery, IMU, IR */

static bool batt_present(void *ctx, uint8_t pack)
{
    (void)ctx;
    return pack < 3u;
}

static uint16_t batt_voltage_mv(void *ctx, uint8_t pack)
{
    sim_node_t *n = N(ctx);
    double minutes = (double)n->k->now * 1e-9 / 60.0;
    double v = 12.3 - 0.01 * minutes - 0.05 * (double)pack + urbsim_rng_normal(&n->rng, 0.0, 0.005);
    return (uint16_t)(v * 1000.0);
}

static int16_t batt_current_ma(void *ctx, uint8_t pack)
{
    sim_node_t *n = N(ctx);
    (void)pack;
    return clamp16(1500.0 + urbsim_rng_normal(&n->rng, 0.0, 40.0));
}

static int8_t batt_temp_c(void *ctx, uint8_t pack)
{
    (void)ctx;
    return (int8_t)(28 + pack);
}

static bool batt_charger(void *ctx)
{
    (void)ctx;
    return false;
}

static bool imu_read(void *ctx, sensorhex_imu_reading_t *out)
{
    sim_node_t *n = N(ctx);
    static const double g[3] = {0.0, 0.0, 9.81};
    for (int i = 0; i < 3; i++) {
        out->accel[i] = clamp16((g[i] + urbsim_rng_normal(&n->rng, 0.0, 0.05)) * 1000.0);
        out->gyro[i] = clamp16(urbsim_rng_normal(&n->rng, 0.0, 0.01) * 1000.0);
    }
    out->temp = 31;
    return true;
}

static uint16_t ir_distance_mm(void *ctx)
{
    return (uint16_t)(800.0 + urbsim_rng_normal(&N(ctx)->rng, 0.0, 5.0));
}

static uint8_t ir_strength(void *ctx)
{
    (void)ctx;
    return 120u;
}

/* ---------------------------------------------------------------- binding */

bool sim_sensorhex_bind(sim_node_t *n, int app, uint8_t index, const urbsim_motor_params_t *motor,
                        const urbsim_rng_t *rng, urb_node_config_t *ncfg)
{
    sim_app_state_t *s = &n->app_state;
    switch (app) {
    case SIM_APP_MOTOR:
        urbsim_motor_init(&n->plant, motor, rng);
        s->motor.io = (sensorhex_motor_io_t){.ctx = n, .encoder = motor_encoder, .current_ma = motor_current_ma,
                                             .voltage_mv = motor_voltage_mv, .case_temp_cdeg = motor_temp_cdeg,
                                             .hall = motor_hall, .drive_mv = motor_drive_mv};
        n->has_plant = true;
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
    sim_app_binding_t b;
    if (!sim_app_bind(s, app, index, ncfg, &b)) {
        return false;
    }
    n->hooks = b.hooks;
    n->app = b.app;
    n->storage_len = b.storage_len;
    return true;
}
