/*
 * The hosted bridge's CAN downlink (urb-bridge-hosted --downlink can): the bridge core and the CAN
 * master (firmware/downlink/can) on a connection to tools/can_hub.py, in real time, with the nodes
 * in other processes (urb-node-hosted) on the same hub.
 */
#ifndef URB_HOSTED_CAN_H
#define URB_HOSTED_CAN_H

#include <signal.h>
#include <stdbool.h>
#include <stdint.h>

#include "urb_bridge.h"

/** Runs the bridge with configuration *cfg, its RS232 uplink on the pty master `pty`, its
 *  downlink the CAN hub at `hub` (CAN master timeout `timeout_us`: the nodes are processes the
 *  host schedules, slower than a microcontroller's interrupt), until *stop is set or `seconds`
 *  pass (0: no limit). Returns the process exit code (1 when the hub cannot be reached or goes). */
int urb_hosted_can_run(const urb_bridge_config_t *cfg, int pty, const char *hub, uint32_t timeout_us,
                       unsigned long seconds, volatile sig_atomic_t *stop, bool verbose);

#endif /* URB_HOSTED_CAN_H */
