/*
 * sim_app_bind.h: the applications a simulated node runs, set up the same way whatever its port:
 * the I2C world's nodes (node_hal_sim.c, their hardware in sensorhex_io_sim.c) and the CAN and RS485
 * nodes of the downlink models (sim/downlink/sim_dl_node.c). The port fills the hardware (the io
 * member) of the application it chose; sim_app_bind does the rest.
 */
#ifndef URBSIM_SIM_APP_BIND_H
#define URBSIM_SIM_APP_BIND_H

#include <stdbool.h>
#include <stdint.h>

#include "sensorhex_battery.h"
#include "sensorhex_imu.h"
#include "sensorhex_ir.h"
#include "sensorhex_motor.h"
#include "sim_apps.h"
#include "urb_node.h"

/** The state of the application a node runs, with the hardware it sees; caller-owned. */
typedef union {
    sim_probe_app_t probe;
    struct { sensorhex_motor_t app; sensorhex_motor_io_t io; } motor;
    struct { sensorhex_battery_t app; sensorhex_battery_io_t io; } battery;
    struct { sensorhex_imu_t app; sensorhex_imu_io_t io; } imu;
    struct { sensorhex_ir_t app; sensorhex_ir_io_t io; } ir;
} sim_app_state_t;

/** What urb_node_init is given for the application. */
typedef struct {
    const urb_node_hooks_t *hooks;
    void *app;
    uint16_t storage_len;
} sim_app_binding_t;

/** Sets up application `app` (SIM_APP_*, sim_devices.h) in *state for node `index`: a SensoRHex
 *  application with its default settings, the hardware of state's io member (filled by the port
 *  first) and *ncfg adjusted as it requires; the probe as the port configured it in state->probe.
 *  Fills *out. False for an unknown application. */
bool sim_app_bind(sim_app_state_t *state, int app, uint8_t index, urb_node_config_t *ncfg, sim_app_binding_t *out);

#endif /* URBSIM_SIM_APP_BIND_H */
