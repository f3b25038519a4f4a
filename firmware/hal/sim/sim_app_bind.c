/* sim_app_bind.c: sim_app_bind.h. */
#include "sim_app_bind.h"

#include "sim_devices.h"

bool sim_app_bind(sim_app_state_t *state, int app, uint8_t index, urb_node_config_t *ncfg, sim_app_binding_t *out)
{
    switch (app) {
    case SIM_APP_PROBE:
        *out = (sim_app_binding_t){&sim_probe_hooks, &state->probe, sim_probe_storage(&state->probe)};
        return true;
    case SIM_APP_MOTOR: {
        sensorhex_motor_config_t cfg;
        sensorhex_motor_defaults(&cfg, index);
        sensorhex_motor_setup(&state->motor.app, &state->motor.io, &cfg);
        sensorhex_motor_node_config(ncfg);
        *out = (sim_app_binding_t){&sensorhex_motor_hooks, &state->motor.app, SENSORHEX_MOTOR_STORAGE};
        return true;
    }
    case SIM_APP_BATTERY: {
        sensorhex_battery_config_t cfg;
        sensorhex_battery_defaults(&cfg, index);
        sensorhex_battery_setup(&state->battery.app, &state->battery.io, &cfg);
        sensorhex_battery_node_config(ncfg);
        *out = (sim_app_binding_t){&sensorhex_battery_hooks, &state->battery.app, SENSORHEX_BATTERY_STORAGE};
        return true;
    }
    case SIM_APP_IMU: {
        sensorhex_imu_config_t cfg;
        sensorhex_imu_defaults(&cfg, index);
        sensorhex_imu_setup(&state->imu.app, &state->imu.io, &cfg);
        sensorhex_imu_node_config(ncfg);
        *out = (sim_app_binding_t){&sensorhex_imu_hooks, &state->imu.app, SENSORHEX_IMU_STORAGE};
        return true;
    }
    case SIM_APP_IR: {
        sensorhex_ir_config_t cfg;
        sensorhex_ir_defaults(&cfg, index);
        sensorhex_ir_setup(&state->ir.app, &state->ir.io, &cfg);
        sensorhex_ir_node_config(ncfg);
        *out = (sim_app_binding_t){&sensorhex_ir_hooks, &state->ir.app, SENSORHEX_IR_STORAGE};
        return true;
    }
    default:
        return false;
    }
}
