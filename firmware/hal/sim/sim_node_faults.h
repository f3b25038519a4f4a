/*
 * sim_node_faults.h: what a node's port notices of a downlink fault on its own (the world calls
 * it when it injects the fault; the node decides, from the bus lines, whether and when its
 * hardware reacts).
 *
 * Separate from sim_devices.h so that fault injection can grow without touching the device
 * handles every world file includes.
 */
#ifndef URBSIM_SIM_NODE_FAULTS_H
#define URBSIM_SIM_NODE_FAULTS_H

#include "sim_devices.h"

/** SCL was just pulled low and stays low until released: the node's I2C peripheral starts its
 *  SCL low timeout (`timeout_ns`; SMBus t_TIMEOUT is 25..35 ms). If SCL is still low, without a
 *  release in between, when it expires, the peripheral's error interrupt reports URB_I2C_STUCK to
 *  the node library (trace "fault"/"scl_timeout", then "app_fault" STUCK_BUS from the main loop).
 *  Unpowered nodes ignore it. */
void sim_node_scl_low(sim_node_t *n, urbsim_ns_t timeout_ns);

#endif /* URBSIM_SIM_NODE_FAULTS_H */
