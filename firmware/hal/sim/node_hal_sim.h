/*
 * node_hal_sim.h (private to node_hal_sim.c; the world uses sim_devices.h): one URB node (the real node library and application) on a simulated
 * microcontroller, attached to a simulated I2C bus.
 *
 * What the port does, and when (virtual time):
 *   - now(): the node's timer counter, ticks of its own crystal (clock.h), 32 bits;
 *   - set_compare(at): the timer compare interrupt fires when the counter reaches `at`; the
 *     handler (urb_node_timer_event) starts after the interrupt latency (mcu.h);
 *   - the I2C slave interrupt: urb_node_i2c_event is called once per bus event at the slave's
 *     ISR instant (i2c.h), holding SCL low (clock stretching) until the handler returns;
 *   - sync_capture (optional, node.sync_capture): the tick at the general-call address match,
 *     as an input-capture unit would latch it;
 *   - the main loop (urb_node_poll) runs after every heartbeat and every STOP, when the CPU is
 *     not busy. ACQUISITION MODEL: a poll that runs a due app_update first spends the node's
 *     acquisition time (node.acq_us plus a uniform 0..node.acq_jitter_cycles extra, lengthened by
 *     any interrupt handler that preempts it), and the whole poll takes effect at the END of that
 *     time: the outbox release, hence the ACQ_END mark and the data the bridge reads, happen when
 *     acquisition really finishes.
 *   - marks (BEAT, ACQ_END, SYNC) are logged with their virtual time for the experiments.
 */
#ifndef URBSIM_NODE_HAL_SIM_H
#define URBSIM_NODE_HAL_SIM_H

#include <stdbool.h>
#include <stdint.h>

#include "motor.h"
#include "sim_app_bind.h"
#include "sim_devices.h"
#include "urb_node.h"

struct sim_node {
    char name[32];
    urbsim_kernel_t *k;
    urbsim_trace_t *tr;
    urbsim_i2c_bus_t *bus;
    urbsim_mcu_t mcu;
    sim_node_cfg_t cfg;
    urbsim_rng_t rng;            /**< acquisition jitter */
    /* firmware */
    urb_node_t node;
    urb_node_hal_t hal;
    urb_node_config_t ncfg;
    const urb_node_hooks_t *hooks;     /**< what the library calls: port_hooks */
    const urb_node_hooks_t *app_hooks; /**< the application's own hooks */
    urb_node_hooks_t port_hooks;       /**< the application's, with the fault hook logged by the port */
    void *app;
    uint8_t storage[512];
    uint16_t storage_len;
    /* port state */
    urbsim_i2c_slave_t slave;
    bool powered;
    uint64_t gen;                /**< bumped at power loss: pending events are dropped */
    uint64_t compare_gen;
    urbsim_handle_t compare_ev;  /**< the pending compare event, withdrawn when replaced */
    urbsim_ns_t gc_hw;           /**< bus instant of the last general-call match */
    bool poll_pending;
    urbsim_ns_t poll_at;
    uint64_t poll_gen;
    urbsim_handle_t poll_ev;     /**< the pending main-loop event, withdrawn when superseded */
    bool acquiring;
    urbsim_ns_t acq_start;
    sim_log_t log;
    uint64_t polls, updates, boots;
    int init_result;
    sim_app_state_t app_state;   /**< the application and its hardware (sim_app_bind.h) */
    urbsim_motor_t plant;        /**< the motor and leg of a motor driver node */
    bool reading_mb1;            /**< trace observer: a bridge read of outbox 1 is in progress */
    uint64_t faults[URB_NODE_FAULT_CODES + 1u]; /**< app_fault deliveries per code */
    urbsim_ns_t scl_low_from;    /**< SCL low timeout: the low period being timed began here */
    uint64_t stuck_reports;      /**< URB_I2C_STUCK events the port raised */
    bool has_plant;
};

/** Bind a SensoRHex application (sensorhex_io_sim.c): its hooks, state, storage size and the
 *  hardware it sees; adjusts *ncfg as the application requires. False for other apps. */
bool sim_sensorhex_bind(sim_node_t *n, int app, uint8_t index, const urbsim_motor_params_t *motor,
                        const urbsim_rng_t *rng, urb_node_config_t *ncfg);

#endif /* URBSIM_NODE_HAL_SIM_H */
